#pragma once
// Frames lost between two that arrived, told apart by why: the sequences a driver dropped itself
// (its queue full) against the rest (never received). Both drivers hand over which sequences they
// dropped; the store gets one drops row per run of one reason.
#include <algorithm>
#include <cstdint>
#include <vector>

namespace pvcap {

// Calls fn(first, count, dropped) for each maximal run of [from, to) whose sequences are all in
// `dropped` (sorted ascending; entries outside the range are ignored) or all not in it.
template <class Fn>
void for_each_loss_run(std::uint64_t from, std::uint64_t to, const std::vector<std::uint64_t>& dropped, Fn&& fn) {
  std::uint64_t at = from;
  auto it = std::lower_bound(dropped.begin(), dropped.end(), from);
  while (at < to) {
    if (it != dropped.end() && *it == at) {  // a run of dropped sequences
      std::uint64_t end = at;
      while (it != dropped.end() && *it == end && end < to) ++it, ++end;
      fn(at, end - at, true);
      at = end;
    } else {  // up to the next dropped one (or the end): not received
      const std::uint64_t end = it != dropped.end() && *it < to ? *it : to;
      fn(at, end - at, false);
      at = end;
    }
  }
}

}  // namespace pvcap
