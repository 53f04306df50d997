#pragma once
// `pvcap session`'s body (app/cmd_session.cpp parses its command line into a SessionSetup): a
// participant session, a session::Recording of the rig, with (when a protocol is given) the
// protocol's Runner prompting the participant, the operator's terminal console and the session's
// web pages attached, until the duration ends, the protocol is done, or the operator stops it.
#include <atomic>
#include <filesystem>
#include <functional>
#include <iosfwd>
#include <memory>
#include <optional>
#include <string>

#include "console/web_console.h"
#include "core/rig_config.h"
#include "protocol/runner.h"
#include "session/recording.h"

namespace pvcap::console {

// What a resumed session takes over from the folder it continues (filled by prepare_session).
struct Continuation {
  std::filesystem::path previous;
  int first_step = 0;
  std::string protocol_text, protocol_file, hand_order;
};

struct SessionSetup {
  session::RecordingOptions recording;
  std::optional<double> duration_s;               // stop after this long; otherwise on stop request
  std::optional<std::filesystem::path> protocol;  // run this protocol (rig-configs/protocols/*.yaml)
  // An automatic participant performs the takes (a simulated rig's hand): the runner starts and
  // advances by itself. What performs them is `decorate_env`'s (app/ steers the simulator).
  bool auto_participant = false;
  bool fast = false;                            // the protocol's fast timings
  std::optional<std::filesystem::path> resume;  // continue this interrupted session's protocol
  std::optional<Continuation> continuation;     // set by prepare_session from `resume`
  // The session's pages (bound by main before a simulated rig's network namespace); none: --no-web.
  std::unique_ptr<WebConsole> web;
  // Wraps the runner's environment (the recording's) before the runner gets it: how an automatic
  // participant learns when each take is due. None: the environment as it is.
  std::function<std::unique_ptr<protocol::RunnerEnv>(std::unique_ptr<protocol::RunnerEnv>)> decorate_env;
};

// The rig `session` recorded, for `--resume` without `--rig`: its file when unchanged since, else the
// rig as the session recorded it (warned). Throws UserError when the session cannot be read.
RigConfig rig_of_session(const std::filesystem::path& session);

// Checks and completes the setup before any device is opened (throws UserError): the participant
// code is pseudonymous, --auto is on a simulated rig, a board session runs no protocol, a resumed
// session's protocol and participant are taken over.
void prepare_session(const RigConfig& rig, SessionSetup& setup);

// At the start of a protocol session whose participant or conditions were not given on the
// command line: asks the operator for them (a participant code is required; the rest may stay
// "unrecorded"). Throws UserError when the input ends first.
void ask_for_participant(SessionSetup& setup, std::istream& in, std::ostream& out);

struct SessionOutcome {
  session::RecordingResult recording;  // exit_code 0 recorded, 1 failed (the message was logged)
  bool protocol = false;               // a protocol ran (its takes are in the store)
};

// Records until the duration ends, the protocol is done, `interrupt` is set or the recording stops
// itself; then closes the session (its report is the caller's: report/).
SessionOutcome run_session(const RigConfig& rig, const SessionSetup& setup, const std::atomic<bool>& interrupt);

}  // namespace pvcap::console
