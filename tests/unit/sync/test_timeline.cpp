// Grouper, subsampler and pressure aligner on seeded streams (no sockets, no sleeping).
#include <gtest/gtest.h>

#include <set>

#include "sync/timeline.h"
#include "tests/unit/sync/sync_test_util.h"

using namespace pvcap::sync;
using namespace pvcap::sync::testing;

namespace {
constexpr std::int64_t kPeriod60 = 16'666'667;

// Four cameras at 60 Hz, each with its own phase and +-jitter, interleaved in time order
// of arrival (arrival = t + 3 ms +- 1 ms).
std::vector<FrameRef> four_cameras(double seconds, std::uint64_t seed,
                                   std::set<std::pair<int, std::uint64_t>> skip = {}) {
  std::mt19937_64 rng(seed);
  std::uniform_int_distribution<std::int64_t> jitter(-300'000, 300'000), arrive(2'000'000, 4'000'000);
  const std::int64_t phase[4] = {0, 1'500'000, -2'000'000, 3'000'000};
  std::vector<std::pair<std::int64_t, FrameRef>> all;
  for (int c = 0; c < 4; ++c)
    for (std::uint64_t i = 0; double(i) < seconds * 60; ++i) {
      if (skip.count({c, i})) continue;
      const std::int64_t t = 1'000'000'000 + std::int64_t(i) * kPeriod60 + phase[c] + jitter(rng);
      all.push_back({t + arrive(rng), FrameRef{c, i, t}});
    }
  std::sort(all.begin(), all.end(), [](auto& a, auto& b) { return a.first < b.first; });
  std::vector<FrameRef> out;
  for (auto& [arrival, f] : all) out.push_back(f);
  return out;
}
}  // namespace

TEST(Grouper, FourCamerasMakeCompleteGroupsOfTheSameFrameIndex) {
  Grouper g(4, kPeriod60 / 2, 200'000'000);
  std::vector<Group> groups;
  for (const auto& f : four_cameras(10, 1)) {
    g.add(f);
    for (auto& x : g.take()) groups.push_back(x);
  }
  for (auto& x : g.take(true)) groups.push_back(x);
  ASSERT_EQ(groups.size(), 600u);
  std::set<std::pair<int, std::uint64_t>> used;
  for (std::size_t i = 0; i < groups.size(); ++i) {
    ASSERT_TRUE(groups[i].complete()) << "group " << i;
    for (const auto& m : groups[i].members) {
      EXPECT_EQ(m->sequence, i) << "same instant, same frame index";
      EXPECT_TRUE(used.insert({m->stream, m->sequence}).second) << "each frame is used once";
    }
    EXPECT_LE(groups[i].span_ns, kPeriod60 / 2);
    if (i) {
      EXPECT_GT(groups[i].t_ns, groups[i - 1].t_ns) << "in order";
    }
  }
  EXPECT_EQ(g.complete_groups(), 600u);
  EXPECT_EQ(g.incomplete_groups(), 0u);
}

TEST(Grouper, AMissingFrameMakesACountedIncompleteGroupAndShiftsNothing) {
  Grouper g(4, kPeriod60 / 2, 200'000'000);
  std::vector<Group> groups;
  for (const auto& f : four_cameras(2, 2, {{2, 30}, {2, 31}, {0, 77}})) {
    g.add(f);
    for (auto& x : g.take()) groups.push_back(x);
  }
  for (auto& x : g.take(true)) groups.push_back(x);
  ASSERT_EQ(groups.size(), 120u);
  EXPECT_EQ(g.incomplete_groups(), 3u);
  EXPECT_FALSE(groups[30].members[2]);
  EXPECT_FALSE(groups[31].members[2]);
  EXPECT_FALSE(groups[77].members[0]);
  for (std::size_t i = 0; i < groups.size(); ++i)
    for (const auto& m : groups[i].members)
      if (m) {
        EXPECT_EQ(m->sequence, i);
      }
}

TEST(Grouper, ASilentCameraDelaysGroupsByAtMostTheWait) {
  Grouper g(2, kPeriod60 / 2, 100'000'000);
  std::size_t decided = 0;
  for (std::uint64_t i = 0; i < 120; ++i) {
    const std::int64_t t = std::int64_t(i) * kPeriod60;
    g.add({0, i, t});
    if (i < 30) g.add({1, i, t + 1'000'000});  // camera 1 stops after half a second
    decided += g.take().size();
    // Everything older than the wait (plus the half-period window) is decided.
    EXPECT_GE(decided + 8, i) << "at frame " << i;
  }
  EXPECT_GE(g.incomplete_groups(), 80u);
}

