#include "lighting/light_model.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace pvcap::lighting {

bool LightModel::visible(std::size_t camera, double step) const {
  const double n = camera < noise.size() ? noise[camera] : 0;
  return std::abs(step) >= std::max(1.0, 4 * n);
}

bool LightModel::seen(std::size_t light) const {
  // A lamp adds light, over more than one region: a single region's step, or a darker one, is a
  // region whose noise the check's short dark step underrated (the simulator's timecode once made a
  // dead lamp "seen" by -2.2 levels in one region of one camera).
  int regions = 0;
  for (std::size_t c = 0; c < contribution.size(); ++c)
    if (light < contribution[c].size() && contribution[c][light] >= 2.0 && visible(c, contribution[c][light]))
      ++regions;
  return regions >= 2;
}

std::uint32_t LightModel::seen_mask() const {
  std::uint32_t m = 0;
  for (std::size_t i = 0; i < names.size(); ++i)
    if (seen(i)) m |= 1u << i;
  return m;
}

double LightModel::predicted(std::size_t camera, std::uint32_t mask) const {
  double level = dark.at(camera);
  for (std::size_t i = 0; i < names.size(); ++i)
    if (mask >> i & 1u) level += contribution.at(camera).at(i);
  return level;
}

std::uint32_t LightModel::classify(const std::vector<double>& levels) const {
  const std::uint32_t seen_lights = seen_mask();
  std::uint32_t best = 0;
  double best_cost = std::numeric_limits<double>::infinity();
  // Every subset of the seen lights (a light no camera sees is never said to be on).
  for (std::uint32_t m = seen_lights;; m = (m - 1) & seen_lights) {
    double cost = 0;
    for (std::size_t c = 0; c < levels.size() && c < dark.size(); ++c) {
      if (std::isnan(levels[c]) || std::isnan(dark[c])) continue;
      const double d = (levels[c] - predicted(c, m)) / std::max(0.5, noise[c]);
      cost += d * d;
    }
    if (cost < best_cost) best_cost = cost, best = m;
    if (m == 0) break;
  }
  return best;
}

void to_json(nlohmann::json& j, const LightModel& m) {
  j = {{"lights", m.names}, {"dark", m.dark}, {"noise", m.noise}, {"contribution", m.contribution}};
}
void from_json(const nlohmann::json& j, LightModel& m) {
  j.at("lights").get_to(m.names);
  j.at("dark").get_to(m.dark);
  j.at("noise").get_to(m.noise);
  j.at("contribution").get_to(m.contribution);
}

LightModel learn_light_model(const LightNames& names, const std::vector<double>& dark,
                             const std::vector<double>& noise, const std::vector<std::vector<double>>& alone) {
  LightModel m;
  m.names = names;
  m.dark = dark;
  m.noise = noise;
  m.contribution.assign(dark.size(), std::vector<double>(names.size(), 0.0));
  for (std::size_t i = 0; i < names.size() && i < alone.size(); ++i)
    for (std::size_t c = 0; c < dark.size() && c < alone[i].size(); ++c)
      if (!std::isnan(alone[i][c]) && !std::isnan(dark[c])) m.contribution[c][i] = alone[i][c] - dark[c];
  return m;
}

}  // namespace pvcap::lighting
