#include "storage/writer/session_folder.h"

#include <fcntl.h>
#include <grp.h>
#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cctype>
#include <cerrno>
#include <chrono>
#include <cstdio>  // renameat2
#include <cstring>
#include <optional>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "core/durable_folder.h"
#include "core/time.h"
#include "core/version.h"
#include "storage/index/database.h"
#include "storage/index/index_queries.h"
#include "storage/index/session_index.h"

namespace pvcap {

namespace {

// A start killed between its hidden folder and the rename (kill -9, a power cut) leaves
// `.starting-<name>-<pid>` holding only an index with nothing recorded. Removed at the next start in
// the same sessions folder once its process is gone and it is a minute old (a start takes
// milliseconds; another machine starting in a shared folder has a pid this one does not know).
// One with anything else in it is kept and named. A tidy-up: nothing here stops a start.
void remove_start_leftovers(const std::filesystem::path& root) try {
  std::error_code ec;
  const auto now = std::filesystem::file_time_type::clock::now();
  for (const auto& entry : std::filesystem::directory_iterator(root, ec)) {
    const std::string name = entry.path().filename().string();
    std::error_code e;
    if (name.rfind(".starting-", 0) != 0 || !entry.is_directory(e)) continue;
    const std::string pid_text = name.substr(name.rfind('-') + 1);
    if (pid_text.empty() || pid_text.size() > 9 || pid_text.find_first_not_of("0123456789") != std::string::npos)
      continue;
    const auto pid = pid_t(std::stol(pid_text));
    if (pid <= 0 || kill(pid, 0) == 0 || errno != ESRCH) continue;  // its process may still be starting
    const auto modified = std::filesystem::last_write_time(entry.path(), e);
    if (e || now - modified < std::chrono::minutes(1)) continue;
    bool only_index = true;
    for (const auto& f : std::filesystem::directory_iterator(entry.path(), e)) {
      const std::string n = f.path().filename().string();
      only_index &= n == "session.db" || n == "session.db-wal" || n == "session.db-shm" || n == "session.db-journal";
    }
    if (e || !only_index) {
      spdlog::warn(
          "{}: left by a session start that did not finish, and it holds more than an empty index: kept "
          "(look inside, then remove it)",
          entry.path().string());
      continue;
    }
    if (std::filesystem::remove_all(entry.path(), e) > 0 && !e)
      spdlog::info("removed {}: left by a session start killed before it recorded anything (an empty index)",
                   entry.path().string());
  }
} catch (const std::filesystem::filesystem_error& e) {  // a folder listing that failed part-way
  spdlog::debug("looking for start-up leftovers in {}: {}", root.string(), e.what());
}

}  // namespace

std::string safe_file_name(std::string name) {
  for (char& c : name)
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '-' && c != '_') c = '-';
  return name;
}

Result<std::filesystem::path> make_session_folder(const std::filesystem::path& root, const RigConfig& rig,
                                                  std::int64_t started_wall_ns, std::int64_t started_host_ns) {
  std::optional<gid_t> lab_group;
  if (!rig.store.group.empty()) {
    const struct group* g = getgrnam(rig.store.group.c_str());
    if (!g)
      return Error{
          fmt::format("{}: store.group: there is no group '{}' on this machine", rig.source.string(), rig.store.group)};
    lab_group = g->gr_gid;
  }
  remove_start_leftovers(root);
  const std::string base = format_utc_compact(started_wall_ns) + "_" + safe_file_name(rig.name);
  const std::filesystem::path staging = root / fmt::format(".starting-{}-{}", base, getpid());
  if (mkdir(staging.c_str(), 0750) != 0)
    return Error{fmt::format("{}: cannot create the session folder: {}", staging.string(), std::strerror(errno))};
  auto unstage = [&staging](Error e) -> Error {
    std::error_code ignored;
    std::filesystem::remove_all(staging, ignored);
    return e;
  };
  // The lab's group reads the session: the folder is the group's, and setgid, so what is made in
  // it is the group's too (the umask leaves files 0640).
  if (lab_group && (chown(staging.c_str(), uid_t(-1), *lab_group) != 0 || chmod(staging.c_str(), 02750) != 0))
    return unstage(Error{fmt::format("{}: cannot give the session folder to group '{}' (store.group): {}",
                                     staging.string(), rig.store.group, std::strerror(errno))});
  try {
    SessionIndex index = SessionIndex::create(staging / "session.db");
    index.add_session(
        {started_wall_ns, started_host_ns, kVersion, rig.name, rig.source.string(), rig.text, rig.simulated});
    // Into the index file now, where a failure is an error: closing would checkpoint too, but
    // SQLite ignores what goes wrong there (a failed fsync of session.db went unsaid).
    checkpoint_index(index.db());
  } catch (const sqlite::SqliteError& e) {
    return unstage(Error{e.what()});
  }
  std::filesystem::path dir;
  for (int n = 1;; ++n) {
    const auto candidate = root / (n == 1 ? base : fmt::format("{}-{}", base, n));
    // Atomic and never over an existing session (RENAME_NOREPLACE).
    if (renameat2(AT_FDCWD, staging.c_str(), AT_FDCWD, candidate.c_str(), RENAME_NOREPLACE) == 0) {
      dir = candidate;
      break;
    }
    if (errno != EEXIST || n > 999)
      return unstage(
          Error{fmt::format("{}: cannot create the session folder: {}", candidate.string(), std::strerror(errno))});
  }
  // The session folder's name is an entry of the sessions folder: until that is synced, a power cut
  // can lose the whole session however often its files are (found by the power-cut test).
  if (Status s = sync_to_disk(root); !s.ok()) {
    std::error_code ignored;
    std::filesystem::remove_all(dir, ignored);
    return s.error();
  }
  return dir;
}

}  // namespace pvcap
