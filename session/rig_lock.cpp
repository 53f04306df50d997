#include "session/rig_lock.h"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <functional>

#include <fmt/format.h>

namespace pvcap::session {

namespace {

std::filesystem::path lock_folder() {
  std::error_code ec;
  const std::filesystem::path run = "/run/pvcap";
  std::filesystem::create_directories(run, ec);
  if (!ec && access(run.c_str(), W_OK) == 0) return run;
  return std::filesystem::temp_directory_path();
}

std::string read_holder(int fd) {
  char buf[1024];
  const ssize_t n = pread(fd, buf, sizeof buf - 1, 0);
  std::string s(buf, n > 0 ? std::size_t(n) : 0);
  while (!s.empty() && (s.back() == '\n' || s.back() == '\0')) s.pop_back();
  return s.empty() ? "another pvcap" : s;
}

}  // namespace

Result<std::unique_ptr<RigLock>> RigLock::acquire(const std::filesystem::path& rig_file) {
  std::error_code ec;
  std::filesystem::path rig = std::filesystem::weakly_canonical(rig_file, ec);
  if (ec) rig = std::filesystem::absolute(rig_file);
  const std::filesystem::path path =
      lock_folder() / fmt::format("rig-{:016x}.lock", std::hash<std::string>{}(rig.string()));
  const int fd = ::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  if (fd < 0) return Error{fmt::format("cannot make the rig's lock file {}: {}", path.string(), std::strerror(errno))};
  if (flock(fd, LOCK_EX | LOCK_NB) != 0) {
    const std::string holder = read_holder(fd);
    ::close(fd);
    return Error{
        fmt::format("{} is already recording: {}. One rig, one recorder: stop that session first "
                    "(Ctrl-C in its terminal)",
                    rig_file.string(), holder)};
  }
  std::unique_ptr<RigLock> lock(new RigLock(fd, path, rig));
  lock->write_holder("opening the devices");
  return lock;
}

RigLock::~RigLock() {
  if (fd_ < 0) return;
  if (ftruncate(fd_, 0) != 0) {
  }
  ::close(fd_);  // releases the lock; the file stays (removing it would race a new holder)
}

void RigLock::set_session(const std::filesystem::path& session_dir) {
  write_holder("recording into " + std::filesystem::absolute(session_dir).string());
}

void RigLock::write_holder(const std::string& where) {
  const std::string text = fmt::format("pvcap session pid {} ({}), {}\n", getpid(), rig_.string(), where);
  if (ftruncate(fd_, 0) != 0 || pwrite(fd_, text.data(), text.size(), 0) < 0) {
    // The lock holds regardless; only the message to a second recorder would be poorer.
  }
}

}  // namespace pvcap::session
