#pragma once
// `pvcap session`: records the rig into a new session store until the duration
// ends, the protocol is done, or the operator stops it, then prints what was
// stored and what was dropped, and why. Wiring only: the recording is
// session::Recording, the protocol protocol::Runner.
#include <atomic>
#include <filesystem>
#include <iosfwd>
#include <memory>
#include <optional>
#include <string>

#include "core/rig_config.h"
#include "protocol/web_console.h"
#include "session/recording.h"

namespace pvcap {

// What a resumed session takes over from the folder it continues (filled by prepare_session).
struct Continuation {
  std::filesystem::path previous;
  int first_step = 0;
  std::string protocol_text, protocol_file, hand_order;
};

struct SessionCommand {
  session::RecordingOptions recording;
  std::optional<double> duration_s;            // stop after this long; otherwise on stop request
  std::optional<std::filesystem::path> protocol;  // run this protocol (rig-configs/protocols/*.yaml)
  bool auto_participant = false;               // the simulated hand performs each take (simulated rigs)
  bool fast = false;                           // the protocol's fast timings
  std::optional<std::filesystem::path> resume;  // continue this interrupted session's protocol
  std::optional<Continuation> continuation;     // set by prepare_session from `resume`
  // The session's pages (bound by main before a simulated rig's network namespace); none: --no-web.
  std::unique_ptr<protocol::WebConsole> web;
};

// Checks and completes the command before any device is opened (throws UserError): the protocol
// loads, --auto is on a simulated rig, a resumed session's protocol and participant are taken over.
void prepare_session(const RigConfig& rig, SessionCommand& command);

// At the start of a protocol session whose participant or conditions were not given on the
// command line: asks the operator for them (a participant code is required; the rest may stay
// "unrecorded"). Throws UserError when the input ends first.
void ask_for_participant(SessionCommand& command, std::istream& in, std::ostream& out);

// Returns the process exit code: 0 recorded, 1 failed (the message was logged).
int run_session(const RigConfig& rig, const SessionCommand& command, const std::atomic<bool>& interrupt);

}  // namespace pvcap
