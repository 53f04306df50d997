// The group rule (sync/group_rule.h) on its own and beside the live grouper that applies it: what
// the end-of-session re-mapping does with a group must be what the grouper did with its frames.
#include <gtest/gtest.h>

#include <random>

#include "sync/group_rule.h"
#include "sync/timeline.h"

using namespace pvcap::sync;

TEST(GroupRule, AGroupsTimeIsItsMembersMeanAndItsSpanLatestMinusEarliest) {
  EXPECT_EQ(group_time({}).t_ns, 0);
  EXPECT_EQ(group_time({}).span_ns, 0);
  EXPECT_EQ(group_time({1'000}).t_ns, 1'000);
  const GroupTime g = group_time({1'300, 1'000, 1'200, 1'100});
  EXPECT_EQ(g.t_ns, 1'150);
  EXPECT_EQ(g.span_ns, 300);
  // Near the end of the clock's range: relative to the earliest, the sum cannot overflow.
  const std::int64_t far = INT64_MAX - 1'000'000;
  EXPECT_EQ(group_time({far, far + 400, far + 200}).t_ns, far + 200);
}

TEST(GroupRule, FramesWithinTheLimitStayAndTheMostThatKeepItWin) {
  const std::int64_t limit = 8'000'000;  // half a 60-Hz period
  // All within the limit: the whole group, whatever the tick.
  EXPECT_EQ(members_within({0, 3'000'000, 8'000'000}, limit, 40'000'000), (std::pair<std::size_t, std::size_t>{0, 3}));
  // One camera the final fits put 12 ms late: it leaves, the three together stay.
  EXPECT_EQ(members_within({0, 1'000'000, 2'000'000, 14'000'000}, limit, 0),
            (std::pair<std::size_t, std::size_t>{0, 3}));
  EXPECT_EQ(members_within({0, 12'000'000, 13'000'000, 14'000'000}, limit, 0),
            (std::pair<std::size_t, std::size_t>{1, 4}));
  // Two and two: the pair whose mean is nearer the tick stays.
  const std::vector<std::int64_t> split{0, 1'000'000, 20'000'000, 21'000'000};
  EXPECT_EQ(members_within(split, limit, 2'000'000), (std::pair<std::size_t, std::size_t>{0, 2}));
  EXPECT_EQ(members_within(split, limit, 19'000'000), (std::pair<std::size_t, std::size_t>{2, 4}));
  EXPECT_EQ(members_within({}, limit, 0), (std::pair<std::size_t, std::size_t>{0, 0}));
}

// Four jittery cameras through the live grouper: every group it makes keeps the rule whole (the
// re-mapping, with unchanged fits, changes no group), and its instant is the rule's group time.
TEST(GroupRule, TheLiveGroupersGroupsAreTheRulesGroups) {
  const std::int64_t period = 16'666'667, limit = Grouper::limit_for(60);
  Grouper grouper(4, limit, 200'000'000);
  std::mt19937_64 rng(5);
  std::uniform_int_distribution<std::int64_t> jitter(-3'000'000, 3'000'000);
  std::uniform_real_distribution<double> drop(0, 1);
  std::vector<Group> groups;
  for (std::uint64_t i = 0; i < 600; ++i)
    for (int c = 0; c < 4; ++c) {
      if (drop(rng) < 0.03) continue;  // a frame lost now and then: incomplete groups too
      grouper.add({c, i, 1'000'000'000 + std::int64_t(i) * period + c * 2'000'000 + jitter(rng), 0});
      for (auto& g : grouper.take()) groups.push_back(std::move(g));
    }
  for (auto& g : grouper.take(true)) groups.push_back(std::move(g));
  ASSERT_GT(groups.size(), 590u);
  std::size_t incomplete = 0;
  for (const Group& g : groups) {
    std::vector<std::int64_t> times;
    for (const auto& m : g.members)
      if (m) times.push_back(m->t_ns);
    std::sort(times.begin(), times.end());
    incomplete += !g.complete();
    EXPECT_EQ(members_within(times, limit, g.t_ns), (std::pair<std::size_t, std::size_t>{0, times.size()}));
    const GroupTime at = group_time(times);
    EXPECT_EQ(at.t_ns, g.t_ns);
    EXPECT_EQ(at.span_ns, g.span_ns);
  }
  EXPECT_GT(incomplete, 0u);
}