// In the session's stop the cameras stop at different moments, and nothing advances the horizon
// any more: the instants after the first camera stopped wait. A settled bound (no frame of any
// camera before it can still come) decides them up to it, as the end's flush would, and no later.
TEST(Grouper, AfterTheCamerasStoppedASettledBoundDecidesWhatNoFrameCanStillJoin) {
  std::set<std::pair<int, std::uint64_t>> stopped_early;
  for (std::uint64_t i = 108; i < 120; ++i) stopped_early.insert({0, i}), stopped_early.insert({1, i});
  const auto frames = four_cameras(2, 4, stopped_early);  // cameras 0 and 1 stop at 1.8 s, 2 and 3 at 2 s
  Grouper settled(4, kPeriod60 / 2, 200'000'000), flushed(4, kPeriod60 / 2, 200'000'000);
  std::vector<Group> a, b;
  for (const auto& f : frames) {
    settled.add(f);
    flushed.add(f);
    for (auto& x : settled.take()) a.push_back(x);
    for (auto& x : flushed.take()) b.push_back(x);
  }
  const std::size_t waiting = 120 - a.size();
  ASSERT_GE(waiting, 8u) << "the instants after 1.8 s wait for a horizon no frame moves now";
  const std::int64_t bound = 2'900'000'000;  // 1.9 s into the streams
  for (auto& x : settled.take(false, bound)) a.push_back(x);
  EXPECT_GT(a.size(), 120 - waiting) << "decided up to the bound";
  EXPECT_LT(a.size(), 120u) << "and no further";
  for (const auto& g : a) EXPECT_LT(g.t_ns, bound + kPeriod60 / 2);
  for (auto& x : settled.take(false, INT64_MAX)) a.push_back(x);
  for (auto& x : flushed.take(true)) b.push_back(x);
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].t_ns, b[i].t_ns) << "group " << i << ": as the flush decides it";
    EXPECT_EQ(a[i].complete(), b[i].complete()) << "group " << i;
  }
}

// The pending tick is given up to its best group once no group can come within half a period after
// it, and not before.
TEST(Subsampler, SettleDecidesAPendingTickOnlyWhenNoNearerGroupCanCome) {
  Subsampler s(0, 15.0);  // ticks every 66.7 ms
  Group g;
  g.t_ns = 66'000'000;  // near tick 1
  EXPECT_TRUE(s.add(g).empty());
  EXPECT_TRUE(s.settle(66'666'667 + 33'000'000).empty()) << "a group at 99 ms could still be nearer";
  const auto out = s.settle(66'666'667 + 34'000'000);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].tick, 1);
  EXPECT_TRUE(s.flush().empty()) << "decided once";
}

