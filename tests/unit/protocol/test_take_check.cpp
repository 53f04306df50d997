#include <gtest/gtest.h>

#include <cmath>

#include "protocol/take_check.h"

using namespace pvcap::protocol;

namespace {
// A take of `seconds` at 125 Hz: `presses` presses peaking at `peak_n`, centred at x_mm.
std::vector<ForcePoint> take(double seconds, int presses, double peak_n, double x_mm, std::int64_t gap_from = -1,
                             std::int64_t gap_to = -1) {
  std::vector<ForcePoint> out;
  const double period = seconds / presses;
  for (std::int64_t t = 0; t < std::int64_t(seconds * 1e9); t += 8'000'000) {
    if (t >= gap_from && t < gap_to) continue;
    const double phase = std::fmod(double(t) / 1e9, period) / period;
    const double f = phase < 0.5 ? std::sin(phase * 2 * M_PI) * peak_n : 0.0;
    out.push_back({t, f, f > 0 ? 50.0 : 0.0, x_mm});
  }
  return out;
}

Action action(Force f) {
  Action a;
  a.name = "press_palm";
  a.group = "press_palm";
  a.force = f;
  a.repetitions = 5;
  return a;
}

TakeCheck check(const Action& a, Hand hand, const std::vector<ForcePoint>& pts, std::optional<double> low = {},
                double camera_gap = 10) {
  TakeCheckInput in;
  in.action = &a;
  in.hand = hand;
  in.measures = measure_take(pts, 0, 10'000'000'000);
  in.low_mean_newtons = low;
  in.max_camera_gap_ms = camera_gap;
  return check_take(in, TakeCheckConfig{});
}
}  // namespace

TEST(TakeCheck, MeasuresForceContactAndWhere) {
  const auto m = measure_take(take(10, 5, 4.0, 160), 0, 10'000'000'000);
  EXPECT_EQ(m.frames, 1250u);
  EXPECT_NEAR(m.peak_newtons, 4.0, 0.01);
  EXPECT_NEAR(m.mean_newtons, 4.0 / M_PI, 0.05);  // half of each period a sine, half nothing
  ASSERT_TRUE(m.centroid_x_mm);
  EXPECT_NEAR(*m.centroid_x_mm, 160, 1e-6);
  EXPECT_LE(m.max_pressure_gap_ms, 8.01);
}

TEST(TakeCheck, APressOfTheRightKindAndHandPasses) {
  const Action low = action(Force::Low);
  EXPECT_TRUE(check(low, Hand::Right, take(10, 5, 2.0, 160)).ok);
  EXPECT_TRUE(check(low, Hand::Left, take(10, 5, 2.0, 60)).ok);
}

TEST(TakeCheck, NoPressWhenOneWasAskedFails) {
  const auto c = check(action(Force::Low), Hand::Right, take(10, 5, 0.1, 160));
  ASSERT_FALSE(c.ok);
  EXPECT_NE(c.problems[0].find("no press was felt"), std::string::npos);
}

TEST(TakeCheck, NoContactFailsWhenThePadFeltSomething) {
  const Action none = action(Force::NoContact);
  EXPECT_TRUE(check(none, Hand::Right, take(10, 5, 0.0, 160)).ok);
  EXPECT_TRUE(check(none, Hand::Right, take(10, 5, 0.1, 160)).ok);
  EXPECT_FALSE(check(none, Hand::Right, take(10, 5, 1.0, 160)).ok);
}

TEST(TakeCheck, HighMustBeClearlyAboveTheSameParticipantsLow) {
  const Action high = action(Force::High);
  const double low_mean = measure_take(take(10, 5, 2.0, 160), 0, 10'000'000'000).mean_newtons;
  EXPECT_TRUE(check(high, Hand::Right, take(10, 5, 6.0, 160), low_mean).ok);
  const auto c = check(high, Hand::Right, take(10, 5, 2.2, 160), low_mean);
  ASSERT_FALSE(c.ok);
  EXPECT_NE(c.problems[0].find("High was not clearly above Low"), std::string::npos);
  EXPECT_TRUE(check(high, Hand::Right, take(10, 5, 2.2, 160)).ok) << "without a Low take there is nothing to compare";
}

TEST(TakeCheck, TheWrongHalfOfThePadFailsUnlessTheActionSaysOtherwise) {
  Action low = action(Force::Low);
  const auto c = check(low, Hand::Right, take(10, 5, 2.0, 60));
  ASSERT_FALSE(c.ok);
  EXPECT_NE(c.problems[0].find("left half"), std::string::npos);
  low.check_side = false;
  EXPECT_TRUE(check(low, Hand::Right, take(10, 5, 2.0, 60)).ok);
}

TEST(TakeCheck, ADeviceGapFails) {
  const Action low = action(Force::Low);
  EXPECT_FALSE(check(low, Hand::Right, take(10, 5, 2.0, 160, 3'000'000'000, 3'400'000'000)).ok);
  EXPECT_FALSE(check(low, Hand::Right, take(10, 5, 2.0, 160), {}, 400).ok);
}

// A take whose images showed another lighting than commanded fails, naming each light that differs.
TEST(TakeCheck, ALightingTheImagesDidNotShowFailsNamingTheLights) {
  const Action low = action(Force::Low);
  TakeCheckInput in;
  in.action = &low;
  in.hand = Hand::Right;
  in.measures = measure_take(take(10, 5, 2.0, 160), 0, 10'000'000'000);
  in.lighting_commanded = "LC-";
  in.lighting_seen = "LC-";
  EXPECT_TRUE(check_take(in, TakeCheckConfig{}).ok);
  in.lighting_seen = "L-R";
  const TakeCheck c = check_take(in, TakeCheckConfig{});
  ASSERT_FALSE(c.ok);
  EXPECT_EQ(c.problems[0], "the images show lighting L-R, not the LC- commanded (light C did not come on, light R was on)");
  in.lighting_seen = "";  // nothing could tell (no light check): not checked
  EXPECT_TRUE(check_take(in, TakeCheckConfig{}).ok);
}
