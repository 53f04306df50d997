#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "protocol/runner.h"

using namespace pvcap;
using namespace pvcap::protocol;

namespace {

const std::filesystem::path kPictogram =
    std::filesystem::path(PVCAP_SOURCE_DIR) / "rig-configs/protocols/pictograms/press_palm.svg";

Protocol small_protocol() {
  return parse_protocol(
      "name: small\n"
      "timings: {prompt_s: 1, countdown_s: 1, record_s: 4, rest_s: 1}\n"
      "actions:\n"
      "  - {name: press_palm, text: Press, pictogram: pictograms/press_palm.svg, forces: [low, high], repetitions: 2}\n"
      "  - {name: draw_word, text: Draw, pictogram: pictograms/press_palm.svg, repetitions: 5}\n",
      kPictogram.parent_path().parent_path() / "small.yaml");
}

// A recording stand-in with a clock the test moves, a pressure stream it scripts, and a store
// that may refuse.
struct FakeEnv : RunnerEnv {
  std::int64_t now = 1'000'000'000;
  bool live = true, store_ok = true;
  double newtons = 3.0, x_mm = 160;
  std::vector<ProtocolEventRecord> events;
  std::vector<std::string> notes;
  int scheduled = 0, cancelled = 0;

  std::int64_t now_ns() override { return now; }
  bool commit(const ProtocolEventRecord& e) override {
    if (store_ok) events.push_back(e);
    return store_ok;
  }
  bool commit_note(const std::string& t) override {
    if (store_ok) notes.push_back(t);
    return store_ok;
  }
  bool devices_live() override { return live; }
  double stream_silence_ms() override { return live ? 10 : 1000; }
  bool has_pressure() override { return true; }
  std::vector<ForcePoint> pressure(std::int64_t from, std::int64_t to) override {
    std::vector<ForcePoint> out;
    for (std::int64_t t = from; t < to; t += 8'000'000) out.push_back({t, newtons, 40, x_mm});
    return out;
  }
  // The participant presses as prompted: High harder than Low.
  void take_scheduled(const PlannedTake& t, std::int64_t, std::int64_t) override {
    ++scheduled;
    if (scripted_force) newtons = t.action->force == Force::High ? 6.0 : 2.0;
    x_mm = t.hand == Hand::Left ? 60 : 160;
  }
  bool scripted_force = true;
  void take_cancelled(std::int64_t) override { ++cancelled; }
  // Lights: every switch asked, in the rig's form; the images show `seen` (empty: as commanded).
  std::vector<std::string> switched;
  std::string lit = "LCR", seen;
  std::optional<std::string> set_lighting(const std::string& code) override {
    switched.push_back(code);
    lit = code;
    return code;
  }
  std::string lighting_seen(std::int64_t, std::int64_t) override { return seen.empty() ? lit : seen; }
  std::string lighting_now() override { return "LCR"; }
  std::vector<std::string> kinds() const {
    std::vector<std::string> k;
    for (const auto& e : events) k.push_back(e.kind);
    return k;
  }
};

// Moves the clock in 50 ms ticks for `seconds`.
void run_for(Runner& r, FakeEnv& env, double seconds) {
  for (int i = 0; i < int(seconds * 20); ++i) {
    env.now += 50'000'000;
    r.tick();
  }
}

// Brings a fresh runner to `phase` (in its first take, or after it for rest).
void reach(Runner& r, FakeEnv& env, Phase phase) {
  if (phase == Phase::Idle) return;
  ASSERT_TRUE(r.command(Command::Start).ok);
  if (phase == Phase::Prompt) return;
  if (phase == Phase::Paused) {
    ASSERT_TRUE(r.command(Command::Pause).ok);
    return;
  }
  if (phase == Phase::Aborted) {
    ASSERT_TRUE(r.command(Command::Abort).ok);
    return;
  }
  run_for(r, env, 1.05);
  if (phase == Phase::Countdown) return;
  run_for(r, env, 1.0);
  if (phase == Phase::Recording) return;
  run_for(r, env, 4.0);
  ASSERT_EQ(r.view().phase, Phase::Rest);
  if (phase == Phase::Rest) return;
  FAIL() << "cannot reach " << to_string(phase);
}

}  // namespace

