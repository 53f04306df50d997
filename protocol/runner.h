#pragma once
// The protocol runner: prompts the participant through the plan and lets the
// operator steer. A state machine
//
//   idle -> prompt -> countdown -> recording -> rest -> (next take's) prompt ... -> done
//                 (paused from any of them; aborted from anywhere)
//
// with the operator's commands start, next, redo, skip, pause, resume, abort,
// bad (mark the last take bad) and note. Every transition is committed to the
// store, on the capture clock, before a command is acknowledged; a countdown
// never starts while a device is missing. Thread-safe: commands from the
// console and the pages, tick() from the session's loop.
#include <cstdint>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "protocol/protocol.h"
#include "protocol/take_check.h"
#include "storage/index/records.h"

namespace pvcap::protocol {

// What the runner needs of a recording (session::Recording in pvcap; a fake in the unit tests).
class RunnerEnv {
 public:
  virtual ~RunnerEnv() = default;
  virtual std::int64_t now_ns() = 0;  // the capture clock
  // On disk before it returns true; false: not committed (the command is refused).
  virtual bool commit(const ProtocolEventRecord& event) = 0;
  virtual bool commit_note(const std::string& text) = 0;
  // Every camera and the Sensel delivered a frame within the last 250 ms.
  virtual bool devices_live() = 0;
  // The longest any stream has now gone without a frame (ms).
  virtual double stream_silence_ms() = 0;
  virtual bool has_pressure() = 0;
  virtual std::vector<ForcePoint> pressure(std::int64_t from_ns, std::int64_t to_ns) = 0;
  // A take will record from start to end (the automatic participant acts on it); cancelled at `at`.
  virtual void take_scheduled(const PlannedTake&, std::int64_t /*start_ns*/, std::int64_t /*end_ns*/) {}
  virtual void take_cancelled(std::int64_t /*at_ns*/) {}
  // Switches the rig's lights to `code` (docs/lighting.md) before a take's prompt: the code as
  // commanded, in the rig's form ("L-R"), or nullopt when the lights could not be switched (why is
  // logged). A rig without lights keeps its code as a label.
  virtual std::optional<std::string> set_lighting(const std::string& code) { return code; }
  // The lighting the images showed over [from, to), in the same form; "" when nothing can tell.
  virtual std::string lighting_seen(std::int64_t /*from_ns*/, std::int64_t /*to_ns*/) { return ""; }
  // The lighting commanded now (the session's, set at its start), in the rig's form; "" without lights.
  virtual std::string lighting_now() { return ""; }
};

enum class Phase { Idle, Prompt, Countdown, Recording, Rest, Paused, Done, Aborted };
const char* to_string(Phase p);

enum class Command { Start, Next, Redo, Skip, Pause, Resume, Abort, Bad, Note };
std::optional<Command> parse_command(
    const std::string& word);  // start, next, redo, skip, pause, resume, abort, bad, note

struct Attempt {
  int step = 0, attempt = 1;
  std::string sequence;  // e.g. press_palm_high_5x_left(2)
  std::string status;    // recording | done | superseded | skipped | bad | interrupted
  std::int64_t start_ns = 0, end_ns = 0;
  std::optional<TakeCheck> check;
};

// A snapshot for the pages and the console.
struct RunnerView {
  Phase phase = Phase::Idle;
  Phase paused_in = Phase::Idle;
  int step = 0, steps = 0;  // the current take's position in the plan, and the plan's length
  int takes_done = 0;       // steps with a done (or bad) take
  std::string sequence, action_text, action_name, pictogram, force, hand;
  int repetition = 0, repetitions = 0;  // while recording: which repetition is due (1-based)
  double seconds_left = 0;              // in the current timed phase
  bool waiting_for_devices = false;
  bool holding = false;                  // after a take that failed its check: the operator decides
  std::optional<Attempt> last;           // the latest finished attempt
  std::string message;                   // the last thing the runner told the operator
  std::vector<std::string> step_status;  // per step: pending | done | skipped | bad
};

struct RunnerOptions {
  bool auto_start = false;      // start at once (no operator start command)
  bool auto_advance = false;    // a take that fails its check does not hold for the operator
  bool fast = false;            // the protocol's fast timings
  int first_step = 0;           // resume: begin here
  std::string protocol_detail;  // extra JSON fields for the protocol_start event (e.g. what it continues)
  std::string lighting;         // the session's lighting (--lighting): the takes' unless an action names its own
};

class Runner {
 public:
  Runner(const Protocol& protocol, std::string hand_order, RunnerEnv& env, RunnerOptions options);

  // Acknowledged (true, with a message) only once its events are committed; refused with why.
  struct Reply {
    bool ok = false;
    std::string message;
  };
  Reply command(Command c, const std::string& argument = {});
  // Advances the timed phases; call often (every 50 ms or so).
  void tick();
  RunnerView view() const;
  bool finished() const;  // done or aborted
  const std::vector<PlannedTake>& plan() const { return plan_; }
  std::vector<Attempt> attempts() const;

 private:
  const Timings& timings(const PlannedTake& t) const;
  ProtocolEventRecord event(const char* kind, int step, const std::string& detail_json) const;
  bool post(const char* kind, int step, const std::string& detail_json);
  bool enter_prompt(std::int64_t now);
  bool enter_countdown(std::int64_t now);
  bool enter_recording(std::int64_t now);
  bool finish_take(std::int64_t now, const std::string& status);
  bool advance(std::int64_t now);
  void set_phase(Phase p, std::int64_t now, double seconds);
  Attempt* last_finished();
  int attempts_of(int step) const;
  std::optional<double> low_mean(const PlannedTake& t) const;

  const Protocol& protocol_;
  std::string hand_order_;
  RunnerEnv& env_;
  RunnerOptions options_;
  std::vector<PlannedTake> plan_;

  mutable std::mutex mu_;
  Phase phase_ = Phase::Idle, paused_in_ = Phase::Idle;
  std::int64_t phase_start_ns_ = 0, phase_end_ns_ = 0;
  int current_ = 0;
  std::optional<int> return_to_;  // after a redo: the step to go on with
  bool holding_ = false, waiting_for_devices_ = false, started_ = false;
  double max_silence_ms_ = 0;  // during the current recording
  std::string lighting_;            // as last commanded (the rig's form)
  std::string requested_lighting_;  // as the protocol last asked it (its own form)
  bool lighting_known_ = false;     // lighting_ read from the session before the first prompt
  std::vector<Attempt> attempts_;
  std::vector<std::string> step_status_;
  std::string message_;
};

}  // namespace pvcap::protocol
