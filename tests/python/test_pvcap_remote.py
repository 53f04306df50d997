#!/usr/bin/env python3
"""pvcap.remote (docs/remote.md) against a session on the simulated rig, as experiment software uses
it: the session's status, a mark committed on its clock, a wrong token refused, the protocol's
commands refused without a protocol, and the stop, which ends the session as Ctrl-C does. Runs the
pvcap command (PVCAP_BIN; root: the simulated rig's network namespace), PYTHONPATH=build/python."""
import os
import re
import shutil
import sqlite3
import subprocess
import tempfile
import threading
import time
import unittest

from pvcap.remote import Remote, RemoteError

PVCAP = os.environ["PVCAP_BIN"]
SIM_RIG = os.path.join(os.path.dirname(__file__), "..", "..", "rig-configs", "sim.yaml")
TOKEN = "remote-test-token-0123"


class RemoteControl(unittest.TestCase):
    def setUp(self):
        self.work = tempfile.mkdtemp(prefix="pvcap-remote-")
        with open(SIM_RIG, encoding="utf-8") as f:
            rig = f.read().replace("width: 1920", "width: 320").replace("height: 1080", "height: 240")
        self.rig = os.path.join(self.work, "rig.yaml")
        with open(self.rig, "w", encoding="utf-8") as f:
            f.write(rig)
        self.token_file = os.path.join(self.work, "token")
        with open(self.token_file, "w", encoding="utf-8") as f:
            f.write(TOKEN + "\n")
        self.proc = None
        self.output = []

    def tearDown(self):
        if self.proc and self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait()
        shutil.rmtree(self.work, ignore_errors=True)

    def start_session(self):
        """A 60-s session with its pages on a free port; returns their address once printed."""
        self.proc = subprocess.Popen(
            [PVCAP, "session", "--rig", self.rig, "--root", os.path.join(self.work, "sessions"), "--duration", "60",
             "--web-port", "0", "--web-token-file", self.token_file],
            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        found = threading.Event()
        url = []

        def read():  # every line kept, the pipe always drained
            for line in self.proc.stdout:
                self.output.append(line)
                m = re.search(r"operator console: +(http://\S+)", line)
                if m and not url:
                    url.append(m.group(1))
                    found.set()

        threading.Thread(target=read, daemon=True).start()
        self.assertTrue(found.wait(60), "no address printed:\n" + "".join(self.output))
        return url[0]

    def test_experiment_software_marks_and_stops_a_session(self):
        remote = Remote(self.start_session(), token_file=self.token_file)
        deadline = time.time() + 60
        while remote.status()["state"] != "recording":
            self.assertLess(time.time(), deadline, "the session never started recording")
            time.sleep(0.2)
        status = remote.status()
        self.assertEqual(status["api"], 1)
        self.assertEqual([s["name"] for s in status["streams"]], ["cam0", "cam1", "cam2", "cam3", "sensel"])
        session = status["session"]

        with self.assertRaises(RemoteError) as refused:
            Remote(remote.base, token="wrong-token-456789").status()
        self.assertEqual(refused.exception.status, 401)

        before = time.monotonic_ns()
        self.assertEqual(remote.mark("stimulus_on", note="trial 3"), {"ok": True})
        after = time.monotonic_ns()
        with self.assertRaises(RemoteError) as unlabelled:
            remote.mark("")
        self.assertEqual(unlabelled.exception.status, 400)
        with self.assertRaises(RemoteError) as no_protocol:
            remote.command("next")
        self.assertEqual(no_protocol.exception.status, 409)
        self.assertIn("runs no protocol", str(no_protocol.exception))

        self.assertEqual(remote.stop("experiment over"), {"ok": True})
        self.assertEqual(self.proc.wait(60), 0, "".join(self.output))
        log = "".join(self.output)
        self.assertIn("stopped through the remote-control API: experiment over", log)
        self.assertIn("remote-control API: GET /api/v1/status from 127.0.0.1 refused: no token or a wrong one", log)

        # Both are in the session, the mark on the session's clock (CLOCK_MONOTONIC, as Python's).
        db = sqlite3.connect(f"file:{os.path.join(session, 'session.db')}?mode=ro", uri=True)
        rows = db.execute("SELECT host_ns, kind, detail FROM protocol_events WHERE kind LIKE 'remote_%' "
                          "ORDER BY host_ns").fetchall()
        db.close()
        kinds = [r[1] for r in rows]
        self.assertEqual(kinds, ["remote_mark", "remote_stop"], rows)
        self.assertTrue(before <= rows[0][0] <= after, rows[0])
        self.assertIn('"label":"stimulus_on"', rows[0][2])
        self.assertIn('"reason":"experiment over"', rows[1][2])


if __name__ == "__main__":
    unittest.main(verbosity=2)
