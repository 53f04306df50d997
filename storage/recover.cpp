#include "storage/recover.h"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <fmt/format.h>

#include "core/time.h"
#include "core/version.h"
#include "storage/session_index.h"
#include "storage/video_repair.h"

namespace pvcap {

namespace {
std::string interrupted_name(const std::string& path) {
  const auto dot = path.rfind('.');
  return (dot == std::string::npos ? path : path.substr(0, dot)) + ".interrupted.mkv";
}

std::string describe_migration(const std::vector<int>& passed, const std::filesystem::path& db) {
  std::string versions;
  for (int v : passed) versions += fmt::format(" -> {}", v);
  return fmt::format("index upgraded{} (the old index is kept as {}.v{}.bak)", versions, db.string(),
                     passed.front() - 1);
}
}  // namespace

Result<std::vector<std::string>> migrate_session(const std::filesystem::path& dir,
                                                 const std::function<void(const std::string&)>& progress) {
  try {
    std::vector<int> passed;
    auto index = SessionIndex::open_for_update(dir / "session.db", &passed, progress);
    index.db().exec("PRAGMA wal_checkpoint(TRUNCATE)");
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
  if (!fs::is_regular_file(db_path)) return Error{fmt::format("{}: not a session folder (no session.db)", dir.string())};
  RecoverReport report;
  // A session still being recorded is not ours to touch (its recorder holds this lock while alive).
  if (const int fd = ::open((dir / kRecordingLock).c_str(), O_WRONLY | O_CLOEXEC); fd >= 0) {
    const bool live = flock(fd, LOCK_EX | LOCK_NB) != 0;
    ::close(fd);
    if (live) return Error{fmt::format("{}: is being recorded right now; recover it after the recording ends", dir.string())};
  }
  try {
    std::vector<int> passed;
    auto index = SessionIndex::open_for_update(db_path, &passed, progress);  // opening replays the write-ahead log
    if (!passed.empty()) report.done.push_back(describe_migration(passed, db_path));
    auto& db = index.db();

    {
      auto s = db.prepare("SELECT ended_host_ns IS NULL FROM session");
      if (!s.step()) return Error{fmt::format("{}: holds no session", db_path.string())};
      report.was_interrupted = s.column_int(0) != 0;
    }  // statements end before the checkpoint below, which needs no reader open

    struct Open {
      std::int64_t id;
      std::string path;
    };
    std::vector<Open> open;
    {
      auto q = db.prepare("SELECT id, path FROM video_files WHERE state = 'open' ORDER BY id");
      while (q.step()) open.push_back({q.column_int(0), q.column_text(1)});
    }

    for (const auto& v : open) {
      if (progress) progress(fmt::format("closing {}", v.path));
      const fs::path file = dir / v.path;
      const fs::path tmp = file.string() + ".recovering";
      const std::string aside = interrupted_name(v.path);
      if (!fs::exists(file) && fs::exists(tmp) && fs::exists(dir / aside)) {
        // An earlier recover stopped between its two renames: finish it.
        fs::rename(tmp, file);
        const auto r = reconcile_video_file(index, dir, v.id, "lost_at_interruption", "recovered");
        report.done.push_back(fmt::format("{}: closed with {} frames (finishing an earlier recover)", v.path,
                                          r.frames_in_file));
        continue;
      }
      std::int64_t indexed = 0;
      {
        auto rows = db.prepare("SELECT count(*) FROM frames WHERE video_file_id = ? AND kept = 1");
        rows.bind_all(v.id);
        if (rows.step()) indexed = rows.column_int(0);
      }
      auto on_disk = count_video_frames(file);
      if (!on_disk) {  // nothing readable (cut before its first cluster): rows say so, the file stays
        const auto r = reconcile_video_file(index, dir, v.id, "lost_at_interruption", "unreadable");
        report.done.push_back(fmt::format("{}: no readable frame ({}); {} indexed frames marked lost", v.path,
                                          on_disk.error().message, r.rows_marked_lost));
        continue;
      }
      const std::int64_t keep = std::min(indexed, on_disk.value());
      // Finish a copy first; only then move the cut original aside: a failure leaves the original as it was.
      std::error_code ec;
      fs::remove(tmp, ec);
      if (Status m = remux_prefix(file, tmp, keep); !m.ok()) {
        fs::remove(tmp, ec);
        const auto r = reconcile_video_file(index, dir, v.id, "lost_at_interruption", "interrupted");
        report.done.push_back(fmt::format("{}: could not be closed ({}); left as it is, {} frames readable, {} indexed "
                                          "frames marked lost",
                                          v.path, m.error().message, r.frames_in_file, r.rows_marked_lost));
        continue;
      }
      if (fs::exists(dir / aside)) return Error{fmt::format("{}: already exists; not overwriting it", (dir / aside).string())};
      fs::rename(file, dir / aside);
      fs::rename(tmp, file);
      const auto r = reconcile_video_file(index, dir, v.id, "lost_at_interruption", "recovered");
      std::string line = fmt::format("{}: closed with {} frames (the cut original is kept as {})", v.path,
                                     r.frames_in_file, aside);
      if (r.rows_marked_lost) line += fmt::format("; {} indexed frames never reached the disk", r.rows_marked_lost);
      if (on_disk.value() > keep)
        line += fmt::format("; {} frames on disk had no committed index row (left in the original)",
                            on_disk.value() - keep);
      report.done.push_back(line);
    }

    if (report.was_interrupted) {
      auto last = db.prepare(
          "SELECT max(t) FROM (SELECT max(host_ns) AS t FROM frames UNION ALL SELECT max(host_ns) FROM pressure_frames "
          "UNION ALL SELECT started_host_ns FROM session)");
      const std::int64_t end = last.step() ? last.column_int(0) : 0;
      last.reset();
      sqlite::Transaction tx(db);
      db.prepare("UPDATE session SET ended_host_ns = ?, end_reason = ?")
          .bind_all(end, fmt::format("interrupted; recovered by pvcap {}", kVersion))
          .run();
      tx.commit();
      report.done.push_back("the session's end set to its last stored frame (end_reason: interrupted)");
    }
    if (!report.done.empty()) {
      std::string summary;
      for (const auto& d : report.done) summary += (summary.empty() ? "" : "; ") + d;
      index.add_event(EventRecord{host_now().ns, "recovered", std::nullopt, summary});
    }
    db.exec("PRAGMA wal_checkpoint(TRUNCATE)");
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
