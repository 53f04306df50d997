#include "storage/tools/compact.h"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>
#include <iterator>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <ctime>
#include <map>
#include <set>

#include <fmt/format.h>
#include <opencv2/core.hpp>

#include "core/durable_folder.h"
#include "core/time.h"
#include "storage/index/index_queries.h"
#include "storage/index/records.h"
#include "storage/index/session_index.h"
#include "storage/video/bayer_planes.h"
#include "storage/video/video_reader.h"
#include "storage/video/video_writer.h"

namespace pvcap {

namespace fs = std::filesystem;

namespace {

constexpr const char* kPartialSuffix = ".compacting";

// The codecs a segment can be in after a compact, and the tag its file name carries.
const std::map<std::string, std::string>& compact_tags() {
  static const std::map<std::string, std::string> tags{{"libx264", "x264"}, {"ffv1", "ffv1"}, {"ffvhuff", "huff"}};
  return tags;
}

// A segment's name without any codec tag: "cam0-000" for cam0-000.mkv and cam0-000.x264.mkv.
std::string base_name(const fs::path& path) {
  const std::string name = path.filename().string();
  return name.substr(0, name.find('.'));
}

// The codec a segment is compacted to: the one asked for, but FFV1 for a mosaic of more than 8 bits
// (x264 keeps at most 10 and this build's 8).
std::string target_codec(int bit_depth, const CompactOptions& o) {
  return bit_depth > 8 && o.codec == "libx264" ? "ffv1" : o.codec;
}

fs::path compacted_path(const fs::path& path, const std::string& codec) {
  return path.parent_path() / (base_name(path) + "." + compact_tags().at(codec) + ".mkv");
}

// Whether segment `s` is already what compacting to `codec` makes of it (its file carries the tag;
// a store recorded in x264 or FFV1 is already in that codec).
bool already_compacted(const std::string& path, const std::string& codec, const std::string& stored_codec) {
  return fs::path(path).filename() == compacted_path(path, codec).filename() ||
         (codec != "ffvhuff" && stored_codec == codec);
}

// The left-prediction residuals of a segment's first frames (up to 16), counted: what its Huffman
// tables are fitted to (the noise of one sensor changes little within a segment). Empty when they
// cannot be read (the copy then takes HuffYUV's default tables; its own reading says why).
std::vector<std::uint64_t> residual_counts(const fs::path& file) {
  std::vector<std::uint64_t> counts;
  auto reader = VideoReader::open(file);
  if (!reader) return counts;
  cv::Mat picture;
  std::int64_t pts = 0;
  bool key = false;
  for (int k = 0; k < 16; ++k) {
    auto more = reader.value()->next_stored(picture, pts, key);
    if (!more || !more.value() || picture.type() != CV_8UC1) break;
    add_left_residual_counts(picture, counts);
  }
  return counts;
}

// Shuffled crops of a training read's size (480x384 and the demosaicing margin) from `file`, per
// second of this thread's CPU: what `pvcap compact` says of the store before and after.
double crops_per_second(const fs::path& file, const std::vector<std::int64_t>& pts_ms) {
  auto reader = VideoReader::open(file);
  if (!reader || pts_ms.empty()) return 0;
  VideoReader& v = *reader.value();
  const cv::Size box(std::min(484, v.width()) & ~1, std::min(388, v.height()) & ~1);
  cv::RNG rng(7);
  cv::Mat crop;
  constexpr int kCrops = 24;
  const double t0 = thread_cpu_seconds();
  for (int k = 0; k < kCrops; ++k) {
    const std::int64_t at = pts_ms[std::size_t(rng.uniform(0, int(pts_ms.size())))];
    const cv::Rect r(rng.uniform(0, (v.width() - box.width) / 2 + 1) * 2,
                     rng.uniform(0, (v.height() - box.height) / 2 + 1) * 2, box.width, box.height);
    if (auto ok = v.read_raw_region_at(at, r, crop); !ok || !ok.value()) return 0;
  }
  const double s = thread_cpu_seconds() - t0;
  return s > 0 ? kCrops / s : 0;
}

// Holds the session's recording.lock for the whole run: no recorder, recover or other compact works
// on the folder meanwhile. The file goes at the end (also one a killed run left: it holds no data).
class FolderLock {
 public:
  static Result<FolderLock> take(const fs::path& dir) {
    const fs::path file = dir / kRecordingLock;
    const int fd = ::open(file.c_str(), O_CREAT | O_WRONLY | O_CLOEXEC, 0644);
    if (fd < 0) return Error{fmt::format("{}: cannot be opened: {}", file.string(), std::strerror(errno))};
    if (flock(fd, LOCK_EX | LOCK_NB) != 0) {
      ::close(fd);
      return Error{fmt::format("{}: is being recorded, recovered or compacted right now; compact it after that ends",
                               dir.string())};
    }
    return FolderLock(fd, file);
  }
  FolderLock(FolderLock&& o) noexcept : fd_(o.fd_), file_(std::move(o.file_)) { o.fd_ = -1; }
  FolderLock(const FolderLock&) = delete;
  ~FolderLock() {
    if (fd_ < 0) return;
    std::error_code ec;
    fs::remove(file_, ec);
    ::close(fd_);
  }

