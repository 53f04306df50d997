#include "core/stop_signals.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/resource.h>
#include <unistd.h>

#include <cerrno>
#include <climits>

namespace pvcap {
namespace {

std::atomic<bool>* g_stop = nullptr;
// /dev/null, opened at install: where a hang-up sends the output that went to the terminal.
int g_dev_null = -1;
bool g_stdout_tty = false, g_stderr_tty = false;

void on_signal(int sig) {
  if (sig == SIGHUP) {
    // The shell forwards a hang-up more than once, whatever repeats; dup2 is safe in a handler.
    if (g_dev_null >= 0) {
      if (g_stdout_tty) dup2(g_dev_null, STDOUT_FILENO);
      if (g_stderr_tty) dup2(g_dev_null, STDERR_FILENO);
    }
    g_stop->store(true);
    return;
  }
  if (g_stop->exchange(true)) _exit(130);  // a second Ctrl-C or SIGTERM: leave now
}

}  // namespace

bool hangups_ignored_by_the_caller() {
  struct sigaction now {};
  return sigaction(SIGHUP, nullptr, &now) == 0 && now.sa_handler == SIG_IGN;
}

void install_stop_handlers(std::atomic<bool>& stop, bool keep_hangups_ignored) {
  g_stop = &stop;
  g_stdout_tty = isatty(STDOUT_FILENO) == 1;
  g_stderr_tty = isatty(STDERR_FILENO) == 1;
  g_dev_null = open("/dev/null", O_WRONLY | O_CLOEXEC);
  struct sigaction sa {};
  sa.sa_handler = on_signal;
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
  if (!keep_hangups_ignored) sigaction(SIGHUP, &sa, nullptr);
  signal(SIGPIPE, SIG_IGN);
  signal(SIGTTOU, SIG_IGN);
}

std::filesystem::path self_exe() {
  std::error_code ec;
  auto p = std::filesystem::read_symlink("/proc/self/exe", ec);
  return ec ? std::filesystem::path("pvcap") : p;
}

int lower_priority_to(int nice) {
  errno = 0;
  const int now = getpriority(PRIO_PROCESS, 0);
  // The calling thread's (Linux: a thread's own); every thread it starts after this inherits it.
  if (errno == 0 && now < nice) (void)setpriority(PRIO_PROCESS, 0, nice);
  return current_nice();
}

int current_nice() {
  errno = 0;
  const int now = getpriority(PRIO_PROCESS, 0);
  return errno == 0 ? now : INT_MIN;
}

}  // namespace pvcap
