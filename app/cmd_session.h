#pragma once
// `pvcap session`: records the rig into a new session store until the duration
// ends, the protocol is done, or the operator stops it, then prints what was
// stored and what was dropped, and why. Wiring only: the recording is
// session::Recording.
#include <atomic>
#include <optional>

#include "core/rig_config.h"
#include "session/recording.h"

namespace pvcap {

struct SessionCommand {
  session::RecordingOptions recording;
  std::optional<double> duration_s;  // stop after this long; otherwise on stop request
};

// Returns the process exit code: 0 recorded, 1 failed (the message was logged).
int run_session(const RigConfig& rig, const SessionCommand& command, const std::atomic<bool>& interrupt);

}  // namespace pvcap
