#pragma once
// `pvcap replay SESSION --as-devices`: the rig file under which the simulated devices re-serve a
// recorded session through the devices' own protocols (sim/session_replay.h). A `pvcap session` on
// that rig file starts them and records the session again: a regression check of the whole
// pipeline, or a way to run an old session through a newer pvcap.
#include <filesystem>

#include "core/result.h"

namespace pvcap::sim {

struct ReplayRig {
  std::filesystem::path rig_file;
  double session_seconds = 0;  // from the first recorded frame to the last
  double replay_seconds = 0;   // at the chosen rate
  // At the chosen rate, from the first recorded frame to the cameras' last (every frame a sample can
  // hold): what a re-recording should last. The Sensel recorded on while the cameras stopped (it
  // stops last); a re-recording that waited for that tail too would leave its cameras silent for as
  // long, toward their stall limit (0.5 s at 30 fps), past which they are called lost.
  double record_seconds = 0;
};

// Writes `out` (default: ./<session folder name>-replay.yaml): the session's own rig, its cameras on
// loopback addresses, its Sensel (if any) on the emulator, and `sim: {replay: SESSION, replay_rate}`.
Result<ReplayRig> write_replay_rig(const std::filesystem::path& session_dir, std::filesystem::path out, double rate);

}  // namespace pvcap::sim
