// `pvcap camera check --node-map`: a real camera's node map judged offline, its exit code and JSON.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include <nlohmann/json.hpp>

#include "session_under_test.h"

namespace fs = std::filesystem;
using pvcap::testing::run_pvcap;
using pvcap::testing::work_dir;

namespace {
const fs::path kNodeMaps = fs::path(PVCAP_SOURCE_DIR) / "../shared/data/genicam";
}

TEST(CameraCheck, ANodeMapIsJudgedWithItsExitCode) {
  // A FLIR Blackfly S: usable, on the latch clock under its SFNC 2 names (exit 0).
  auto r = run_pvcap("camera check --json --node-map " + (kNodeMaps / "FLIR-BFS-PGE-23S6C.xml").string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const auto j = nlohmann::json::parse(r.output.substr(r.output.find('{')));
  EXPECT_EQ(j["usable"], true);
  EXPECT_EQ(j["clock"], "latch");
  EXPECT_EQ(j["features"]["timestamp_latch"], "TimestampLatch");
  EXPECT_EQ(j["features"]["timestamp_latch_value"], "TimestampLatchValue");
  EXPECT_TRUE(j["missing"].empty());
  // The same as a table for a person.
  r = run_pvcap("camera check --node-map " + (kNodeMaps / "FLIR-BFS-PGE-23S6C.xml").string());
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("clock: latch (the camera's own, latched)"), std::string::npos) << r.output;
  // A mono Basler ace 2 asked for a colour mosaic: not usable, and why (exit 1).
  r = run_pvcap("camera check --pixel-format BayerRG8 --node-map " +
                (kNodeMaps / "Basler-a2A2600-20gmBAS.xml").string());
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.output.find("missing: pixel format BayerRG8 is not among its Mono12p"), std::string::npos) << r.output;
  // Not a node map at all (exit 2), said with the file's name.
  const fs::path work = work_dir("camera-check");
  std::ofstream(work / "page.xml") << "<html><body>a web page</body></html>";
  r = run_pvcap("camera check --node-map " + (work / "page.xml").string());
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("page.xml: not a GenICam node map"), std::string::npos) << r.output;
}
