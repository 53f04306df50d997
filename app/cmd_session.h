#pragma once
// `pvcap session`: runs a participant session (protocol/participant_session.h),
// then prints what was stored and what was lost, and why, and writes report.html.
#include <atomic>

#include "core/rig_config.h"
#include "protocol/participant_session.h"

namespace pvcap {

// Returns the exit code: 0 recorded, 1 failed (the message was logged).
int cmd_session(const RigConfig& rig, const protocol::SessionSetup& setup, const std::atomic<bool>& interrupt);

}  // namespace pvcap
