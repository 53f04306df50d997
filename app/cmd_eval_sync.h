#pragma once
// `pvcap eval-sync`: records a simulated session with a hard timing scenario and measures it
// against the simulator's ground truth (sim/sync_evaluation.h). Without --root it records into a
// temporary folder, says so, and removes it at the end. `--evaluate SESSION` measures a session
// it recorded before (kept with --root) again, without recording.
#include <filesystem>

#include "sim/sync_evaluation.h"

namespace pvcap {

struct EvalSyncOptions {
  sim::EvalScenario scenario;
  double warmup_s = 3;
  std::filesystem::path root;      // where the scenario and its session go (empty: a temporary folder, removed)
  std::filesystem::path evaluate;  // a recorded session to measure again (nothing recorded)
};

}  // namespace pvcap
