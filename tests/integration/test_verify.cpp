// `pvcap verify` on a real recording of the simulated rig, then on damaged copies of it.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include <fmt/format.h>

#include "tests/integration/session_under_test.h"

namespace fs = std::filesystem;
using pvcap::testing::record;
using pvcap::testing::run_pvcap;
using pvcap::testing::sim_rig_yaml;

TEST(Verify, ARecordingVerifiesAndDamageIsNamed) {
  const auto s = record("verify", sim_rig_yaml({{}, {}}, 640, 480, 30, 15, "free-run", /*sensel=*/true), 5);
  ASSERT_EQ(s.result.exit_code, 0) << s.result.output;

  auto ok = run_pvcap(fmt::format("--log-level warn verify {}", s.dir.string()));
  EXPECT_TRUE(ok.exit_code == 0 || ok.exit_code == 3) << ok.output;  // 3: a frame lost on a busy machine
  EXPECT_NE(ok.output.find("cam0-000.mkv:"), std::string::npos) << ok.output;
  EXPECT_NE(ok.output.find("pressure frames:"), std::string::npos) << ok.output;
  EXPECT_EQ(ok.output.find("ERROR"), std::string::npos) << ok.output;

  // A video cut short after a clean end: indexed frames are missing, named with the file.
  const auto copy = s.dir.parent_path() / "damaged";
  fs::copy(s.dir, copy, fs::copy_options::recursive | fs::copy_options::copy_symlinks);
  const auto video = copy / "cam1-000.mkv";
  fs::resize_file(video, fs::file_size(video) / 2);
  auto cut = run_pvcap(fmt::format("--log-level warn verify {}", copy.string()));
  EXPECT_EQ(cut.exit_code, 1) << cut.output;
  EXPECT_NE(cut.output.find("ERROR: cam1-000.mkv"), std::string::npos) << cut.output;

  // A foreign file where the index should be.
  std::ofstream(copy / "session.db", std::ios::trunc) << "this is not a database, it is a shopping list\n";
  auto foreign = run_pvcap(fmt::format("--log-level warn verify {}", copy.string()));
  EXPECT_EQ(foreign.exit_code, 1) << foreign.output;
  EXPECT_NE(foreign.output.find("session.db"), std::string::npos) << foreign.output;

  // Not a session folder at all.
  fs::remove(copy / "session.db");
  auto none = run_pvcap(fmt::format("--log-level warn verify {}", copy.string()));
  EXPECT_EQ(none.exit_code, 1) << none.output;
  EXPECT_NE(none.output.find("not a session folder"), std::string::npos) << none.output;
  fs::remove_all(s.dir.parent_path().parent_path());
}
