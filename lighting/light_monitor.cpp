#include "lighting/light_monitor.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace pvcap::lighting {

namespace {
constexpr std::int64_t kKeepNs = 60'000'000'000;

double median(std::vector<double> v) {
  if (v.empty()) return std::numeric_limits<double>::quiet_NaN();
  const auto mid = v.begin() + std::ptrdiff_t(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}
}  // namespace

LightMonitor::LightMonitor(std::size_t channels) : per_camera_(channels) {}

void LightMonitor::add(std::size_t camera, std::int64_t t_ns, double level) {
  if (camera >= per_camera_.size()) return;
  Camera& c = per_camera_[camera];
  std::lock_guard lock(c.mu);
  c.levels.push_back({t_ns, level});
  while (!c.levels.empty() && c.levels.front().t_ns < t_ns - kKeepNs) c.levels.pop_front();
}

std::vector<Level> LightMonitor::levels(std::size_t camera, std::int64_t from_ns, std::int64_t to_ns) const {
  std::vector<Level> out;
  if (camera >= per_camera_.size()) return out;
  const Camera& c = per_camera_[camera];
  std::lock_guard lock(c.mu);
  for (const Level& l : c.levels)
    if (l.t_ns >= from_ns && l.t_ns < to_ns) out.push_back(l);
  std::sort(out.begin(), out.end(), [](const Level& a, const Level& b) { return a.t_ns < b.t_ns; });
  return out;
}

std::vector<double> LightMonitor::medians(std::int64_t from_ns, std::int64_t to_ns, std::vector<double>* spread) const {
  std::vector<double> out;
  if (spread) spread->clear();
  for (std::size_t c = 0; c < per_camera_.size(); ++c) {
    std::vector<double> v;
    for (const Level& l : levels(c, from_ns, to_ns)) v.push_back(l.level);
    const double m = median(v);
    out.push_back(m);
    if (spread) {
      for (double& x : v) x = std::abs(x - m);
      spread->push_back(v.empty() ? std::numeric_limits<double>::quiet_NaN() : 1.4826 * median(v));
    }
  }
  return out;
}

SwitchSeen switch_seen(const LightModel& model, const LightMonitor& monitor, std::int64_t command_ns,
                       std::uint32_t from, std::uint32_t to, std::int64_t now_ns) {
  SwitchSeen s;
  s.visible = false;
  bool all = true;
  for (std::size_t c = 0; c < monitor.channels() && c < model.dark.size(); ++c) {
    if (std::isnan(model.dark[c])) continue;
    const double before = model.predicted(c, from), after = model.predicted(c, to);
    if (!model.visible(c, after - before)) continue;  // this camera cannot tell them apart
    s.visible = true;
    const auto levels = monitor.levels(c, command_ns, now_ns + 1);
    const auto shows_new = [&](double level) { return std::abs(level - after) < std::abs(level - before); };
    std::size_t first = levels.size();
    for (std::size_t i = 0; i + 1 < levels.size(); ++i)
      if (shows_new(levels[i].level) && shows_new(levels[i + 1].level)) {
        first = i;
        break;
      }
    if (first == levels.size()) {
      all = false;
      s.channels_waiting.push_back(int(c));
      continue;
    }
    s.delay_ms = std::max(s.delay_ms, double(levels[first].t_ns - command_ns) / 1e6);
    s.frames = std::max(s.frames, int(first));
  }
  s.confirmed = s.visible && all;
  return s;
}

}  // namespace pvcap::lighting
