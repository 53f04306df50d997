#include "sync/group_rule.h"

#include <algorithm>
#include <climits>

namespace pvcap::sync {

GroupTime group_time(const std::vector<std::int64_t>& times_ns) {
  if (times_ns.empty()) return {};
  const auto [lo, hi] = std::minmax_element(times_ns.begin(), times_ns.end());
  std::int64_t rel = 0;
  for (const std::int64_t t : times_ns) rel += t - *lo;
  return {*lo + rel / std::int64_t(times_ns.size()), *hi - *lo};
}

std::pair<std::size_t, std::size_t> members_within(const std::vector<std::int64_t>& sorted_ns, std::int64_t limit_ns,
                                                   std::int64_t tick_ns) {
  if (sorted_ns.empty() || sorted_ns.back() - sorted_ns.front() <= limit_ns) return {0, sorted_ns.size()};
  std::pair<std::size_t, std::size_t> best{0, 0};
  std::int64_t best_distance = INT64_MAX;
  for (std::size_t i = 0, j = 0; i < sorted_ns.size(); ++i) {
    j = std::max(j, i);
    while (j + 1 < sorted_ns.size() && sorted_ns[j + 1] - sorted_ns[i] <= limit_ns) ++j;
    const std::int64_t mean = group_time(std::vector<std::int64_t>(sorted_ns.begin() + std::ptrdiff_t(i),
                                                                   sorted_ns.begin() + std::ptrdiff_t(j + 1)))
                                  .t_ns;
    const std::int64_t distance = mean > tick_ns ? mean - tick_ns : tick_ns - mean;
    const std::size_t n = j - i + 1, best_n = best.second - best.first;
    if (n > best_n || (n == best_n && distance < best_distance)) {
      best = {i, j + 1};
      best_distance = distance;
    }
  }
  return best;
}

}  // namespace pvcap::sync