 private:
  FolderLock(int fd, fs::path file) : fd_(fd), file_(std::move(file)) {}
  int fd_;
  fs::path file_;
};

struct Segment {
  std::int64_t id = 0;
  std::string path;  // relative to the session folder, as the index has it
  std::string codec, layout, state;
  int bit_depth = 8;
  std::int64_t frames = 0;
};

std::vector<Segment> list_segments(sqlite::Database& db) {
  std::vector<Segment> out;
  for (const IndexedVideo& v : indexed_videos(db))
    out.push_back({v.id, v.path, v.codec, v.layout, v.state, v.bit_depth, v.kept_frames});
  return out;
}

// What an interrupted run left: its partial files, and for each segment the other file of its
// replacement (the new one when the index still names the old, the old one when it names the new).
void remove_leftovers(const fs::path& dir, const std::vector<Segment>& segments, CompactReport& report) {
  std::set<fs::path> referenced;
  for (const auto& s : segments) referenced.insert(fs::path(s.path).lexically_normal());
  std::set<fs::path> folders;
  for (const auto& s : segments) folders.insert(fs::path(s.path).parent_path());
  std::error_code ec;
  for (const auto& folder : folders)
    for (fs::directory_iterator it(dir / folder, ec), end; !ec && it != end; it.increment(ec))
      if (const std::string name = it->path().filename().string();
          name.size() > std::strlen(kPartialSuffix) && name.ends_with(kPartialSuffix)) {
        std::error_code rm;
        if (fs::remove(it->path(), rm))
          report.done.push_back(fmt::format("{}: removed (a copy an interrupted compact had not finished)", name));
      }
  for (const auto& s : segments) {
    const fs::path p(s.path);
    std::vector<fs::path> others{p.parent_path() / (base_name(p) + ".mkv")};
    for (const auto& [codec, tag] : compact_tags()) others.push_back(compacted_path(p, codec));
    for (const auto& other : others) {
      std::error_code rm;
      if (referenced.count(other.lexically_normal()) || !fs::exists(dir / other)) continue;
      if (fs::remove(dir / other, rm))
        report.done.push_back(
            fmt::format("{}: removed (the other half of a replacement an interrupted compact "
                        "left; the index names {})",
                        other.string(), s.path));
    }
  }
  if (Status d = sync_to_disk(dir); !d.ok()) report.done.push_back(d.error().message);
}

// The capture checksums of a segment's kept frames, by their position in the video.
std::map<std::int64_t, std::uint32_t> capture_checksums(sqlite::Database& db, std::int64_t id) {
  std::map<std::int64_t, std::uint32_t> out;
  for (const KeptFrameRow& row : kept_frames_of_video(db, id))
    if (row.video_index && row.checksum) out[*row.video_index] = *row.checksum;
  return out;
}

struct Copied {
  std::vector<std::uint32_t> crcs;  // of every stored picture, in file order
  std::vector<std::int64_t> pts_ms;
  std::int64_t checked_against_capture = 0;
};

class SegmentCompactor {
 public:
  SegmentCompactor(const fs::path& dir, SessionIndex& index, const CompactOptions& o, CompactReport& report,
                   std::int64_t& session_done, std::int64_t session_total)
      : dir_(dir), index_(index), o_(o), report_(report), session_done_(session_done), session_total_(session_total) {}

