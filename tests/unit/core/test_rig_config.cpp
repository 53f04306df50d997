#include <gtest/gtest.h>

#include "core/result.h"
#include "core/rig_config.h"

using pvcap::parse_rig_config;
using pvcap::UserError;

namespace {
std::string error_of(const std::string& yaml) {
  try {
    parse_rig_config(yaml, "rig.yaml");
  } catch (const UserError& e) {
    return e.what();
  }
  return "";
}
const char* kGood = R"(name: lab
cameras:
  - name: top
    serial: 21A0001
    frame_rate: 60
    trigger: hardware
    trigger_source: Line1
  - address: 192.168.10.12
store:
  video_fps: 15
  crf: 12
)";
}  // namespace

TEST(RigConfig, ParsesCamerasAndDefaults) {
  const auto rig = parse_rig_config(kGood, "rig.yaml");
  ASSERT_EQ(rig.cameras.size(), 2u);
  EXPECT_EQ(rig.cameras[0].name, "top");
  EXPECT_EQ(rig.cameras[0].trigger, pvcap::TriggerMode::Hardware);
  EXPECT_EQ(rig.cameras[0].trigger_source, "Line1");
  EXPECT_EQ(rig.cameras[1].name, "cam1");  // default name from position
  EXPECT_EQ(rig.cameras[1].address, "192.168.10.12");
  EXPECT_EQ(rig.cameras[1].width, 1920);
  EXPECT_EQ(rig.store.crf, 12);
  EXPECT_FALSE(rig.simulated);
}

TEST(RigConfig, UnknownKeyIsAnErrorWithLineAndPath) {
  const std::string e = error_of("name: x\ncameras:\n  - serial: A\n    frame_rat: 60\n");
  EXPECT_NE(e.find("rig.yaml:4:"), std::string::npos) << e;
  EXPECT_NE(e.find("cameras[0].frame_rat"), std::string::npos) << e;
  EXPECT_NE(e.find("unknown key"), std::string::npos) << e;
}

// A misspelt key is the cause of whatever else looks wrong: said first, with the key it meant.
TEST(RigConfig, AMisspeltKeyIsSaidBeforeWhatItLeftMissingWithTheKeyItMeant) {
  std::string e = error_of("name: x\ncameras:\n  - name: top\n    serail: 21A0001\n");
  EXPECT_NE(e.find("rig.yaml:4: cameras[0].serail: unknown key; did you mean 'serial'?"), std::string::npos) << e;
  EXPECT_EQ(e.find("needs a 'serial'"), std::string::npos) << e;
  e = error_of("name: x\ncameras:\n  - serial: A\n    frame_rat: 60\n");
  EXPECT_NE(e.find("did you mean 'frame_rate'?"), std::string::npos) << e;
  e = error_of("name: x\ncameras:\n  - serial: A\nsensel:\n  ttty: /dev/ttyACM0\n");
  EXPECT_NE(e.find("sensel.ttty: unknown key; did you mean 'tty'?"), std::string::npos) << e;
  e = error_of("name: x\ncameras:\n  - serial: A\n    colour: 1\n");  // no key near it: the list
  EXPECT_NE(e.find("unknown key (known here:"), std::string::npos) << e;
}

TEST(RigConfig, WrongTypeNamesTheValueAndTheKey) {
  const std::string e = error_of("name: x\ncameras:\n  - serial: A\n    frame_rate: fast\n");
  EXPECT_NE(e.find("rig.yaml:4:"), std::string::npos) << e;
  EXPECT_NE(e.find("'fast' is not a valid number"), std::string::npos) << e;
}

TEST(RigConfig, OutOfRangeValueIsRefused) {
  const std::string e = error_of("name: x\ncameras:\n  - serial: A\n    frame_rate: 0\n");
  EXPECT_NE(e.find("out of range"), std::string::npos) << e;
}