TEST(Runner, WalksThePlanThroughEveryPhaseAndCommitsEachTransition) {
  const Protocol p = small_protocol();
  FakeEnv env;
  Runner r(p, "right_first", env, {});
  EXPECT_EQ(r.view().phase, Phase::Idle);
  run_for(r, env, 2);
  EXPECT_EQ(r.view().phase, Phase::Idle) << "nothing happens before start";
  ASSERT_TRUE(r.command(Command::Start).ok);
  EXPECT_EQ(r.view().phase, Phase::Prompt);
  EXPECT_EQ(r.view().sequence, "press_palm_low_2x_right");
  run_for(r, env, 1.05);
  EXPECT_EQ(r.view().phase, Phase::Countdown);
  run_for(r, env, 1.0);
  EXPECT_EQ(r.view().phase, Phase::Recording);
  EXPECT_EQ(r.view().repetition, 1);
  run_for(r, env, 2.1);
  EXPECT_EQ(r.view().repetition, 2);
  run_for(r, env, 2.0);
  EXPECT_EQ(r.view().phase, Phase::Rest);
  EXPECT_EQ(r.view().sequence, "press_palm_low_2x_right") << "resting after the take just made";
  run_for(r, env, 60);
  EXPECT_EQ(r.view().phase, Phase::Done);
  EXPECT_TRUE(r.finished());
  EXPECT_EQ(r.view().takes_done, 6);
  const auto k = env.kinds();
  EXPECT_EQ(k.front(), "protocol_start");
  EXPECT_EQ(k.back(), "protocol_end");
  EXPECT_EQ(std::count(k.begin(), k.end(), "action_start"), 6);
  EXPECT_EQ(std::count(k.begin(), k.end(), "action_end"), 6);
  // Events are stamped on the capture clock, in order; both hands in the hand order.
  for (std::size_t i = 1; i < env.events.size(); ++i) EXPECT_GE(env.events[i].host_ns, env.events[i - 1].host_ns);
  const auto attempts = r.attempts();
  ASSERT_EQ(attempts.size(), 6u);
  EXPECT_EQ(attempts[3].sequence, "press_palm_low_2x_left");
  for (const auto& a : attempts) EXPECT_EQ(a.status, "done");
}

TEST(Runner, EveryCommandInEveryStateIsAcceptedOrRefusedAsDocumented) {
  const Protocol p = small_protocol();
  // For each state: which commands are accepted, and the phase each leads to.
  struct Expect {
    bool ok;
    Phase after;
  };
  using C = Command;
  using P = Phase;
  const std::map<P, std::map<C, Expect>> table = {
      {P::Idle,
       {{C::Start, {true, P::Prompt}},
        {C::Next, {false, P::Idle}},
        {C::Redo, {false, P::Idle}},
        {C::Skip, {false, P::Idle}},
        {C::Pause, {false, P::Idle}},
        {C::Resume, {false, P::Idle}},
        {C::Abort, {true, P::Aborted}},
        {C::Bad, {false, P::Idle}},
        {C::Note, {true, P::Idle}}}},
      {P::Prompt,
       {{C::Start, {false, P::Prompt}},
        {C::Next, {true, P::Countdown}},
        {C::Redo, {false, P::Prompt}},
        {C::Skip, {true, P::Prompt}},
        {C::Pause, {true, P::Paused}},
        {C::Resume, {false, P::Prompt}},
        {C::Abort, {true, P::Aborted}},
        {C::Bad, {false, P::Prompt}},
        {C::Note, {true, P::Prompt}}}},
      {P::Countdown,
       {{C::Start, {false, P::Countdown}},
        {C::Next, {true, P::Recording}},
        {C::Redo, {false, P::Countdown}},
        {C::Skip, {true, P::Prompt}},
        {C::Pause, {true, P::Paused}},
        {C::Resume, {false, P::Countdown}},
        {C::Abort, {true, P::Aborted}},
        {C::Bad, {false, P::Countdown}},
        {C::Note, {true, P::Countdown}}}},
      {P::Recording,
       {{C::Start, {false, P::Recording}},
        {C::Next, {true, P::Prompt}},
        {C::Redo, {true, P::Prompt}},
        {C::Skip, {true, P::Prompt}},
        {C::Pause, {true, P::Paused}},
        {C::Resume, {false, P::Recording}},
        {C::Abort, {true, P::Aborted}},
        {C::Bad, {false, P::Recording}},
        {C::Note, {true, P::Recording}}}},
      {P::Rest,
       {{C::Start, {false, P::Rest}},
        {C::Next, {true, P::Prompt}},
        {C::Redo, {true, P::Prompt}},
        {C::Skip, {false, P::Rest}},
        {C::Pause, {true, P::Paused}},
        {C::Resume, {false, P::Rest}},
        {C::Abort, {true, P::Aborted}},
        {C::Bad, {true, P::Rest}},
        {C::Note, {true, P::Rest}}}},
      {P::Paused,
       {{C::Start, {false, P::Paused}},
        {C::Next, {false, P::Paused}},
        {C::Redo, {false, P::Paused}},
        {C::Skip, {false, P::Paused}},
        {C::Pause, {false, P::Paused}},
        {C::Resume, {true, P::Prompt}},
        {C::Abort, {true, P::Aborted}},
        {C::Bad, {false, P::Paused}},
        {C::Note, {true, P::Paused}}}},
      {P::Aborted,
       {{C::Start, {false, P::Aborted}},
        {C::Next, {false, P::Aborted}},
        {C::Redo, {false, P::Aborted}},
        {C::Skip, {false, P::Aborted}},
        {C::Pause, {false, P::Aborted}},
        {C::Resume, {false, P::Aborted}},
        {C::Abort, {false, P::Aborted}},
        {C::Bad, {false, P::Aborted}},
        {C::Note, {true, P::Aborted}}}},
  };
  for (const auto& [state, commands] : table)
    for (const auto& [command, expect] : commands) {
      FakeEnv env;
      Runner r(p, "right_first", env, {});
      reach(r, env, state);
      ASSERT_EQ(r.view().phase, state);
      const std::size_t events_before = env.events.size();
      const auto reply = r.command(command, "a note");
      EXPECT_EQ(reply.ok, expect.ok) << "in " << to_string(state) << ", command " << int(command) << ": "
                                     << reply.message;
      EXPECT_EQ(r.view().phase, expect.after) << "in " << to_string(state) << ", command " << int(command);
      if (!reply.ok) {
        EXPECT_FALSE(reply.message.empty());
      }
      if (reply.ok && command != Command::Note) {
        EXPECT_GT(env.events.size(), events_before);
      }
      if (!reply.ok) {
        EXPECT_EQ(env.events.size(), events_before) << "a refused command leaves no event";
      }
    }
}

