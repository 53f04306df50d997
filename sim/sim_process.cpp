#include "sim/sim_process.h"

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <string>
#include <thread>
#include <vector>

#include <fmt/format.h>

extern char** environ;

namespace pvcap::sim {

Result<std::unique_ptr<SimProcess>> SimProcess::start(const std::filesystem::path& exe,
                                                      const std::filesystem::path& rig,
                                                      const std::filesystem::path& truth_dir, bool steerable,
                                                      bool board) {
  std::unique_ptr<SimProcess> self(new SimProcess());
  std::vector<std::string> args = {exe.string(), "--log-level", "warn",    "sim",
                                   "--rig",      rig.string(),  "--truth", truth_dir.string()};
  if (steerable) args.push_back("--hand-commands");
  if (board) args.push_back("--board");
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  int fds[2] = {-1, -1};
  if (steerable && pipe2(fds, O_CLOEXEC) != 0)
    return Error{fmt::format("cannot start the simulator: pipe: {}", std::strerror(errno))};
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  if (steerable) posix_spawn_file_actions_adddup2(&actions, fds[0], STDIN_FILENO);  // dup2 clears CLOEXEC
  // Its own process group, as real devices are: the terminal's Ctrl-C or hang-up reaches the
  // recorder, which stops the simulator itself after the devices' last frames (and it dies with
  // the recorder: PR_SET_PDEATHSIG in `pvcap sim`).
  posix_spawnattr_t attr;
  posix_spawnattr_init(&attr);
  posix_spawnattr_setflags(&attr, POSIX_SPAWN_SETPGROUP);
  posix_spawnattr_setpgroup(&attr, 0);
  const int rc = posix_spawn(&self->pid_, exe.c_str(), &actions, &attr, argv.data(), environ);
  posix_spawnattr_destroy(&attr);
  posix_spawn_file_actions_destroy(&actions);
  if (steerable) close(fds[0]);
  if (rc != 0) {
    if (steerable) close(fds[1]);
    self->pid_ = -1;
    return Error{fmt::format("cannot start the camera simulator ({}): {}", exe.string(), std::strerror(rc))};
  }
  self->commands_fd_ = steerable ? fds[1] : -1;
  return self;
}

SimProcess::~SimProcess() {
  if (commands_fd_ >= 0) close(commands_fd_);
  if (pid_ <= 0) return;
  kill(pid_, SIGTERM);
  int status = 0;
  using namespace std::chrono_literals;
  // Looked at every 5 ms for up to 5 s: it ends within ~0.2 s, and every session waits for it.
  for (int i = 0; i < 1000 && waitpid(pid_, &status, WNOHANG) == 0; ++i) std::this_thread::sleep_for(5ms);
  if (waitpid(pid_, &status, WNOHANG) == 0) {
    kill(pid_, SIGKILL);
    waitpid(pid_, &status, 0);
  }
}

bool SimProcess::steer(const HandCommand& c) {
  std::lock_guard lock(mu_);
  if (commands_fd_ < 0) return false;
  const std::string line = c.format() + "\n";
  // A line is far below PIPE_BUF, so the write is atomic; SIGPIPE is ignored by the pvcap command.
  return write(commands_fd_, line.data(), line.size()) == ssize_t(line.size());
}

}  // namespace pvcap::sim
