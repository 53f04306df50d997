#pragma once
// The rule that makes one dataset instant of several cameras' frames, in one place: the live
// Grouper (sync/timeline.h) applies it as frames arrive, the end-of-session re-mapping
// (session/realign.h) again on the same groups with the final clock fits. Pure functions of
// mapped times, free of I/O and state.
#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

namespace pvcap::sync {

// A group's instant: the mean of its members' times (taken relative to the earliest, so the sum
// cannot overflow), and its span, latest minus earliest. Empty: both 0.
struct GroupTime {
  std::int64_t t_ns = 0;
  std::int64_t span_ns = 0;
};
GroupTime group_time(const std::vector<std::int64_t>& times_ns);

// Which members of a group stay in it when their times (sorted) spread wider than `limit_ns`:
// the most that lie within `limit_ns` of each other; among as many, the run whose mean is nearest
// `tick_ns` (the grid tick the group serves). Returns [first, last) into `sorted_ns`; all of them
// when the group already keeps the limit.
std::pair<std::size_t, std::size_t> members_within(const std::vector<std::int64_t>& sorted_ns, std::int64_t limit_ns,
                                                   std::int64_t tick_ns);

}  // namespace pvcap::sync
