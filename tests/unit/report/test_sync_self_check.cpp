// The sync self-check's estimator on synthetic presses: a known offset between an image signal and
// the pressure is recovered, whatever monotone curve links them and at whatever frame phases; too
// few presses, or an image that does not follow the pressure, are said so rather than guessed.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "report/press_windows.h"
#include "report/sync_self_check.h"

using namespace pvcap;
using namespace pvcap::report;

namespace {

// Force of a press of 1 s starting at `start_s` (a half sine), 0 outside.
double force_at(double t_s, double start_s) {
  const double u = t_s - start_s;
  return u > 0 && u < 1 ? std::sin(M_PI * u) : 0.0;
}

// `n` presses 2.3 s apart; pressure at 125 Hz; image frames at 15 Hz whose pixels show the force
// `latency_ms` before their timestamp, through a monotone curve with a jump where contact begins
// (a fingertip's footprint), plus noise.
std::vector<PressSignals> presses(int n, double latency_ms, std::uint64_t seed, double noise = 0.01) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> gauss(0, noise);
  std::uniform_real_distribution<double> phase(0, 1.0 / 15);
  std::vector<PressSignals> out;
  for (int k = 0; k < n; ++k) {
    const double start = 1 + 2.3 * k, from = start - 0.3, to = start + 1.3;
    PressSignals p;
    for (double t = from; t <= to; t += 0.008) p.pressure.push_back({std::int64_t(t * 1e9), 300 * force_at(t, start)});
    for (double t = from + phase(rng); t <= to; t += 1.0 / 15) {
      const double f = force_at(t - latency_ms / 1e3, start);
      const double footprint = f > 0 ? std::pow(3 + 5 * f, 2) : 0.0;
      p.image.push_back({std::int64_t(t * 1e9), footprint / 64 + gauss(rng)});
    }
    out.push_back(std::move(p));
  }
  return out;
}

}  // namespace

TEST(SyncSelfCheck, RecoversAKnownOffsetFromTheFlanksOfThePresses) {
  for (double latency : {0.0, 7.0, -5.0, 20.0}) {
    const auto e = estimate_offset(presses(16, latency, 11));
    ASSERT_EQ(e.verdict, "ok") << latency;
    ASSERT_TRUE(e.offset_ms && e.uncertainty_ms);
    EXPECT_NEAR(*e.offset_ms, latency, 1.0) << "uncertainty " << *e.uncertainty_ms;
    EXPECT_LT(*e.uncertainty_ms, 1.0);
    EXPECT_EQ(e.presses_used, 16);
  }
}

TEST(SyncSelfCheck, APressThatDisagreesWithTheOthersIsLeftOut) {
  auto p = presses(12, 7.0, 21);
  // One window caught something else: its image change runs the other way.
  for (auto& v : p[4].image) v.value = 1.0 - v.value;
  const auto e = estimate_offset(p);
  ASSERT_EQ(e.verdict, "ok");
  EXPECT_EQ(e.presses_rejected, 1);
  EXPECT_EQ(e.presses_used, 11);
  EXPECT_NEAR(*e.offset_ms, 7.0, 1.0);
}

TEST(SyncSelfCheck, SaysWhenThereAreTooFewPressesToTell) {
  const auto e = estimate_offset(presses(3, 7.0, 5));
  EXPECT_FALSE(e.offset_ms);
  EXPECT_EQ(e.presses_used, 3);
  EXPECT_NE(e.verdict.find("too few presses"), std::string::npos) << e.verdict;
}

TEST(SyncSelfCheck, AnImageThatDoesNotFollowThePressureGivesNoOffset) {
  auto p = presses(12, 0.0, 3);
  std::mt19937_64 rng(9);
  std::uniform_real_distribution<double> any(0, 1);
  for (auto& press : p)
    for (auto& v : press.image) v.value = any(rng);  // the camera sees something unrelated
  const auto e = estimate_offset(p);
  EXPECT_FALSE(e.offset_ms) << *e.offset_ms;
  EXPECT_NE(e.verdict, "ok");
}

TEST(PressWindows, IsolatedPressesAreFoundWithTheirPeaksAndCrowdedOnesLeftOut) {
  std::vector<PressureTotal> totals;
  // Presses at 1 s, 3 s and 3.75 s (the last two 0.15 s apart: too close to tell apart), each 0.6 s long.
  std::uint64_t seq = 0;
  for (double t = 0; t < 6; t += 0.008) {
    double v = 0;
    for (double start : {1.0, 3.0, 3.75}) v += 1000 * force_at((t - start) / 0.6 + start, start);
    totals.push_back({seq++, std::int64_t(t * 1e9), v});
  }
  const PressFinding f = find_presses(totals);
  EXPECT_EQ(f.presses, 3u);
  ASSERT_EQ(f.isolated.size(), 1u);
  EXPECT_NEAR(double(f.isolated[0].onset_ns) / 1e9, 1.0, 0.02);
  EXPECT_NEAR(double(f.isolated[0].release_ns) / 1e9, 1.6, 0.02);
  EXPECT_NEAR(f.isolated[0].peak_total, 1000, 1);
  EXPECT_EQ(f.isolated[0].from_ns, f.isolated[0].onset_ns - 300'000'000);
  EXPECT_TRUE(find_presses({}).isolated.empty());
}