TEST(Runner, RedoSupersedesThePreviousTakeAndNamesTheRetake) {
  const Protocol p = small_protocol();
  FakeEnv env;
  Runner r(p, "right_first", env, {});
  reach(r, env, Phase::Rest);
  ASSERT_TRUE(r.command(Command::Redo).ok);
  EXPECT_EQ(r.view().sequence, "press_palm_low_2x_right(2)");
  run_for(r, env, 1.05 + 1.0 + 4.0 + 1.0);
  // After the retake the plan goes on with the take after it.
  EXPECT_EQ(r.view().phase, Phase::Prompt);
  EXPECT_EQ(r.view().sequence, "press_palm_high_2x_right");
  const auto a = r.attempts();
  ASSERT_EQ(a.size(), 2u);
  EXPECT_EQ(a[0].status, "superseded");
  EXPECT_EQ(a[1].status, "done");
  EXPECT_EQ(a[1].sequence, "press_palm_low_2x_right(2)");
  const auto k = env.kinds();
  EXPECT_NE(std::find(k.begin(), k.end(), "superseded"), k.end());
}

TEST(Runner, RedoDuringTheNextPromptRetakesThePreviousTakeThenComesBack) {
  const Protocol p = small_protocol();
  FakeEnv env;
  Runner r(p, "right_first", env, {});
  reach(r, env, Phase::Rest);
  run_for(r, env, 1.0);
  ASSERT_EQ(r.view().sequence, "press_palm_high_2x_right");
  ASSERT_TRUE(r.command(Command::Redo).ok);
  EXPECT_EQ(r.view().sequence, "press_palm_low_2x_right(2)");
  run_for(r, env, 7.05);
  EXPECT_EQ(r.view().sequence, "press_palm_high_2x_right");
}

TEST(Runner, SkipPauseResumeAndBadAreRecordedPerTake) {
  const Protocol p = small_protocol();
  FakeEnv env;
  Runner r(p, "right_first", env, {});
  reach(r, env, Phase::Recording);
  ASSERT_TRUE(r.command(Command::Pause).ok);
  EXPECT_EQ(r.attempts().back().status, "interrupted");
  ASSERT_TRUE(r.command(Command::Resume).ok);
  EXPECT_EQ(r.view().sequence, "press_palm_low_2x_right(2)") << "an interrupted take is prompted again";
  ASSERT_TRUE(r.command(Command::Skip).ok);
  EXPECT_EQ(r.view().sequence, "press_palm_high_2x_right");
  EXPECT_EQ(r.view().step_status[0], "skipped");
  run_for(r, env, 6.05);
  ASSERT_EQ(r.view().phase, Phase::Rest);
  ASSERT_TRUE(r.command(Command::Bad, "sneezed").ok);
  EXPECT_EQ(r.view().step_status[1], "bad");
  EXPECT_EQ(r.attempts().back().status, "bad");
  EXPECT_FALSE(r.command(Command::Bad).ok) << "a take is marked bad once";
}

TEST(Runner, NoCountdownWhileADeviceIsMissing) {
  const Protocol p = small_protocol();
  FakeEnv env;
  Runner r(p, "right_first", env, {});
  ASSERT_TRUE(r.command(Command::Start).ok);
  env.live = false;
  run_for(r, env, 5);
  EXPECT_EQ(r.view().phase, Phase::Prompt);
  EXPECT_TRUE(r.view().waiting_for_devices);
  EXPECT_FALSE(r.command(Command::Next).ok);
  env.live = true;
  run_for(r, env, 0.1);
  EXPECT_EQ(r.view().phase, Phase::Countdown);
  // Lost during the countdown: back to the prompt.
  env.live = false;
  run_for(r, env, 1.1);
  EXPECT_EQ(r.view().phase, Phase::Prompt);
}

