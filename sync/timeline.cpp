#include "sync/timeline.h"

#include <algorithm>
#include <cmath>

#include "sync/group_rule.h"

namespace pvcap::sync {

// ---------------------------------------------------------------------------------------------
// Grouper

Grouper::Grouper(int cameras, std::int64_t limit_ns, std::int64_t wait_ns)
    : pending_(std::size_t(cameras)),
      latest_(std::size_t(cameras), INT64_MIN),
      limit_ns_(limit_ns),
      wait_ns_(wait_ns) {}

bool Grouper::add(const FrameRef& frame) {
  const auto c = std::size_t(frame.stream);
  if (c >= pending_.size()) return false;
  if (frame.t_ns <= decided_until_ || (!pending_[c].empty() && frame.t_ns <= pending_[c].back().t_ns)) {
    ++late_;  // its instant is decided already (or it is out of order within its camera)
    return false;
  }
  pending_[c].push_back(frame);
  latest_[c] = std::max(latest_[c], frame.t_ns);
  return true;
}

bool Grouper::decide(bool flush, std::int64_t settled_before) {
  std::size_t anchor = pending_.size();
  for (std::size_t c = 0; c < pending_.size(); ++c)
    if (!pending_[c].empty() && (anchor == pending_.size() || pending_[c].front().t_ns < pending_[anchor].front().t_ns))
      anchor = c;
  if (anchor == pending_.size()) return false;
  const std::int64_t a = pending_[anchor].front().t_ns;
  const std::int64_t close = a + limit_ns_;
  if (!flush) {
    const std::int64_t newest = *std::max_element(latest_.begin(), latest_.end());
    const bool horizon_passed = (newest != INT64_MIN && newest - wait_ns_ > close) || close < settled_before;
    bool everyone_past = true;
    for (std::size_t c = 0; c < pending_.size(); ++c) everyone_past &= latest_[c] != INT64_MIN && latest_[c] > close;
    if (!everyone_past && !horizon_passed) return false;
  }
  Group g;
  g.members.resize(pending_.size());
  const FrameRef* next_of_anchor = pending_[anchor].size() > 1 ? &pending_[anchor][1] : nullptr;
  std::vector<std::int64_t> times;
  for (std::size_t c = 0; c < pending_.size(); ++c) {
    if (pending_[c].empty()) continue;
    const FrameRef& f = pending_[c].front();
    if (c != anchor) {
      if (f.t_ns - a > limit_ns_) continue;
      // Nearer the anchor's next frame than the anchor: it belongs to the next instant.
      if (next_of_anchor && next_of_anchor->t_ns - f.t_ns < f.t_ns - a) continue;
    }
    g.members[c] = f;
    times.push_back(f.t_ns);
    pending_[c].pop_front();
  }
  const GroupTime at = group_time(times);
  g.t_ns = at.t_ns;
  g.span_ns = at.span_ns;
  (g.complete() ? complete_ : incomplete_) += 1;
  decided_until_ = a;
  out_.push_back(std::move(g));
  return true;
}

std::vector<Group> Grouper::take(bool flush, std::int64_t settled_before) {
  while (decide(flush, settled_before)) {
  }
  std::vector<Group> out;
  out.swap(out_);
  return out;
}

// ---------------------------------------------------------------------------------------------
// Subsampler

Subsampler::Subsampler(std::int64_t anchor_ns, double grid_hz) : anchor_ns_(anchor_ns), period_ns_(1e9 / grid_hz) {}

std::int64_t grid_lattice_floor(std::int64_t t_ns, double grid_hz) {
  const long double period = 1e9L / static_cast<long double>(grid_hz);
  const long double k = std::floor(static_cast<long double>(t_ns) / period);
  return std::int64_t(std::llround(k * period));
}

std::int64_t Subsampler::tick_time(std::int64_t tick) const {
  return anchor_ns_ + std::int64_t(std::llround(double(tick) * period_ns_));
}

std::vector<Subsampler::Sample> Subsampler::add(const Group& group, std::vector<Group>* discarded) {
  std::vector<Sample> out;
  auto discard = [&](const Group& g) {
    if (discarded) discarded->push_back(g);
  };
  const double rel = double(group.t_ns - anchor_ns_);
  if (rel < -0.5 * period_ns_) {  // before the session's first tick
    discard(group);
    return out;
  }
  const auto tick = std::int64_t(std::llround(rel / period_ns_));
  const std::int64_t tick_ns = tick_time(tick);
  if (best_ && tick == best_->tick) {
    if (std::llabs(group.t_ns - tick_ns) < std::llabs(best_->group.t_ns - tick_ns)) {
      discard(best_->group);
      best_->group = group;
    } else {
      discard(group);
    }
    return out;
  }
  if (best_ && tick < best_->tick) {  // groups come in order; an older one cannot win
    discard(group);
    return out;
  }
  if (best_) {
    out.push_back(*best_);
    last_emitted_ = best_->tick;
  }
  missed_ += std::uint64_t(std::max<std::int64_t>(0, tick - last_emitted_ - 1));
  best_ = Sample{tick, tick_ns, group};
  return out;
}

std::vector<Subsampler::Sample> Subsampler::flush() {
  std::vector<Sample> out;
  if (best_) {
    out.push_back(*best_);
    last_emitted_ = best_->tick;
    best_.reset();
  }
  return out;
}

std::vector<Subsampler::Sample> Subsampler::settle(std::int64_t no_group_before_ns) {
  if (!best_ || double(no_group_before_ns - best_->tick_ns) <= 0.5 * period_ns_) return {};
  return flush();
}

// ---------------------------------------------------------------------------------------------
// PressureAligner

PressureAligner::PressureAligner(std::int64_t window_ns, std::int64_t max_offset_ns, std::int64_t sample_lag_ns)
    : window_ns_(window_ns), max_offset_ns_(max_offset_ns), sample_lag_ns_(sample_lag_ns) {}

void PressureAligner::add_pressure(const FrameRef& frame) {
  if (frame.t_ns <= decided_until_) {
    ++unpaired_["pressure frame arrived after the samples around it were paired"];
    return;
  }
  // Mostly appended; a late frame within the window is slotted into place.
  auto it = frames_.end();
  while (it != frames_.begin() && (it - 1)->t_ns > frame.t_ns) --it;
  frames_.insert(it, frame);
  newest_ = std::max(newest_, frame.t_ns);
  // Forget what no sample can still need (keeping one frame before that point as a neighbour).
  const std::int64_t keep_from = newest_ - sample_lag_ns_ - max_offset_ns_;
  while (frames_.size() > 1 && frames_[1].t_ns <= keep_from) frames_.pop_front();
}

void PressureAligner::add_sample(std::int64_t sample_ns, std::uint64_t key) { samples_.emplace_back(sample_ns, key); }

PressureAligner::Pairing PressureAligner::pair(std::int64_t t) const {
  return pair_nearest(frames_.begin(), frames_.end(), t, max_offset_ns_);
}

std::vector<std::pair<std::uint64_t, PressureAligner::Pairing>> PressureAligner::take(bool flush,
                                                                                      std::int64_t give_up_before_ns) {
  std::vector<std::pair<std::uint64_t, Pairing>> out;
  while (!samples_.empty() &&
         (flush || newest_ >= samples_.front().first + window_ns_ || samples_.front().first < give_up_before_ns)) {
    const auto [t, key] = samples_.front();
    samples_.pop_front();
    Pairing p = pair(t);
    if (!p.nearest) {
      if (frames_.empty())
        ++unpaired_["no pressure frames"];
      else if (frames_.front().t_ns > t + max_offset_ns_ && !p.before)
        ++unpaired_["sample older than the pressure kept"];
      else
        ++unpaired_["no pressure frame within the allowed offset"];
    }
    decided_until_ = std::max(decided_until_, t);
    out.emplace_back(key, std::move(p));
  }
  return out;
}

}  // namespace pvcap::sync
