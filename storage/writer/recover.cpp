#include "storage/writer/recover.h"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <map>
#include <memory>
#include <optional>
#include <set>

#include <fmt/format.h>

#include "core/durable_folder.h"
#include "core/rig_config.h"
#include "core/time.h"
#include "core/version.h"
#include "storage/index/index_queries.h"
#include "storage/index/session_index.h"
#include "storage/index/video_repair.h"
#include "storage/video/bayer_planes.h"
#include "storage/video/camera_video_settings.h"
#include "storage/video/video_writer.h"
#include "storage/video/view_video.h"
#include "storage/writer/frame_spill.h"
#include "storage/writer/index_journal.h"
#include "storage/writer/index_overflow.h"
#include "storage/writer/session_writer.h"

namespace pvcap {

namespace {
std::string interrupted_name(const std::string& path) {
  const auto dot = path.rfind('.');
  return (dot == std::string::npos ? path : path.substr(0, dot)) + ".interrupted.mkv";
}

// The name a segment is set aside under when the index has no row for it (see set_aside_unindexed).
std::string unindexed_name(const std::string& path) {
  const auto dot = path.rfind('.');
  return (dot == std::string::npos ? path : path.substr(0, dot)) + ".unindexed.mkv";
}

// Whether segment `path` (relative to the session folder) is taken on disk, under its own name, set
// aside, or as a view copy: recover's new segments never reuse such a number.
bool segment_name_taken(const std::filesystem::path& dir, const std::string& path) {
  namespace fs = std::filesystem;
  std::error_code ec;
  return fs::exists(dir / path, ec) || fs::exists(dir / interrupted_name(path), ec) ||
         fs::exists(dir / unindexed_name(path), ec) || fs::exists(dir / view_video_path(path), ec);
}

std::string describe_migration(const std::vector<int>& passed, const std::filesystem::path& db) {
  std::string versions;
  for (int v : passed) versions += fmt::format(" -> {}", v);
  return fmt::format("index upgraded{} (the old index is kept as {}.v{}.bak)", versions, db.string(),
                     passed.front() - 1);
}
// A camera's video segment opened by recover, for the frames of a spill.
struct SpillSegment {
  std::unique_ptr<VideoWriter> video;
  std::int64_t file_id = 0;
  std::string path;
};

// The camera's next segment, with the settings its other segments were written with.
Result<SpillSegment> open_next_segment(SessionIndex& index, const std::filesystem::path& dir, const StoreConfig& store,
                                       std::int64_t device_id) {
  const auto previous = last_segment_of(index.db(), device_id);
  if (!previous) return Error{fmt::format("device {} has no video file to follow", device_id)};
  const std::string& last = previous->path;
  const std::string bayer = previous->bayer_format.value_or("");
  VideoSettings vs = camera_video_settings(store, previous->width, previous->height, bayer);
  if (bayer.empty()) vs.bayer_format.clear();
  // The spilled frames' checksums were taken in the layout the session was recording with.
  if (is_bayer_planes_layout(previous->layout)) vs.layout = previous->layout;
  int segment = previous->segment + 1;
  SpillSegment o;
  const std::string stem = last.substr(0, last.rfind('-'));
  // A number no file holds: a segment the cut left without its row is on disk under the next one.
  while (segment_name_taken(dir, fmt::format("{}-{:03}.mkv", stem, segment))) ++segment;
  o.path = fmt::format("{}-{:03}.mkv", stem, segment);
  auto opened = VideoWriter::open(dir / o.path, vs);
  if (!opened) return opened.error();
  o.video = std::move(opened.value());
  VideoFileRecord rec{0, device_id, o.path, vs.stored_codec(), vs.stored_pixel_format(), vs.width, vs.height, segment};
  if (vs.raw()) {
    rec.layout = vs.layout;
    rec.bayer_format = vs.bayer_format;
    rec.bit_depth = vs.bit_depth;
  }
  rec.id = next_video_file_id(index.db());
  index.add_video_file(rec);
  o.file_id = rec.id;
  return o;
}

// Segments a cut left on disk without their row in the index: a segment begun in the last moment
// before the cut, its row lost with the rows after it (the journal's unsynced tail), so its frames
// have no rows either. Set aside under another name (with its view copy), never overwritten, and
// said with its frame count; its frames that came through the spill get their rows back when the
// spill is drained.
void set_aside_unindexed(SessionIndex& index, const std::filesystem::path& dir, RecoverReport& report) {
  namespace fs = std::filesystem;
  std::set<std::string> indexed;
  std::set<std::string> stems;  // the cameras' file names, from their indexed segments
  for (const IndexedVideo& v : indexed_videos(index.db())) {
    indexed.insert(v.path);
    if (const auto dash = v.path.rfind('-'); dash != std::string::npos) stems.insert(v.path.substr(0, dash));
  }
  std::vector<std::string> orphans;
  std::error_code ec;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    const auto dash = name.rfind('-');
    if (dash == std::string::npos || !stems.count(name.substr(0, dash)) || indexed.count(name)) continue;
    const std::string number = name.substr(dash + 1);
    if (number.size() < 5 || number.substr(number.size() - 4) != ".mkv") continue;
    const std::string digits = number.substr(0, number.size() - 4);
    if (std::all_of(digits.begin(), digits.end(), [](unsigned char c) { return std::isdigit(c); }))
      orphans.push_back(name);
  }
  std::sort(orphans.begin(), orphans.end());
  for (const std::string& name : orphans) {
    const auto frames = count_video_frames(dir / name);
    fs::rename(dir / name, dir / unindexed_name(name), ec);
    if (ec) {
      report.done.push_back(fmt::format("{}: not in the index and could not be set aside ({})", name, ec.message()));
      continue;
    }
    if (fs::exists(dir / view_video_path(name)))
      fs::rename(dir / view_video_path(name), dir / unindexed_name(view_video_path(name).string()), ec);
    report.done.push_back(fmt::format(
        "{}: on disk but not in the index (begun just before the cut, its row and its frames' rows were lost with "
        "it): {} kept as {}",
        name, frames ? fmt::format("{} frames", frames.value()) : std::string("no readable frame"),
        unindexed_name(name)));
  }
  if (!orphans.empty()) (void)sync_to_disk(dir);
}

// One spill file's frames that no video holds, encoded into new segments in one transaction: all of
// them committed and the spill deleted, or none and the spill kept for another try.
void drain_spill(SessionIndex& index, const std::filesystem::path& dir, const std::filesystem::path& file,
                 const StoreConfig& store, std::int64_t started_host_ns,
                 const std::function<void(const std::string&)>& progress, RecoverReport& report) {
  auto& db = index.db();
  std::map<std::int64_t, SpillSegment> writers;  // by device
  std::size_t encoded = 0, already = 0;
  std::optional<std::string> failure;
  sqlite::Transaction tx(db);
  auto read = read_spill_file(file, [&](SpillRecord&& r) {
    if (failure) return;
    if (frame_kept(db, r.rec.device_id, std::int64_t(r.rec.connection), std::int64_t(r.rec.sequence)) == true) {
      ++already;
      return;
    }
    auto it = writers.find(r.rec.device_id);
    if (it == writers.end()) {
      auto opened = open_next_segment(index, dir, store, r.rec.device_id);
      if (!opened) {
        failure = opened.error().message;
        return;
      }
      it = writers.emplace(r.rec.device_id, std::move(opened.value())).first;
    }
    const std::int64_t pts_us = (r.rec.mapped_ns.value_or(r.rec.host_ns) - started_host_ns) / 1000;
    auto at = it->second.video->write(r.image, pts_us);
    if (!at) {
      failure = at.error().message;
      return;
    }
    FrameRecord row = r.rec;
    row.kept = true;
    row.reason.clear();
    row.video_file_id = it->second.file_id;
    row.video_index = at.value();
    row.video_pts_ms = it->second.video->last_pts_ms();
    if (!place_frame_in_video(db, row)) index.add_frame(row);
    ++encoded;
    if (progress && encoded % 50 == 0)
      progress(fmt::format("{}: {} spilled frames encoded", file.filename().string(), encoded));
  });
  for (auto& [device, o] : writers) {
    const std::int64_t frames = o.video->frames_written();
    if (Status c = o.video->close(); !c.ok() && !failure) failure = c.error().message;
    index.close_video_file(VideoFileClosed{o.file_id, frames});
  }
  if (!read) failure = read.error().message;
  std::error_code ec;
  if (failure) {
    // Nothing of this file is committed; the spill stays for another try.
    tx.rollback();
    for (auto& [device, o] : writers) std::filesystem::remove(dir / o.path, ec);
    report.done.push_back(
        fmt::format("{}: could not be encoded ({}); kept for another recover", file.filename().string(), *failure));
    return;
  }
  tx.commit();
  std::filesystem::remove(file, ec);
  std::string line = fmt::format("{}: {} spilled frames encoded", file.filename().string(), encoded);
  for (const auto& [device, o] : writers) line += fmt::format(" into {}", o.path);
  if (already) line += fmt::format(" ({} were already in a video)", already);
  report.done.push_back(line);
}

// Frames spill files hold that no video does (the encoder was behind when the recording was cut):
// encoded into a new segment of their camera, and their rows made to say where they are. A spill
// is deleted once all its frames are in a committed video; a second run finds nothing to do.
void drain_spills(SessionIndex& index, const std::filesystem::path& dir,
                  const std::function<void(const std::string&)>& progress, RecoverReport& report) {
  namespace fs = std::filesystem;
  const fs::path folder = dir / kSpillFolder;
  std::error_code ec;
  if (!fs::is_directory(folder, ec)) return;
  std::vector<fs::path> files;
  for (const auto& e : fs::directory_iterator(folder))
    if (e.path().extension() == ".spill") files.push_back(e.path());
  std::sort(files.begin(), files.end());  // <camera>-<n>: each camera's episodes in order
  std::int64_t started_host_ns = 0;
  StoreConfig store;
  if (const auto session = session_row(index.db())) {
    started_host_ns = session->started_host_ns;
    try {
      store = parse_rig_config(session->rig_config, session->rig_path).store;
    } catch (const std::exception&) {
      // A stored rig text this pvcap cannot read: pvcap's default store settings encode the frames.
    }
  }
  for (const fs::path& file : files) drain_spill(index, dir, file, store, started_host_ns, progress, report);
  fs::remove(folder, ec);  // when empty
}

// Rows the index had not committed when the recording was cut: the journal's (every row not yet
// committed, storage/writer/index_journal.h) and the overflow's (rows that waited for a slow index,
// storage/writer/index_overflow.h). Their records are written into the index in their order, those it
// holds already left as they are, in one transaction; the files go only once they are committed,
// so a recover cut here and run again writes the same rows once. Their frames are on disk: the
// index must name them before the cut segments are closed against it.
void replay_waiting_rows(SessionIndex& index, const std::filesystem::path& dir, RecoverReport& report) {
  namespace fs = std::filesystem;
  std::vector<fs::path> files = index_journal_files(dir / kSpillFolder);
  std::error_code ec;
  if (fs::exists(dir / kSpillFolder / kIndexOverflowFile, ec)) files.push_back(dir / kSpillFolder / kIndexOverflowFile);
  if (files.empty()) return;
  std::size_t written = 0, held = 0;
  std::uint64_t unreadable = 0;
  {
    sqlite::Transaction tx(index.db());
    for (const fs::path& file : files) {
      auto rows = read_record_file(file);
      if (!rows) throw fs::filesystem_error(rows.error().message, file, std::make_error_code(std::errc::io_error));
      unreadable += rows.value().unreadable_bytes;
      for (const IndexRecord& r : rows.value().records) {
        if (index.holds(r)) {
          ++held;
          continue;
        }
        index.add(r);
        ++written;
      }
    }
    tx.commit();
  }
  for (const fs::path& file : files) fs::remove(file, ec);
  std::string said = fmt::format(
      "{} index rows not yet committed when the recording was cut written into the index from {} ({} it held "
      "already)",
      written, files.size() == 1 ? files[0].filename().string() : fmt::format("{} files of spill/", files.size()),
      held);
  if (unreadable > 0) said += fmt::format("; the last {} bytes were not a whole chunk (cut by the crash)", unreadable);
  report.done.push_back(said);
}

// The view video of a segment a crash left open (storage/video/view_video.h) is cut too: a cut file cannot
// seek, so the replay would read past it whole. Its readable frames go into a finished file that
// replaces it (it is a viewer's copy: nothing is kept aside); one with none is removed.
void close_cut_view(const std::filesystem::path& dir, const std::string& segment, RecoverReport& report) {
  namespace fs = std::filesystem;
  const fs::path view = dir / view_video_path(segment);
  std::error_code ec;
  if (!fs::is_regular_file(view, ec)) return;
  const fs::path tmp = view.string() + ".recovering";
  fs::remove(tmp, ec);
  const std::string name = view_video_path(segment).string();
  auto frames = count_video_frames(view);
  if (!frames || frames.value() == 0) {
    fs::remove(view, ec);
    report.done.push_back(fmt::format("{}: no readable frame; removed (the replay reads {})", name, segment));
    return;
  }
  if (Status m = remux_prefix(view, tmp, frames.value()); !m.ok()) {
    fs::remove(tmp, ec);
    fs::remove(view, ec);
    report.done.push_back(
        fmt::format("{}: could not be closed ({}); removed (the replay reads {})", name, m.error().message, segment));
    return;
  }
  fs::rename(tmp, view, ec);
  report.done.push_back(ec ? fmt::format("{}: could not be replaced ({})", name, ec.message())
                           : fmt::format("{}: closed with {} frames", name, frames.value()));
}

// Closes one segment a crash left open: a finished copy of its leading frames that are their index
// rows' frames replaces it (the cut original kept beside it), and rows past them are marked lost.
Status close_cut_segment(SessionIndex& index, const std::filesystem::path& dir, std::int64_t id,
                         const std::string& path, std::int64_t started_host_ns, RecoverReport& report) {
  namespace fs = std::filesystem;
  const fs::path file = dir / path;
  const fs::path tmp = file.string() + ".recovering";
  const std::string aside = interrupted_name(path);
  // An earlier recover killed after it moved the cut original aside: between its two renames (the
  // closed copy still under its temporary name), or after both, before the index said so (the
  // segment under its name is the closed copy). Finish it; never close the copy again.
  const bool between_renames = !fs::exists(file) && fs::exists(tmp);
  const bool after_renames = fs::exists(file) && !fs::exists(tmp);
  if (fs::exists(dir / aside) && (between_renames || after_renames)) {
    if (between_renames) fs::rename(tmp, file);
    if (Status d = sync_to_disk(dir); !d.ok()) return d.error();
    const auto r = reconcile_video_file(index, dir, id, "lost_at_interruption", "recovered");
    report.done.push_back(
        fmt::format("{}: closed with {} frames (finishing an earlier recover)", path, r.frames_in_file));
    return {};
  }
  close_cut_view(dir, path, report);  // once: a recover finishing an earlier one leaves the view as it is
  const auto indexed = std::int64_t(kept_frames_of_video(index.db(), id).size());
  auto on_disk = count_video_frames(file);
  // What is kept is the leading frames that are their rows' frames: after a power cut a segment's
  // tail may hold frames the demuxer reads past a hole, or frames partly overwritten.
  auto matching = on_disk ? count_frames_matching_index(index, dir, id, started_host_ns) : on_disk;
  if (!matching) {  // nothing readable (cut before its first cluster): rows say so, the file stays
    const auto r = reconcile_video_file(index, dir, id, "lost_at_interruption", "unreadable");
    report.done.push_back(fmt::format("{}: no readable frame ({}); {} indexed frames marked lost", path,
                                      matching.error().message, r.rows_marked_lost));
    return {};
  }
  const std::int64_t keep = std::min(indexed, matching.value());
  // Finish a copy first; only then move the cut original aside: a failure leaves the original as it was.
  std::error_code ec;
  fs::remove(tmp, ec);
  if (Status m = remux_prefix(file, tmp, keep); !m.ok()) {
    fs::remove(tmp, ec);
    const auto r = reconcile_video_file(index, dir, id, "lost_at_interruption", "interrupted");
    report.done.push_back(
        fmt::format("{}: could not be closed ({}); left as it is, {} frames readable, {} indexed "
                    "frames marked lost",
                    path, m.error().message, r.frames_in_file, r.rows_marked_lost));
    return {};
  }
  if (fs::exists(dir / aside))
    return Error{fmt::format("{}: already exists; not overwriting it", (dir / aside).string())};
  // The copy on disk before its name replaces the original's, and the names before the index says so.
  if (Status d = sync_to_disk(tmp); !d.ok()) return d.error();
  fs::rename(file, dir / aside);
  fs::rename(tmp, file);
  if (Status d = sync_to_disk(dir); !d.ok()) return d.error();
  const auto r = reconcile_video_file(index, dir, id, "lost_at_interruption", "recovered");
  std::string line =
      fmt::format("{}: closed with {} frames (the cut original is kept as {})", path, r.frames_in_file, aside);
  if (r.rows_marked_lost) line += fmt::format("; {} indexed frames never reached the disk", r.rows_marked_lost);
  if (keep < std::min(indexed, on_disk.value()))
    line += fmt::format(
        "; {} frames after it on disk are not the frames their rows name (cut writes; left in "
        "the original)",
        std::min(indexed, on_disk.value()) - keep);
  if (on_disk.value() > indexed)
    line +=
        fmt::format("; {} frames on disk had no committed index row (left in the original)", on_disk.value() - indexed);
  report.done.push_back(line);
  return {};
}

}  // namespace