TEST(Runner, ACommandTheStoreDidNotTakeIsNotAcknowledged) {
  const Protocol p = small_protocol();
  FakeEnv env;
  Runner r(p, "right_first", env, {});
  env.store_ok = false;
  const auto reply = r.command(Command::Start);
  EXPECT_FALSE(reply.ok);
  EXPECT_NE(reply.message.find("store"), std::string::npos);
  EXPECT_TRUE(env.events.empty());
}

TEST(Runner, AFailedTakeCheckHoldsForTheOperatorUnlessAutomatic) {
  const Protocol p = small_protocol();
  for (bool automatic : {false, true}) {
    FakeEnv env;
    env.scripted_force = false;
    env.newtons = 0.0;  // nothing pressed
    RunnerOptions o;
    o.auto_advance = automatic;
    Runner r(p, "right_first", env, o);
    reach(r, env, Phase::Rest);
    const auto last = r.view().last;
    ASSERT_TRUE(last && last->check);
    EXPECT_FALSE(last->check->ok);
    EXPECT_NE(r.view().message.find("does not match its prompt"), std::string::npos);
    run_for(r, env, 1.05);
    EXPECT_EQ(r.view().phase, automatic ? Phase::Prompt : Phase::Rest);
    if (!automatic) {
      run_for(r, env, 30);
      EXPECT_EQ(r.view().phase, Phase::Rest) << "holds until the operator decides";
    }
    EXPECT_EQ(r.view().holding, !automatic);
    // The check's verdict is in the store with the take's end.
    const auto& end = *std::find_if(env.events.rbegin(), env.events.rend(),
                                    [](const ProtocolEventRecord& e) { return e.kind == "action_end"; });
    EXPECT_FALSE(nlohmann::json::parse(end.detail)["check"]["ok"].get<bool>());
  }
}

TEST(Runner, ResumeStartsAtTheGivenStep) {
  const Protocol p = small_protocol();
  FakeEnv env;
  RunnerOptions o;
  o.first_step = 4;
  o.auto_start = true;
  Runner r(p, "left_first", env, o);
  r.tick();
  EXPECT_EQ(r.view().phase, Phase::Prompt);
  EXPECT_EQ(r.view().sequence, "press_palm_high_2x_right");
  EXPECT_EQ(r.view().takes_done, 4);
}

// A protocol's lighting is switched while the take's prompt shows, only when it changes, back to the
// session's after an action with its own; a take whose images showed another lighting fails its check.
TEST(Runner, TheLightingIsSwitchedAtThePromptWhenItChangesAndCheckedAtTheTakesEnd) {
  const Protocol p = parse_protocol(
      "name: lit\n"
      "timings: {prompt_s: 1, countdown_s: 1, record_s: 4, rest_s: 1}\n"
      "actions:\n"
      "  - {name: a, text: A, pictogram: pictograms/press_palm.svg, lighting: L--, hands: [right]}\n"
      "  - {name: b, text: B, pictogram: pictograms/press_palm.svg, lighting: L--, hands: [right]}\n"
      "  - {name: c, text: C, pictogram: pictograms/press_palm.svg, hands: [right]}\n",
      kPictogram.parent_path().parent_path() / "lit.yaml");
  FakeEnv env;
  RunnerOptions o;
  o.lighting = "LCR";
  o.auto_advance = true;
  Runner r(p, "right_first", env, o);
  ASSERT_TRUE(r.command(Command::Start).ok);
  run_for(r, env, 8);   // take a under L--
  env.seen = "---";     // take b: the lamp went out
  run_for(r, env, 8);
  env.seen = "";
  run_for(r, env, 10);  // take c under the session's LCR
  EXPECT_EQ(env.switched, (std::vector<std::string>{"L--", "LCR"})) << "b keeps a's lighting; c goes back";
  const auto attempts = r.attempts();
  ASSERT_EQ(attempts.size(), 3u);
  EXPECT_TRUE(attempts[0].check->ok);
  ASSERT_FALSE(attempts[1].check->ok);
  EXPECT_NE(attempts[1].check->problems[0].find("light L did not come on"), std::string::npos);
  EXPECT_TRUE(attempts[2].check->ok);
  // The takes' events carry the lighting commanded and seen.
  int with_lighting = 0;
  for (const auto& e : env.events)
    if (e.kind == "action_end" && e.detail.find("\"commanded\":\"L--\"") != std::string::npos) ++with_lighting;
  EXPECT_EQ(with_lighting, 2);
}
