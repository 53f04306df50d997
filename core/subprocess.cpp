#include "core/subprocess.h"

#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <fcntl.h>

#include <cerrno>
#include <cstring>

#include <fmt/format.h>

extern "C" char** environ;

namespace pvcap {

namespace {
ProgramOutput with_status(ProgramOutput out, int status) {
  out.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return out;
}
}  // namespace

Result<ProgramOutput> run_program(const std::vector<std::string>& args,
                                  std::optional<std::chrono::milliseconds> time_limit) {
  if (args.empty()) return Error{"no program to run"};
  int out[2];
  if (pipe2(out, O_CLOEXEC) != 0) return Error{fmt::format("cannot run {}: {}", args[0], std::strerror(errno))};
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_adddup2(&actions, out[1], STDOUT_FILENO);
  posix_spawn_file_actions_adddup2(&actions, out[1], STDERR_FILENO);
  std::vector<char*> argv;
  for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  pid_t pid = 0;
  const int rc = posix_spawnp(&pid, args[0].c_str(), &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  close(out[1]);
  if (rc != 0) {
    close(out[0]);
    return Error{fmt::format("cannot run {}: {}", args[0], std::strerror(rc))};
  }
  ProgramOutput result;
  const auto deadline = time_limit ? std::chrono::steady_clock::now() + *time_limit
                                   : std::chrono::steady_clock::time_point::max();
  char buf[4096];
  for (;;) {
    int wait_ms = -1;
    if (time_limit) {
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
      if (left.count() <= 0) {
        result.timed_out = true;
        kill(pid, SIGKILL);
        break;
      }
      wait_ms = int(left.count());
    }
    pollfd p{out[0], POLLIN, 0};
    const int ready = poll(&p, 1, wait_ms);
    if (ready < 0 && errno == EINTR) continue;
    if (ready < 0) break;
    if (ready == 0) continue;  // the deadline is checked above
    const ssize_t n = read(out[0], buf, sizeof buf);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;  // its end of the pipe closed: it has ended (or closed its output)
    result.text.append(buf, std::size_t(n));
  }
  close(out[0]);
  int status = 0;
  // Its output closed; it may still be running (a time limit holds for its exit too).
  while (time_limit && !result.timed_out) {
    const pid_t done = waitpid(pid, &status, WNOHANG);
    if (done == pid) return with_status(result, status);
    if (done < 0 && errno != EINTR) break;
    if (std::chrono::steady_clock::now() >= deadline) {
      result.timed_out = true;
      kill(pid, SIGKILL);
      break;
    }
    usleep(5000);
  }
  while (waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  return with_status(result, status);
}

}  // namespace pvcap
