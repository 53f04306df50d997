// The clock model against seeded clocks: drift, offsets, jittered arrivals with a long
// tail, drops, reordering, a 32-bit wrap, a reset, a busy start and a long recording. Errors are measured online, as
// the recorder maps: each frame with the fit it had when the frame arrived.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "core/sequence_unwrap.h"
#include "sync/clock_model.h"
#include "tests/unit/sync/sync_test_util.h"

using namespace pvcap::sync;
using namespace pvcap::sync::testing;

namespace {

struct Errors {
  std::vector<double> ms;  // mapped - true, per frame, after a warm-up
  double bias() const { return percentile(ms, 50); }
  double p99_after_bias() const {
    std::vector<double> d;
    for (double e : ms) d.push_back(std::fabs(e - bias()));
    return percentile(d, 99);
  }
  double max_after_bias() const {
    double m = 0;
    for (double e : ms) m = std::max(m, std::fabs(e - bias()));
    return m;
  }
};

// Runs one stream for `seconds` at `hz` and returns the online mapping errors after `warmup_s`.
Errors run(ClockModel& model, DeviceClock clock, Link link, double hz, double seconds, double warmup_s, double drop = 0,
           std::uint64_t seed = 7) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0, 1);
  Errors e;
  const auto period = std::int64_t(1e9 / hz);
  for (std::int64_t t = 0; t < std::int64_t(seconds * 1e9); t += period) {
    if (u(rng) < drop) continue;
    const std::int64_t device = clock.device(t);
    model.add(device, link.arrival(t));
    if (t >= std::int64_t(warmup_s * 1e9)) e.ms.push_back(double(model.map(device) - t) / 1e6);
  }
  return e;
}

}  // namespace

