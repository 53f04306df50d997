#include "report/press_windows.h"

#include <algorithm>

namespace pvcap::report {

PressFinding find_presses(const std::vector<PressureTotal>& totals, std::int64_t margin_ns) {
  PressFinding f;
  double highest = 0;
  for (const auto& t : totals) highest = std::max(highest, t.total_counts);
  if (highest <= 0) return f;
  f.threshold = 0.05 * highest;
  constexpr std::int64_t kBridge = 100'000'000, kShortest = 150'000'000;
  std::vector<PressWindow> runs;
  for (const auto& t : totals) {
    if (t.total_counts <= f.threshold) continue;
    if (!runs.empty() && t.t_ns - runs.back().release_ns <= kBridge) {
      PressWindow& w = runs.back();
      w.release_ns = t.t_ns;
      if (t.total_counts > w.peak_total)
        w.peak_total = t.total_counts, w.peak_sequence = t.sequence, w.peak_connection = t.connection;
    } else {
      runs.push_back({t.t_ns, t.t_ns, 0, 0, t.sequence, t.total_counts, t.connection});
    }
  }
  std::erase_if(runs, [](const PressWindow& w) { return w.release_ns - w.onset_ns < kShortest; });
  f.presses = runs.size();
  for (std::size_t i = 0; i < runs.size(); ++i) {
    PressWindow w = runs[i];
    w.from_ns = w.onset_ns - margin_ns;
    w.to_ns = w.release_ns + margin_ns;
    const bool clear_before = i == 0 || runs[i - 1].release_ns < w.from_ns;
    const bool clear_after = i + 1 == runs.size() || runs[i + 1].onset_ns > w.to_ns;
    const bool inside = !totals.empty() && w.from_ns >= totals.front().t_ns && w.to_ns <= totals.back().t_ns;
    if (clear_before && clear_after && inside) f.isolated.push_back(w);
  }
  return f;
}

}  // namespace pvcap::report
