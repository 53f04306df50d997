// Where a Morph may be behind a tty: the names `pvcap devices` lists and a replugged Morph is
// looked for among (cdc_acm's ttyACM*, udev names containing "morph" in any case), nothing else.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>

#include <fmt/format.h>

#include "capture/sensel_transport.h"

namespace fs = std::filesystem;

TEST(SenselTtyCandidates, CdcAcmAndMorphNamesSortedAndNothingElse) {
  const fs::path dir = fs::temp_directory_path() / fmt::format("pvcap-tty-candidates-{}", getpid());
  fs::remove_all(dir);
  fs::create_directories(dir);
  for (const char* name :
       {"ttyACM1", "ttyACM0", "morph-replugged", "SenselMorph0", "ttyS0", "ttyUSB0", "sensel.tty", "null"})
    std::ofstream(dir / name) << "";
  const auto got = pvcap::sensel::sensel_tty_candidates(dir);
  const std::vector<std::string> want = {(dir / "SenselMorph0").string(), (dir / "morph-replugged").string(),
                                         (dir / "ttyACM0").string(), (dir / "ttyACM1").string()};
  EXPECT_EQ(got, want);
  EXPECT_TRUE(pvcap::sensel::sensel_tty_candidates(dir / "missing").empty());
  fs::remove_all(dir);
}
