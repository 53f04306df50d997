#pragma once
// One recorded protocol session that several tests read (export, compact): a 960x540 session of
// the simulated rig with its pad calibrated (the simulator's lenses given, as a lab gives the lenses
// a board session measured). Under ctest (PVCAP_EXPORT_FIXTURE set) ExportFixture.Record records it
// into that folder before the tests that need it and ExportFixture.Remove removes it after them;
// run alone, a test process records its own, removed at exit. Tests that change a session work on
// a copy.
#include <filesystem>

namespace pvcap::testing {

struct Recorded {
  std::filesystem::path work, session;
};

// Records the session into `work` (its rig, protocol, lenses and sessions/ folder).
Recorded record_export_session(const std::filesystem::path& work);

// The shared session (recorded on first use when no fixture folder is given).
const Recorded& recorded();

}  // namespace pvcap::testing
