#include "sync/clock_model.h"

#include <algorithm>
#include <cmath>
#include <utility>

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
  segments_.push_back({arrival_ns, fit_, options_.latency_ns - options_.stamp_to_instant_ns});
  if (segment_ == 0)
    for (const EarlyProbe& p : std::exchange(before_first_frame_, {}))
      add_probe(p.device_ns, p.host_lo_ns, p.host_hi_ns);
}

void ClockModel::publish() {
  segments_.back().fit = probed_ ? probe_fit_ : fit_;
  segments_.back().latency_ns = (probed_ ? 0 : options_.latency_ns) - options_.stamp_to_instant_ns;
}

void ClockModel::add_probe(std::int64_t device_ns, std::int64_t host_lo_ns, std::int64_t host_hi_ns) {
  if (host_hi_ns < host_lo_ns) return;
  if (segment_ < 0) {
    if (before_first_frame_.size() < 16) before_first_frame_.push_back({device_ns, host_lo_ns, host_hi_ns});
    return;
  }
  device_ns = bounded_device_time(device_ns);
  const std::int64_t x = device_ns - fit_.x0;
  // A probe from before this segment's clock (x far back) belongs to no segment we fit.
  if (x < -options_.reset_back_ns) return;
  probes_.push_back({x, host_lo_ns - device_ns, host_hi_ns - device_ns});
  if (probes_.size() > options_.max_probes) {
    // Thin by half, keeping the segment's whole span: of each neighbouring pair, the tighter
    // bracket (it constrains the line more).
    std::vector<Probe> kept;
    kept.reserve(probes_.size() / 2 + 1);
    for (std::size_t i = 0; i + 1 < probes_.size(); i += 2) {
      const Probe& a = probes_[i];
      const Probe& b = probes_[i + 1];
      kept.push_back(b.hi - b.lo < a.hi - a.lo ? b : a);
    }
    if (probes_.size() % 2) kept.push_back(probes_.back());
    probes_ = std::move(kept);
  }
  refit_probes();
  publish();
}

double ClockModel::probe_band(double slope, double* centre) const {
  double lo = -1e300, hi = 1e300;
  for (const Probe& p : probes_) {
    lo = std::max(lo, double(p.lo) - slope * double(p.x));
    hi = std::min(hi, double(p.hi) - slope * double(p.x));
  }
  if (centre) *centre = 0.5 * (lo + hi);
  return hi - lo;
}

void ClockModel::refit_probes() {
  const std::size_t n = probes_.size();
  if (n == 0) return;
  if (n < 4 || probes_.back().x - probes_.front().x < options_.min_span_for_skew_ns) {
    // Too short a span for a slope: no drift, the offset the brackets leave open.
    double offset = 0;
    if (probe_band(0.0, &offset) < 0) {
      const Probe& tightest = *std::min_element(
          probes_.begin(), probes_.end(), [](const Probe& a, const Probe& b) { return a.hi - a.lo < b.hi - b.lo; });
      offset = 0.5 * (double(tightest.lo) + double(tightest.hi));
    }
    probe_fit_ = {fit_.x0, offset, 0.0};
    probed_ = true;
    return;
  }
  // Every probe says the line passes through its bracket: offset + slope x in [lo, hi]. The
  // width of what all of them leave open is concave in the slope; take the slope where it is
  // widest (the middle of that plateau), and the offset at the centre of the band there. When
  // brackets disagree (width < 0), the same search finds the line that violates them least.
  // (Theil-Sen slopes over bracket midpoints came first: a load that lengthens the read-back
  // half of the brackets late in a session biases the midpoints, and an 8 s session's fit
  // came out a millisecond off at its ends; docs/performance-log.md.)
  const double m = options_.max_skew;
  double a = -m, b = m;
  for (int i = 0; i < 80; ++i) {
    const double s1 = a + (b - a) / 3, s2 = b - (b - a) / 3;
    if (probe_band(s1) < probe_band(s2))
      a = s1;
    else
      b = s2;
  }
  const double best = 0.5 * (a + b);
  const double widest = probe_band(best) - 1.0;  // within a nanosecond of the widest
  auto edge = [&](double inside, double outside) {
    if (probe_band(outside) >= widest) return outside;
    for (int i = 0; i < 60; ++i) {
      const double mid = 0.5 * (inside + outside);
      (probe_band(mid) >= widest ? inside : outside) = mid;
    }
    return inside;
  };
  const double slope = 0.5 * (edge(best, -m) + edge(best, m));
  double offset = 0;
  probe_band(slope, &offset);
  probe_fit_ = {fit_.x0, offset, slope};
  probed_ = true;
}

bool ClockModel::add(std::int64_t device_ns, std::int64_t arrival_ns) {
  device_ns = bounded_device_time(device_ns);
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
        if (merged.empty() || merged.back().x / bin_ns_ != b.x / bin_ns_)
          merged.push_back(b);
        else if (b.y < merged.back().y)
          merged.back() = b;
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
