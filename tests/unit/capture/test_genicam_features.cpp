// Real cameras' GenICam node maps (../shared/data/genicam/, read in place): the feature pvcap would
// use for each role, under whichever name each vendor's map declares, and the clock it would use.
#include <gtest/gtest.h>

#include <cctype>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <set>

#include "capture/genicam_features.h"
#include "capture/genicam_node_map.h"

using namespace pvcap;

namespace {
CameraConfig in_format(const std::string& pixel_format) {
  CameraConfig c;
  c.pixel_format = pixel_format;
  return c;
}
const std::filesystem::path kNodeMaps = std::filesystem::path(PVCAP_SOURCE_DIR) / "../shared/data/genicam";

std::string read(const std::filesystem::path& p) {
  std::ifstream f(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>()};
}

std::map<std::string, std::string> features_of(const NodeMapCheck& c) {
  std::map<std::string, std::string> out;
  for (const auto& f : c.features) out[f.role] = f.name;
  return out;
}

struct Expected {
  const char* file;
  const char* latch;
  const char* exposure;
  const char* rate;
  const char* rate_enable;  // "" when the map has none
  const char* gain;
  const char* ptp;  // "" when none
  const char* bandwidth;
  const char* chunk_counter;  // the chunk values of a frame's own state ("" when the map has none)
  const char* chunk_gain;
  const char* chunk_line_status;  // the lines' levels per frame ("" when the map has none)
};
// As ../shared/data/genicam/README.md describes each map.
const Expected kExpected[] = {
    {"FLIR-BFS-PGE-23S6C.xml", "TimestampLatch", "ExposureTime", "AcquisitionFrameRate", "AcquisitionFrameRateEnable",
     "Gain", "GevIEEE1588", "GevSCPD", "ChunkFrameID", "ChunkGain", "ChunkExposureEndLineStatusAll"},
    {"FLIR_ORX_10G_51S5M.xml", "TimestampLatch", "ExposureTime", "AcquisitionFrameRate", "AcquisitionFrameRateEnable",
     "Gain", "GevIEEE1588", "GevSCPD", "ChunkFrameID", "ChunkGain", ""},
    {"PGR_Blackfly_50S5C.xml", "GevTimestampControlLatch", "ExposureTime", "AcquisitionFrameRate",
     "AcquisitionFrameRateEnable", "Gain", "", "GevSCPD", "ChunkFrameCounter", "ChunkGain", ""},
    {"PGR_GS3_PGE_23S6C.xml", "GevTimestampControlLatch", "ExposureTime", "AcquisitionFrameRate",
     "AcquisitionFrameRateEnabled", "Gain", "", "GevSCPD", "ChunkFrameCounter", "ChunkGain", ""},
    {"Basler-acA1920-25gm.xml", "GevTimestampControlLatch", "ExposureTimeAbs", "AcquisitionFrameRateAbs",
     "AcquisitionFrameRateEnable", "GainRaw", "", "GevSCPD", "ChunkFramecounter", "ChunkGainAll", "ChunkLineStatusAll"},
    {"Basler-a2A2600-20gmBAS.xml", "TimestampLatch", "ExposureTime", "AcquisitionFrameRate",
     "AcquisitionFrameRateEnable", "Gain", "PtpEnable", "GevSCPD", "ChunkFrameID", "ChunkGain", "ChunkLineStatusAll"},
    {"AVT_Mako_G158C.xml", "GevTimestampControlLatch", "ExposureTimeAbs", "AcquisitionFrameRateAbs", "", "Gain", "",
     "StreamBytesPerSecond", "", "", ""},
    {"AVT_Manta_G507C.xml", "GevTimestampControlLatch", "ExposureTimeAbs", "AcquisitionFrameRateAbs", "", "Gain",
     "PtpMode", "StreamBytesPerSecond", "", "", ""},
};
}  // namespace