// store.raw_tiles: auto (0 x 0: chosen per camera, storage/video/camera_video_settings.cpp), or a grid.
TEST(RigConfig, RawTilesAreAutoOrAGridAndAnythingElseIsNamed) {
  const auto rig = parse_rig_config(kGood, "rig.yaml");
  EXPECT_EQ(rig.store.raw_tile_cols, 0);
  EXPECT_EQ(rig.store.raw_tile_rows, 0);
  const auto grid = parse_rig_config("name: x\ncameras:\n  - serial: A\nstore: {raw_tiles: 8x6}\n", "rig.yaml");
  EXPECT_EQ(grid.store.raw_tile_cols, 8);
  EXPECT_EQ(grid.store.raw_tile_rows, 6);
  for (const char* bad : {"8", "8x", "0x6", "8x6x", "65x1", "eight"}) {
    const std::string e = error_of(std::string("name: x\ncameras:\n  - serial: A\nstore: {raw_tiles: ") + bad + "}\n");
    EXPECT_NE(e.find("raw_tiles"), std::string::npos) << bad << ": " << e;
    EXPECT_NE(e.find("COLSxROWS"), std::string::npos) << bad << ": " << e;
  }
}

TEST(RigConfig, CameraNeedsSerialOrAddress) {
  EXPECT_NE(error_of("name: x\ncameras:\n  - name: a\n").find("needs a 'serial' or an 'address'"), std::string::npos);
}

TEST(RigConfig, DuplicateCameraIsRefused) {
  EXPECT_NE(error_of("name: x\ncameras:\n  - serial: A\n  - serial: A\n").find("listed twice"), std::string::npos);
}

TEST(RigConfig, SyntaxErrorHasALine) {
  const std::string e = error_of("name: x\ncameras: [\n");
  EXPECT_NE(e.find("YAML syntax error"), std::string::npos) << e;
  EXPECT_NE(e.find("rig.yaml:"), std::string::npos) << e;
}

TEST(RigConfig, MissingRequiredName) {
  EXPECT_NE(error_of("cameras:\n  - serial: A\n").find("name: missing"), std::string::npos);
}

TEST(RigConfig, ShippedRigFilesLoad) {
  for (const char* f : {"sim.yaml", "lab-4cam.yaml"}) {
    const auto rig = pvcap::load_rig_config(std::string(PVCAP_SOURCE_DIR) + "/rig-configs/" + f);
    EXPECT_EQ(rig.cameras.size(), 4u) << f;
  }
}

TEST(RigConfig, SenselIsReachedByExactlyOneOfTtyOrUsb) {
  const std::string cams = "name: lab\ncameras:\n  - address: 192.168.10.11\n";
  auto rig = parse_rig_config(cams + "sensel:\n  tty: /dev/morph0\n", "rig.yaml");
  ASSERT_TRUE(rig.sensel);
  EXPECT_EQ(rig.sensel->tty, "/dev/morph0");
  EXPECT_FALSE(rig.sensel->usb_serial);

  rig = parse_rig_config(cams + "sensel:\n  usb: 2044B8374E33\n", "rig.yaml");
  ASSERT_TRUE(rig.sensel && rig.sensel->usb_serial);
  EXPECT_EQ(*rig.sensel->usb_serial, "2044B8374E33");
  rig = parse_rig_config(cams + "sensel:\n  usb: any\n", "rig.yaml");
  ASSERT_TRUE(rig.sensel && rig.sensel->usb_serial);
  EXPECT_EQ(*rig.sensel->usb_serial, "");

  const auto both = error_of(cams + "sensel:\n  tty: /dev/ttyACM0\n  usb: any\n");
  EXPECT_NE(both.find("rig.yaml:5"), std::string::npos) << both;
  EXPECT_NE(both.find("exactly one of tty"), std::string::npos) << both;
  EXPECT_NE(error_of(cams + "sensel:\n  scan_detail: high\n").find("exactly one of tty"), std::string::npos);
  EXPECT_NE(error_of(cams + "sensel:\n  usb: ''\n").find("pvcap devices lists it"), std::string::npos);
}