TEST(Subsampler, OneSampleNearestEachTickAndTheGridNeverDrifts) {
  Subsampler s(1'000'000'000, 15.0);
  std::mt19937_64 rng(3);
  std::uniform_int_distribution<std::int64_t> jitter(-200'000, 200'000);
  std::vector<Subsampler::Sample> samples;
  const std::int64_t n = 60 * 3600;  // one hour of 60 Hz groups
  for (std::int64_t i = 0; i < n; ++i) {
    Group g;
    g.t_ns = 1'000'000'000 + std::int64_t(std::llround(double(i) * 1e9 / 60.0)) + 4'000'000 + jitter(rng);
    for (auto& x : s.add(g)) samples.push_back(x);
  }
  for (auto& x : s.flush()) samples.push_back(x);
  // Ticks 0 .. 54000: the last 60 Hz group (3599.99 s) is nearest the tick at 3600 s.
  ASSERT_EQ(samples.size(), std::size_t(n / 4 + 1));
  for (std::size_t k = 0; k + 1 < samples.size(); ++k) {
    ASSERT_EQ(samples[k].tick, std::int64_t(k));
    // The nearest 60 Hz group to a 15 Hz tick is at most half a source period away.
    ASSERT_LE(std::llabs(samples[k].group.t_ns - samples[k].tick_ns), kPeriod60 / 2) << k;
  }
  EXPECT_EQ(s.tick_time(54'000), 1'000'000'000 + 3'600'000'000'000) << "tick k is computed, not accumulated";
  EXPECT_EQ(s.missed_ticks(), 0u);
}

TEST(Subsampler, TicksWithoutAGroupAreCountedAsMissed) {
  Subsampler s(0, 15.0);
  std::vector<Subsampler::Sample> samples;
  for (std::int64_t i = 0; i < 600; ++i) {
    if (i >= 100 && i < 200) continue;  // all cameras gone for 1.67 s
    Group g;
    g.t_ns = i * kPeriod60;
    for (auto& x : s.add(g)) samples.push_back(x);
  }
  for (auto& x : s.flush()) samples.push_back(x);
  EXPECT_EQ(samples.size() + s.missed_ticks(), 151u);  // ticks 0 .. 150 (the last group, 9.98 s, is nearest 10 s)
  EXPECT_GE(s.missed_ticks(), 24u);
}

TEST(PressureAligner, PairsTheTrulyNearestFrameDespiteReorderAndDrops) {
  std::mt19937_64 rng(4);
  std::uniform_real_distribution<double> u(0, 1);
  std::uniform_int_distribution<std::int64_t> jitter(-300'000, 300'000);
  // Pressure at ~115 Hz with 1 % lost, arriving in bursts slightly out of order.
  std::vector<FrameRef> pressure;
  for (std::uint64_t i = 0; i < 115 * 60; ++i)
    if (u(rng) > 0.01) pressure.push_back({9, i, std::int64_t(double(i) * 1e9 / 115.0) + jitter(rng)});
  std::vector<FrameRef> arrival = pressure;
  for (std::size_t i = 0; i + 1 < arrival.size(); i += 7) std::swap(arrival[i], arrival[i + 1]);

  PressureAligner a(50'000'000, 20'000'000);
  std::vector<std::pair<std::uint64_t, PressureAligner::Pairing>> out;
  std::size_t next = 0;
  std::size_t max_buffered = 0;
  for (std::int64_t k = 0; k < 15 * 60; ++k) {
    const std::int64_t t = k * 66'666'667 + 5'000'000;
    // Samples reach the aligner ~300 ms after their instant (the grouper's and grid's delays).
    while (next < arrival.size() && arrival[next].t_ns < t + 300'000'000) a.add_pressure(arrival[next++]);
    a.add_sample(t, std::uint64_t(k));
    for (auto& p : a.take()) out.push_back(p);
    max_buffered = std::max(max_buffered, a.buffered());
  }
  while (next < arrival.size()) a.add_pressure(arrival[next++]);
  for (auto& p : a.take(true)) out.push_back(p);

  ASSERT_EQ(out.size(), 900u);
  std::size_t right = 0;
  for (const auto& [key, p] : out) {
    ASSERT_TRUE(p.nearest) << key;
    const FrameRef* truth = &pressure[0];
    for (const auto& f : pressure)
      if (std::llabs(f.t_ns - p.sample_ns) < std::llabs(truth->t_ns - p.sample_ns)) truth = &f;
    right += p.nearest->sequence == truth->sequence;
    ASSERT_TRUE(p.before && p.after);
    EXPECT_LE(p.before->t_ns, p.sample_ns);
    EXPECT_GT(p.after->t_ns, p.sample_ns);
    EXPECT_EQ(p.offset_ns, p.nearest->t_ns - p.sample_ns);
  }
  EXPECT_EQ(right, out.size());
  EXPECT_TRUE(a.unpaired().empty());
  EXPECT_LT(max_buffered, 300u) << "memory is bounded by the lag window, not the session";
}

TEST(PressureAligner, GapsAndLateFramesAreCountedWithReasons) {
  PressureAligner a(30'000'000, 20'000'000);
  std::size_t unpaired = 0;
  std::uint64_t i = 0;
  for (std::int64_t k = 0; k < 45; ++k) {
    const std::int64_t sample = k * 66'666'667;
    for (; std::int64_t(i) * 8'000'000 < sample + 300'000'000; ++i) {
      const std::int64_t t = std::int64_t(i) * 8'000'000;
      if (t > 1'000'000'000 && t < 1'500'000'000) continue;  // Sensel unplugged for half a second
      a.add_pressure({9, i, t});
    }
    a.add_sample(sample, std::uint64_t(k));
    for (auto& [key, p] : a.take()) unpaired += !p.nearest;
  }
  EXPECT_GE(unpaired, 6u);
  EXPECT_EQ(a.unpaired().at("no pressure frame within the allowed offset"), unpaired);
  a.add_pressure({9, 999, 500'000'000});  // arrives long after its samples were paired
  EXPECT_EQ(a.unpaired().at("pressure frame arrived after the samples around it were paired"), 1u);
}
