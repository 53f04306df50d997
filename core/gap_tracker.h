#pragma once
// Turns sequence gaps into drop records without double counting: a gap stays
// open for `grace_ns` because a frame can arrive late (GigE Vision delivers a
// timed-out incomplete frame after its successor); a late frame closes its part
// of the gap and only what is still missing when the grace ends is reported.
#include <cstdint>
#include <functional>
#include <optional>
#include <vector>

namespace pvcap {

class GapTracker {
 public:
  struct Gap {
    std::uint64_t first = 0;
    std::uint64_t count = 0;
    std::int64_t noticed_ns = 0;
  };
  using Report = std::function<void(const Gap&)>;

  GapTracker(std::int64_t grace_ns, Report report) : grace_ns_(grace_ns), report_(std::move(report)) {}

  void missing(std::uint64_t first, std::uint64_t count, std::int64_t now_ns) {
    if (count) open_.push_back({first, count, now_ns});
  }

  // A late frame arrived: true when it filled an open gap (it was not a duplicate).
  bool arrived_late(std::uint64_t seq) {
    for (std::size_t i = 0; i < open_.size(); ++i) {
      Gap g = open_[i];
      if (seq < g.first || seq >= g.first + g.count) continue;
      open_.erase(open_.begin() + std::ptrdiff_t(i));
      if (seq > g.first) open_.push_back({g.first, seq - g.first, g.noticed_ns});
      if (seq + 1 < g.first + g.count) open_.push_back({seq + 1, g.first + g.count - seq - 1, g.noticed_ns});
      return true;
    }
    return false;
  }

  // Reports gaps older than the grace (all of them when `flush_all`).
  void settle(std::int64_t now_ns, bool flush_all = false) {
    std::vector<Gap> keep;
    for (const Gap& g : open_) {
      if (flush_all || now_ns - g.noticed_ns >= grace_ns_)
        report_(g);
      else
        keep.push_back(g);
    }
    open_.swap(keep);
  }

  std::size_t open_gaps() const { return open_.size(); }
  // When the oldest open gap was noticed (none open: empty).
  std::optional<std::int64_t> oldest_noticed_ns() const {
    std::optional<std::int64_t> oldest;
    for (const Gap& g : open_)
      if (!oldest || g.noticed_ns < *oldest) oldest = g.noticed_ns;
    return oldest;
  }

 private:
  std::int64_t grace_ns_;
  Report report_;
  std::vector<Gap> open_;
};

}  // namespace pvcap
