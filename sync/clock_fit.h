#pragma once
// The clock model applied: a device time put on the host clock under one fit. The one function that
// does it: the live timeline (sync/clock_model.h) and the end-of-session re-mapping (storage's
// SessionIndex::remap, through the SQL function pvcap_map) both call it, so a frame mapped live and
// re-mapped later under the same fit agree to the nanosecond. docs/store.md pins the arithmetic.
#include <cmath>
#include <cstdint>

namespace pvcap::sync {

// Device times are bytes from outside (a camera's timestamp, a Sensel's counter): one beyond 2^61 ns
// (73 years) either way is no clock reading, and is held at that bound, so that no difference of
// two device times, and no mapping, can overflow.
inline constexpr std::int64_t kDeviceTimeLimitNs = std::int64_t(1) << 61;
inline std::int64_t bounded_device_time(std::int64_t t) {
  return t < -kDeviceTimeLimitNs ? -kDeviceTimeLimitNs : t > kDeviceTimeLimitNs ? kDeviceTimeLimitNs : t;
}

// host = device + round(offset + skew * (device - x0)) - latency, in integer ns; the product is taken
// in double precision (|device - x0| < 2^53 ns, about 104 days) and rounded half away from zero.
// Outside any real clock's range (docs/store.md): device and x0 are bounded to +-2^61, the rounded
// shift (host minus device: up to 2^61 and the host's time) to +-2^62 (0 when it is not a number),
// the latency to +-2^60, so a damaged fit in a store gives a wrong time, never undefined arithmetic.
inline std::int64_t map_device_time(std::int64_t device_ns, std::int64_t x0, double offset_ns, double skew,
                                    std::int64_t latency_ns) {
  device_ns = bounded_device_time(device_ns);
  const double limit = 2.0 * double(kDeviceTimeLimitNs);
  const double shift = offset_ns + skew * double(device_ns - bounded_device_time(x0));
  const std::int64_t rounded = std::isnan(shift) ? 0
                                                 : std::llround(shift < -limit  ? -limit
                                                                : shift > limit ? limit
                                                                                : shift);
  const std::int64_t latency_limit = kDeviceTimeLimitNs / 2;
  latency_ns = latency_ns < -latency_limit ? -latency_limit : latency_ns > latency_limit ? latency_limit : latency_ns;
  return device_ns + rounded - latency_ns;
}

struct ClockFit {
  std::int64_t x0 = 0;   // device time the fit is expressed around
  double offset_ns = 0;  // host - device at x0 (earliest arrival)
  double skew = 0;       // d(host - device)/d(device): +1e-6 = device runs 1 ppm slow
  std::int64_t map(std::int64_t device_ns) const { return map_device_time(device_ns, x0, offset_ns, skew, 0); }
};

}  // namespace pvcap::sync
