#include "storage/tools/verify.h"

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <mutex>

#include <fmt/format.h>

#include "codec/sensel_frame.h"
#include "core/side_by_side.h"
#include "storage/index/index_queries.h"
#include "storage/index/pressure_blob.h"
#include "storage/index/session_index.h"
#include "storage/video/frame_checksum.h"
#include "storage/video/video_reader.h"
#include "storage/video/view_video.h"

namespace pvcap {

namespace {

// The checks of one session folder, step by step, each adding to the report.
class Verifier {
 public:
  Verifier(const std::filesystem::path& dir, const std::function<void(const std::string&)>& progress, VerifyReport& r)
      : dir_(dir),
        db_path_(dir / "session.db"),
        progress_(progress),
        r_(r),
        db_(db_path_, sqlite::Database::Mode::ReadOnly) {}

  void run() {
    if (!check_format() || !check_session_row()) return;
    check_videos();
    check_pressure();
    check_samples();
    check_recorded_losses();
  }

 private:
  void say(const std::string& step) const {
    const std::lock_guard lock(progress_mutex_);
    if (progress_) progress_(step);
  }

  // A store this pvcap reads, and not damaged as a database.
  bool check_format() {
    const int version = db_.user_version();
    if (version != kSchemaVersion) {
      r_.errors.push_back(
          version < kSchemaVersion && version >= 1
              ? fmt::format("{}: written by an older pvcap (store version {}); 'pvcap migrate {}' upgrades it to "
                            "version {} (keeping a copy of the old index)",
                            db_path_.string(), version, dir_.string(), kSchemaVersion)
              : fmt::format("{}: store format version {}; this pvcap reads version {}", db_path_.string(), version,
                            kSchemaVersion));
      return false;
    }
    if (const std::string check = index_quick_check(db_); check != "ok")
      r_.errors.push_back(fmt::format("{}: damaged: {}", db_path_.string(), check));
    return true;
  }

  // How the recording ended.
  bool check_session_row() {
    const auto session = session_row(db_);
    if (!session) {
      r_.errors.push_back(fmt::format("{}: no session row", db_path_.string()));
      return false;
    }
    started_ = session->started_host_ns;
    clean_end_ = session->ended_host_ns.has_value();
    if (clean_end_) r_.session_s = double(*session->ended_host_ns - started_) / 1e9;
    const std::string& reason = session->end_reason;
    if (!clean_end_)
      r_.losses.push_back(
          "the recording did not end cleanly (crash, kill or power loss): 'pvcap recover' makes it "
          "readable");
    else if (reason.rfind("interrupted", 0) == 0)
      r_.losses.push_back(fmt::format("the recording was interrupted ({}): its last moments are lost", reason));
    else
      r_.facts.push_back(fmt::format("ended: {}", reason));
    return true;
  }

  // Videos against the index, several at once: decoding a raw video and checking its frames keeps
  // one core busy, so a session's videos (a camera's each) are checked side by side, and what each
  // found is said in the index's order.
  void check_videos() {
    std::vector<VideoJob> jobs;
    for (const IndexedVideo& v : indexed_videos(db_)) jobs.push_back({v.id, v.path, v.camera, v.state, {}});
    for (VideoJob& job : jobs) job.kept = kept_rows(job.id);
    std::vector<VideoFindings> found(jobs.size());
    run_side_by_side(jobs.size(), kMaxVideoThreads, [&](std::size_t i, std::size_t) {
      try {
        check_video(jobs[i], found[i]);
      } catch (const std::exception& e) {  // out of memory, say: that video is not checked
        found[i].errors.push_back(fmt::format("{}: could not be checked: {}", jobs[i].path, e.what()));
      }
    });

    std::size_t checked = 0, damaged = 0;
    for (const VideoFindings& f : found) {
      for (auto [from, to] : {std::pair{&f.facts, &r_.facts}, {&f.losses, &r_.losses}, {&f.errors, &r_.errors}})
        to->insert(to->end(), from->begin(), from->end());
      checked += f.checked;
      damaged += f.damaged;
    }
    if (checked)
      r_.facts.push_back(
          fmt::format("video frames: {} checked against their capture checksum, {} damaged", checked, damaged));
    report_view_videos(found);
  }

  // A video's kept rows, in video order.
  struct KeptRow {
    std::optional<std::int64_t> video_index;
    VideoTimestamp ts;
    std::optional<std::uint32_t> checksum;
    std::int64_t connection = 0, sequence = 0;
  };

  struct VideoJob {
    std::int64_t id = 0;
    std::string path, camera, state;
    std::vector<KeptRow> kept;
  };

