#pragma once
// Time bases. Everything pvcap stamps is int64 nanoseconds on the host's
// CLOCK_MONOTONIC; what devices send is kept apart as DeviceNs so the two can
// never be mixed by accident (the clock models in sync/ map one to the other).
#include <compare>
#include <cstdint>
#include <string>

namespace pvcap {

struct HostNs {
  std::int64_t ns = 0;
  auto operator<=>(const HostNs&) const = default;
};

struct DeviceNs {
  std::int64_t ns = 0;
  auto operator<=>(const DeviceNs&) const = default;
};

// CLOCK_MONOTONIC now. Cheap (vDSO), safe on any thread.
HostNs host_now();

// Wall-clock (CLOCK_REALTIME) now, in ns since the Unix epoch: recorded once per
// session so monotonic stamps can be related to calendar time.
std::int64_t wall_now_ns();

// CPU time used so far, in seconds: by the calling thread (CLOCK_THREAD_CPUTIME_ID) and by the whole
// process (CLOCK_PROCESS_CPUTIME_ID, every thread): what a speed figure per core is measured in.
double thread_cpu_seconds();
double process_cpu_seconds();

// "2026-11-22T14:05:03Z"-style UTC text for a wall-clock time.
std::string format_utc(std::int64_t wall_ns);

// Compact "20261122-140503" UTC text, used in session directory names.
std::string format_utc_compact(std::int64_t wall_ns);

}  // namespace pvcap