TEST(ClockModel, CameraWithDriftAndOffsetMapsWithinATenthOfAMillisecond) {
  for (double drift : {-100.0, 0.0, 100.0}) {
    ClockModel m;
    // A GigE camera: its clock started 1234 s before ours; arrivals 2 ms after capture, +-0.3 ms jitter.
    const auto e = run(m, {1'234'000'000'000, drift}, {2'000'000, 150'000, 1'000'000}, 60, 120, 2);
    EXPECT_NEAR(e.bias(), 2.0, 0.05) << "the line is the earliest arrival: the constant latency remains";
    EXPECT_LE(e.p99_after_bias(), 0.1) << "drift " << drift;
    EXPECT_NEAR(m.fit().skew, -drift * 1e-6 / (1 + drift * 1e-6), 2e-6) << "drift " << drift;
    EXPECT_EQ(m.segment(), 0);
    EXPECT_LE(m.envelope_points(), 241u) << "one point per half second";
  }
}

TEST(ClockModel, SenselWithALongUsbTailMapsWithinHalfAMillisecond) {
  ClockModel m;
  // USB arrival jitter: mean 1 ms, capped at 4 ms; 1 % of frames lost.
  const auto e = run(m, {5'000'000'000, 60}, {300'000, 1'000'000, 4'000'000}, 125, 120, 2, 0.01);
  EXPECT_LE(e.p99_after_bias(), 0.5);
  EXPECT_LT(std::fabs(e.bias() - 0.3), 0.3);
  // Least squares would be pulled ~1 ms late by the mean jitter; the envelope is not.
}

TEST(ClockModel, DeclaredLatencyRemovesTheConstantBias) {
  ClockModel m({.latency_ns = 2'000'000});
  const auto e = run(m, {0, 30}, {2'000'000, 100'000, 800'000}, 60, 30, 2);
  EXPECT_LT(std::fabs(e.bias()), 0.05);
}

TEST(ClockModel, ReorderedPairsAreIgnoredAndDoNotReset) {
  ClockModel m;
  DeviceClock clock{0, 20};
  Link link{1'000'000, 100'000, 500'000};
  for (std::int64_t t = 0; t < 10'000'000'000; t += 16'666'667) {
    m.add(clock.device(t), link.arrival(t));
    if (t % 1'000'000'000 < 16'666'667) m.add(clock.device(t - 33'000'000), link.arrival(t));  // a late one
  }
  EXPECT_EQ(m.segment(), 0);
  EXPECT_LT(std::llabs(m.map(clock.device(9'000'000'000)) - 9'001'000'000), 100'000);
}

TEST(ClockModel, ThirtyTwoBitMicrosecondWrapContinuesTheSegment) {
  ClockModel m;
  pvcap::SequenceUnwrapper unwrap(32, false);
  const double start_us = 4294967295.0 - 2e6;  // 2 s before the wrap
  for (std::int64_t t = 0; t < 5'000'000'000; t += 8'000'000) {
    const auto raw = std::uint64_t(start_us + double(t) / 1e3) & 0xFFFFFFFFu;
    const auto device_ns = std::int64_t(unwrap.next(raw).sequence) * 1000;
    m.add(device_ns, t + 500'000);
  }
  EXPECT_EQ(m.segment(), 0) << "the wrap is not a reset";
  EXPECT_GT(m.pairs(), 600u);
}

TEST(ClockModel, ClockResetStartsANewSegmentAndMappingRecovers) {
  ClockModel m;
  Link link{400'000, 500'000, 4'000'000};
  int resets = 0;
  std::vector<double> after;
  for (std::int64_t t = 0; t < 20'000'000'000; t += 8'000'000) {
    // The device restarts its clock at 0 at t = 10 s (power cycle, replug).
    const std::int64_t device = t < 10'000'000'000 ? 7'000'000'000 + t : t - 10'000'000'000;
    resets += m.add(device, link.arrival(t)) ? 1 : 0;
    if (t > 12'000'000'000) after.push_back(double(m.map(device) - t) / 1e6);
  }
  EXPECT_EQ(resets, 1);
  EXPECT_EQ(m.segment(), 1);
  EXPECT_LT(percentile(after, 99), 0.4 + 0.5);
}

TEST(ClockModel, ForwardJumpOfTheDeviceClockIsAResetToo) {
  ClockModel m;
  int resets = 0;
  for (std::int64_t t = 0; t < 4'000'000'000; t += 10'000'000) {
    const std::int64_t device = t < 2'000'000'000 ? t : t + 3'600'000'000'000;  // +1 h
    resets += m.add(device, t + 1'000'000) ? 1 : 0;
  }
  EXPECT_EQ(resets, 1);
  EXPECT_LT(std::llabs(m.map(3'600'000'000'000 + 3'990'000'000) - 3'991'000'000), 10'000);
}

TEST(ClockModel, AFirstLateArrivalIsNotMistakenForAReset) {
  ClockModel m;
  m.add(0, 300'000'000);  // the first frame came 300 ms late
  int resets = 0;
  for (std::int64_t t = 8'000'000; t < 2'000'000'000; t += 8'000'000) resets += m.add(t, t + 1'000'000) ? 1 : 0;
  EXPECT_EQ(resets, 0);
  EXPECT_LT(std::llabs(m.map(1'000'000'000) - 1'001'000'000), 10'000);
}

TEST(ClockModel, ABusyStartDoesNotTiltTheLine) {
  // For the first 5 s the minimum latency is 1.5 ms higher (a machine still starting up);
  // arrivals reach their minimum rarely (mean 2.5 ms above it).
  ClockModel m;
  DeviceClock clock{0, -80};
  Link link{500'000, 2'500'000, 8'000'000};
  std::vector<double> err;
  for (std::int64_t t = 0; t < 30'000'000'000; t += 16'666'667) {
    const std::int64_t arrival = link.arrival(t) + (t < 5'000'000'000 ? 1'500'000 : 0);
    m.add(clock.device(t), arrival);
  }
  for (std::int64_t t = 3'000'000'000; t < 30'000'000'000; t += 16'666'667)
    err.push_back(double(m.map(clock.device(t)) - t) / 1e6);
  const double bias = percentile(err, 50);
  double worst = 0;
  for (double e : err) worst = std::max(worst, std::fabs(e - bias));
  EXPECT_LT(worst, 0.1) << "final fit, after bias";
  EXPECT_NEAR(m.fit().skew, 80e-6, 8e-6);
}

TEST(ClockModel, AnHourLongRecordingKeepsItsMemoryBounded) {
  ClockModel m;
  DeviceClock clock{0, 40};
  Link link{300'000, 500'000, 3'000'000};
  for (std::int64_t t = 0; t < 3'600'000'000'000; t += 8'000'000) m.add(clock.device(t), link.arrival(t));
  EXPECT_LE(m.envelope_points(), 4096u);
  EXPECT_NEAR(m.fit().skew, -40e-6, 1e-6);
  EXPECT_LT(std::llabs(m.map(clock.device(3'599'000'000'000)) - 3'599'000'300'000), 60'000);
}

TEST(ClockModel, LatchProbesMapTheCameraDespiteAWanderingLatencyFloor) {
  // Arrivals whose floor rises 1 ms over 30 s (a machine getting busier) tilt any fit of
  // arrival times; probes of the device clock (read at an instant inside a 0.6 ms bracket,
  // four a second) do not.
  ClockModel m({.latency_ns = 2'000'000});
  DeviceClock clock{1'000'000'000'000, 60};
  Link link{2'000'000, 300'000, 2'000'000};
  std::mt19937_64 rng(9);
  std::uniform_int_distribution<std::int64_t> where(0, 500'000), rtt(50'000, 150'000);
  std::vector<double> err;
  for (std::int64_t t = 0; t < 30'000'000'000; t += 16'666'667) {
    const std::int64_t floor_rise = t / 30'000;  // 1 ms over 30 s
    m.add(clock.device(t), link.arrival(t) + floor_rise);
    if (t % 250'000'000 < 16'666'667) {
      const std::int64_t latch = t + 5'000'000;  // the instant the device read its clock
      const std::int64_t lo = latch - rtt(rng) - where(rng), hi = latch + rtt(rng);
      m.add_probe(clock.device(latch), lo, hi);
    }
  }
  ASSERT_TRUE(m.probed());
  for (std::int64_t t = 3'000'000'000; t < 30'000'000'000; t += 16'666'667)
    err.push_back(double(m.map(clock.device(t)) - t) / 1e6);
  EXPECT_LT(std::fabs(percentile(err, 50)), 0.1) << "no latency to subtract: the probe reads the stamping clock";
  double worst = 0;
  for (double e : err) worst = std::max(worst, std::fabs(e - percentile(err, 50)));
  EXPECT_LT(worst, 0.1);
  EXPECT_GT(std::fabs(m.fit().skew + 60e-6), 2e-5) << "the arrival envelope alone is tilted by the floor";
  EXPECT_EQ(m.segments().back().latency_ns, 0);
}

TEST(ClockModel, ProbesFromBeforeAResetAreNotMixedIn) {
  ClockModel m;
  for (std::int64_t t = 0; t < 4'000'000'000; t += 10'000'000) {
    m.add(t, t + 1'000'000);
    if (t % 250'000'000 == 0) m.add_probe(t, t - 100'000, t + 100'000);
  }
  ASSERT_TRUE(m.probed());
  // The device restarts its clock at 0, and its arrivals now come 3 ms late. The new segment is
  // mapped by its own probes from the first on (no drift yet), none of the old segment's.
  for (std::int64_t t = 4'000'000'000; t < 5'000'000'000; t += 10'000'000) {
    m.add(t - 4'000'000'000, t + 3'000'000);
    if (t % 250'000'000 == 0) m.add_probe(t - 4'000'000'000, t - 100'000, t + 100'000);
  }
  EXPECT_EQ(m.segment(), 1);
  EXPECT_TRUE(m.probed());
  EXPECT_EQ(m.segments().back().fit.skew, 0.0) << "a slope needs 2 s of the segment's own probes";
  EXPECT_LT(std::llabs(m.map(900'000'000) - 4'900'000'000), 1'000);
}

TEST(ClockModel, ALoadedStartIsMappedByTheFirstProbeNotByLateArrivals) {
  // The first 2 s of a session on a busy machine: every frame arrives 20-30 ms after it was stamped
  // (no arrival at the usual 2 ms). One probe was read (in a 0.4 ms bracket) before the first frame,
  // then four a second. The frames are mapped within the bracket from the first frame on; the
  // arrivals alone would put them 18 ms or more late.
  ClockModel probed({.latency_ns = 2'000'000}), arrivals_only({.latency_ns = 2'000'000});
  DeviceClock clock{7'000'000'000, 50};
  std::mt19937_64 rng(11);
  std::uniform_int_distribution<std::int64_t> late(20'000'000, 30'000'000);
  probed.add_probe(clock.device(-5'000'000), -5'200'000, -4'800'000);
  double worst_probed = 0, best_arrivals = 1e9;
  for (std::int64_t t = 0; t < 2'000'000'000; t += 16'666'667) {
    const std::int64_t arrival = t + late(rng);
    probed.add(clock.device(t), arrival);
    arrivals_only.add(clock.device(t), arrival);
    if (t % 250'000'000 < 16'666'667) probed.add_probe(clock.device(t + 3'000'000), t + 2'800'000, t + 3'200'000);
    ASSERT_TRUE(probed.probed()) << "mapped by the probe from the first frame";
    worst_probed = std::max(worst_probed, std::fabs(double(probed.map(clock.device(t)) - t)) / 1e6);
    best_arrivals = std::min(best_arrivals, double(arrivals_only.map(clock.device(t)) - t) / 1e6);
  }
  std::printf("loaded start: worst error mapped by probes %.3f ms; least error by arrivals alone %.1f ms\n",
              worst_probed, best_arrivals);
  EXPECT_LT(worst_probed, 0.3) << "within the bracket, less the clock's 50 ppm over 2 s";
  EXPECT_GT(best_arrivals, 17.0) << "the arrivals alone cannot see the late start";
}

TEST(ClockModel, ProbesWhoseReadBackSlowsLateInTheSessionDoNotTiltTheLine) {
  // An 8 s session on a machine that gets busier: every probe's bracket holds the latch instant,
  // but from the fourth second on the read-back half of the bracket is three times as long.
  // The brackets' midpoints drift late; the band every bracket leaves open does not.
  std::mt19937_64 rng(20261124);
  std::exponential_distribution<double> delay(1.0 / 1e6);
  std::vector<double> worst_us;
  for (int trial = 0; trial < 50; ++trial) {
    ClockModel m;
    DeviceClock clock{5'000'000'000, 80};
    m.add(clock.device(0), 3'000'000);
    for (std::int64_t t = 1'000'000; t < 8'000'000'000; t += 250'000'000) {
      const double scale = t > 4'000'000'000 ? 3.0 : 1.0;
      const auto before = std::int64_t(100'000 + 0.3 * delay(rng)), after = std::int64_t(200'000 + scale * delay(rng));
      m.add_probe(clock.device(t), t - before, t + after);
    }
    ASSERT_TRUE(m.probed());
    double worst = 0;
    for (std::int64_t t = 0; t < 8'000'000'000; t += 100'000'000)
      worst = std::max(worst, std::fabs(double(m.map(clock.device(t)) - t)) / 1e3);
    worst_us.push_back(worst);
  }
  // A bracket's own asymmetry (0.1 ms before, 0.2 ms after at the least) stays: ~50 us.
  EXPECT_LT(percentile(worst_us, 50), 200.0);
  EXPECT_LT(percentile(worst_us, 95), 500.0);
}

TEST(ClockModel, ThinnedProbesKeepTheSegmentsSpanAndTheTighterBrackets) {
  ClockModel m({.max_probes = 16});
  DeviceClock clock{0, -30};
  m.add(clock.device(0), 1'000'000);
  std::mt19937_64 rng(3);
  std::uniform_int_distribution<std::int64_t> wide(0, 3'000'000);
  for (std::int64_t t = 0; t < 60'000'000'000; t += 250'000'000) {
    // Every tenth probe is tight; the rest are up to 3 ms wide around the instant.
    const std::int64_t half = (t / 250'000'000) % 10 == 0 ? 20'000 : wide(rng);
    m.add_probe(clock.device(t), t - half, t + half);
  }
  for (std::int64_t t = 0; t < 60'000'000'000; t += 1'000'000'000)
    EXPECT_LT(std::llabs(m.map(clock.device(t)) - t), 200'000) << t;
}

// Found by fuzz_timeline: a device time at either end of int64 overflowed the model's differences.
// Device times are bytes from outside; they are bounded to +-2^61 ns, and a wild one is a clock jump.
TEST(ClockModel, AWildDeviceTimeIsAJumpNotAnOverflow) {
  ClockModel m;
  for (std::int64_t t = 0; t < 3'000'000'000; t += 16'666'667) m.add(5'000'000'000 + t, 1'000'000'000 + t);
  const std::int64_t arrival = 4'100'000'000;
  EXPECT_TRUE(m.add(std::numeric_limits<std::int64_t>::min(), arrival));  // a new segment...
  // ...that maps it at its arrival (to the double offset's precision at 2^61: 512 ns)
  EXPECT_NEAR(double(m.map(std::numeric_limits<std::int64_t>::min())), double(arrival), 1000);
  // The other end, into a young segment: a wrong time (nothing can place it), but a bounded one.
  m.add(std::numeric_limits<std::int64_t>::max(), arrival + 16'666'667);
  EXPECT_LE(std::llabs(m.map(std::numeric_limits<std::int64_t>::max())),
            3 * kDeviceTimeLimitNs + kDeviceTimeLimitNs / 2);
  m.add_probe(std::numeric_limits<std::int64_t>::min(), arrival, arrival + 1000);
}

TEST(ClockModel, TheMappingOfADamagedFitIsBoundedNotUndefined) {
  const std::int64_t big = std::numeric_limits<std::int64_t>::max();
  EXPECT_EQ(map_device_time(big, -big, 0, 0, 0), kDeviceTimeLimitNs);
  EXPECT_EQ(map_device_time(0, 0, std::nan(""), 0, 0), 0);
  EXPECT_EQ(map_device_time(0, 0, 1e300, 0, 0), 2 * kDeviceTimeLimitNs);
  EXPECT_EQ(map_device_time(-big, 0, -1e300, 1e300, big),
            -kDeviceTimeLimitNs - 2 * kDeviceTimeLimitNs - kDeviceTimeLimitNs / 2);
  // Real clocks are untouched: the pinned arithmetic (docs/store.md).
  EXPECT_EQ(map_device_time(1'000'000'123, 1'000, 2.5, 1e-6, 40),
            1'000'000'123 + std::llround(2.5 + 1e-6 * 999'999'123.0) - 40);
}
