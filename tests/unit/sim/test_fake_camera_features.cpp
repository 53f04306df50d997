// The simulated cameras' two node maps: Aravis' fake camera's names and SFNC 2's, on the same
// registers. The offline check must read each as the cameras whose naming it copies, and the SFNC 2
// camera's rate must take only with its enable on (as a FLIR's does), or the live code's enable is
// never put to the test.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <fstream>
#include <iterator>
#include <map>
#include <thread>

#include "capture/genicam_node_map.h"
#include "sim/fake_camera_features.h"

using namespace pvcap;

namespace {
std::map<std::string, std::string> chosen(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  const std::string xml{std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>()};
  auto map = GenicamNodeMap::parse(xml);
  EXPECT_TRUE(map) << path;
  std::map<std::string, std::string> out;
  if (!map) return out;
  const NodeMapCheck c = check_node_map(map.value(), CameraConfig{});
  EXPECT_TRUE(c.usable()) << path;
  EXPECT_EQ(c.clock, "latch") << path;
  for (const auto& feature : c.features) out[feature.role] = feature.name;
  return out;
}

guint32 read(ArvFakeCamera* fake, std::uint32_t address) {
  guint32 v = 0;
  EXPECT_TRUE(arv_fake_camera_read_register(fake, address, &v));
  return v;
}

// Waits (up to a second) for the feature service's next rounds to have acted.
bool eventually(const std::function<bool()>& done) {
  for (int i = 0; i < 1000 && !done(); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  return done();
}
}  // namespace

TEST(FakeCameraFeatures, EachMapIsReadUnderItsFamilysNames) {
  auto aravis = chosen(sim::fake_camera_genicam(sim::NodeMapNaming::Aravis));
  EXPECT_EQ(aravis["timestamp_latch"], "TimestampControlLatch");
  EXPECT_EQ(aravis["exposure_time"], "ExposureTimeAbs");
  EXPECT_EQ(aravis["gain"], "GainRaw");
  EXPECT_EQ(aravis.count("frame_rate_enable"), 0u);
  auto sfnc2 = chosen(sim::fake_camera_genicam(sim::NodeMapNaming::Sfnc2));
  EXPECT_EQ(sfnc2["timestamp_latch"], "TimestampLatch");
  EXPECT_EQ(sfnc2["timestamp_latch_value"], "TimestampLatchValue");
  EXPECT_EQ(sfnc2["exposure_time"], "ExposureTime");
  EXPECT_EQ(sfnc2["gain"], "Gain");
  EXPECT_EQ(sfnc2["frame_rate"], "AcquisitionFrameRate");
  EXPECT_EQ(sfnc2["frame_rate_enable"], "AcquisitionFrameRateEnable");
  auto raw = chosen(sim::fake_camera_genicam(sim::NodeMapNaming::RawExposure));
  EXPECT_EQ(raw["exposure_time"], "ExposureTimeRaw") << "in steps of its ExposureTimeBaseAbs";
  EXPECT_EQ(raw["gain"], "GainRaw");
}

static std::string map_text(sim::NodeMapNaming naming) {
  std::ifstream f(sim::fake_camera_genicam(naming), std::ios::binary);
  return {std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>()};
}

// The check gives each role's access and, where the map states it, its range (a bound held in the
// camera's registers is the camera's to say: none offline).
TEST(FakeCameraFeatures, TheCheckGivesEachRolesAccessAndRange) {
  auto map = GenicamNodeMap::parse(map_text(sim::NodeMapNaming::RawExposure));
  ASSERT_TRUE(map);
  const NodeMapCheck c = check_node_map(map.value(), CameraConfig{});
  std::map<std::string, const NodeMapCheck::Feature*> by_role;
  for (const auto& f : c.features) by_role[f.role] = &f;
  ASSERT_TRUE(by_role.count("exposure_time") && by_role.count("timestamp_latch_value") && by_role.count("width"));
  EXPECT_EQ(by_role["exposure_time"]->access, "RW");
  ASSERT_TRUE(by_role["exposure_time"]->range);
  EXPECT_EQ(by_role["exposure_time"]->range->first, 1);
  EXPECT_EQ(by_role["exposure_time"]->range->second, 500000);
  EXPECT_EQ(by_role["timestamp_latch_value"]->access, "RO");
  EXPECT_FALSE(by_role["width"]->range) << "Width's maximum is the sensor's, in a register: not known offline";
  EXPECT_EQ(by_role["pixel_format"]->access, "RW");
  EXPECT_FALSE(by_role["pixel_format"]->entries.empty());
}

// A rate above the most the map's rate feature allows is named before any recording.
TEST(FakeCameraFeatures, ARateTheCameraCannotReachIsNamed) {
  std::string xml = map_text(sim::NodeMapNaming::Aravis);
  const std::string rate = "<Float Name=\"AcquisitionFrameRate\">";
  const auto at = xml.find(rate);
  ASSERT_NE(at, std::string::npos);
  xml.insert(at + rate.size(), "<Min>1</Min><Max>30</Max>");
  auto map = GenicamNodeMap::parse(xml);
  ASSERT_TRUE(map);
  CameraConfig camera;
  camera.frame_rate = 60;
  const NodeMapCheck c = check_node_map(map.value(), camera);
  EXPECT_FALSE(c.usable());
  bool named = false;
  for (const auto& m : c.missing) named |= m == "a frame rate of 60 Hz: its AcquisitionFrameRate goes up to 30";
  EXPECT_TRUE(named) << (c.missing.empty() ? "nothing missing" : c.missing[0]);
  camera.frame_rate = 25;
  EXPECT_TRUE(check_node_map(map.value(), camera).usable());
}

// ExposureTimeRaw without its base is never taken for microseconds: the check says what is missing.
TEST(FakeCameraFeatures, AnExposureInTheCamerasOwnStepsWithoutItsBaseIsRefusedByName) {
  std::ifstream f(sim::fake_camera_genicam(sim::NodeMapNaming::RawExposure), std::ios::binary);
  std::string xml{std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>()};
  const auto at = xml.find("<Float Name=\"ExposureTimeBaseAbs\"");
  ASSERT_NE(at, std::string::npos);
  xml.replace(at, std::string("<Float Name=\"ExposureTimeBaseAbs\"").size(), "<Float Name=\"PvcapNoBase\"");
  auto map = GenicamNodeMap::parse(xml);
  ASSERT_TRUE(map);
  const NodeMapCheck c = check_node_map(map.value(), CameraConfig{});
  EXPECT_FALSE(c.usable());
  ASSERT_FALSE(c.missing.empty());
  EXPECT_NE(c.missing[0].find("ExposureTimeRaw counts in the camera's own steps, and the map has no "
                              "ExposureTimeBaseAbs"),
            std::string::npos)
      << c.missing[0];
}

TEST(FakeCameraFeatures, AnSfnc2CamerasRateTakesOnlyWithItsEnableOn) {
  const std::string map = sim::fake_camera_genicam(sim::NodeMapNaming::Sfnc2);
  arv::GPtr<ArvFakeCamera> fake(arv_fake_camera_new_full("PVSIM-RATE", map.c_str()));
  ASSERT_TRUE(fake);
  constexpr std::uint32_t kEnginePeriod = ARV_FAKE_CAMERA_REGISTER_ACQUISITION_FRAME_PERIOD_US;
  const guint32 own = read(fake.get(), kEnginePeriod);
  ASSERT_GT(own, 0u);
  int owner = 0;
  sim::serve_features(
      &owner, fake.get(), [](std::int64_t ns) { return ns; }, sim::TriggerLine(), sim::NodeMapNaming::Sfnc2);
  // The host asks for 60 fps with the enable off: the engine keeps its rate, which reads back.
  arv_fake_camera_write_register(fake.get(), sim::kFramePeriodRegister, 16667);
  EXPECT_TRUE(eventually([&] { return read(fake.get(), sim::kFramePeriodRegister) == own; }));
  EXPECT_EQ(read(fake.get(), kEnginePeriod), own);
  // With the enable on, the rate asked is the engine's.
  arv_fake_camera_write_register(fake.get(), sim::kFrameRateEnableRegister, 1);
  arv_fake_camera_write_register(fake.get(), sim::kFramePeriodRegister, 16667);
  EXPECT_TRUE(eventually([&] { return read(fake.get(), kEnginePeriod) == 16667u; }));
  EXPECT_EQ(read(fake.get(), sim::kFramePeriodRegister), 16667u);
  sim::stop_serving(&owner);
}

// Every simulated map has SFNC's output lines (Line0-Line3, UserOutput1-3): a steady light on one of
// them passes the check, a line it lacks is named; and the lines the host sets reach the lamps.
TEST(FakeCameraFeatures, EveryMapHasOutputLinesAndTheirLevelsReachTheLamps) {
  for (auto naming : {sim::NodeMapNaming::Aravis, sim::NodeMapNaming::Sfnc2, sim::NodeMapNaming::RawExposure}) {
    auto map = GenicamNodeMap::parse(map_text(naming));
    ASSERT_TRUE(map);
    CameraConfig camera;
    camera.lights = {{"C", "cam0", "Line1", false}, {"R", "cam0", "Line2", true}};
    const NodeMapCheck ok = check_node_map(map.value(), camera);
    EXPECT_TRUE(ok.usable()) << (ok.missing.empty() ? "" : ok.missing.back());
    camera.lights = {{"C", "cam0", "Line9", false}};
    const NodeMapCheck bad = check_node_map(map.value(), camera);
    ASSERT_FALSE(bad.missing.empty());
    EXPECT_NE(bad.missing.back().find("light C on Line9 (steady): Line9 is not among its lines (Line0, Line1, Line2, "
                                      "Line3)"),
              std::string::npos)
        << bad.missing.back();
  }
  // Line1 from UserOutput2, held high; Line3 from ExposureActive, high while the camera acquires.
  arv::GPtr<ArvFakeCamera> fake(arv_fake_camera_new("PVSIM-LINES"));
  std::atomic<std::uint32_t> lines{0};
  int owner = 0;
  sim::serve_features(
      &owner, fake.get(), [](std::int64_t t) { return t; }, {}, sim::NodeMapNaming::Aravis,
      [&](std::uint32_t mask, std::int64_t) { lines.store(mask); });
  arv_fake_camera_write_register(fake.get(), sim::kLineSourceRegister + 4 * 1, 3);  // UserOutput2
  arv_fake_camera_write_register(fake.get(), sim::kUserOutputValueRegister + 4 * 1, 1);
  EXPECT_TRUE(eventually([&] { return lines.load() == 0b0010u; })) << lines.load();
  arv_fake_camera_write_register(fake.get(), sim::kLineSourceRegister + 4 * 3, 1);  // ExposureActive
  arv_fake_camera_write_register(fake.get(), ARV_FAKE_CAMERA_REGISTER_ACQUISITION, 1);
  EXPECT_TRUE(eventually([&] { return lines.load() == 0b1010u; })) << lines.load();
  arv_fake_camera_write_register(fake.get(), sim::kUserOutputValueRegister + 4 * 1, 0);
  EXPECT_TRUE(eventually([&] { return lines.load() == 0b1000u; })) << lines.load();
  sim::stop_serving(&owner);
}
