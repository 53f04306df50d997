#pragma once
// How the report writes times and figures: seconds from the session's start, rounded to a unit.
#include <cmath>
#include <cstdint>

namespace pvcap::report {

inline double seconds(std::int64_t ns, std::int64_t start_ns) { return double(ns - start_ns) / 1e9; }
inline double round_to(double v, double unit) { return std::round(v / unit) * unit; }

}  // namespace pvcap::report
