#include <gtest/gtest.h>

#include <random>

#include "sync/grid_keeper.h"

TEST(GridKeeper, SixtyHertzWithJitterKeepsOneFramePerFifteenHertzTick) {
  const std::int64_t anchor = 1'000'000'000;
  pvcap::GridKeeper keeper(anchor, 15.0, 60.0);
  std::mt19937 rng(1);
  std::normal_distribution<double> jitter(0, 1e6);  // 1 ms
  std::vector<std::int64_t> kept;
  for (int i = 0; i < 6000; ++i) {  // 100 s at 60 Hz, starting 3 ms after the anchor
    const auto t = anchor + 3'000'000 + std::int64_t(i * 1e9 / 60.0 + jitter(rng));
    if (keeper.keep(t)) kept.push_back(t);
  }
  EXPECT_NEAR(double(kept.size()), 1500.0, 2.0);
  for (std::size_t i = 1; i < kept.size(); ++i) {
    const double tick = (double(kept[i] - anchor) * 15.0 / 1e9);
    EXPECT_NEAR(tick, std::round(tick), 0.5 * 15.0 / 60.0 + 0.1) << i;  // within half a source period of its tick
  }
  // Anchored: the last kept frame is still on the grid after 100 s (no drift).
  const double last_tick = double(kept.back() - anchor) * 15.0 / 1e9;
  EXPECT_NEAR(last_tick, std::round(last_tick), 0.2);
}

TEST(GridKeeper, ZeroRateKeepsEverything) {
  pvcap::GridKeeper keeper(0, 0.0, 60.0);
  for (int i = 0; i < 10; ++i) EXPECT_TRUE(keeper.keep(i * 1000));
}

TEST(GridKeeper, NeverKeepsTwoFramesForOneTick) {
  pvcap::GridKeeper keeper(0, 15.0, 60.0);
  EXPECT_TRUE(keeper.keep(1'000'000));
  EXPECT_FALSE(keeper.keep(2'000'000));  // same tick
}

TEST(GridKeeper, LateArrivalsStillServeTheirTick) {
  // 60 Hz frames arriving 10-30 ms late (a loaded machine): no tick may be left empty.
  pvcap::GridKeeper keeper(0, 15.0, 60.0);
  std::mt19937 rng(2);
  std::uniform_real_distribution<double> late(10e6, 30e6);
  int kept = 0;
  for (int i = 0; i < 600; ++i)
    if (keeper.keep(std::int64_t(i * 1e9 / 60.0 + late(rng)))) ++kept;
  EXPECT_GE(kept, 149);
  EXPECT_LE(kept, 151);
}
