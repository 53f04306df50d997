"""The recorded session the Python tests read: the export fixture's calibrated protocol session
(tests/integration/export_fixture.h), whose folder ctest names in PVCAP_EXPORT_FIXTURE."""
import glob
import os

FIXTURE = os.environ.get("PVCAP_EXPORT_FIXTURE", "")


def only_session():
    """The fixture's one session folder. Without it the tests fail (never skip: ctest would count
    a skipped file as passed, and the reader would go untested)."""
    found = glob.glob(os.path.join(FIXTURE, "sessions", "*", "session.db"))
    if len(found) != 1:
        raise AssertionError(f"{len(found)} recorded sessions under {FIXTURE!r}, not one: run under ctest, whose "
                             "the fixture step fixture.export_session records it (PVCAP_EXPORT_FIXTURE names its folder)")
    return os.path.dirname(found[0])
