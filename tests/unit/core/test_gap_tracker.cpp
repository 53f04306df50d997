#include <gtest/gtest.h>

#include "core/gap_tracker.h"

using pvcap::GapTracker;

TEST(GapTracker, LateFrameClosesItsGapAndIsNotCountedAsDropped) {
  std::vector<GapTracker::Gap> reported;
  GapTracker t(1000, [&](const GapTracker::Gap& g) { reported.push_back(g); });
  t.missing(10, 1, 0);
  EXPECT_TRUE(t.arrived_late(10));
  t.settle(5000);
  EXPECT_TRUE(reported.empty());
}

TEST(GapTracker, LateFrameSplitsALongerGap) {
  std::vector<GapTracker::Gap> reported;
  GapTracker t(1000, [&](const GapTracker::Gap& g) { reported.push_back(g); });
  t.missing(10, 5, 0);  // 10..14
  EXPECT_TRUE(t.arrived_late(12));
  t.settle(5000);
  ASSERT_EQ(reported.size(), 2u);
  std::uint64_t total = 0;
  for (const auto& g : reported) total += g.count;
  EXPECT_EQ(total, 4u);
}

TEST(GapTracker, GapIsReportedOnlyAfterTheGrace) {
  int reports = 0;
  GapTracker t(1000, [&](const GapTracker::Gap&) { ++reports; });
  t.missing(3, 2, 100);
  t.settle(900);
  EXPECT_EQ(reports, 0);
  t.settle(1100);
  EXPECT_EQ(reports, 1);
  EXPECT_EQ(t.open_gaps(), 0u);
}

TEST(GapTracker, DuplicateIsNotALateFrame) {
  GapTracker t(1000, [](const GapTracker::Gap&) {});
  t.missing(3, 1, 0);
  EXPECT_FALSE(t.arrived_late(7));
}

TEST(GapTracker, FlushReportsEverythingOpen) {
  int reports = 0;
  GapTracker t(1'000'000, [&](const GapTracker::Gap&) { ++reports; });
  t.missing(1, 1, 0);
  t.missing(5, 1, 0);
  t.settle(1, /*flush_all=*/true);
  EXPECT_EQ(reports, 2);
}