  // What checking one video found, said in the report in the index's order of videos.
  struct VideoFindings {
    std::vector<std::string> facts, losses, errors;
    std::size_t checked = 0, damaged = 0;          // frames checked against their capture checksum
    bool has_view = false;                         // a view video beside it
    std::size_t view_frames = 0, kept_frames = 0;  // kept frames in its view video; in the index
  };

  std::vector<KeptRow> kept_rows(std::int64_t file_id) {
    std::vector<KeptRow> kept;
    for (const KeptFrameRow& row : kept_frames_of_video(db_, file_id))
      kept.push_back({row.video_index, video_timestamp(row.video_pts_ms, row.host_ns, started_), row.checksum,
                      row.connection, row.sequence});
    return kept;
  }

  // One video against its index rows (no member of this class is written: several run at once).
  void check_video(const VideoJob& job, VideoFindings& f) const {
    const std::string& path = job.path;
    const std::vector<KeptRow>& kept = job.kept;
    // A segment left open by a crash, or cut by a failed write, may hold frames whose rows were
    // never committed, or miss frames whose rows were: losses, not damage. A closed one may not.
    const bool finished = job.state == "closed" || job.state == "recovered";
    if (job.state == "open" && !clean_end_)
      f.losses.push_back(
          fmt::format("{}: was being written when the recording stopped; 'pvcap recover' closes it", path));
    say(fmt::format("checking {}", path));
    auto reader = VideoReader::open(dir_ / path);
    if (!reader) {
      // Cut before its first frame reached the disk, or before any of its frames had a committed
      // row (recover then closes it with none: a file without frames, which no reader opens): a
      // loss when nothing indexed is in it or the recording was interrupted; damage otherwise.
      const bool cut_early = (job.state == "open" && !clean_end_) || job.state == "unreadable";
      if (kept.empty())
        f.losses.push_back(fmt::format("{}: holds no readable frame and no indexed one ({})", path,
                                       cut_early ? "cut before its first frame was written" : reader.error().message));
      else
        ((cut_early ? f.losses : f.errors))
            .push_back(
                fmt::format("{}: {}; {} indexed frames cannot be read", path, reader.error().message, kept.size()));
      check_view_video(path, kept, f);
      return;
    }
    // A raw video is decoded frame by frame and each picture checked against the checksum its
    // camera's bytes got at capture; a colour (lossy) one is read packet by packet.
    VideoReader& video = *reader.value();
    std::size_t n = 0, wrong_time = 0, key_frames = 0;
    std::vector<std::string> damaged;
    std::int64_t pts_ms = 0;
    bool key = false;
    std::string read_error;
    cv::Mat picture;
    for (;;) {
      auto more = video.raw() ? video.next_stored(picture, pts_ms, key) : video.next_packet(pts_ms, key);
      if (!more) {
        read_error = more.error().message;
        break;
      }
      if (!more.value()) break;
      if (n < kept.size()) {
        const KeptRow& row = kept[n];
        if (std::llabs(pts_ms - row.ts.ms) > row.ts.tolerance_ms) ++wrong_time;
        if (video.raw() && row.checksum) {
          ++f.checked;
          if (const std::uint32_t crc = picture_crc(picture); crc != *row.checksum)
            damaged.push_back(
                fmt::format("{}: frame {} ({} connection {} sequence {}): its pixels are not the bytes "
                            "the camera sent (checksum at capture {:08x}, stored picture {:08x})",
                            path, n, job.camera, row.connection, row.sequence, *row.checksum, crc));
        }
      }
      key_frames += key;
      ++n;
    }
    report_video(path, n, kept, key_frames, f.checked, wrong_time, read_error, clean_end_ && finished, f);
    for (std::size_t i = 0; i < damaged.size() && i < kMaxNamed; ++i) f.errors.push_back(damaged[i]);
    if (damaged.size() > kMaxNamed)
      f.errors.push_back(fmt::format("{}: {} more damaged frames", path, damaged.size() - kMaxNamed));
    f.damaged = damaged.size();
    check_view_video(path, kept, f);
  }

  static void report_video(const std::string& path, std::size_t n, const std::vector<KeptRow>& kept,
                           std::size_t key_frames, std::size_t checked, std::size_t wrong_time,
                           const std::string& read_error, bool must_be_whole, VideoFindings& f) {
    bool contiguous = true;
    for (std::size_t i = 0; i < kept.size(); ++i) contiguous &= kept[i].video_index == std::int64_t(i);
    f.facts.push_back(
        fmt::format("{}: {} frames in the video, {} kept in the index, {} key frames, {} checked against "
                    "their capture checksum",
                    path, n, kept.size(), key_frames, checked));
    if (!read_error.empty()) f.errors.push_back(read_error);
    if (!contiguous) f.errors.push_back(fmt::format("{}: the index's video positions are not 0, 1, 2, ...", path));
    // A session that did not end cleanly may lose the open part of a video; one that did, may not.
    auto& missing = must_be_whole ? f.errors : f.losses;
    if (n < kept.size())
      missing.push_back(fmt::format("{}: {} indexed frames are missing from the video (it ends at frame {})", path,
                                    kept.size() - n, n));
    if (n > kept.size())
      missing.push_back(fmt::format("{}: {} frames in the video have no index row", path, n - kept.size()));
    if (wrong_time)
      f.errors.push_back(fmt::format("{}: {} frames carry another timestamp than their index row", path, wrong_time));
  }

