#include "core/durable_folder.h"

#include <dirent.h>
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <fstream>
#include <set>
#include <thread>

#include <fmt/format.h>

namespace pvcap {

namespace {

Status fsync_path_fd(int fd, const std::filesystem::path& path, const char* what) {
  if (fsync(fd) == 0) return {};
  return Error{fmt::format("{}: could not be made durable ({}: {}); what the disk holds of it may be incomplete",
                           path.string(), what, std::strerror(errno))};
}

// Each regular file of `folder` with its stat; false when the folder is not there (not made yet,
// as the spill, or gone with the session: nothing to keep).
template <typename Each>
bool for_each_file(const std::filesystem::path& folder, Each&& each) {
  DIR* d = opendir(folder.c_str());
  if (!d) return false;
  while (dirent* e = readdir(d)) {
    if (e->d_type != DT_REG && e->d_type != DT_UNKNOWN) continue;
    const std::filesystem::path path = folder / e->d_name;
    struct stat st {};
    if (stat(path.c_str(), &st) != 0 || !S_ISREG(st.st_mode)) continue;
    each(path, st);
  }
  closedir(d);
  return true;
}

}  // namespace

Status sync_to_disk(const std::filesystem::path& path) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0)
    return Error{fmt::format("{}: could not be made durable (open: {})", path.string(), std::strerror(errno))};
  Status s = fsync_path_fd(fd, path, "fsync");
  ::close(fd);
  return s;
}

Status write_file_atomically(const std::filesystem::path& file, std::string_view bytes, Durability durability) {
  namespace fs = std::filesystem;
  const fs::path tmp = file.string() + fmt::format(".tmp-{}", getpid());
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    out.write(bytes.data(), std::streamsize(bytes.size()));
    out.flush();
    if (!out) {
      const std::string why = std::strerror(errno);
      std::error_code ec;
      fs::remove(tmp, ec);
      // The temporary file is named too: it is the one the disk refused.
      return Error{
          fmt::format("{}: could not be written (writing {}: {})", file.string(), tmp.filename().string(), why)};
    }
  }
  if (durability == Durability::Synced)
    if (Status s = sync_to_disk(tmp); !s.ok()) return s;
  std::error_code ec;
  fs::rename(tmp, file, ec);
  if (ec) return Error{fmt::format("{}: could not be written: {}", file.string(), ec.message())};
  if (durability == Durability::Renamed) return {};
  return sync_to_disk(file.parent_path().empty() ? fs::path(".") : file.parent_path());
}

DurableFolder::DurableFolder(std::filesystem::path dir, std::vector<std::string> subfolders) : dir_(std::move(dir)) {
  folders_.push_back(dir_);
  for (const auto& s : subfolders) folders_.push_back(dir_ / s);
}

Status DurableFolder::list_folder(const std::filesystem::path& folder, std::vector<Changed>& changed,
                                  bool& entries_changed) {
  std::set<std::filesystem::path> present;
  const bool there = for_each_file(folder, [&](const std::filesystem::path& path, const struct stat& st) {
    present.insert(path);
    const Tracked& t = files_[path];
    if (t.size == st.st_size && t.mtime.tv_sec == st.st_mtim.tv_sec && t.mtime.tv_nsec == st.st_mtim.tv_nsec) return;
    changed.push_back({path, Tracked{st.st_size, st.st_mtim}, {}});
  });
  if (!there) return {};
  // Files that went (a drained spill file, a replaced segment): forget them.
  for (auto it = files_.begin(); it != files_.end();) {
    if (it->first.parent_path() == folder && !present.count(it->first)) {
      it = files_.erase(it);
      entries_changed = true;
    } else {
      ++it;
    }
  }
  std::size_t& known = entries_[folder];
  if (known != present.size()) entries_changed = true;
  known = present.size();
  return {};
}

