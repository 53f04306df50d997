// The simulated rig's lamps (sim/lights.h): driven by their cameras' lines, late or dead as the faults
// say, and shading each view from their side.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include <unistd.h>

#include <opencv2/core.hpp>

#include "sim/camera_views.h"
#include "sim/lights.h"

using namespace pvcap;

namespace {
RigConfig three_lamps() {
  RigConfig rig;
  for (const char* name : {"cam0", "cam1", "cam2"}) {
    CameraConfig c;
    c.name = name;
    rig.cameras.push_back(c);
  }
  rig.lights = {{"L", "cam0", "Line1", false}, {"C", "cam1", "Line1", false}, {"R", "cam2", "Line2", false}};
  return rig;
}
}  // namespace

TEST(SimLights, TheLinesDriveTheLampsLateOrNeverAsTheFaultsSay) {
  const auto truth = std::filesystem::temp_directory_path() / ("pvcap-sim-lights-" + std::to_string(getpid()));
  std::filesystem::create_directories(truth);
  {
    sim::SimLights lights(three_lamps(), "", 0, truth);
    lights.outputs(0, 0b0010, 100);  // cam0's Line1: L
    lights.outputs(2, 0b0010, 200);  // cam2's Line1 drives nothing (R is on its Line2)
    lights.outputs(2, 0b0100, 300);  // cam2's Line2: R
    EXPECT_EQ(lights.lit_at(99), 0u);
    EXPECT_EQ(lights.lit_at(150), 0b001u);
    EXPECT_EQ(lights.lit_at(250), 0b001u);
    EXPECT_EQ(lights.lit_at(300), 0b101u);
  }
  {
    sim::SimLights lights(three_lamps(), "C", 0.5, truth);  // C dead, every lamp 0.5 s late
    lights.outputs(1, 0b0010, 1'000'000'000);
    lights.outputs(0, 0b0010, 1'000'000'000);
    EXPECT_EQ(lights.lit_at(1'400'000'000), 0u);
    EXPECT_EQ(lights.lit_at(1'500'000'000), 0b001u) << "L on, 0.5 s late; C never";
  }
  std::ifstream csv(truth / "lights.csv");
  std::string header, first;
  std::getline(csv, header);
  std::getline(csv, first);
  EXPECT_EQ(header, "host_ns,lit,driven");
  EXPECT_EQ(first, "100,L,L");
  std::filesystem::remove_all(truth);
}

TEST(SimLights, EachLampLightsItsOwnSideOfTheViewAndTheRoomKeepsItsShare) {
  const RigConfig rig = three_lamps();
  sim::SimLights lights(rig, "", 0, std::filesystem::temp_directory_path());
  const cv::Size size(320, 240);
  const auto model = sim::sim_camera_model(0, sim::SimCameraClock{}, size, size);  // from above, rows along +y
  const auto shading = sim::lamp_shading(model, lights.lamps());
  ASSERT_EQ(shading.size(), 3u);
  // L lights the view's left edge more than its right, R the other way round.
  const auto at = [&](std::size_t lamp, int x) { return sim::light_at(shading, 1u << lamp, {double(x), 120}, size); };
  EXPECT_GT(at(0, 10), at(0, 310));
  EXPECT_GT(at(2, 310), at(2, 10));
  // None lit: the room's share alone; every lamp lit: about all the light at the pad's centre.
  EXPECT_DOUBLE_EQ(sim::light_at(shading, 0, {160, 120}, size), sim::kAmbientLight);
  EXPECT_NEAR(sim::light_at(shading, 0b111, model.project({115, 65, 0}), size), 1.0, 0.15);
  // The image is scaled by that light: darker with fewer lamps.
  const cv::Mat grey(size, CV_8UC1, cv::Scalar(200));
  EXPECT_LT(cv::mean(sim::lit_image(grey, shading, 0b001))[0], cv::mean(sim::lit_image(grey, shading, 0b111))[0]);
  EXPECT_NEAR(cv::mean(sim::lit_image(grey, shading, 0))[0], 200 * sim::kAmbientLight, 1.0);
}