// Cameras naming one link are counted on it; one link has one capacity.
TEST(RigConfig, CamerasOnOneLinkAreCountedAndShareOneCapacity) {
  const auto rig = parse_rig_config(
      "name: x\ncameras:\n  - {serial: A, link: nic0}\n  - {serial: B, link: nic0}\n  - {serial: C}\n"
      "  - {serial: D, link: nic0}\n",
      "rig.yaml");
  EXPECT_EQ(rig.cameras[0].link_cameras, 3);
  EXPECT_EQ(rig.cameras[3].link_cameras, 3);
  EXPECT_EQ(rig.cameras[2].link_cameras, 1) << "a link of its own";
  const std::string e = error_of(
      "name: x\ncameras:\n  - {serial: A, link: nic0, link_mbps: 1000}\n  - {serial: B, link: nic0, link_mbps: "
      "10000}\n");
  EXPECT_NE(e.find("cam0 and cam1 share link 'nic0' but give it 1000 and 10000 Mbit/s"), std::string::npos) << e;
}

// Lights: a letter of the lighting codes each, driven by a camera of the rig on one of its lines.
TEST(RigConfig, LightsNameTheirCameraAndLineAndAreCheckedAgainstTheRig) {
  const auto rig = parse_rig_config(
      "name: x\ncameras:\n  - {name: top, serial: A}\n  - {name: side, serial: B}\nlights:\n"
      "  - {name: L, camera: top, line: Line2}\n  - {name: C, camera: top, line: Line3, mode: strobe}\n"
      "  - {name: R, camera: side, line: SyncOut1}\n",
      "rig.yaml");
  ASSERT_EQ(rig.lights.size(), 3u);
  ASSERT_EQ(rig.cameras[0].lights.size(), 2u);
  EXPECT_EQ(rig.cameras[0].lights[1].name, "C");
  EXPECT_TRUE(rig.cameras[0].lights[1].strobe);
  EXPECT_FALSE(rig.cameras[0].lights[0].strobe) << "steady by default";
  EXPECT_EQ(rig.cameras[1].lights[0].line, "SyncOut1");
  const std::string cams = "name: x\ncameras:\n  - {name: top, serial: A}\nlights:\n";
  EXPECT_NE(error_of(cams + "  - {name: left, camera: top, line: Line2}\n").find("one capital letter"),
            std::string::npos);
  EXPECT_NE(error_of(cams + "  - {name: L, camera: bottom, line: Line2}\n").find("'bottom' is not one of the rig's"),
            std::string::npos);
  EXPECT_NE(error_of(cams + "  - {name: L, camera: top, line: Line2}\n  - {name: C, camera: top, line: Line2}\n")
                .find("top's Line2 already drives light L"),
            std::string::npos);
  EXPECT_NE(error_of(cams + "  - {name: L, camera: top, line: Line2, mode: flash}\n").find("steady, strobe"),
            std::string::npos);
}

TEST(RigConfig, APtpSectionGivesPtp4lsSocketAndTheOffsetLimit) {
  EXPECT_FALSE(parse_rig_config(kGood, "rig.yaml").ptp) << "no section, no PTP";
  const auto defaults = parse_rig_config(std::string(kGood) + "ptp:\n", "rig.yaml");
  ASSERT_TRUE(defaults.ptp);
  EXPECT_EQ(defaults.ptp->ptp4l_socket, "/var/run/ptp4l");
  EXPECT_DOUBLE_EQ(defaults.ptp->max_offset_us, 1.0);
  const auto set = parse_rig_config(std::string(kGood) + "ptp:\n  ptp4l_socket: /run/lab/ptp4l\n  max_offset_us: 50\n",
                                    "rig.yaml");
  ASSERT_TRUE(set.ptp);
  EXPECT_EQ(set.ptp->ptp4l_socket, "/run/lab/ptp4l");
  EXPECT_DOUBLE_EQ(set.ptp->max_offset_us, 50.0);
  EXPECT_EQ(set.ptp->line, 13);
  const std::string typo = error_of(std::string(kGood) + "ptp:\n  ptp4l_sock: /run/ptp4l\n");
  EXPECT_NE(typo.find("ptp.ptp4l_sock: unknown key; did you mean 'ptp4l_socket'?"), std::string::npos) << typo;
  const std::string zero = error_of(std::string(kGood) + "ptp:\n  max_offset_us: 0\n");
  EXPECT_NE(zero.find("ptp.max_offset_us"), std::string::npos) << zero;
}
