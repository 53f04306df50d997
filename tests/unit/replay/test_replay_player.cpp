// The replay window's state machine without a window: every key, and playback that follows the
// session's clock (at the chosen speed) rather than the pace pictures can be drawn at.
#include <gtest/gtest.h>

#include <cmath>

#include "replay/replay_player.h"
#include "sync/timeline.h"

using namespace pvcap::replay;

namespace {
constexpr std::int64_t kMs = 1'000'000;
// 100 samples at 15 Hz from t = 1 s, takes starting at samples 10, 40 and 70.
ReplayPlayer player() {
  std::vector<std::int64_t> t;
  for (int i = 0; i < 100; ++i) t.push_back(1'000 * kMs + i * 1'000 * kMs / 15);
  return ReplayPlayer(t, {10, 40, 70});
}
}  // namespace

TEST(ReplayPlayer, KeysOfBothBackendsAndByNameMapToTheSameActions) {
  EXPECT_EQ(key_from_code(' '), PlayerKey::PlayPause);
  EXPECT_EQ(key_from_code(0xFF53), PlayerKey::StepForward);      // GTK right arrow
  EXPECT_EQ(key_from_code(0x01000014), PlayerKey::StepForward);  // Qt right arrow
  EXPECT_EQ(key_from_code(0xFF51), PlayerKey::StepBack);
  EXPECT_EQ(key_from_code(0x01000012), PlayerKey::StepBack);
  EXPECT_EQ(key_from_code(27), PlayerKey::Quit);
  EXPECT_EQ(key_from_code('x'), PlayerKey::None);
  EXPECT_EQ(key_from_name("space"), PlayerKey::PlayPause);
  EXPECT_EQ(key_from_name("right"), PlayerKey::StepForward);
  EXPECT_EQ(key_from_name("pgdn"), PlayerKey::SeekForward);
  EXPECT_EQ(key_from_name("n"), PlayerKey::NextTake);
  EXPECT_EQ(key_from_name("+"), PlayerKey::Faster);
  EXPECT_EQ(key_from_name("q"), PlayerKey::Quit);
  EXPECT_EQ(key_from_name("nonsense"), PlayerKey::None);
}

TEST(ReplayPlayer, StepsSeeksAndJumpsBetweenTakes) {
  auto p = player();
  EXPECT_EQ(p.position(), 0u);
  EXPECT_FALSE(p.playing());
  p.press(PlayerKey::StepBack, 0);
  EXPECT_EQ(p.position(), 0u) << "never before the first sample";
  p.press(PlayerKey::StepForward, 0);
  p.press(PlayerKey::StepForward, 0);
  EXPECT_EQ(p.position(), 2u);
  p.press(PlayerKey::SeekForward, 0);  // +5 s = 75 samples at 15 Hz
  EXPECT_EQ(p.position(), 77u);
  p.press(PlayerKey::SeekForward, 0);
  EXPECT_EQ(p.position(), 99u) << "a seek stops at the end";
  p.press(PlayerKey::SeekBack, 0);
  EXPECT_EQ(p.position(), 24u);
  p.press(PlayerKey::NextTake, 0);
  EXPECT_EQ(p.position(), 40u);
  p.press(PlayerKey::NextTake, 0);
  EXPECT_EQ(p.position(), 70u);
  p.press(PlayerKey::NextTake, 0);
  EXPECT_EQ(p.position(), 70u) << "no take after the last";
  p.press(PlayerKey::StepForward, 0);  // 71: inside the third take
  p.press(PlayerKey::PreviousTake, 0);
  EXPECT_EQ(p.position(), 40u) << "the take before the one shown";
  p.press(PlayerKey::PreviousTake, 0);
  EXPECT_EQ(p.position(), 10u);
  p.press(PlayerKey::PreviousTake, 0);
  EXPECT_EQ(p.position(), 10u) << "the first take has none before it";
  p.press(PlayerKey::End, 0);
  EXPECT_EQ(p.position(), 99u);
  p.press(PlayerKey::Start, 0);
  EXPECT_EQ(p.position(), 0u);
  p.press(PlayerKey::Quit, 0);
  EXPECT_TRUE(p.quit());
}

TEST(ReplayPlayer, PlaybackFollowsTheSessionClockAtTheChosenSpeed) {
  auto p = player();
  p.press(PlayerKey::NextTake, 0);  // sample 10
  p.press(PlayerKey::PlayPause, 0);
  ASSERT_TRUE(p.playing());
  EXPECT_GE(p.wait_ms(0), 66);
  EXPECT_LE(p.wait_ms(0), 67) << "the next sample is a 15th of a second away";
  p.tick(1'000 * kMs);  // one second of wall time: 15 samples on
  EXPECT_EQ(p.position(), 25u);
  // However late the window gets to it, the sample shown is where the clock is: pictures are
  // skipped, the clock is not slowed.
  p.tick(2'000 * kMs);
  EXPECT_EQ(p.position(), 40u);
  p.press(PlayerKey::Faster, 2'000 * kMs);
  EXPECT_DOUBLE_EQ(p.speed(), 2.0);
  p.tick(2'500 * kMs);  // half a second at 2x: another second of session
  EXPECT_EQ(p.position(), 55u);
  p.press(PlayerKey::Slower, 2'500 * kMs);
  p.press(PlayerKey::Slower, 2'500 * kMs);
  EXPECT_DOUBLE_EQ(p.speed(), 0.5);
  p.tick(4'500 * kMs);  // two seconds at 0.5x: one second
  EXPECT_EQ(p.position(), 70u);
  p.press(PlayerKey::PlayPause, 4'500 * kMs);
  EXPECT_FALSE(p.playing());
  p.tick(9'000 * kMs);
  EXPECT_EQ(p.position(), 70u) << "paused: time does not move it";
  p.press(PlayerKey::PlayPause, 9'000 * kMs);
  p.tick(60'000 * kMs);
  EXPECT_EQ(p.position(), 99u);
  EXPECT_FALSE(p.playing()) << "stops at the end";
  p.press(PlayerKey::PlayPause, 60'000 * kMs);
  EXPECT_TRUE(p.playing());
  EXPECT_EQ(p.position(), 0u) << "play at the end starts again";
  for (int i = 0; i < 10; ++i) p.press(PlayerKey::Faster, 0);
  EXPECT_DOUBLE_EQ(p.speed(), 8.0);
}

TEST(SampleGrid, SessionsOfOneRateShareTheGridsLattice) {
  const double hz = 15;
  const std::int64_t a = pvcap::sync::grid_lattice_floor(123'456'789'012, hz);
  const std::int64_t b = pvcap::sync::grid_lattice_floor(987'654'321'098, hz);
  EXPECT_LE(a, 123'456'789'012);
  EXPECT_GT(a, 123'456'789'012 - 66'666'667);
  // Any two anchors are a whole number of periods apart (to the nanosecond's rounding).
  const double periods = double(b - a) * hz / 1e9;
  EXPECT_NEAR(periods, std::round(periods), 1e-6);
  EXPECT_EQ(pvcap::sync::grid_lattice_floor(a, hz), a) << "a lattice point is its own floor";
}
