#pragma once
// Presses found in a session's total pressure: the isolated rises and falls the sync self-check
// and the report's overlay thumbnails are made from.
#include <cstddef>
#include <cstdint>
#include <vector>

#include "storage/index/session_reader.h"

namespace pvcap::report {

struct PressWindow {
  std::int64_t onset_ns = 0, release_ns = 0;  // first and last frame above the threshold
  std::int64_t from_ns = 0, to_ns = 0;        // the window around it (margin either side)
  std::uint64_t peak_sequence = 0;            // the pressure frame at its peak
  double peak_total = 0;
  std::uint32_t peak_connection = 0;  // the Sensel connection of the peak frame (one more after each replug)
};

struct PressFinding {
  double threshold = 0;               // counts: 5 % of the session's highest total
  std::size_t presses = 0;            // all found (isolated or not)
  std::vector<PressWindow> isolated;  // with nothing else pressed within their window
};

// `totals` in time order. A press is a run of frames above 5 % of the session's highest total
// (gaps under 0.1 s bridged) lasting at least 0.15 s; it is isolated when no other press comes
// within `margin_ns` of it.
PressFinding find_presses(const std::vector<PressureTotal>& totals, std::int64_t margin_ns = 300'000'000);

}  // namespace pvcap::report