  // A segment's view video (storage/video/view_video.h): the kept frames the replay finds in it. It is not
  // the record, so what it lacks or cannot be read is said as a fact, never as a loss.
  void check_view_video(const std::string& path, const std::vector<KeptRow>& kept, VideoFindings& f) const {
    f.kept_frames = kept.size();
    const std::filesystem::path view = view_video_path(path);
    if (!std::filesystem::exists(dir_ / view)) return;
    f.has_view = true;
    auto reader = VideoReader::open(dir_ / view);
    if (!reader) {
      f.facts.push_back(fmt::format("{}: cannot be read ({}); the replay reads {} from the lossless video",
                                    view.string(), reader.error().message, path));
      return;
    }
    // Both in time order: a view packet counts when it is a kept frame's (a view skips frames whose
    // encoder was behind, and ends where a crash cut it).
    std::size_t k = 0;
    for (std::int64_t pts_ms = 0;;) {
      bool key = false;
      auto more = reader.value()->next_packet(pts_ms, key);
      if (!more || !more.value()) break;
      while (k < kept.size() && kept[k].ts.ms + kept[k].ts.tolerance_ms < pts_ms) ++k;
      if (k < kept.size() && std::llabs(pts_ms - kept[k].ts.ms) <= kept[k].ts.tolerance_ms) {
        ++f.view_frames;
        ++k;
      }
    }
  }

  void report_view_videos(const std::vector<VideoFindings>& found) {
    std::size_t segments = 0, frames = 0, kept = 0;
    for (const VideoFindings& f : found) {
      segments += f.has_view;
      frames += f.view_frames;
      kept += f.kept_frames;
    }
    if (found.empty()) return;
    if (!segments) {
      r_.facts.push_back(
          "view videos: none (recorded without them, or by an older pvcap); the replay decodes the lossless videos");
      return;
    }
    r_.facts.push_back(fmt::format(
        "view videos (the replay's small copies, not the record): {} of {} segments, {} of {} kept frames{}", segments,
        found.size(), frames, kept, frames < kept ? "; the replay reads the others from the lossless videos" : ""));
  }

  // The device payload parses on its grid, and the portable counts beside it hold the same image.
  void check_pressure() {
    say("checking pressure frames");
    std::size_t total = 0, bad = 0, checksummed = 0, damaged = 0;
    std::string first_bad;
    auto fail = [&](std::int64_t seq, const std::string& why) {
      if (!bad++) first_bad = fmt::format("sequence {}: {}", seq, why);
    };
    for_each_stored_pressure_frame(db_, [&](const StoredPressureRow& q) {
      ++total;
      const auto& payload = q.payload;
      if (q.checksum) {
        ++checksummed;
        if (const std::uint32_t crc = crc32_of(payload.data(), payload.size()); crc != *q.checksum) {
          if (damaged++ < kMaxNamed)
            r_.errors.push_back(
                fmt::format("pressure frame (connection {} sequence {}): its payload is not the bytes "
                            "the Sensel sent (checksum at capture {:08x}, stored {:08x})",
                            q.connection, q.sequence, *q.checksum, crc));
          return;
        }
      }
      const sensel::Grid grid{q.grid_cols, q.grid_rows, q.grid_xscale, q.grid_yscale};
      auto f = sensel::parse_frame(payload, grid);
      if (!f) {
        fail(q.sequence, f.error().message);
        return;
      }
      const auto& image = f.value().pressure;
      if (image.has_value() != q.counts.has_value()) {
        fail(q.sequence, image ? "its counts are missing" : "counts stored for a frame without pressure");
        return;
      }
      if (!image) return;
      auto counts = decompress_counts(*q.counts, std::size_t(grid.cells()));
      if (!counts)
        fail(q.sequence, counts.error().message);
      else if (counts.value() != image->counts || q.base != image->base)
        fail(q.sequence, "its counts differ from its device payload");
    });
    r_.facts.push_back(
        fmt::format("pressure frames: {} stored, {} decode, {} checked against their capture checksum, "
                    "{} damaged",
                    total, total - bad - damaged, checksummed, damaged));
    if (damaged > kMaxNamed) r_.errors.push_back(fmt::format("{} more damaged pressure frames", damaged - kMaxNamed));
    if (bad) r_.errors.push_back(fmt::format("{} pressure frames do not decode (first: {})", bad, first_bad));
  }

