// pvcap: capture and synchronization for visual hand-pressure datasets.
// Thin: each subcommand registers its own options (app/command.h); main parses the line, sets up
// logging and signals, and runs the one given. See docs/ for the user guide.
#include <signal.h>
#include <unistd.h>

#include <atomic>
#include <cstdlib>
#include <filesystem>
#include <vector>

#include <spdlog/spdlog.h>
#include <CLI/CLI.hpp>

#include "app/command.h"
#include "core/log.h"
#include "core/result.h"
#include "core/version.h"

namespace {

std::atomic<bool> g_stop{false};

void on_signal(int) {
  if (g_stop.exchange(true)) _exit(130);  // a second Ctrl-C: leave now
}

void install_stop_handlers() {
  struct sigaction sa {};
  sa.sa_handler = on_signal;
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
  sigaction(SIGHUP, &sa, nullptr);  // an ssh connection that drops stops the session cleanly
  signal(SIGPIPE, SIG_IGN);         // a closed pipe or socket is an error return, not death
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
      pvcap::add_migrate_command(app, ctx)};
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // --help and --version exit 0; any mistake on the command line (a missing rig file too) exits 2.
    return app.exit(e) == 0 ? 0 : 2;
  }
  pvcap::log::init_console(log_level);
  install_stop_handlers();
  ctx.faults = read_faults();
  try {
    for (const auto& c : commands)
      if (*c.command) return c.run();
  } catch (const pvcap::UserError& e) {
    spdlog::error("{}", e.what());
    return 2;
  }
  return 0;
}
