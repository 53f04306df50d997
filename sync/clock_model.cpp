#include "sync/clock_model.h"

#include <algorithm>
#include <cmath>

namespace pvcap::sync {

void ClockModel::start_segment(std::int64_t device_ns, std::int64_t arrival_ns) {
  ++segment_;
  hull_.clear();
  hull_.push_back({0, arrival_ns - device_ns});
  sum_x_ = 0;
  n_ = 1;
  last_x_ = 0;
  above_run_ = 0;
  behind_run_ = 0;
  fit_ = {device_ns, double(arrival_ns - device_ns), 0.0};
  segments_.push_back({arrival_ns, fit_});
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
  const Point p{x, arrival_ns - device_ns};
  last_x_ = x;
  sum_x_ += x;
  ++n_;
  if (p.x == hull_.back().x) {  // same device time twice: only the earlier arrival bounds the line
    if (p.y >= hull_.back().y) return false;
    hull_.pop_back();
  }
  // Monotone chain, lower hull: drop vertices that are no longer below the chord.
  auto cross = [](const Point& o, const Point& a, const Point& b) {
    return (long double)(a.x - o.x) * (long double)(b.y - o.y) - (long double)(a.y - o.y) * (long double)(b.x - o.x);
  };
  while (hull_.size() >= 2 && cross(hull_[hull_.size() - 2], hull_.back(), p) <= 0) hull_.pop_back();
  hull_.push_back(p);
  refit();
  segments_.back().fit = fit_;
  return false;
}

// The supporting line of the hull at the mean device time.
void ClockModel::refit() {
  // The line of slope `slope` that touches the hull from below.
  auto support = [&](long double slope) {
    long double offset = (long double)(hull_.front().y) - slope * (long double)(hull_.front().x);
    for (const Point& q : hull_) offset = std::min(offset, (long double)(q.y) - slope * (long double)(q.x));
    fit_.skew = double(slope);
    fit_.offset_ns = double(offset);
  };
  if (hull_.size() < 2 || hull_.back().x - hull_.front().x < options_.min_span_for_skew_ns) {
    support(0);
    return;
  }
  const long double mean_x = sum_x_ / (long double)(n_);
  auto it = std::upper_bound(hull_.begin(), hull_.end(), mean_x,
                             [](long double v, const Point& q) { return v < (long double)(q.x); });
  if (it == hull_.begin()) ++it;
  if (it == hull_.end()) --it;
  const Point& a = *(it - 1);
  const Point& b = *it;
  const long double slope = (long double)(b.y - a.y) / (long double)(b.x - a.x);
  if (std::fabs(double(slope)) > options_.max_skew) {
    support(slope > 0 ? options_.max_skew : -options_.max_skew);
    return;
  }
  fit_.skew = double(slope);
  fit_.offset_ns = double((long double)(a.y) - slope * (long double)(a.x));  // at x = 0, i.e. device = x0
}

}  // namespace pvcap::sync