TEST(GenicamFeatures, EverySharedNodeMapGivesTheLatchAndTheMapsOwnExposureAndRate) {
  std::set<std::string> seen;
  for (const Expected& e : kExpected) {
    SCOPED_TRACE(e.file);
    auto map = GenicamNodeMap::parse(read(kNodeMaps / e.file));
    ASSERT_TRUE(map) << map.error().message;
    const NodeMapCheck c = check_node_map(map.value(), in_format("Mono8"));
    auto f = features_of(c);
    EXPECT_EQ(c.clock, "latch") << "not the weaker arrival clock";
    EXPECT_EQ(f["timestamp_latch"], e.latch);
    EXPECT_EQ(f["exposure_time"], e.exposure);
    EXPECT_EQ(f["frame_rate"], e.rate);
    EXPECT_EQ(f["frame_rate_enable"], e.rate_enable);
    EXPECT_EQ(f["gain"], e.gain);
    EXPECT_EQ(f["ptp_enable"], e.ptp);
    EXPECT_EQ(c.ptp, *e.ptp != '\0');
    EXPECT_EQ(f["bandwidth_limit"], e.bandwidth);
    EXPECT_TRUE(c.chunks);
    // A frame's own state: under the map's names, where it has them (Allied Vision's maps have chunk
    // mode but no chunk values of these).
    EXPECT_EQ(f["chunk_frame_counter"], e.chunk_counter);
    EXPECT_EQ(f["chunk_gain"], e.chunk_gain);
    EXPECT_EQ(f["chunk_line_status"], e.chunk_line_status);
    EXPECT_EQ(f["chunk_exposure_time"], *e.chunk_counter ? "ChunkExposureTime" : "");
    EXPECT_EQ(f["chunk_timestamp"], *e.chunk_counter ? "ChunkTimestamp" : "");
    EXPECT_TRUE(c.usable()) << (c.missing.empty() ? "" : c.missing.front());
    EXPECT_FALSE(c.vendor.empty());
    seen.insert(e.file);
  }
  // Every node map shared is in the table above: a new one is checked, not skipped.
  for (const auto& entry : std::filesystem::directory_iterator(kNodeMaps)) {
    if (entry.path().extension() == ".xml") {
      EXPECT_TRUE(seen.count(entry.path().filename().string())) << entry.path();
    }
  }
}

