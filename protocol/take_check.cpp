#include "protocol/take_check.h"

#include <algorithm>

#include <fmt/format.h>
#include <fmt/ranges.h>

namespace pvcap::protocol {

TakeMeasures measure_take(const std::vector<ForcePoint>& points, std::int64_t from_ns, std::int64_t to_ns) {
  TakeMeasures m;
  std::int64_t previous = from_ns;
  double sum = 0, contact_sum = 0, weighted_x = 0;
  for (const auto& p : points) {
    if (p.t_ns < from_ns || p.t_ns >= to_ns) continue;
    ++m.frames;
    sum += p.newtons;
    contact_sum += p.contact_mm2;
    m.peak_newtons = std::max(m.peak_newtons, p.newtons);
    m.peak_contact_mm2 = std::max(m.peak_contact_mm2, p.contact_mm2);
    weighted_x += p.newtons * p.centroid_x_mm;
    m.max_pressure_gap_ms = std::max(m.max_pressure_gap_ms, double(p.t_ns - previous) / 1e6);
    previous = p.t_ns;
  }
  m.max_pressure_gap_ms = std::max(m.max_pressure_gap_ms, double(to_ns - previous) / 1e6);
  if (m.frames) {
    m.mean_newtons = sum / double(m.frames);
    m.mean_contact_mm2 = contact_sum / double(m.frames);
  }
  if (sum > 0) m.centroid_x_mm = weighted_x / sum;
  return m;
}

std::string lighting_difference(const std::string& commanded, const std::string& seen) {
  std::vector<std::string> lights;
  for (std::size_t i = 0; i < commanded.size() && i < seen.size(); ++i) {
    if (commanded[i] == seen[i]) continue;
    lights.push_back(commanded[i] != '-' ? fmt::format("light {} did not come on", commanded[i])
                                         : fmt::format("light {} was on", seen[i]));
  }
  return fmt::format("the images show lighting {}, not the {} commanded ({})", seen, commanded,
                     lights.empty() ? std::string("a different code") : fmt::format("{}", fmt::join(lights, ", ")));
}

TakeCheck check_take(const TakeCheckInput& in, const TakeCheckConfig& cfg) {
  TakeCheck c;
  c.measures = in.measures;
  const TakeMeasures& m = in.measures;
  auto problem = [&](std::string s) {
    c.ok = false;
    c.problems.push_back(std::move(s));
  };
  if (in.max_camera_gap_ms > cfg.max_gap_ms)
    problem(fmt::format("a camera delivered no frame for {:.0f} ms during the take", in.max_camera_gap_ms));
  if (!in.lighting_commanded.empty() && !in.lighting_seen.empty() && in.lighting_seen != in.lighting_commanded)
    problem(lighting_difference(in.lighting_commanded, in.lighting_seen));
  if (!in.has_pressure) return c;
  if (m.max_pressure_gap_ms > cfg.max_gap_ms)
    problem(fmt::format("the Sensel delivered no frame for {:.0f} ms during the take", m.max_pressure_gap_ms));
  const Force f = in.action->force;
  if (f == Force::NoContact) {
    if (m.peak_newtons >= cfg.no_contact_newtons)
      problem(fmt::format("No contact was asked, but the pad felt up to {:.2f} N", m.peak_newtons));
    return c;
  }
  if (m.peak_newtons <= cfg.contact_newtons) {
    problem(fmt::format("no press was felt (peak {:.2f} N, at least {:.2f} N expected)", m.peak_newtons,
                        cfg.contact_newtons));
    return c;
  }
  if (f == Force::High && in.low_mean_newtons && m.mean_newtons < cfg.high_over_low * *in.low_mean_newtons)
    problem(fmt::format("High was not clearly above Low: mean {:.2f} N against Low's {:.2f} N (x{:.1f} expected)",
                        m.mean_newtons, *in.low_mean_newtons, cfg.high_over_low));
  if (in.action->check_side && m.centroid_x_mm) {
    const bool on_left = *m.centroid_x_mm < in.pad_width_mm / 2;
    if (on_left != (in.hand == Hand::Left))
      problem(fmt::format("the press was on the {} half of the pad, but the {} hand was asked",
                          on_left ? "left" : "right", to_string(in.hand)));
  }
  return c;
}

}  // namespace pvcap::protocol
