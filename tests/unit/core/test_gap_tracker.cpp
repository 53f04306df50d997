#include <gtest/gtest.h>

#include <tuple>
#include <vector>

#include "core/gap_tracker.h"
#include "core/loss_runs.h"

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

TEST(LossRuns, ARangeSplitsIntoRunsOfDroppedAndNotReceived) {
  std::vector<std::tuple<std::uint64_t, std::uint64_t, bool>> runs;
  auto collect = [&](std::uint64_t first, std::uint64_t count, bool dropped) {
    runs.emplace_back(first, count, dropped);
  };
  // 10..19 missing; the driver dropped 12, 13 and 19 (and 5 and 30, outside the range).
  pvcap::for_each_loss_run(10, 20, {5, 12, 13, 19, 30}, collect);
  using R = std::tuple<std::uint64_t, std::uint64_t, bool>;
  EXPECT_EQ(runs, (std::vector<R>{{10, 2, false}, {12, 2, true}, {14, 5, false}, {19, 1, true}}));
  runs.clear();
  pvcap::for_each_loss_run(7, 7, {7}, collect);
  EXPECT_TRUE(runs.empty()) << "an empty range has no run";
  pvcap::for_each_loss_run(3, 6, {}, collect);
  EXPECT_EQ(runs, (std::vector<R>{{3, 3, false}}));
  runs.clear();
  pvcap::for_each_loss_run(3, 6, {3, 4, 5}, collect);
  EXPECT_EQ(runs, (std::vector<R>{{3, 3, true}}));
}
