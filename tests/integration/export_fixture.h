#pragma once
// One recorded protocol session that several tests read (export, compact): a 960x540 session of
// the simulated rig with its pad calibrated (the simulator's lenses given, as a lab gives the lenses
// a board session measured). Under ctest (PVCAP_EXPORT_FIXTURE set) the fixture step
// fixture.export_session (make_export_fixture.cpp: a step, not a test) records it into that folder
// before the tests that need it and fixture.export_session_removed removes it after them; run alone, a
// test process records its own, removed at exit. Tests that change a session work on a copy.
#include <filesystem>
#include <string>

namespace pvcap::testing {

struct Recorded {
  std::filesystem::path work, session;
  std::string problem;  // why it could not be recorded and calibrated (empty: it was)
};

// Records the session into `work` (its rig, protocol, lenses and sessions/ folder).
Recorded record_export_session(const std::filesystem::path& work);

// The shared session (recorded on first use when no fixture folder is given).
const Recorded& recorded();

}  // namespace pvcap::testing