Result<std::vector<std::string>> migrate_session(const std::filesystem::path& dir,
                                                 const std::function<void(const std::string&)>& progress) {
  try {
    std::vector<int> passed;
    auto index = SessionIndex::open_for_update(dir / "session.db", &passed, progress);
    checkpoint_index(index.db());
    if (passed.empty()) return std::vector<std::string>{fmt::format("already at store version {}", kSchemaVersion)};
    return std::vector<std::string>{describe_migration(passed, dir / "session.db")};
  } catch (const sqlite::SqliteError& e) {
    return Error{e.what()};
  }
}

Result<RecoverReport> recover_session(const std::filesystem::path& dir,
                                      const std::function<void(const std::string&)>& progress) {
  namespace fs = std::filesystem;
  const fs::path db_path = dir / "session.db";
  if (!fs::is_regular_file(db_path))
    return Error{fmt::format("{}: not a session folder (no session.db)", dir.string())};
  RecoverReport report;
  // A session still being recorded is not ours to touch (its recorder holds this lock while alive).
  if (const int fd = ::open((dir / kRecordingLock).c_str(), O_WRONLY | O_CLOEXEC); fd >= 0) {
    const bool live = flock(fd, LOCK_EX | LOCK_NB) != 0;
    ::close(fd);
    if (live)
      return Error{fmt::format("{}: is being recorded right now; recover it after the recording ends", dir.string())};
  }
  try {
    std::vector<int> passed;
    auto index = SessionIndex::open_for_update(db_path, &passed, progress);  // opening replays the write-ahead log
    if (!passed.empty()) report.done.push_back(describe_migration(passed, db_path));
    auto& db = index.db();

    const auto session = session_row(db);
    if (!session) return Error{fmt::format("{}: holds no session", db_path.string())};
    report.was_interrupted = !session->ended_host_ns;
    const std::int64_t started_host_ns = session->started_host_ns;

    replay_waiting_rows(index, dir, report);
    set_aside_unindexed(index, dir, report);

    for (const IndexedVideo& v : indexed_videos_in_state(db, "open")) {
      if (progress) progress(fmt::format("closing {}", v.path));
      if (Status c = close_cut_segment(index, dir, v.id, v.path, started_host_ns, report); !c.ok()) return c.error();
    }

    drain_spills(index, dir, progress, report);

    if (report.was_interrupted) {
      const std::int64_t end = last_stored_host_ns(db);
      sqlite::Transaction tx(db);
      index.finish_session(end, fmt::format("interrupted; recovered by pvcap {}", kVersion));
      tx.commit();
      report.done.push_back("the session's end set to its last stored frame (end_reason: interrupted)");
    }
    if (!report.done.empty()) {
      std::string summary;
      for (const auto& d : report.done) summary += (summary.empty() ? "" : "; ") + d;
      index.add_event(EventRecord{host_now().ns, "recovered", std::nullopt, summary});
    }
    checkpoint_index(db);
  } catch (const sqlite::SqliteError& e) {
    return Error{e.what()};
  } catch (const fs::filesystem_error& e) {
    return Error{e.what()};
  }
  // The space reserve and the lock of an interrupted recording hold no data.
  std::error_code ec;
  if (fs::remove(dir / "space-reserve", ec)) report.done.push_back("removed the unused space reserve");
  fs::remove(dir / kRecordingLock, ec);
  return report;
}

}  // namespace pvcap
