// The simulator's own section of a rig file (sim/sim_config.h): read as strictly as the rest.
#include <gtest/gtest.h>

#include "core/result.h"
#include "core/rig_config.h"
#include "sim/sim_config.h"

using pvcap::UserError;

namespace {
std::optional<pvcap::sim::SimConfig> sim_config_of(const std::string& yaml, const char* source) {
  return pvcap::sim::load_sim_config(pvcap::parse_rig_config(yaml, source));
}
std::string error_of(const std::string& yaml) {
  try {
    (void)sim_config_of(yaml, "rig.yaml");
  } catch (const UserError& e) {
    return e.what();
  }
  return "";
}
}  // namespace

TEST(SimConfig, ARigWithoutASimSectionHasNone) {
  EXPECT_FALSE(sim_config_of("name: x\ncameras:\n  - address: 10.0.0.2\n", "rig.yaml"));
}

TEST(SimConfig, SimSectionMustMatchCameraCount) {
  const std::string e = error_of("name: x\ncameras:\n  - address: 127.0.0.2\nsim:\n  cameras:\n    - {}\n    - {}\n");
  EXPECT_NE(e.find("has 2 entries but the rig has 1 cameras"), std::string::npos) << e;
}

TEST(SimConfig, SimClocksAreRead) {
  const auto sim = sim_config_of(
      "name: x\ncameras:\n  - address: 127.0.0.2\nsim:\n  seed: 3\n  cameras:\n    - {drift_ppm: 50, packet_loss: "
      "0.01, "
      "stop_after_s: 4}\n",
      "rig.yaml");
  ASSERT_TRUE(sim);
  EXPECT_EQ(sim->seed, 3u);
  EXPECT_DOUBLE_EQ(sim->cameras[0].drift_ppm, 50);
  EXPECT_DOUBLE_EQ(sim->cameras[0].packet_loss, 0.01);
  EXPECT_DOUBLE_EQ(*sim->cameras[0].stop_after_s, 4);
}

TEST(SimConfig, SimCameraLensAndPlaceAreReadAndChecked) {
  const auto sim = sim_config_of(
      "name: x\ncameras:\n  - address: 127.0.0.2\nsim:\n  cameras:\n    - {position_mm: [10, 20, 400], look_at_mm: "
      "[100, 60, 0], focal_px: 1200, distortion: [-0.1, 0.05, 0, 0, 0]}\n",
      "rig.yaml");
  const auto& c = sim->cameras[0];
  EXPECT_DOUBLE_EQ((*c.position_mm)[2], 400);
  EXPECT_DOUBLE_EQ((*c.look_at_mm)[0], 100);
  EXPECT_DOUBLE_EQ(*c.focal_px, 1200);
  EXPECT_DOUBLE_EQ((*c.distortion)[1], 0.05);
  std::string e =
      error_of("name: x\ncameras:\n  - address: 127.0.0.2\nsim:\n  cameras:\n    - {position_mm: [1, 2]}\n");
  EXPECT_NE(e.find("rig.yaml:6: sim.cameras[0].position_mm: expected a list of 3 numbers"), std::string::npos) << e;
  e = error_of("name: x\ncameras:\n  - address: 127.0.0.2\nsim:\n  cameras:\n    - {position_mm: [1, 2, -5]}\n");
  EXPECT_NE(e.find("must stand above the pad"), std::string::npos) << e;
  e = error_of("name: x\ncameras:\n  - address: 127.0.0.2\nsim:\n  cameras:\n    - {distortion: [a, 0, 0, 0, 0]}\n");
  EXPECT_NE(e.find("'a' is not a number"), std::string::npos) << e;
}

// The Sensel's transport: pty (the default) or usb; anything else, or a replug on usb (emulated on the
// pseudo-terminal only), is named with its line.
TEST(SimConfig, TheSenselTransportIsPtyOrUsb) {
  const std::string rig = "name: x\ncameras:\n  - address: 127.0.0.2\nsim:\n  sensel: ";
  auto sim = sim_config_of(rig + "{}\n", "rig.yaml");
  ASSERT_TRUE(sim);
  EXPECT_EQ(sim->sensel.transport, "pty");
  sim = sim_config_of(rig + "{transport: usb}\n", "rig.yaml");
  ASSERT_TRUE(sim);
  EXPECT_EQ(sim->sensel.transport, "usb");
  std::string e = error_of(rig + "{transport: serial}\n");
  EXPECT_NE(e.find("rig.yaml:5"), std::string::npos) << e;
  EXPECT_NE(e.find("'serial' is not pty or usb"), std::string::npos) << e;
  e = error_of(rig + "{transport: usb, unplug_at_s: 2, replug_after_s: 3}\n");
  EXPECT_NE(e.find("emulated on transport: pty only"), std::string::npos) << e;
}