  // Samples name frames that are in the videos.
  void check_samples() {
    const IndexTallies& t = tallies();
    r_.facts.push_back(fmt::format("samples: {}", t.samples));
    if (t.sample_frames_not_in_video)
      r_.losses.push_back(
          fmt::format("{} sample frames are not in a video (frames.reason says why)", t.sample_frames_not_in_video));
    if (t.has_sensel && t.samples_without_pressure)
      r_.losses.push_back(fmt::format("{} samples have no pressure frame", t.samples_without_pressure));
  }

  // Losses recorded during capture.
  void check_recorded_losses() {
    const IndexTallies& t = tallies();
    auto with_reason = [&](const char* why) {
      const auto it = t.frames_by_reason.find(why);
      return it == t.frames_by_reason.end() ? std::int64_t(0) : it->second;
    };
    if (t.frames_dropped) r_.losses.push_back(fmt::format("{} frames never arrived (drops table)", t.frames_dropped));
    if (t.frames_incomplete)
      r_.losses.push_back(fmt::format("{} frames arrived incomplete (frames.status)", t.frames_incomplete));
    if (const auto n = with_reason("encoder_behind"))
      r_.losses.push_back(fmt::format("{} kept frames were not encoded in time (reason encoder_behind)", n));
    for (const char* why : {"lost_at_interruption", "video_write_failed", "spill_write_failed", "storage_failed"})
      if (const auto n = with_reason(why))
        r_.losses.push_back(fmt::format("{} frames meant for a video are not in it (reason {})", n, why));
    // Frames still waiting in a spill (a crash caught the encoder behind): recover encodes them.
    std::error_code ec;
    std::size_t spills = 0;
    for (std::filesystem::directory_iterator it(dir_ / kSpillFolder, ec), end; !ec && it != end; it.increment(ec))
      spills += it->path().extension() == ".spill";
    if (spills)
      r_.losses.push_back(
          fmt::format("{}: {} spill file(s) hold frames that may not be in a video yet; 'pvcap "
                      "recover' encodes them",
                      (dir_ / kSpillFolder).string(), spills));
  }

  // The index's counts, read once for the checks that use them.
  const IndexTallies& tallies() {
    if (!tallies_) tallies_ = index_tallies(db_);
    return *tallies_;
  }

  const std::filesystem::path dir_, db_path_;
  const std::function<void(const std::string&)>& progress_;
  VerifyReport& r_;
  sqlite::Database db_;
  std::optional<IndexTallies> tallies_;
  std::int64_t started_ = 0;
  bool clean_end_ = true;
  mutable std::mutex progress_mutex_;                 // videos are checked on several threads
  static constexpr std::size_t kMaxNamed = 20;        // damaged frames named one by one, per file
  static constexpr std::size_t kMaxVideoThreads = 4;  // a rig's cameras; more would only seek the disk
};

}  // namespace

VerifyReport verify_session(const std::filesystem::path& dir, const std::function<void(const std::string&)>& progress) {
  VerifyReport r;
  const auto t0 = std::chrono::steady_clock::now();
  if (!std::filesystem::exists(dir / "session.db")) {
    r.errors.push_back(fmt::format("{}: not a session folder (no session.db)", dir.string()));
    return r;
  }
  try {
    Verifier(dir, progress, r).run();
  } catch (const sqlite::SqliteError& e) {
    r.errors.push_back(fmt::format("{}: {}", (dir / "session.db").string(), e.what()));
  }
  r.elapsed_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

std::string format_report(const std::filesystem::path& dir, const VerifyReport& r) {
  std::string out = fmt::format("session {}\n", dir.string());
  for (const auto& f : r.facts) out += "  " + f + "\n";
  for (const auto& l : r.losses) out += "  LOSS: " + l + "\n";
  for (const auto& e : r.errors) out += "  ERROR: " + e + "\n";
  if (r.session_s > 0)
    out += fmt::format("checked in {:.1f} s; the session lasted {:.1f} s\n", r.elapsed_s, r.session_s);
  else
    out += fmt::format("checked in {:.1f} s\n", r.elapsed_s);
  out += r.exit_code() == 0   ? "verdict: clean\n"
         : r.exit_code() == 3 ? "verdict: lossy but readable (exit 3)\n"
                              : "verdict: FAILED: parts cannot be read as indexed (exit 1)\n";
  return out;
}

}  // namespace pvcap
