// `pvcap eval-sync`: records a simulated session with a hard timing scenario and measures it against
// the simulator's ground truth (sim/sync_evaluation.h). Without --root it records into a temporary
// folder, says so, and removes it at the end; `--evaluate SESSION` measures one it recorded before.

#include <unistd.h>

#include <fstream>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "app/cmd_session.h"
#include "app/command.h"
#include "app/rig_launcher.h"
#include "core/rig_config.h"
#include "sim/sync_evaluation.h"

namespace pvcap {

namespace {
struct EvalSyncOptions {
  sim::EvalScenario scenario;
  double warmup_s = 3;
  std::filesystem::path root;      // where the scenario and its session go (empty: a temporary folder, removed)
  std::filesystem::path evaluate;  // a recorded session to measure again (nothing recorded)
};
}  // namespace

namespace {

int evaluate_again(const EvalSyncOptions& o) {
  if (!std::filesystem::is_directory(o.evaluate / "sim-truth"))
    throw UserError(fmt::format("{}: not a session recorded on the simulated rig (it has no sim-truth folder)",
                                o.evaluate.string()));
  const sim::SyncEvaluation e = sim::evaluate_sync(o.evaluate, o.warmup_s);
  fmt::print("{}", sim::format_evaluation(e));
  return e.missed.empty() ? 0 : 1;
}

int eval_sync(const EvalSyncOptions& o, AppContext& ctx) {
  if (!o.evaluate.empty()) return evaluate_again(o);
  const bool temporary = o.root.empty();
  const std::filesystem::path root =
      temporary ? std::filesystem::temp_directory_path() / fmt::format("pvcap-eval-sync-{}", getpid()) : o.root;
  const auto scenario = sim::write_eval_scenario(o.scenario, root);
  const RigConfig rig = load_rig_config(scenario);
  prepare_rig_network(rig);
  spdlog::info("eval-sync: scenario {}, {:g} s, recorded into {}{}", scenario.string(), o.scenario.seconds,
               root.string(), temporary ? " (removed at the end; give --root to keep it)" : "");
  console::SessionSetup setup;
  setup.recording.root = root / "sessions";
  setup.duration_s = o.scenario.seconds;
  const auto outcome = record_session(rig, setup, ctx);
  int rc = 1;
  const auto& dir = outcome.recording.dir;
  if (outcome.recording.exit_code != 0 || dir.empty()) {
    spdlog::error("the evaluation session failed; nothing to evaluate");
  } else {
    (void)report_recorded_session(outcome);
    const sim::SyncEvaluation e = sim::evaluate_sync(dir, o.warmup_s);
    const std::string text = sim::format_evaluation(e);
    fmt::print("\n{}", text);
    std::ofstream(dir / "eval-sync.txt") << text;
    rc = e.missed.empty() ? 0 : 1;
  }
  if (temporary) {
    std::error_code ec;
    std::filesystem::remove_all(root, ec);
    fmt::print("eval-sync: removed {} (give --root to keep its session)\n", root.string());
  }
  return rc;
}

}  // namespace

Registered add_eval_sync_command(CLI::App& app, AppContext& ctx) {
  auto o = std::make_shared<EvalSyncOptions>();
  auto* e = app.add_subcommand(
      "eval-sync", "record a simulated session with a hard timing scenario and measure the timeline against its truth");
  e->add_option("--seconds", o->scenario.seconds, "length of the recording")
      ->capture_default_str()
      ->check(CLI::Range(5.0, 3600.0));
  e->add_option("--drift-ppm", o->scenario.drift_ppm, "camera clock drift (+- this; the Sensel half of it)")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 1000.0));
  e->add_option("--jitter-ms", o->scenario.jitter_ms, "Sensel USB arrival jitter cap (long tail; mean a quarter)")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 50.0));
  e->add_option("--loss", o->scenario.loss, "fraction of pressure frames the device loses")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 0.5));
  e->add_option("--seed", o->scenario.seed, "scenario seed")->capture_default_str();
  e->add_option("--warmup", o->warmup_s, "seconds at the start left out of the timing errors")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 60.0));
  e->add_option("--root", o->root,
                "folder for the scenario and its session (default: a temporary one, removed at "
                "the end)");
  e->add_option("--evaluate", o->evaluate,
                "measure a session eval-sync recorded before (kept with --root: ROOT/sessions/NAME) again, "
                "recording nothing")
      ->excludes("--root");
  return {e, [o, &ctx] { return eval_sync(*o, ctx); }};
}

}  // namespace pvcap
