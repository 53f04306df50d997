"""The recorded session the Python tests read: the export fixture's calibrated protocol session
(tests/integration/export_fixture.h), whose folder ctest names in PVCAP_EXPORT_FIXTURE."""
import glob
import os
import unittest

FIXTURE = os.environ.get("PVCAP_EXPORT_FIXTURE", "")


def only_session():
    found = glob.glob(os.path.join(FIXTURE, "sessions", "*", "session.db"))
    if len(found) != 1:
        raise unittest.SkipTest(f"no recorded session under {FIXTURE} (run under ctest: ExportFixture.Record)")
    return os.path.dirname(found[0])
