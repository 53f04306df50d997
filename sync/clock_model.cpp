#include "sync/clock_model.h"

#include <algorithm>
#include <cmath>

namespace pvcap::sync {

void ClockModel::start_segment(std::int64_t device_ns, std::int64_t arrival_ns) {
  ++segment_;
  bins_.clear();
  bins_.push_back({0, arrival_ns - device_ns});
  bin_ns_ = options_.bin_ns;
  n_ = 1;
  last_x_ = 0;
  above_run_ = 0;
  behind_run_ = 0;
  fit_ = {device_ns, double(arrival_ns - device_ns), 0.0};
  probes_.clear();
  probed_ = false;
  segments_.push_back({arrival_ns, fit_, options_.latency_ns});
}

void ClockModel::publish() {
  segments_.back().fit = probed_ ? probe_fit_ : fit_;
  segments_.back().latency_ns = probed_ ? 0 : options_.latency_ns;
}

void ClockModel::add_probe(std::int64_t device_ns, std::int64_t host_lo_ns, std::int64_t host_hi_ns) {
  if (segment_ < 0 || host_hi_ns < host_lo_ns) return;
  const std::int64_t x = device_ns - fit_.x0;
  // A probe from before this segment's clock (x far back) belongs to no segment we fit.
  if (x < -options_.reset_back_ns) return;
  probes_.push_back({x, host_lo_ns - device_ns, host_hi_ns - device_ns});
  if (probes_.size() > options_.max_bins) probes_.erase(probes_.begin(), probes_.begin() + std::ptrdiff_t(probes_.size() / 2));
  refit_probes();
  publish();
}

void ClockModel::refit_probes() {
  const std::size_t n = probes_.size();
  if (n < 4 || probes_.back().x - probes_.front().x < options_.min_span_for_skew_ns) return;
  auto mid = [](const Probe& p) { return 0.5 * double(p.lo + p.hi); };
  const std::size_t h = n / 2;
  slopes_.clear();
  for (std::size_t i = 0; i + h < n; ++i)
    slopes_.push_back((mid(probes_[i + h]) - mid(probes_[i])) / double(probes_[i + h].x - probes_[i].x));
  std::nth_element(slopes_.begin(), slopes_.begin() + std::ptrdiff_t(slopes_.size() / 2), slopes_.end());
  const double slope = std::clamp(slopes_[slopes_.size() / 2], -options_.max_skew, options_.max_skew);
  // Every probe says: offset in [lo - slope x, hi - slope x]. Take the centre of what all allow;
  // if a wrong slope leaves nothing, the median of the midpoints.
  double lo = -1e300, hi = 1e300;
  std::vector<double> mids;
  for (const Probe& p : probes_) {
    lo = std::max(lo, double(p.lo) - slope * double(p.x));
    hi = std::min(hi, double(p.hi) - slope * double(p.x));
    mids.push_back(mid(p) - slope * double(p.x));
  }
  double offset = 0.5 * (lo + hi);
  if (lo > hi) {
    std::nth_element(mids.begin(), mids.begin() + std::ptrdiff_t(mids.size() / 2), mids.end());
    offset = mids[mids.size() / 2];
  }
  probe_fit_ = {fit_.x0, offset, slope};
  probed_ = true;
}

bool ClockModel::add(std::int64_t device_ns, std::int64_t arrival_ns) {
  if (segment_ < 0) {
    start_segment(device_ns, arrival_ns);
    return false;  // the first segment is not a reset
  }
  const std::int64_t x = device_ns - fit_.x0;
  const std::int64_t above = arrival_ns - fit_.map(device_ns);
  above_run_ = above > options_.reset_above_ns ? above_run_ + 1 : 0;
  behind_run_ = x < last_x_ ? behind_run_ + 1 : 0;
  // Below the line is normal while the fit is young (the first pairs may all have come late).
  const bool impossible_early = n_ >= 32 && above < -options_.reset_below_ns;
  const bool far_back = x < last_x_ - options_.reset_back_ns;
  if (far_back || impossible_early || above_run_ >= options_.reset_run || behind_run_ >= options_.reset_run) {
    start_segment(device_ns, arrival_ns);
    return true;
  }
  if (x < last_x_) return false;  // back in device time once: a reordered pair; the line needs none
  last_x_ = x;
  ++n_;
  const Point p{x, arrival_ns - device_ns};
  Point& current = bins_.back();
  if (x / bin_ns_ == current.x / bin_ns_) {
    if (p.y >= current.y) return false;  // not the earliest arrival of its bin: the line is unchanged
    current = p;
  } else {
    bins_.push_back(p);
    if (bins_.size() > options_.max_bins) {  // a long recording: halve the resolution, keep the minima
      bin_ns_ *= 2;
      std::vector<Point> merged;
      for (const Point& b : bins_)
        if (merged.empty() || merged.back().x / bin_ns_ != b.x / bin_ns_) merged.push_back(b);
        else if (b.y < merged.back().y) merged.back() = b;
      bins_.swap(merged);
    }
  }
  refit();
  publish();
  return false;
}

// Slope: the median of the slopes between bin minima half the recording apart (Theil-Sen
// on long baselines: a few bins whose minimum came late move it little). Offset: the line of
// that slope lowered onto the lowest bin minimum, so it lies under the envelope.
void ClockModel::refit() {
  auto support = [&](double slope) {
    double offset = double(bins_.front().y);
    for (const Point& b : bins_) offset = std::min(offset, double(b.y) - slope * double(b.x));
    fit_.skew = slope;
    fit_.offset_ns = offset;
  };
  const std::size_t n = bins_.size();
  if (n < 4 || bins_.back().x - bins_.front().x < options_.min_span_for_skew_ns) {
    support(0);
    return;
  }
  const std::size_t h = n / 2;
  slopes_.clear();
  for (std::size_t i = 0; i + h < n; ++i)
    slopes_.push_back(double(bins_[i + h].y - bins_[i].y) / double(bins_[i + h].x - bins_[i].x));
  std::nth_element(slopes_.begin(), slopes_.begin() + std::ptrdiff_t(slopes_.size() / 2), slopes_.end());
  support(std::clamp(slopes_[slopes_.size() / 2], -options_.max_skew, options_.max_skew));
}

}  // namespace pvcap::sync
