#pragma once
// `pvcap eval-sync`: records a simulated session with a hard timing scenario and measures it
// against the simulator's ground truth (sim/sync_evaluation.h).
#include <atomic>
#include <filesystem>

#include "sim/sync_evaluation.h"

namespace pvcap {

struct EvalSyncOptions {
  sim::EvalScenario scenario;
  double warmup_s = 3;
  std::filesystem::path root;  // where the scenario and its session go
  std::filesystem::path self_exe;
};

// Records the scenario (already loaded; the caller has made its network) and evaluates it.
int eval_sync(const std::filesystem::path& scenario, const EvalSyncOptions& options, const std::atomic<bool>& stop);

}  // namespace pvcap