  // Ok(false): stopped (the stop flag, or after_step said so).
  Result<bool> run(const Segment& s) {
    const std::string codec = target_codec(s.bit_depth, o_);
    const fs::path old_file = dir_ / s.path;
    const fs::path new_rel = compacted_path(s.path, codec);
    const fs::path new_file = dir_ / new_rel;
    const fs::path partial = new_file.string() + kPartialSuffix;
    Copied copied;
    auto written = copy(s, codec, old_file, partial, copied);
    if (!written || !written.value()) {
      std::error_code ec;
      fs::remove(partial, ec);
      if (!written) return written.error();
      return false;
    }
    const std::uint64_t before = fs::file_size(old_file), after = fs::file_size(partial);
    if (after >= before) {
      std::error_code ec;
      fs::remove(partial, ec);
      ++report_.segments_kept;
      report_.done.push_back(fmt::format("{}: kept as it is ({} would be {:.2f} MB per frame, not smaller than {:.2f})",
                                         s.path, codec, mb_per_frame(after, copied.crcs.size()),
                                         mb_per_frame(before, copied.crcs.size())));
      return true;
    }
    if (auto c = check_copy(partial, copied); !c.ok()) {
      std::error_code ec;
      fs::remove(partial, ec);
      return c.error();
    }
    if (!copied.pts_ms.empty() && report_.crops_per_s_after == 0) {  // measured once, on the first segment
      report_.crops_per_s_before = crops_per_second(old_file, copied.pts_ms);
      report_.crops_per_s_after = crops_per_second(partial, copied.pts_ms);
    }
    if (!step("written")) return false;
    // The new file complete under its name before the index names it.
    fs::rename(partial, new_file);
    if (Status d = sync_to_disk(new_file.parent_path()); !d.ok()) return d.error();
    if (!step("renamed")) return false;
    {
      sqlite::Transaction tx(index_.db());
      rename_video_file(index_.db(), s.id, new_rel.string(), codec);
      tx.commit();  // synchronous=FULL: on disk before the old file goes
    }
    if (!step("committed")) return false;
    fs::remove(old_file);
    if (Status d = sync_to_disk(old_file.parent_path()); !d.ok()) return d.error();
    ++report_.segments_compacted;
    report_.frames += std::int64_t(copied.crcs.size());
    report_.bytes_before += before;
    report_.bytes_after += after;
    report_.done.push_back(fmt::format(
        "{} -> {}: {} frames, {:.2f} -> {:.2f} MB per frame ({:.0f} %), every frame bit-exact ({} checked against "
        "its capture checksum)",
        s.path, new_rel.string(), copied.crcs.size(), mb_per_frame(before, copied.crcs.size()),
        mb_per_frame(after, copied.crcs.size()), 100.0 * double(after) / double(before),
        copied.checked_against_capture));
    return true;
  }

 private:
  static double mb_per_frame(std::uint64_t bytes, std::size_t frames) {
    return frames ? double(bytes) / 1e6 / double(frames) : 0;
  }
  bool step(std::string_view name) const { return !o_.after_step || o_.after_step(name); }
  bool stopped() const { return o_.stop && o_.stop->load(); }