// The changed files' fsyncs run side by side (a few threads): each fsync commits the file system's
// journal, and concurrent ones share a commit, so a round of a dozen busy files takes about as long
// as its slowest, not the sum (at 1080p, one by one, a round took 2 s).
void DurableFolder::sync_files(std::vector<Changed>& changed) {
  constexpr std::size_t kThreads = 4;
  std::atomic<std::size_t> next{0};
  auto work = [&] {
    for (std::size_t i = next++; i < changed.size(); i = next++) {
      const int fd = ::open(changed[i].path.c_str(), O_RDONLY | O_CLOEXEC);
      if (fd < 0) continue;  // removed between the listing and now
      changed[i].status = fsync_path_fd(fd, changed[i].path, "fsync");
      changed[i].synced = changed[i].status.ok();
      ::close(fd);
    }
  };
  std::vector<std::thread> helpers;
  for (std::size_t t = 1; t < std::min(kThreads, changed.size()); ++t) helpers.emplace_back(work);
  work();
  for (auto& h : helpers) h.join();
}

void DurableFolder::start_writeback() {
  std::set<std::filesystem::path> seen;
  for (const auto& folder : folders_)
    for_each_file(folder, [&](const std::filesystem::path& path, const struct stat& st) {
      seen.insert(path);
      auto [known, added] = written_back_.try_emplace(path, -1);
      if (!added && known->second == st.st_size) return;  // nothing new to write
      known->second = st.st_size;
      const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
      if (fd < 0) return;
      (void)sync_file_range(fd, 0, 0, SYNC_FILE_RANGE_WRITE);  // a failure shows at the next fsync
      ::close(fd);
    });
  // Files that went (a drained spill, a finished journal file) are forgotten.
  std::erase_if(written_back_, [&](const auto& entry) { return !seen.count(entry.first); });
}

Status DurableFolder::sync_changed() {
  const auto t0 = std::chrono::steady_clock::now();
  Status failure;
  std::vector<Changed> changed;
  std::vector<bool> entries_changed(folders_.size(), false);
  for (std::size_t f = 0; f < folders_.size(); ++f) {
    bool e = false;
    if (Status s = list_folder(folders_[f], changed, e); !s.ok() && failure.ok()) failure = s;
    entries_changed[f] = e;
  }
  sync_files(changed);
  for (const auto& c : changed) {
    if (!c.status.ok() && failure.ok()) failure = c.status;
    if (!c.synced) continue;
    files_[c.path] = c.seen;  // what it was when listed: a write since shows at the next round
    ++counts_.file_syncs;
  }
  bool any_entries_changed = false;
  for (std::size_t f = 0; f < folders_.size(); ++f) {
    if (!entries_changed[f]) continue;
    any_entries_changed = true;
    // A new (or removed) file's name is in its folder's data: synced too, or a power cut can keep a
    // file's bytes and lose its name.
    const int fd = ::open(folders_[f].c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (fd < 0) continue;
    if (Status s = fsync_path_fd(fd, folders_[f], "fsync of the folder"); !s.ok() && failure.ok()) failure = s;
    ::close(fd);
    ++counts_.folder_syncs;
  }
  // A subfolder made since the last round is an entry of the session folder (synced above when
  // its own entries changed too).
  if (any_entries_changed && !entries_changed[0] && folders_.size() > 1) {
    const int fd = ::open(dir_.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (fd >= 0) {
      if (Status s = fsync_path_fd(fd, dir_, "fsync of the folder"); !s.ok() && failure.ok()) failure = s;
      ::close(fd);
      ++counts_.folder_syncs;
    }
  }
  ++counts_.rounds;
  const auto end = std::chrono::steady_clock::now();
  const double ms = std::chrono::duration<double, std::milli>(end - t0).count();
  counts_.slowest_round_ms = std::max(counts_.slowest_round_ms, ms);
  counts_.last_round_ms = ms;
  counts_.last_gap_ms =
      counts_.rounds > 1 ? std::chrono::duration<double, std::milli>(end - last_round_start_).count() : 0;
  last_round_start_ = t0;
  return failure;
}

}  // namespace pvcap
