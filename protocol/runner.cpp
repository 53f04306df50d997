#include "protocol/runner.h"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <nlohmann/json.hpp>

namespace pvcap::protocol {

const char* to_string(Phase p) {
  switch (p) {
    case Phase::Idle:
      return "idle";
    case Phase::Prompt:
      return "prompt";
    case Phase::Countdown:
      return "countdown";
    case Phase::Recording:
      return "recording";
    case Phase::Rest:
      return "rest";
    case Phase::Paused:
      return "paused";
    case Phase::Done:
      return "done";
    case Phase::Aborted:
      return "aborted";
  }
  return "?";
}

std::optional<Command> parse_command(const std::string& w) {
  if (w == "start") return Command::Start;
  if (w == "next") return Command::Next;
  if (w == "redo") return Command::Redo;
  if (w == "skip") return Command::Skip;
  if (w == "pause") return Command::Pause;
  if (w == "resume") return Command::Resume;
  if (w == "abort") return Command::Abort;
  if (w == "bad") return Command::Bad;
  if (w == "note") return Command::Note;
  return std::nullopt;
}

Runner::Runner(const Protocol& protocol, std::string hand_order, RunnerEnv& env, RunnerOptions options)
    : protocol_(protocol), hand_order_(std::move(hand_order)), env_(env), options_(std::move(options)) {
  plan_ = make_plan(protocol_, hand_order_);
  step_status_.assign(plan_.size(), "pending");
  current_ = std::clamp(options_.first_step, 0, int(plan_.size()));
  for (int i = 0; i < current_; ++i) step_status_[std::size_t(i)] = "earlier";
}

const Timings& Runner::timings(const PlannedTake& t) const {
  return options_.fast ? protocol_.fast_timings : t.action->timings;
}

ProtocolEventRecord Runner::event(const char* kind, int step, const std::string& detail) const {
  ProtocolEventRecord e;
  e.kind = kind;
  if (step >= 0 && step < int(plan_.size())) {
    const PlannedTake& t = plan_[std::size_t(step)];
    e.step = step;
    e.action = t.action->name;
    e.hand = to_string(t.hand);
    e.force = to_string(t.action->force);
    e.repetition = t.action->repetitions;
  }
  e.detail = detail;
  return e;
}

bool Runner::post(const char* kind, int step, const std::string& detail) {
  ProtocolEventRecord e = event(kind, step, detail);
  e.host_ns = env_.now_ns();
  if (env_.commit(e)) return true;
  message_ = fmt::format("the store did not take the '{}' event: the protocol holds (see the log)", kind);
  spdlog::error("protocol: {}", message_);
  return false;
}

void Runner::set_phase(Phase p, std::int64_t now, double seconds) {
  phase_ = p;
  phase_start_ns_ = now;
  phase_end_ns_ = now + std::int64_t(seconds * 1e9);
}

int Runner::attempts_of(int step) const {
  return int(std::count_if(attempts_.begin(), attempts_.end(), [&](const Attempt& a) { return a.step == step; }));
}

Attempt* Runner::last_finished() {
  for (auto it = attempts_.rbegin(); it != attempts_.rend(); ++it)
    if (it->status != "recording") return &*it;
  return nullptr;
}

std::optional<double> Runner::low_mean(const PlannedTake& t) const {
  for (auto it = attempts_.rbegin(); it != attempts_.rend(); ++it) {
    const PlannedTake& o = plan_[std::size_t(it->step)];
    if (o.action->group == t.action->group && o.action->force == Force::Low && o.hand == t.hand &&
        it->status == "done" && it->check)
      return it->check->measures.mean_newtons;
  }
  return std::nullopt;
}

bool Runner::enter_prompt(std::int64_t now) {
  if (current_ >= int(plan_.size())) {
    if (!post("protocol_end", -1, nlohmann::json{{"takes", plan_.size()}}.dump())) return false;
    set_phase(Phase::Done, now, 0);
    message_ = "the protocol is complete";
    return true;
  }
  const PlannedTake& t = plan_[std::size_t(current_)];
  const nlohmann::json d = {{"take", t.sequence_name(attempts_of(current_) + 1)},
                            {"attempt", attempts_of(current_) + 1},
                            {"text", t.action->text}};
  if (!post("prompt", current_, d.dump())) return false;
  // The take's lighting, switched while its prompt shows (the images confirm it before the take).
  if (!lighting_known_) {  // the session switched its own lighting at its start
    lighting_known_ = true;
    lighting_ = env_.lighting_now();
    requested_lighting_ = lighting_.empty() ? "" : options_.lighting;
  }
  const std::string lighting = t.action->lighting.empty() ? options_.lighting : t.action->lighting;
  if (!lighting.empty() && lighting != lighting_ && lighting != requested_lighting_) {
    requested_lighting_ = lighting;
    if (auto set = env_.set_lighting(lighting)) {
      lighting_ = *set;
    } else {
      lighting_ = lighting;
      message_ = fmt::format("the lights could not be switched to {} (the log says why)", lighting);
    }
  }
  set_phase(Phase::Prompt, now, timings(t).prompt_s);
  holding_ = false;
  return true;
}

bool Runner::enter_countdown(std::int64_t now) {
  if (!env_.devices_live()) {
    waiting_for_devices_ = true;
    message_ = "waiting for every camera and the Sensel to deliver frames before the countdown";
    return false;
  }
  waiting_for_devices_ = false;
  const PlannedTake& t = plan_[std::size_t(current_)];
  if (!post("countdown", current_, "{}")) return false;
  const Timings& tm = timings(t);
  set_phase(Phase::Countdown, now, tm.countdown_s);
  env_.take_scheduled(t, phase_end_ns_, phase_end_ns_ + std::int64_t(tm.record_s * 1e9));
  return true;
}

bool Runner::enter_recording(std::int64_t now) {
  const PlannedTake& t = plan_[std::size_t(current_)];
  const int attempt = attempts_of(current_) + 1;
  const std::string sequence = t.sequence_name(attempt);
  nlohmann::json start = {{"take", sequence}, {"attempt", attempt}};
  if (!lighting_.empty()) start["lighting"] = lighting_;
  if (!post("action_start", current_, start.dump())) return false;
  attempts_.push_back({current_, attempt, sequence, "recording", now, 0, std::nullopt});
  set_phase(Phase::Recording, now, timings(t).record_s);
  max_silence_ms_ = 0;
  message_ = "recording " + sequence;
  return true;
}

// Ends the attempt being recorded: done (and checked), skipped, superseded or interrupted.
bool Runner::finish_take(std::int64_t now, const std::string& status) {
  Attempt& a = attempts_.back();
  const PlannedTake& t = plan_[std::size_t(current_)];
  nlohmann::json d = {{"take", a.sequence}, {"attempt", a.attempt}, {"status", status}};
  std::optional<TakeCheck> check;
  if (status == "done") {
    TakeCheckInput in;
    in.action = t.action;
    in.hand = t.hand;
    in.measures = measure_take(env_.pressure(a.start_ns, now), a.start_ns, now);
    in.low_mean_newtons = low_mean(t);
    in.max_camera_gap_ms = max_silence_ms_;
    in.has_pressure = env_.has_pressure();
    in.lighting_commanded = lighting_;
    if (!lighting_.empty()) in.lighting_seen = env_.lighting_seen(a.start_ns, now);
    check = check_take(in, protocol_.check);
    if (!in.lighting_commanded.empty())
      d["lighting"] = {{"commanded", in.lighting_commanded}, {"seen", in.lighting_seen}};
    const auto& m = check->measures;
    d["check"] = {{"ok", check->ok},
                  {"problems", check->problems},
                  {"mean_newtons", m.mean_newtons},
                  {"peak_newtons", m.peak_newtons},
                  {"mean_contact_mm2", m.mean_contact_mm2},
                  {"peak_contact_mm2", m.peak_contact_mm2},
                  {"pressure_frames", m.frames}};
  }
  if (!post("action_end", current_, d.dump())) return false;
  a.status = status;
  a.end_ns = now;
  a.check = check;
  if (status != "done") env_.take_cancelled(now);
  if (status == "done" || status == "skipped") step_status_[std::size_t(current_)] = status;
  if (check && !check->ok) {
    message_ = fmt::format("{} does not match its prompt: {}. Redo it, or go on (next).", a.sequence,
                           fmt::join(check->problems, "; "));
    spdlog::warn("protocol: {}", message_);
  } else if (check) {
    message_ = a.sequence + " done";
  }
  return true;
}

bool Runner::advance(std::int64_t now) {
  holding_ = false;
  if (return_to_) {
    current_ = *return_to_;
    return_to_.reset();
  } else {
    ++current_;
  }
  return enter_prompt(now);
}

void Runner::tick() {
  std::lock_guard lock(mu_);
  const std::int64_t now = env_.now_ns();
  if (phase_ == Phase::Idle && options_.auto_start && !started_) {
    started_ = true;
    const std::string detail = options_.protocol_detail;
    if (post("protocol_start", -1, detail)) (void)enter_prompt(now);
    return;
  }
  if (phase_ == Phase::Recording) max_silence_ms_ = std::max(max_silence_ms_, env_.stream_silence_ms());
  if (now < phase_end_ns_) return;
  switch (phase_) {
    case Phase::Prompt:
      (void)enter_countdown(now);
      break;
    case Phase::Countdown:
      // A device lost during the countdown: back to the prompt, the countdown starts again when it is back.
      if (!env_.devices_live()) {
        env_.take_cancelled(now);
        (void)enter_prompt(now);
        waiting_for_devices_ = true;
        break;
      }
      (void)enter_recording(now);
      break;
    case Phase::Recording:
      if (finish_take(now, "done")) {
        const Attempt& a = attempts_.back();
        holding_ = a.check && !a.check->ok && !options_.auto_advance;
        set_phase(Phase::Rest, now, timings(plan_[std::size_t(current_)]).rest_s);
      }
      break;
    case Phase::Rest:
      if (!holding_) (void)advance(now);
      break;
    default:
      break;
  }
}

Runner::Reply Runner::command(Command c, const std::string& argument) {
  std::lock_guard lock(mu_);
  const std::int64_t now = env_.now_ns();
  auto refuse = [&](std::string why) { return Reply{false, std::move(why)}; };
  auto done = [&](bool committed, std::string what) {
    if (!committed) return Reply{false, message_.empty() ? "not committed to the store" : message_};
    message_ = what;
    return Reply{true, std::move(what)};
  };
  if (phase_ == Phase::Done || phase_ == Phase::Aborted) {
    if (c == Command::Note) return done(env_.commit_note(argument), "note saved");
    return refuse("the protocol has ended");
  }
  switch (c) {
    case Command::Start: {
      if (phase_ != Phase::Idle) return refuse("already started");
      started_ = true;
      if (!post("protocol_start", -1, options_.protocol_detail)) return refuse(message_);
      return done(enter_prompt(now), "started");
    }
    case Command::Next: {
      switch (phase_) {
        case Phase::Idle:
          return refuse("not started: use start");
        case Phase::Prompt:
          if (!enter_countdown(now)) return refuse(message_);
          return done(true, "countdown");
        case Phase::Countdown:
          env_.take_cancelled(now);
          return done(enter_recording(now), "recording");
        case Phase::Recording:
          if (!finish_take(now, "done")) return refuse(message_);
          set_phase(Phase::Rest, now, 0);
          return done(advance(now), "take ended early; next take");
        case Phase::Rest:
          return done(advance(now), "next take");
        case Phase::Paused:
          return refuse("paused: resume first");
        default:
          return refuse("nothing to go on to");
      }
    }
    case Command::Redo: {
      if (phase_ == Phase::Idle || phase_ == Phase::Paused) return refuse("redo works while the protocol runs");
      int target;
      if (phase_ == Phase::Recording) {
        if (!finish_take(now, "superseded")) return refuse(message_);
        target = current_;
        return_to_ = current_ + 1;
      } else {
        Attempt* last = last_finished();
        if (!last || last->status == "superseded" || last->status == "skipped")
          return refuse("no finished take to redo");
        if (!post("superseded", last->step, nlohmann::json{{"take", last->sequence}}.dump())) return refuse(message_);
        last->status = "superseded";
        step_status_[std::size_t(last->step)] = "pending";
        target = last->step;
        return_to_ = phase_ == Phase::Rest ? current_ + 1 : current_;
      }
      env_.take_cancelled(now);
      current_ = target;
      return done(enter_prompt(now), "redo " + plan_[std::size_t(target)].sequence_name(attempts_of(target) + 1));
    }
    case Command::Skip: {
      if (phase_ != Phase::Prompt && phase_ != Phase::Countdown && phase_ != Phase::Recording)
        return refuse("skip works on a take that is prompted or recording");
      if (phase_ == Phase::Recording) {
        if (!finish_take(now, "skipped")) return refuse(message_);
      } else {
        env_.take_cancelled(now);
        if (!post("skip", current_, nlohmann::json{{"take", plan_[std::size_t(current_)].sequence_name()}}.dump()))
          return refuse(message_);
        step_status_[std::size_t(current_)] = "skipped";
      }
      return done(advance(now), "skipped");
    }
    case Command::Pause: {
      if (phase_ == Phase::Idle || phase_ == Phase::Paused) return refuse("nothing to pause");
      if (phase_ == Phase::Recording && !finish_take(now, "interrupted")) return refuse(message_);
      if (phase_ == Phase::Countdown) env_.take_cancelled(now);
      if (!post("pause", current_, "{}")) return refuse(message_);
      paused_in_ = phase_;
      set_phase(Phase::Paused, now, 0);
      return done(true, "paused");
    }
    case Command::Resume: {
      if (phase_ != Phase::Paused) return refuse("not paused");
      if (!post("resume", current_, "{}")) return refuse(message_);
      // A take interrupted by the pause is prompted again; after a rest, the next one is.
      const bool after_rest = paused_in_ == Phase::Rest;
      return done(after_rest ? advance(now) : enter_prompt(now), "resumed");
    }
    case Command::Abort: {
      if (phase_ == Phase::Recording && !finish_take(now, "interrupted")) return refuse(message_);
      env_.take_cancelled(now);
      if (!post("abort", current_, argument.empty() ? "{}" : nlohmann::json{{"why", argument}}.dump()))
        return refuse(message_);
      set_phase(Phase::Aborted, now, 0);
      return done(true, "aborted");
    }
    case Command::Bad: {
      Attempt* last = last_finished();
      if (!last || last->status != "done") return refuse("no finished take to mark bad");
      if (!post("mark_bad", last->step, nlohmann::json{{"take", last->sequence}, {"why", argument}}.dump()))
        return refuse(message_);
      last->status = "bad";
      step_status_[std::size_t(last->step)] = "bad";
      return done(true, last->sequence + " marked bad");
    }
    case Command::Note: {
      if (argument.empty()) return refuse("a note needs text");
      return done(env_.commit_note(argument), "note saved");
    }
  }
  return refuse("unknown command");
}

RunnerView Runner::view() const {
  std::lock_guard lock(mu_);
  RunnerView v;
  const std::int64_t now = env_.now_ns();
  v.phase = phase_;
  v.paused_in = paused_in_;
  v.step = current_;
  v.steps = int(plan_.size());
  v.takes_done = int(std::count_if(step_status_.begin(), step_status_.end(),
                                   [](const std::string& s) { return s == "done" || s == "bad" || s == "earlier"; }));
  v.waiting_for_devices = waiting_for_devices_;
  v.holding = holding_;
  v.message = message_;
  v.step_status = step_status_;
  if (current_ < int(plan_.size()) && phase_ != Phase::Done && phase_ != Phase::Aborted) {
    const PlannedTake& t = plan_[std::size_t(current_)];
    // Recording or resting after it: the take just made; before it: the one about to be made.
    const bool after_take =
        phase_ == Phase::Recording || phase_ == Phase::Rest || (phase_ == Phase::Paused && paused_in_ == Phase::Rest);
    v.sequence = t.sequence_name(attempts_of(current_) + (after_take ? 0 : 1));
    v.action_name = t.action->name;
    v.action_text = t.action->text;
    v.pictogram = t.action->pictogram;
    v.force = display_name(t.action->force);
    v.hand = to_string(t.hand);
    v.repetitions = t.action->repetitions;
    if (phase_end_ns_ > now) v.seconds_left = double(phase_end_ns_ - now) / 1e9;
    if (phase_ == Phase::Recording) {
      const double period = timings(t).record_s / t.action->repetitions;
      v.repetition = std::min(t.action->repetitions, int(double(now - phase_start_ns_) / 1e9 / period) + 1);
    }
  }
  for (auto it = attempts_.rbegin(); it != attempts_.rend(); ++it)
    if (it->status != "recording") {
      v.last = *it;
      break;
    }
  return v;
}

bool Runner::finished() const {
  std::lock_guard lock(mu_);
  return phase_ == Phase::Done || phase_ == Phase::Aborted;
}

std::vector<Attempt> Runner::attempts() const {
  std::lock_guard lock(mu_);
  return attempts_;
}

}  // namespace pvcap::protocol
