// The cameras' whole state side by side (report/camera_state.h): what differs between a session's
// cameras and from the rig's previous session, automatic controls left on, and which session is the
// previous one.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>

#include <fmt/format.h>

#include "report/camera_state.h"

using namespace pvcap::report;
using nlohmann::json;

namespace {
std::string settings_with(const json& bag) { return json{{"pixel_format", "BayerRG8"}, {"feature_bag", bag}}.dump(); }
}  // namespace

TEST(CameraState, BagsAreReadFromTheSettingsAndOldSessionsHaveNone) {
  const auto bags = camera_bags({{"cam0", settings_with({{"Gain", "0"}, {"ExposureTime", "6000"}})},
                                 {"cam1", R"({"pixel_format": "BayerRG8"})"},
                                 {"cam2", "not json"}});
  ASSERT_EQ(bags.size(), 1u);
  EXPECT_EQ(bags[0].camera, "cam0");
  EXPECT_EQ(bags[0].features.at("ExposureTime"), "6000");
}

TEST(CameraState, DifferencesAutoControlsAndThePreviousSessionAreSaid) {
  const std::vector<CameraBag> now = {
      {"cam0", {{"ExposureTime", "6000"}, {"BalanceWhiteAuto", "Off"}, {"DeviceSerialNumber", "A"}, {"Gain", "0"}}},
      {"cam1",
       {{"ExposureTime", "6000"}, {"BalanceWhiteAuto", "Continuous"}, {"DeviceSerialNumber", "B"}, {"Gain", "0"}}},
      {"cam2", {{"ExposureTime", "8000"}, {"DeviceSerialNumber", "C"}, {"Gain", "0"}}},
  };
  const std::vector<CameraBag> then = {
      {"cam0", {{"ExposureTime", "4000"}, {"Gain", "0"}, {"DeviceSerialNumber", "Z"}}}};
  const json s = camera_state_section(now, std::string("20261201-100000_rig"), then);
  EXPECT_EQ(s["cameras_with_state"], 3);
  // Exposure and the white balance differ; serials differ by nature; gain agrees.
  std::map<std::string, json> between;
  for (const auto& d : s["differ_between_cameras"]) between[d["feature"]] = d["values"];
  ASSERT_EQ(between.size(), 2u) << s.dump(1);
  EXPECT_EQ(between["ExposureTime"]["cam2"], "8000");
  EXPECT_EQ(between["BalanceWhiteAuto"]["cam1"], "Continuous");
  EXPECT_EQ(between["BalanceWhiteAuto"]["cam2"], "(none)");
  // The automatic white balance left on is a warning naming the camera.
  ASSERT_EQ(s["warnings"].size(), 1u);
  EXPECT_NE(s["warnings"][0].get<std::string>().find("cam1: BalanceWhiteAuto is Continuous"), std::string::npos);
  // Against the previous session: cam0's exposure changed; its serial is not compared.
  ASSERT_EQ(s["differ_from_previous"].size(), 1u) << s.dump(1);
  EXPECT_EQ(s["differ_from_previous"][0]["feature"], "ExposureTime");
  EXPECT_EQ(s["differ_from_previous"][0]["then"], "4000");
  EXPECT_EQ(s["differ_from_previous"][0]["now"], "6000");
  EXPECT_EQ(s["previous_session"], "20261201-100000_rig");
}

TEST(CameraState, ThePreviousSessionIsTheRigsLastOneBefore) {
  namespace fs = std::filesystem;
  const fs::path root = fs::temp_directory_path() / fmt::format("pvcap-camera-state-{}", getpid());
  fs::remove_all(root);
  for (const char* name : {"20261201-090000_lab", "20261201-100000_lab", "20261201-103000_other", "20261201-110000_lab",
                           "20261201-120000_lab", "20261201-105000_lab"}) {
    fs::create_directories(root / name);
    if (std::string(name) != "20261201-105000_lab") std::ofstream(root / name / "session.db") << "";
  }
  EXPECT_EQ(previous_session_of_rig(root / "20261201-110000_lab"), root / "20261201-100000_lab")
      << "the newest earlier session of the same rig that holds a store";
  EXPECT_FALSE(previous_session_of_rig(root / "20261201-090000_lab"));
  EXPECT_FALSE(previous_session_of_rig(root / "20261201-103000_other"));
  fs::remove_all(root);
}
