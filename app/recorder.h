#pragma once
// `pvcap session`: records the rig into a new session store until the duration
// ends or the operator stops it (Ctrl-C), then prints what was stored and what
// was dropped, and why. Wires capture/ -> sync/ -> storage/; owns no logic of
// those modules.
#include <atomic>
#include <filesystem>
#include <optional>

#include "core/rig_config.h"
#include "storage/session_index.h"

namespace pvcap {

struct RecordOptions {
  std::filesystem::path root;          // sessions are created under it
  std::optional<double> duration_s;    // stop after this long; otherwise on stop request
  double device_wait_s = 0;            // keep trying to open cameras this long (the sim needs a moment)
  std::filesystem::path self_exe;      // to start the simulator as a child process
  std::optional<ParticipantRecord> participant;  // who sits in the chair (stored in the session)
  std::optional<ConditionsRecord> conditions;    // lighting, sensor overlay
};

// Returns the process exit code: 0 recorded, 1 failed (the message was logged).
int record_session(const RigConfig& rig, const RecordOptions& options, const std::atomic<bool>& stop_requested);

}  // namespace pvcap
