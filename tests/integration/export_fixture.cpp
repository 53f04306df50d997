#include "tests/integration/export_fixture.h"

#include <cstdlib>
#include <fstream>
#include <string>
#include <utility>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "tests/integration/session_under_test.h"

namespace fs = std::filesystem;

namespace pvcap::testing {

Recorded record_export_session(const fs::path& work) {
  Recorded out;
  out.work = work;
  fs::create_directories(out.work);
  std::string rig = read_all(fs::path(PVCAP_SOURCE_DIR) / "rig-configs" / "sim.yaml");
  for (auto [from, to] :
       {std::pair<std::string, std::string>{"width: 1920", "width: 960"},
        {"height: 1080", "height: 540"},
        // On one trigger line, as the paper's synchronized cameras: free-running, the four started out
        // of phase and a third of the groups could lack a camera (then a take has too few frames).
        {"frame_rate: 30\n", "frame_rate: 30\n    trigger: hardware\n    trigger_source: Line0\n"}})
    for (auto at = rig.find(from); at != std::string::npos; at = rig.find(from, at + to.size()))
      rig.replace(at, from.size(), to);
  std::ofstream(out.work / "rig.yaml") << rig;
  const auto run = run_pvcap(fmt::format(
      "session --rig {} --root {} --protocol {} --auto --fast --participant P017 --skin-tone dark --lighting L-R "
      "--overlay white_vinyl --no-web",
      (out.work / "rig.yaml").string(), (out.work / "sessions").string(),
      write_press_protocol(out.work, "[low, high]", 0.5, 0.4, 1.5, 0.3).string()));
  out.session = only_session(out.work / "sessions");
  if (run.exit_code != 0 || out.session.empty()) {
    out.problem = fmt::format("the session failed (exit {}):\n{}", run.exit_code, run.output);
    return out;
  }
  if (std::string lenses = write_truth_lenses(out.session, out.work / "lenses.yaml"); !lenses.empty()) {
    out.problem = "the simulator's lenses could not be written: " + lenses;
    return out;
  }
  const auto pad = run_pvcap(
      fmt::format("calibrate pad {} --calibration {}", out.session.string(), (out.work / "lenses.yaml").string()));
  if (pad.exit_code != 0) out.problem = fmt::format("calibrate pad failed (exit {}):\n{}", pad.exit_code, pad.output);
  return out;
}

const Recorded& recorded() {
  static const Recorded r = [] {
    if (const char* shared = std::getenv("PVCAP_EXPORT_FIXTURE")) {
      Recorded out{shared, only_session(fs::path(shared) / "sessions"), ""};
      EXPECT_FALSE(out.session.empty()) << "the fixture step fixture.export_session did not record into " << shared;
      return out;
    }
    Recorded out = record_export_session(process_work_dir("export"));  // shared by the tests of this process
    EXPECT_EQ(out.problem, "");
    return out;
  }();
  return r;
}

}  // namespace pvcap::testing
