// pvcap: capture and synchronization for visual hand-pressure datasets.
// Thin: each subcommand registers its own options (app/command.h); main parses the line, sets up
// logging and signals, and runs the one given. See docs/ for the user guide.
#include <sys/stat.h>

#include <atomic>
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
#include "core/stop_signals.h"
#include "core/version.h"

namespace {

std::atomic<bool> g_stop{false};

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
  const bool lower = after_the_session.count(command.get_name()) > 0;
  spdlog::debug("pvcap {}: at nice {}", command.get_name(),
                lower ? pvcap::lower_priority_to(kOfflineNice) : pvcap::current_nice());
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"pvcap: capture and synchronization for visual hand-pressure datasets", "pvcap"};
  app.require_subcommand(1);
  app.set_version_flag("--version", std::string(pvcap::kVersion));
  std::string log_level = "info";
  app.add_option("--log-level", log_level, "console log level: trace, debug, info, warn, error, off")
      ->check(CLI::IsMember({"trace", "debug", "info", "warn", "error", "off"}));
  pvcap::AppContext ctx{g_stop, pvcap::self_exe(), {}};
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
  const bool nohup = pvcap::hangups_ignored_by_the_caller();
  pvcap::install_stop_handlers(g_stop, nohup);
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
