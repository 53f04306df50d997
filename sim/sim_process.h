#pragma once
// The simulated rig as a child process of a recording (`pvcap sim`), in the
// recording's network namespace, like a separate box on the wire. It ends with
// the recording, even when that is killed (the child asks for SIGTERM on its
// parent's death). A steerable one reads hand commands (sim/hand.h) on its stdin.
#include <sys/types.h>

#include <filesystem>
#include <memory>
#include <mutex>

#include "core/result.h"
#include "sim/hand.h"

namespace pvcap::sim {

class SimProcess {
 public:
  static Result<std::unique_ptr<SimProcess>> start(const std::filesystem::path& exe, const std::filesystem::path& rig,
                                                   const std::filesystem::path& truth_dir, bool steerable,
                                                   bool board = false);
  ~SimProcess();  // SIGTERM, then SIGKILL after 5 s
  SimProcess(const SimProcess&) = delete;
  SimProcess& operator=(const SimProcess&) = delete;

  // Sends a hand command (steerable simulators only); false when the simulator is gone.
  bool steer(const HandCommand& c);
  pid_t pid() const { return pid_; }

 private:
  SimProcess() = default;
  pid_t pid_ = -1;
  int commands_fd_ = -1;
  std::mutex mu_;
};

}  // namespace pvcap::sim
