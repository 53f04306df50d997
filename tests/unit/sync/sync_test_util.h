#pragma once
// Seeded clocks and arrivals for the timeline's unit tests: no sockets, no sleeping.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

namespace pvcap::sync::testing {

// A device clock: device = start + (true - t0) * (1 + drift).
struct DeviceClock {
  std::int64_t start_ns = 0;
  double drift_ppm = 0;
  std::int64_t device(std::int64_t true_ns) const {
    return start_ns + std::int64_t(std::llround(double(true_ns) * (1.0 + drift_ppm * 1e-6)));
  }
};

// Arrival = true + constant latency + exponential jitter (mean, capped): a long tail, bounded.
struct Link {
  std::int64_t latency_ns = 0;
  double jitter_mean_ns = 0;
  double jitter_cap_ns = 0;
  std::mt19937_64 rng{1};
  std::int64_t arrival(std::int64_t true_ns) {
    if (jitter_mean_ns <= 0) return true_ns + latency_ns;
    std::exponential_distribution<double> d(1.0 / jitter_mean_ns);
    return true_ns + latency_ns + std::int64_t(std::min(d(rng), jitter_cap_ns));
  }
};

inline double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, std::size_t(p / 100.0 * double(v.size())))];
}

}  // namespace pvcap::sync::testing
