#include "lighting/light_monitor.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>

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
                       std::uint32_t from, std::uint32_t to, std::int64_t now_ns, std::size_t channels_per_camera) {
  SwitchSeen s;
  s.visible = false;
  bool all = true;
  const std::size_t per = std::max<std::size_t>(1, channels_per_camera);
  const std::size_t channels = std::min(monitor.channels(), model.dark.size());
  for (std::size_t first_channel = 0; first_channel < channels; first_channel += per) {
    // A camera's frame is the levels of its regions at one instant; it shows `to` when they lie nearer
    // to what the model predicts under `to` than under `from` (each region scaled by its noise).
    std::map<std::int64_t, double> closer;  // per frame: distance to `from` minus distance to `to`
    double separation = 0;
    for (std::size_t c = first_channel; c < first_channel + per && c < channels; ++c) {
      if (std::isnan(model.dark[c])) continue;
      const double before = model.predicted(c, from), after = model.predicted(c, to);
      const double scale = std::max(0.5, model.noise[c]);
      separation += (after - before) * (after - before) / (scale * scale);
      for (const Level& l : monitor.levels(c, command_ns, now_ns + 1)) {
        const double a = (l.level - after) / scale, b = (l.level - before) / scale;
        closer[l.t_ns] += b * b - a * a;
      }
    }
    if (separation < 16) continue;  // this camera cannot tell the two apart (less than 4 noise steps)
    s.visible = true;
    std::vector<std::pair<std::int64_t, bool>> frames;
    for (const auto& [t, d] : closer) frames.push_back({t, d > 0});
    std::size_t first = frames.size();
    for (std::size_t i = 0; i + 1 < frames.size(); ++i)
      if (frames[i].second && frames[i + 1].second) {
        first = i;
        break;
      }
    if (first == frames.size()) {
      all = false;
      s.channels_waiting.push_back(int(first_channel));
      continue;
    }
    s.delay_ms = std::max(s.delay_ms, double(frames[first].first - command_ns) / 1e6);
    s.frames = std::max(s.frames, int(first));
  }
  s.confirmed = s.visible && all;
  return s;
}

}  // namespace pvcap::lighting
