#pragma once
// One rig, one recorder. A recording holds an exclusive lock named after its rig file (in
// /run/pvcap, or the temporary folder when that cannot be made) for as long as it runs; the lock
// file says who holds it and where it records, so a second `pvcap session` on the same rig is
// refused with the running one's pid and folder. The kernel drops the lock when the process ends,
// however it ends: a crash never leaves the rig locked.
#include <filesystem>
#include <memory>
#include <string>

#include "core/result.h"

namespace pvcap::session {

class RigLock {
 public:
  // Fails, naming the holder, when another process records on `rig_file`.
  static Result<std::unique_ptr<RigLock>> acquire(const std::filesystem::path& rig_file);
  ~RigLock();
  RigLock(const RigLock&) = delete;
  RigLock& operator=(const RigLock&) = delete;

  // What the lock file tells a second recorder: this process records into `session_dir`.
  void set_session(const std::filesystem::path& session_dir);
  const std::filesystem::path& path() const { return path_; }

 private:
  RigLock(int fd, std::filesystem::path path, std::filesystem::path rig)
      : fd_(fd), path_(std::move(path)), rig_(std::move(rig)) {}
  void write_holder(const std::string& where);

  int fd_ = -1;
  std::filesystem::path path_, rig_;
};

}  // namespace pvcap::session