// The roles a multi-host rig (PTP and scheduled action commands) and switched lights (output lines)
// need, under each map's own names, Allied Vision's included: every shared map that offers them.
TEST(GenicamFeatures, EverySharedMapThatOffersThemGivesItsPtpActionAndOutputLineRoles) {
  struct Roles {
    const char* file;
    const char* ptp_enable;
    const char* ptp_status;
    bool actions;  // ActionSelector, ActionDeviceKey, ActionGroupKey, ActionGroupMask
    const char* line_selector;
    const char* line_source;
    const char* user_output_value;
  };
  const Roles kRoles[] = {
      {"AVT_Mako_G158C.xml", "", "", false, "SyncOutSelector", "SyncOutSource", "SyncOutLevels"},
      {"AVT_Manta_G507C.xml", "PtpMode", "PtpStatus", true, "SyncOutSelector", "SyncOutSource", "SyncOutLevels"},
      {"Basler-a2A2600-20gmBAS.xml", "PtpEnable", "PtpStatus", true, "LineSelector", "LineSource", "UserOutputValue"},
      {"Basler-acA1920-25gm.xml", "", "", true, "LineSelector", "LineSource", "UserOutputValue"},
      {"FLIR-BFS-PGE-23S6C.xml", "GevIEEE1588", "GevIEEE1588Status", true, "LineSelector", "LineSource",
       "UserOutputValue"},
      {"FLIR_ORX_10G_51S5M.xml", "GevIEEE1588", "GevIEEE1588Status", false, "LineSelector", "LineSource",
       "UserOutputValue"},
      {"PGR_Blackfly_50S5C.xml", "", "", false, "LineSelector", "LineSource", "UserOutputValue"},
      {"PGR_GS3_PGE_23S6C.xml", "", "", false, "LineSelector", "LineSource", "UserOutputValue"},
  };
  // The PTP data set pvcap reads each second: the latch, the offset it latches, the servo's state.
  struct PtpDataSet {
    const char* file;
    const char* latch;
    const char* offset;
    const char* servo;
  };
  const PtpDataSet kDataSets[] = {
      {"Basler-a2A2600-20gmBAS.xml", "PtpDataSetLatch", "PtpOffsetFromMaster", "PtpServoStatus"},
      {"FLIR-BFS-PGE-23S6C.xml", "GevIEEE1588DataSetLatch", "GevIEEE1588OffsetFromMasterLatched", ""},
  };
  for (const Roles& e : kRoles) {
    SCOPED_TRACE(e.file);
    auto map = GenicamNodeMap::parse(read(kNodeMaps / e.file));
    ASSERT_TRUE(map) << map.error().message;
    auto f = features_of(check_node_map(map.value(), in_format("Mono8")));
    EXPECT_EQ(f["ptp_enable"], e.ptp_enable);
    EXPECT_EQ(f["ptp_status"], e.ptp_status);
    const PtpDataSet none{e.file, "", "", ""};
    const PtpDataSet* d = &none;
    for (const PtpDataSet& k : kDataSets)
      if (std::string(k.file) == e.file) d = &k;
    EXPECT_EQ(f["ptp_data_set_latch"], d->latch);
    EXPECT_EQ(f["ptp_offset_from_master"], d->offset);
    EXPECT_EQ(f["ptp_servo_status"], d->servo);
    for (const char* role : {"action_selector", "action_device_key", "action_group_key", "action_group_mask"}) {
      std::string name = role;  // action_device_key -> ActionDeviceKey
      std::string want;
      for (std::size_t i = 0; i < name.size(); ++i)
        if (name[i] != '_') want += (i == 0 || name[i - 1] == '_') ? char(std::toupper(name[i])) : name[i];
      EXPECT_EQ(f[role], e.actions ? want : "") << role;
    }
    EXPECT_EQ(f["line_selector"], e.line_selector);
    EXPECT_EQ(f["line_source"], e.line_source);
    EXPECT_EQ(f["user_output_value"], e.user_output_value);
  }
}

// A light on a line the camera cannot drive as asked is refused before recording, naming the line
// and what the map offers; one it can drive passes, under either family's names.
TEST(GenicamFeatures, ALightOnALineTheCameraCannotDriveIsNamed) {
  const auto check = [](const char* file, std::vector<LightConfig> lights) {
    auto map = GenicamNodeMap::parse(read(kNodeMaps / file));
    EXPECT_TRUE(map) << file;
    CameraConfig camera = in_format("Mono8");
    camera.lights = std::move(lights);
    return check_node_map(map.value(), camera);
  };
  const auto missing = [](const NodeMapCheck& c) {
    std::string all;
    for (const auto& m : c.missing) all += m + "\n";
    return all;
  };
  // Basler ace 2: three lines, user outputs and ExposureActive.
  auto ok = check("Basler-a2A2600-20gmBAS.xml", {{"L", "cam0", "Line2", false}, {"C", "cam0", "Line3", true}});
  EXPECT_TRUE(ok.usable()) << missing(ok);
  auto bad = check("Basler-a2A2600-20gmBAS.xml", {{"R", "cam0", "Line9", false}});
  EXPECT_NE(missing(bad).find("light R on Line9 (steady): Line9 is not among its lines (Line1, Line2, Line3)"),
            std::string::npos)
      << missing(bad);
  // Allied Vision: SyncOut lines, GPO held by SyncOutLevels, or Exposing.
  auto avt = check("AVT_Manta_G507C.xml", {{"L", "cam0", "SyncOut1", false}, {"C", "cam0", "SyncOut2", true}});
  EXPECT_TRUE(avt.usable()) << missing(avt);
}

