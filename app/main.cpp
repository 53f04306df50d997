// pvcap: capture and synchronization for visual hand-pressure datasets.
// Thin: each subcommand registers its own options (app/command.h); main parses the line, sets up
// logging and signals, and runs the one given. See docs/ for the user guide.
#include <fcntl.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstdlib>
#include <filesystem>
#include <set>
#include <string>
#include <vector>

#include <spdlog/spdlog.h>
#include <CLI/CLI.hpp>

#include "app/command.h"
#include "core/allocator.h"
#include "core/log.h"
#include "core/result.h"
#include "core/version.h"

namespace {

std::atomic<bool> g_stop{false};
// /dev/null, opened at start: where a hang-up sends the output that went to the terminal.
int g_dev_null = -1;
bool g_stdout_tty = false, g_stderr_tty = false;

void on_signal(int sig) {
  if (sig == SIGHUP) {
    // The terminal is gone (a dropped ssh, a closed window): stop cleanly, whatever repeats. The
    // shell forwards a hang-up more than once, and a write to the dead terminal fails with EIO, so
    // what went to it goes to /dev/null from now on (dup2 is safe in a handler); the session's log
    // file keeps every line.
    if (g_dev_null >= 0) {
      if (g_stdout_tty) dup2(g_dev_null, STDOUT_FILENO);
      if (g_stderr_tty) dup2(g_dev_null, STDERR_FILENO);
    }
    g_stop.store(true);
    return;
  }
  if (g_stop.exchange(true)) _exit(130);  // a second Ctrl-C or SIGTERM: leave now
}

// Whether pvcap was started with hang-ups ignored (`nohup pvcap session ...`, a `trap '' HUP`): the
// user asked for the session to outlive the terminal, and pvcap keeps to that.
bool hangups_ignored_by_the_caller() {
  struct sigaction now {};
  return sigaction(SIGHUP, nullptr, &now) == 0 && now.sa_handler == SIG_IGN;
}

void install_stop_handlers(bool keep_hangups_ignored) {
  g_stdout_tty = isatty(STDOUT_FILENO) == 1;
  g_stderr_tty = isatty(STDERR_FILENO) == 1;
  g_dev_null = open("/dev/null", O_WRONLY | O_CLOEXEC);
  struct sigaction sa {};
  sa.sa_handler = on_signal;
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
  // An ssh connection that drops stops the session cleanly, unless the caller asked to ignore it.
  if (!keep_hangups_ignored) sigaction(SIGHUP, &sa, nullptr);
  signal(SIGPIPE, SIG_IGN);         // a closed pipe or socket is an error return, not death
  // A background job that writes to its terminal must not be stopped for it (the session runs on).
  signal(SIGTTOU, SIG_IGN);
}

std::filesystem::path self_exe() {
  std::error_code ec;
  auto p = std::filesystem::read_symlink("/proc/self/exe", ec);
  return ec ? std::filesystem::path("pvcap") : p;
}

// A test's faults, read once here and passed down as a plain value (core/fault_injection.h).
pvcap::FaultPlan read_faults() {
  const char* spec = std::getenv("PVCAP_FAULTS");
  if (!spec || !*spec) return {};
  std::vector<std::string> problems;
  pvcap::FaultPlan plan = pvcap::parse_faults(spec, problems);
  spdlog::warn("PVCAP_FAULTS is set ({}): faults are injected on purpose, for tests; never on a real session", spec);
  for (const auto& p : problems) spdlog::warn("{}", p);
  return plan;
}

constexpr int kOfflineNice = 10;  // yield_to_recordings: below a recording's encoders (nice +5)

// The commands that work through recorded images, frame after frame, and record nothing
// (core/allocator.h: what keeping image buffers in the heap gains them, and why a recorder does not).
bool works_offline_on_images(const CLI::App& command) {
  static const std::set<std::string> offline = {"calibrate", "export", "replay", "report", "compact", "dataset"};
  return offline.count(command.get_name()) > 0;
}

// The commands that read or rewrite finished sessions (and record nothing) run at a lower priority:
// a session recording on the same machine keeps the cores it needs (its frames have a deadline,
// these have none), and on an idle machine they run as fast as before. Not `replay`: its window is
// watched, and as devices it serves frames on their clock.
void yield_to_recordings(const CLI::App& command) {
  static const std::set<std::string> after_the_session = {"calibrate", "export", "report",  "compact",
                                                          "dataset",   "verify", "recover", "migrate"};
  errno = 0;
  const int now = getpriority(PRIO_PROCESS, 0);
  // The calling thread's (Linux: a thread's own); every thread it starts after this inherits it.
  if (after_the_session.count(command.get_name()) && errno == 0 && now < kOfflineNice)
    (void)setpriority(PRIO_PROCESS, 0, kOfflineNice);
  errno = 0;
  const int after = getpriority(PRIO_PROCESS, 0);
  if (errno == 0) spdlog::debug("pvcap {}: at nice {}", command.get_name(), after);
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"pvcap: capture and synchronization for visual hand-pressure datasets", "pvcap"};
  app.require_subcommand(1);
  app.set_version_flag("--version", std::string(pvcap::kVersion));
  std::string log_level = "info";
  app.add_option("--log-level", log_level, "console log level: trace, debug, info, warn, error, off")
      ->check(CLI::IsMember({"trace", "debug", "info", "warn", "error", "off"}));
  pvcap::AppContext ctx{g_stop, self_exe(), {}};
  const std::vector<pvcap::Registered> commands = {
      pvcap::add_devices_command(app, ctx), pvcap::add_session_command(app, ctx),
      pvcap::add_takes_command(app, ctx),   pvcap::add_report_command(app, ctx),
      pvcap::add_replay_command(app, ctx),  pvcap::add_export_command(app, ctx),
      pvcap::add_sim_command(app, ctx),     pvcap::add_calibrate_command(app, ctx),
      pvcap::add_sensel_command(app, ctx),  pvcap::add_eval_sync_command(app, ctx),
      pvcap::add_verify_command(app, ctx),  pvcap::add_recover_command(app, ctx),
      pvcap::add_migrate_command(app, ctx), pvcap::add_dataset_command(app, ctx),
      pvcap::add_compact_command(app, ctx), pvcap::add_camera_command(app, ctx)};
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // --help and --version exit 0; any mistake on the command line (a missing rig file too) exits 2.
    return app.exit(e) == 0 ? 0 : 2;
  }
  pvcap::log::init_console(log_level);
  // What pvcap writes (a participant's videos, their index, reports, exports) is not for other
  // users of the machine: folders 0750, files 0640. A lab shares with its group (store.group).
  umask(027);
  const bool nohup = hangups_ignored_by_the_caller();
  install_stop_handlers(nohup);
  if (nohup && app.got_subcommand("session"))
    spdlog::info("hang-ups are ignored, as the caller asked (nohup): Ctrl-C or SIGTERM stops the session");
  ctx.faults = read_faults();
  try {
    for (const auto& c : commands)
      if (*c.command) {
        if (works_offline_on_images(*c.command)) pvcap::keep_image_buffers_in_heap();
        yield_to_recordings(*c.command);
        return c.run();
      }
  } catch (const pvcap::UserError& e) {
    spdlog::error("{}", e.what());
    return 2;
  } catch (const std::exception& e) {
    // Never unreported: whatever escaped (a bug, or a library's error nobody expected) is named,
    // and the exit status says the command failed.
    try {
      spdlog::error("pvcap stopped on an unexpected error: {}", e.what());
    } catch (...) {
    }
    return 1;
  }
  return 0;
}
