#pragma once
// The simulated fingertip shared by the simulated cameras and the Sensel
// emulator: one definition of where and how hard it presses at each true
// instant, so the images and the pressure of a simulated session agree.
#include <cmath>
#include <cstdint>

namespace pvcap::sim {

// Press strength in [0, 1] at true time `true_ns` (CLOCK_MONOTONIC): once per period, a smooth
// press and release over the first half, nothing over the second.
inline double fingertip_force(std::int64_t true_ns, double period_s) {
  const double phase = std::fmod(double(true_ns) / 1e9, period_s) / period_s;
  return phase < 0.5 ? std::sin(phase * 2 * M_PI) : 0.0;
}

// Radius (mm) of the fingertip's contact disc as seen from above, growing as it presses.
inline double fingertip_radius_mm(double force) { return 3.0 + 5.0 * force; }

}  // namespace pvcap::sim
