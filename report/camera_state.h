#pragma once
// The cameras' whole state as each session recorded it (every readable feature's value after pvcap
// configured it: devices.settings_json.feature_bag, docs/cameras.md), set side by side: what differs
// between a session's cameras, what differs from the rig's previous session, and automatic controls
// left on (ExposureAuto, BalanceWhiteAuto, ...: they change the images within a take and across a
// dataset, so each is a warning).
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

namespace pvcap::report {

struct CameraBag {
  std::string camera;
  std::map<std::string, std::string> features;  // feature -> value
};
// From each camera's recorded settings (name, settings_json); cameras without a bag are left out.
std::vector<CameraBag> camera_bags(const std::vector<std::pair<std::string, std::string>>& settings);

// Features whose values differ by nature from camera to camera or moment to moment (serials,
// addresses, timestamps, temperatures, counters): never reported as a difference.
bool varies_by_nature(const std::string& feature);

// The rig's session recorded last before `session` in the same sessions folder (its folder name
// sorts just before and ends in the same rig name), if any.
std::optional<std::filesystem::path> previous_session_of_rig(const std::filesystem::path& session);

// {"cameras_with_state": n, "differ_between_cameras": [{feature, values: {camera: value}}],
//  "previous_session": folder or null, "differ_from_previous": [{camera, feature, then, now}],
//  "warnings": [text]}
nlohmann::json camera_state_section(const std::vector<CameraBag>& now, const std::optional<std::string>& previous_name,
                                    const std::vector<CameraBag>& previous);

}  // namespace pvcap::report
