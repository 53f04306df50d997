#include "app/cmd_eval_sync.h"

#include <fstream>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "app/cmd_session.h"
#include "core/rig_config.h"

namespace pvcap {

int eval_sync(const std::filesystem::path& scenario, const EvalSyncOptions& o, const std::atomic<bool>& stop) {
  const RigConfig rig = load_rig_config(scenario);
  const auto sessions = o.root / "sessions";
  SessionCommand command;
  command.recording.root = sessions;
  command.recording.device_wait_s = 15.0;
  command.recording.self_exe = o.self_exe;
  command.duration_s = o.scenario.seconds;
  if (const int rc = run_session(rig, command, stop); rc != 0) {
    spdlog::error("the evaluation session failed; nothing to evaluate");
    return 1;
  }
  std::filesystem::path dir;
  for (const auto& entry : std::filesystem::directory_iterator(sessions))
    if (entry.is_directory() && entry.path().filename().string()[0] != '.' &&
        (dir.empty() || entry.path().filename() > dir.filename()))
      dir = entry.path();
  const sim::SyncEvaluation e = sim::evaluate_sync(dir, o.warmup_s);
  const std::string text = sim::format_evaluation(e);
  fmt::print("\n{}", text);
  std::ofstream(dir / "eval-sync.txt") << text;
  return e.missed.empty() ? 0 : 1;
}

}  // namespace pvcap
