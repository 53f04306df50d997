#pragma once
// `pvcap session`: records the rig into a new session store until the duration
// ends, the protocol is done, or the operator stops it, then prints what was
// stored and what was dropped, and why. Wiring only: the recording is
// session::Recording, the protocol protocol::Runner.
#include <atomic>
#include <filesystem>
#include <optional>

#include "core/rig_config.h"
#include "session/recording.h"

namespace pvcap {

struct SessionCommand {
  session::RecordingOptions recording;
  std::optional<double> duration_s;            // stop after this long; otherwise on stop request
  std::optional<std::filesystem::path> protocol;  // run this protocol (rig-configs/protocols/*.yaml)
  bool auto_participant = false;               // the simulated hand performs each take (simulated rigs)
  bool fast = false;                           // the protocol's fast timings
  std::optional<std::filesystem::path> resume;  // continue this interrupted session's protocol
};

// Checks and completes the command before any device is opened (throws UserError): the protocol
// loads, --auto is on a simulated rig, a resumed session's protocol and participant are taken over.
void prepare_session(const RigConfig& rig, SessionCommand& command);

// Returns the process exit code: 0 recorded, 1 failed (the message was logged).
int run_session(const RigConfig& rig, const SessionCommand& command, const std::atomic<bool>& interrupt);

}  // namespace pvcap