TEST(GenicamFeatures, APixelFormatTheMapLacksMakesTheCameraUnusableAndSaysWhich) {
  auto map = GenicamNodeMap::parse(read(kNodeMaps / "Basler-a2A2600-20gmBAS.xml"));
  ASSERT_TRUE(map);
  const NodeMapCheck c = check_node_map(map.value(), in_format("BayerRG8"));
  EXPECT_FALSE(c.usable());
  ASSERT_EQ(c.missing.size(), 1u);
  EXPECT_NE(c.missing[0].find("pixel format BayerRG8 is not among its Mono12p"), std::string::npos) << c.missing[0];
}

TEST(GenicamFeatures, TheLatchIsChosenWithItsValueFromOneNamingFamily) {
  const auto with = [](std::set<std::string> names) {
    return resolve_camera_features([names](const std::string& n) { return names.count(n) > 0; });
  };
  auto f = with({"TimestampLatch", "TimestampLatchValue"});
  EXPECT_EQ(f[CameraRole::TimestampLatch], "TimestampLatch");
  EXPECT_EQ(f[CameraRole::TimestampLatchValue], "TimestampLatchValue");
  f = with({"TimestampLatch", "GevTimestampValue"});  // a latch whose value is of another family
  EXPECT_EQ(f.count(CameraRole::TimestampLatch), 0u);
  f = with({"TimestampControlLatch", "TimestampLatchValue"});  // Aravis' fake camera
  EXPECT_EQ(f[CameraRole::TimestampLatch], "TimestampControlLatch");
  f = with({"timestampControlLatch", "timestampValue"});  // Teledyne DALSA's lower-case names
  EXPECT_EQ(f[CameraRole::TimestampLatch], "timestampControlLatch");
  EXPECT_EQ(f[CameraRole::TimestampLatchValue], "timestampValue");
  f = with({"AcquisitionFrameRate", "AcquisitionFrameRateMode"});  // Daheng: an On/Off enumeration
  EXPECT_EQ(f[CameraRole::FrameRateEnable], "AcquisitionFrameRateMode");
  f = with({"ExposureTimeAbs", "ExposureTime"});  // SFNC's name first when a map has both
  EXPECT_EQ(f[CameraRole::ExposureTime], "ExposureTime");
}

TEST(GenicamFeatures, WhatIsNotANodeMapIsSaid) {
  EXPECT_FALSE(GenicamNodeMap::parse("<html><body>not a camera</body></html>"));
  EXPECT_FALSE(GenicamNodeMap::parse(""));
  EXPECT_FALSE(GenicamNodeMap::parse(std::string("\x00\x01\x02", 3)));
}

TEST(GenicamFeatures, ATriggerLineTheCameraLacksIsNamedWithTheLinesItHas) {
  auto map = GenicamNodeMap::parse(read(kNodeMaps / "FLIR-BFS-PGE-23S6C.xml"));
  ASSERT_TRUE(map);
  CameraConfig camera = in_format("Mono8");
  camera.trigger = TriggerMode::Hardware;
  camera.trigger_source = "Line0";
  EXPECT_TRUE(check_node_map(map.value(), camera).usable());
  camera.trigger_source = "Line9";
  const NodeMapCheck c = check_node_map(map.value(), camera);
  EXPECT_FALSE(c.usable());
  ASSERT_EQ(c.missing.size(), 1u);
  EXPECT_NE(c.missing[0].find("trigger source Line9 is not among its "), std::string::npos) << c.missing[0];
  EXPECT_NE(c.missing[0].find("Line0"), std::string::npos) << c.missing[0];
  camera.trigger = TriggerMode::Software;  // its TriggerSource has Software and it has TriggerSoftware
  EXPECT_TRUE(check_node_map(map.value(), camera).usable());
}

// A line's number from its name, whatever the family's stem; none, or one too long, is -1.
TEST(GenicamFeatures, ALinesNumberIsTheNumberItsNameEndsWith) {
  EXPECT_EQ(line_number("Line2"), 2);
  EXPECT_EQ(line_number("SyncOut1"), 1);
  EXPECT_EQ(line_number("Line0"), 0);
  EXPECT_EQ(line_number("UserOutput"), -1);
  EXPECT_EQ(line_number("Line99999999999999999999"), -1) << "not thrown out of std::stoi";
}