  // Decodes the old segment frame by frame, checks each against its capture checksum, and encodes
  // it into `partial` (closed and fsynced). Ok(false): stopped.
  Result<bool> copy(const Segment& s, const std::string& codec, const fs::path& old_file, const fs::path& partial,
                    Copied& copied) {
    auto reader = VideoReader::open(old_file);
    if (!reader) return reader.error();
    VideoReader& in = *reader.value();
    if (!in.raw())
      return Error{fmt::format("{}: is not a raw video (its file has no Bayer layout tags)", old_file.string())};
    VideoSettings vs;
    vs.bayer_format = in.bayer_format();
    vs.bit_depth = in.bit_depth();
    vs.layout = in.layout();  // the planes stay where the capture checksums have them
    vs.raw_codec = codec;
    vs.preset = o_.preset;
    vs.gop_frames = o_.gop_frames;
    if (codec == "ffvhuff") {
      // For training: every frame alone, in the source's tiles (or tiles of about 240 x 180 for a
      // store recorded in one picture), left prediction as the live store, Huffman tables fitted to
      // the segment's first frames, static: fewer bytes than the live store, decoded as fast (tables
      // fitted to each frame are as small, but rebuilt for every tile a crop reads; bench/lossless_bench
      // "stored layouts").
      vs.raw_codec_options = "pred=left";
      vs.gop_frames = 1;
      if (vs.bit_depth == 8) vs.residual_counts = residual_counts(old_file);
      vs.tile_cols = in.tiles() > 1 ? in.tile_cols() : std::max(1, int(std::lround(in.width() / 240.0)));
      vs.tile_rows = in.tiles() > 1 ? in.tile_rows() : std::max(1, int(std::lround(in.height() / 180.0)));
    }
    vs.threads = o_.threads;
    vs.width = in.width();
    vs.height = in.height();
    auto writer = VideoWriter::open(partial, vs);
    if (!writer) return writer.error();
    const auto capture = capture_checksums(index_.db(), s.id);
    cv::Mat picture, mosaic;
    std::int64_t pts_ms = 0;
    bool key = false;
    for (;;) {
      if (stopped()) return false;
      auto more = in.next_stored(picture, pts_ms, key);
      if (!more) return more.error();
      if (!more.value()) break;
      const std::int64_t k = std::int64_t(copied.crcs.size());
      const std::uint32_t crc = in.decoded_picture_crc().value_or(0);
      if (auto c = capture.find(k); c != capture.end()) {
        if (c->second != crc)
          return Error{
              fmt::format("{}: frame {} is not the bytes the camera sent (checksum {:08x}, captured {:08x}); "
                          "the segment is left as it is: run pvcap verify",
                          old_file.string(), k, crc, c->second)};
        ++copied.checked_against_capture;
      }
      unpack_bayer_planes(picture, mosaic, in.plane_order());
      auto w = writer.value()->write(mosaic, pts_ms * 1000);
      if (!w) return w.error();
      if (writer.value()->last_pts_ms() != pts_ms)
        return Error{fmt::format("{}: frame {} at {} ms would be stored at {} ms", old_file.string(), k, pts_ms,
                                 writer.value()->last_pts_ms())};
      copied.crcs.push_back(crc);
      copied.pts_ms.push_back(pts_ms);
      ++session_done_;
      if (o_.progress && (k % 8 == 7)) o_.progress(s.path, k + 1, s.frames, session_done_, session_total_);
    }
    if (std::int64_t(copied.crcs.size()) < s.frames)
      return Error{
          fmt::format("{}: holds {} frames, its index rows name {}; the segment is left as it is: run pvcap "
                      "verify",
                      old_file.string(), copied.crcs.size(), s.frames)};
    if (Status c = writer.value()->close(); !c.ok()) return c.error();  // fsyncs the file
    if (o_.progress) o_.progress(s.path, std::int64_t(copied.crcs.size()), s.frames, session_done_, session_total_);
    return true;
  }

  // The new file as it is on disk, decoded again: the same pictures at the same timestamps.
  static Status check_copy(const fs::path& file, const Copied& copied) {
    auto reader = VideoReader::open(file);
    if (!reader) return reader.error();
    cv::Mat picture;
    std::int64_t pts_ms = 0;
    bool key = false;
    std::size_t k = 0;
    for (;; ++k) {
      auto more = reader.value()->next_stored(picture, pts_ms, key);
      if (!more) return more.error();
      if (!more.value()) break;
      if (k >= copied.crcs.size() || reader.value()->decoded_picture_crc() != copied.crcs[k] ||
          pts_ms != copied.pts_ms[k])
        return Error{
            fmt::format("{}: frame {} does not decode to the original's (the re-encode is not bit-exact); "
                        "nothing replaced",
                        file.string(), k)};
    }
    if (k != copied.crcs.size())
      return Error{fmt::format("{}: holds {} frames of {}; nothing replaced", file.string(), k, copied.crcs.size())};
    return {};
  }

