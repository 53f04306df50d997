#pragma once
// `pvcap session`: records a session (a participant session when a protocol is given) on a rig,
// real or simulated (app/rig_launcher.h starts a simulated rig's simulator), then writes and prints
// its report (report.txt, report.html) from the store.
#include <filesystem>

#include "app/command.h"
#include "console/session_command.h"

namespace pvcap {

// Records `rig` with `setup`: a simulated rig's simulator started first (app/rig_launcher.h) and its
// ground truth filed in the session folder after; the faults of `ctx` passed down.
console::SessionOutcome record_session(const RigConfig& rig, console::SessionSetup& setup, AppContext& ctx);

// The end of any recording command: the text report (with a protocol session's takes) into
// report.txt and on the console, and report.html. Returns the recording's exit code.
int report_recorded_session(const console::SessionOutcome& outcome, double report_stall_s = 0);

}  // namespace pvcap
