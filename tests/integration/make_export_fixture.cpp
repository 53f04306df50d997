// ctest's fixture step (tests/CMakeLists.txt, fixture.export_session), not a test: records the export
// and compact tests' session into PVCAP_EXPORT_FIXTURE once, before them (export_fixture.h).
#include <cstdio>
#include <cstdlib>
#include <filesystem>

#include "tests/integration/export_fixture.h"

int main() {
  const char* shared = std::getenv("PVCAP_EXPORT_FIXTURE");
  if (!shared || !*shared) {
    std::fprintf(stderr, "make_export_fixture: PVCAP_EXPORT_FIXTURE names the folder to record into\n");
    return 2;
  }
  std::filesystem::remove_all(shared);
  const pvcap::testing::Recorded r = pvcap::testing::record_export_session(shared);
  if (!r.problem.empty()) {
    std::fprintf(stderr, "make_export_fixture: %s\n", r.problem.c_str());
    return 1;
  }
  std::printf("the export tests' session: %s\n", r.session.c_str());
  return 0;
}
