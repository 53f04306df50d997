#pragma once
// The clock model applied: a device time put on the host clock under one fit. The one function that
// does it: the live timeline (sync/clock_model.h) and the end-of-session re-mapping (storage's
// SessionIndex::remap, through the SQL function pvcap_map) both call it, so a frame mapped live and
// re-mapped later under the same fit agree to the nanosecond. docs/store.md pins the arithmetic.
#include <cmath>
#include <cstdint>

namespace pvcap::sync {

// host = device + round(offset + skew * (device - x0)) - latency, in integer ns; the product is taken
// in double precision (|device - x0| < 2^53 ns, about 104 days) and rounded half away from zero.
inline std::int64_t map_device_time(std::int64_t device_ns, std::int64_t x0, double offset_ns, double skew,
                                    std::int64_t latency_ns) {
  return device_ns + std::llround(offset_ns + skew * double(device_ns - x0)) - latency_ns;
}

struct ClockFit {
  std::int64_t x0 = 0;   // device time the fit is expressed around
  double offset_ns = 0;  // host - device at x0 (earliest arrival)
  double skew = 0;       // d(host - device)/d(device): +1e-6 = device runs 1 ppm slow
  std::int64_t map(std::int64_t device_ns) const { return map_device_time(device_ns, x0, offset_ns, skew, 0); }
};

}  // namespace pvcap::sync