  const fs::path& dir_;
  SessionIndex& index_;
  const CompactOptions& o_;
  CompactReport& report_;
  std::int64_t& session_done_;
  std::int64_t session_total_;
};

}  // namespace

Result<CompactReport> compact_session(const fs::path& dir, const CompactOptions& o) {
  const auto started = std::chrono::steady_clock::now();
  if (!compact_tags().count(o.codec))
    return Error{fmt::format("compact: '{}' is not a codec compact writes (libx264, ffvhuff or ffv1)", o.codec)};
  const fs::path db_path = dir / "session.db";
  if (!fs::is_regular_file(db_path))
    return Error{fmt::format("{}: not a session folder (no session.db)", dir.string())};
  auto lock = FolderLock::take(dir);
  if (!lock) return lock.error();
  CompactReport report;
  try {
    auto index = SessionIndex::open_for_update(db_path);
    if (const auto session = session_row(index.db()); !session || !session->ended_host_ns)
      return Error{
          fmt::format("{}: was not closed (a crash or a kill ended it); run pvcap recover first", dir.string())};
    const auto segments = list_segments(index.db());
    for (const auto& s : segments)
      if (s.state == "open")
        return Error{fmt::format("{}: segment {} is still open; run pvcap recover first", dir.string(), s.path)};
    remove_leftovers(dir, segments, report);

    std::vector<Segment> todo;
    for (const auto& s : segments) {
      if (const std::string codec = target_codec(s.bit_depth, o); !is_bayer_planes_layout(s.layout) ||
                                                                  already_compacted(s.path, codec, s.codec) ||
                                                                  (s.state != "closed" && s.state != "recovered")) {
        ++report.segments_kept;
        continue;
      }
      todo.push_back(s);
    }
    // Each new name must be its segment's alone (names are made from the segment's own; a store named
    // otherwise could map two segments to one file): refused before anything is written.
    std::map<fs::path, std::string> named;
    for (const auto& s : segments) named[fs::path(s.path).lexically_normal()] = s.path;
    for (const auto& s : todo) {
      const fs::path target = compacted_path(s.path, target_codec(s.bit_depth, o)).lexically_normal();
      if (const auto [at, fresh] = named.emplace(target, s.path); !fresh)
        return Error{fmt::format("{}: cannot compact {}: its new name {} is {}'s", dir.string(), s.path,
                                 target.string(), at->second)};
    }
    std::int64_t session_total = 0, session_done = 0;
    for (const auto& s : todo) session_total += s.frames;
    if (todo.empty()) report.done.push_back("nothing to compact: no closed raw segment is in another codec");
    SegmentCompactor compactor(dir, index, o, report, session_done, session_total);
    for (const auto& s : todo) {
      auto r = compactor.run(s);
      if (!r) return r.error();
      if (!r.value()) {
        report.stopped = true;
        break;
      }
    }
    if (report.segments_compacted > 0)
      index.add_event(
          EventRecord{host_now().ns, "compacted", std::nullopt,
                      fmt::format("{} segments re-encoded to {} ({} -> {} bytes), every frame bit-exact",
                                  report.segments_compacted, o.codec, report.bytes_before, report.bytes_after)});
    checkpoint_index(index.db());
  } catch (const sqlite::SqliteError& e) {
    return Error{e.what()};
  } catch (const fs::filesystem_error& e) {
    return Error{e.what()};
  }
  report.elapsed_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  return report;
}

std::string describe_compact_report(const std::filesystem::path& dir, const CompactReport& r) {
  std::string out = fmt::format("session {}\n", dir.string());
  auto to = std::back_inserter(out);
  for (const auto& d : r.done) fmt::format_to(to, "  {}\n", d);
  if (r.segments_compacted > 0)
    fmt::format_to(to,
                   "compacted {} segments, {} frames in {:.1f} s ({:.1f} frames/s): {:.1f} -> {:.1f} MB ({:.0f} %)\n",
                   r.segments_compacted, r.frames, r.elapsed_s, r.elapsed_s > 0 ? double(r.frames) / r.elapsed_s : 0,
                   double(r.bytes_before) / 1e6, double(r.bytes_after) / 1e6,
                   100.0 * double(r.bytes_after) / double(r.bytes_before));
  if (r.crops_per_s_after > 0)
    fmt::format_to(to,
                   "read speed, shuffled 480x384 crops on one core (the first segment compacted): {:.0f} crops/s as "
                   "it was, {:.0f} crops/s compacted\n",
                   r.crops_per_s_before, r.crops_per_s_after);
  if (r.stopped) out += "stopped: the segments above are compacted, the rest are as they were; run it again to go on\n";
  return out;
}

}  // namespace pvcap
