#include "app/cmd_eval_sync.h"

#include <fstream>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "app/cmd_report.h"
#include "protocol/participant_session.h"
#include "core/rig_config.h"

namespace pvcap {

int eval_sync(const std::filesystem::path& scenario, const EvalSyncOptions& o, const std::atomic<bool>& stop) {
  const RigConfig rig = load_rig_config(scenario);
  const auto sessions = o.root / "sessions";
  protocol::SessionSetup setup;
  setup.recording.root = sessions;
  setup.recording.device_wait_s = 15.0;
  setup.recording.self_exe = o.self_exe;
  setup.duration_s = o.scenario.seconds;
  const auto outcome = protocol::run_session(rig, setup, stop);
  const auto& dir = outcome.recording.dir;
  fmt::print("\n{}", outcome.recording.report);
  if (outcome.recording.exit_code != 0 || dir.empty()) {
    spdlog::error("the evaluation session failed; nothing to evaluate");
    return 1;
  }
  write_session_report(dir);
  const sim::SyncEvaluation e = sim::evaluate_sync(dir, o.warmup_s);
  const std::string text = sim::format_evaluation(e);
  fmt::print("\n{}", text);
  std::ofstream(dir / "eval-sync.txt") << text;
  return e.missed.empty() ? 0 : 1;
}

}  // namespace pvcap
