#include "report/camera_state.h"

#include <algorithm>
#include <set>

#include <fmt/format.h>

namespace pvcap::report {

using nlohmann::json;

std::vector<CameraBag> camera_bags(const std::vector<std::pair<std::string, std::string>>& settings) {
  std::vector<CameraBag> out;
  for (const auto& [camera, text] : settings) {
    const json j = json::parse(text, nullptr, /*allow_exceptions=*/false);
    if (!j.is_object() || !j.contains("feature_bag") || !j["feature_bag"].is_object()) continue;
    CameraBag bag{camera, {}};
    for (const auto& [feature, value] : j["feature_bag"].items())
      if (value.is_string()) bag.features[feature] = value.get<std::string>();
    out.push_back(std::move(bag));
  }
  return out;
}

bool varies_by_nature(const std::string& feature) {
  static const char* const kParts[] = {"Serial",    "DeviceID", "UserID",    "Address",   "MAC",         "Mac",
                                       "Subnet",    "Gateway",  "IP",        "Timestamp", "Temperature", "Counter",
                                       "Statistic", "Uptime",   "LinkSpeed", "Heartbeat"};
  return std::any_of(std::begin(kParts), std::end(kParts),
                     [&](const char* part) { return feature.find(part) != std::string::npos; });
}

std::optional<std::filesystem::path> previous_session_of_rig(const std::filesystem::path& session) {
  const std::filesystem::path dir = std::filesystem::absolute(session).lexically_normal();
  const std::string name = dir.filename().string();
  const auto cut = name.find('_');
  if (cut == std::string::npos) return std::nullopt;
  const std::string rig = name.substr(cut);  // "_sim-rig"
  std::optional<std::filesystem::path> best;
  std::error_code ec;
  for (const auto& e : std::filesystem::directory_iterator(dir.parent_path(), ec)) {
    const std::string other = e.path().filename().string();
    if (other >= name || other.size() <= rig.size() || other.compare(other.size() - rig.size(), rig.size(), rig) != 0)
      continue;
    if (!std::filesystem::exists(e.path() / "session.db")) continue;
    if (!best || other > best->filename().string()) best = e.path();
  }
  return best;
}

namespace {
const std::map<std::string, std::string>* bag_of(const std::vector<CameraBag>& bags, const std::string& camera) {
  for (const auto& b : bags)
    if (b.camera == camera) return &b.features;
  return nullptr;
}
}  // namespace

json camera_state_section(const std::vector<CameraBag>& now, const std::optional<std::string>& previous_name,
                          const std::vector<CameraBag>& previous) {
  json out = {{"cameras_with_state", now.size()},
              {"differ_between_cameras", json::array()},
              {"previous_session", previous_name ? json(*previous_name) : json(nullptr)},
              {"differ_from_previous", json::array()},
              {"warnings", json::array()}};
  std::set<std::string> features;
  for (const auto& b : now)
    for (const auto& [f, v] : b.features) features.insert(f);
  for (const auto& f : features) {
    if (varies_by_nature(f)) continue;
    json values = json::object();
    std::set<std::string> distinct;
    for (const auto& b : now) {
      const auto it = b.features.find(f);
      const std::string v = it == b.features.end() ? "(none)" : it->second;
      values[b.camera] = v;
      distinct.insert(v);
    }
    if (distinct.size() > 1) out["differ_between_cameras"].push_back({{"feature", f}, {"values", values}});
  }
  // An automatic control left on changes what the camera records as the scene changes.
  for (const auto& b : now)
    for (const auto& [f, v] : b.features)
      if (f.size() > 4 && f.compare(f.size() - 4, 4, "Auto") == 0 && v != "Off")
        out["warnings"].push_back(
            fmt::format("{}: {} is {}: its images change with the scene, within a take and "
                        "across the dataset (set it Off, or set it in the rig's camera "
                        "before the session)",
                        b.camera, f, v));
  for (const auto& b : now) {
    const auto* then = bag_of(previous, b.camera);
    if (!then) continue;
    for (const auto& [f, v] : b.features) {
      if (varies_by_nature(f)) continue;
      const auto it = then->find(f);
      if (it != then->end() && it->second != v)
        out["differ_from_previous"].push_back({{"camera", b.camera}, {"feature", f}, {"then", it->second}, {"now", v}});
    }
  }
  return out;
}

}  // namespace pvcap::report
