#pragma once
// One `pvcap` subcommand: it adds its own options to the command line and returns what runs it once
// the line is parsed (main only picks the one that was given). Options live in the runner's own
// state, so nothing about a command is scattered over main.
#include <atomic>
#include <filesystem>
#include <functional>

#include <CLI/CLI.hpp>

#include "core/fault_injection.h"

namespace pvcap {

struct AppContext {
  std::atomic<bool>& stop;         // Ctrl-C, SIGTERM, SIGHUP: stop cleanly
  std::filesystem::path self_exe;  // this binary (to start the simulator as a child process)
  FaultPlan faults;                // a test's faults, read once from PVCAP_FAULTS (core/fault_injection.h)
};

struct Registered {
  CLI::App* command = nullptr;
  std::function<int()> run;  // the exit code
};

Registered add_devices_command(CLI::App& app, AppContext& ctx);
Registered add_session_command(CLI::App& app, AppContext& ctx);
Registered add_takes_command(CLI::App& app, AppContext& ctx);
Registered add_report_command(CLI::App& app, AppContext& ctx);
Registered add_replay_command(CLI::App& app, AppContext& ctx);
Registered add_export_command(CLI::App& app, AppContext& ctx);
Registered add_sim_command(CLI::App& app, AppContext& ctx);
Registered add_calibrate_command(CLI::App& app, AppContext& ctx);
Registered add_sensel_command(CLI::App& app, AppContext& ctx);
Registered add_eval_sync_command(CLI::App& app, AppContext& ctx);
Registered add_verify_command(CLI::App& app, AppContext& ctx);
Registered add_recover_command(CLI::App& app, AppContext& ctx);
Registered add_migrate_command(CLI::App& app, AppContext& ctx);
Registered add_compact_command(CLI::App& app, AppContext& ctx);
Registered add_dataset_command(CLI::App& app, AppContext& ctx);
Registered add_camera_command(CLI::App& app, AppContext& ctx);

}  // namespace pvcap
