#!/usr/bin/python3
"""`import pvcap` against a recorded session: the export fixture's calibrated protocol session
(tests/integration/export_fixture.h; PVCAP_EXPORT_FIXTURE names its folder) and the pvcap binary
(PVCAP_BIN). Run by ctest with PYTHONPATH=build/python and Debian's python3 (docs/python.md)."""
import glob
import hashlib
import json
import os
import pickle
import subprocess
import tempfile
import unittest

import cv2
import numpy as np

import pvcap
from pvcap_fixture import FIXTURE, only_session

PVCAP = os.environ.get("PVCAP_BIN", "pvcap")
BUILD = os.environ.get("PVCAP_BUILD_DIR", "")


def pvcap_run(*args):
    r = subprocess.run([PVCAP, "--log-level", "warn", *args], capture_output=True, text=True)
    if r.returncode != 0:
        raise AssertionError(f"pvcap {' '.join(args)}: exit {r.returncode}\n{r.stdout}\n{r.stderr}")
    return r.stdout


def folder_fingerprint(folder):
    """Every file's name, size and content hash: what a read-only reader must leave as it was."""
    out = {}
    for root, _, files in os.walk(folder):
        for f in files:
            p = os.path.join(root, f)
            if os.path.islink(p) or not os.path.isfile(p):
                continue
            with open(p, "rb") as fh:
                out[os.path.relpath(p, folder)] = (os.path.getsize(p), hashlib.sha1(fh.read()).hexdigest())
    return out


class SessionTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.folder = only_session()
        cls.before = folder_fingerprint(cls.folder)
        cls.s = pvcap.Session(cls.folder)

    def test_what_the_session_holds(self):
        s = self.s
        self.assertEqual(s.participant["code"], "P017")
        self.assertEqual(s.participant["skin_tone"], "dark")
        self.assertEqual(s.conditions["lighting"], "L-R")
        self.assertEqual(len(s.cameras), 4)
        self.assertTrue(all(c["calibration"] is not None for c in s.cameras), "the fixture's pad is calibrated")
        self.assertEqual(s.cameras[0]["calibration"]["pad_corners_px"].shape, (4, 2))
        n = len(s)
        self.assertGreater(n, 50)
        for key in ("index", "tick", "t_ns", "pressure_sequence"):
            self.assertEqual(s.samples[key].shape, (n,), key)
        self.assertEqual(s.samples["cameras_present"].shape, (n, 4))
        self.assertTrue(np.all(np.diff(s.samples["tick"]) > 0), "ticks increase")
        self.assertTrue(np.all(np.diff(s.samples["t_ns"]) > 0), "times increase")
        # Two hands x (low, high): four takes, each with its samples.
        self.assertEqual([(t["hand"], t["force_level"]) for t in s.takes],
                         [("right", "low"), ("right", "high"), ("left", "low"), ("left", "high")])
        for t in s.takes:
            self.assertEqual(t["status"], "done")
            self.assertLess(t["first_sample"], t["end_sample"])
            self.assertIs(s.take_of(t["first_sample"]), t)

    def test_images_and_pressure(self):
        s = self.s
        t = s.takes[1]  # high force: its firmest sample
        i = max(range(t["first_sample"], t["end_sample"]), key=s.force)
        whole = s.image(i, 0)
        self.assertEqual(whole.shape, (s.cameras[0]["height"], s.cameras[0]["width"], 3))
        self.assertEqual(whole.dtype, np.uint8)
        crop = s.image(i, "cam0", crop="paper", size=(480, 384))
        self.assertEqual(crop.shape, (384, 480, 3))
        x, y, w, h = s.crop_box(0, "paper")
        box = s.image(i, 0, crop=(x, y, w, h))
        np.testing.assert_array_equal(box, whole[y:y + h, x:x + w])
        kpa = s.pressure(i)
        self.assertEqual(kpa.shape, (105, 185))
        self.assertEqual(kpa.dtype, np.float32)
        force = s.force(i)
        self.assertGreater(force, 1.0, "a high press")
        self.assertAlmostEqual(force, float(kpa.astype(np.float64).sum()) * 1e3 * 1.25e-3 * 1.25e-3, delta=1e-3 * force)
        in_image = s.pressure_in_camera(i, 0)
        self.assertEqual(in_image.shape, whole.shape[:2])
        # The pressure lies on the pad: inside the quadrilateral of its corners.
        corners = s.cameras[0]["calibration"]["pad_corners_px"].astype(np.float32)
        ys, xs = np.nonzero(in_image > 0.5)
        self.assertGreater(len(xs), 10)
        inside = [cv2.pointPolygonTest(corners, (float(a), float(b)), True) >= -2 for a, b in zip(xs, ys)]
        self.assertTrue(all(inside), "pressure outside the pad")
        cropped = s.pressure_in_camera(i, 0, crop="paper", size=(480, 384))
        self.assertEqual(cropped.shape, (384, 480))
        self.assertGreater(float(cropped.max()), 0.5)

    def test_mistakes_are_named(self):
        with self.assertRaises(pvcap.StoreError) as e:
            pvcap.Session("/nonexistent/session")
        self.assertIn("/nonexistent/session", str(e.exception))
        with self.assertRaises(ValueError):
            self.s.image(0, 0, crop="square")
        with self.assertRaises(pvcap.StoreError) as e:
            self.s.image(10 ** 6, 0)
        self.assertIn("no sample", str(e.exception))
        with self.assertRaises(pvcap.StoreError) as e:
            self.s.image(0, "cam9")
        self.assertIn("cam0", str(e.exception))

    def test_reading_never_writes_the_session(self):
        s = pvcap.Session(self.folder)
        s.image(len(s) // 2, 2, crop="paper")
        s.pressure_in_camera(len(s) // 2, 2, crop="paper")
        del s
        self.assertEqual(folder_fingerprint(self.folder), self.before)


class SameSampleAsTheExport(unittest.TestCase):
    """What the reader yields for a sample is what `pvcap export --crop-paper` writes for it and
    PressureVision's loader reads: the pressure equal, the image within JPEG's error."""

    def test_export_and_reader_agree(self):
        folder = only_session()
        s = pvcap.Session(folder)
        take = s.takes[1]["sequence"]
        with tempfile.TemporaryDirectory(prefix="pvcap-py-export-") as out:
            pvcap_run("export", folder, "--layout", "pressurevision", "--out", out, "--take", take, "--cameras", "0",
                      "--crop-paper")
            metas = glob.glob(os.path.join(out, "*", "*", "metadata.json"))
            self.assertEqual(len(metas), 1, metas)
            seq = os.path.dirname(metas[0])
            with open(metas[0]) as f:
                meta = json.load(f)
            samples = meta["pvcap"]["samples"]
            self.assertGreater(len(samples), 5)
            self.assertEqual(list(s.crop_box(0, "paper")), meta["pvcap"]["cameras"][0]["crop_box"])
            worst_mean = 0.0
            for t, i in enumerate(samples):
                with open(os.path.join(seq, "force", f"{t:05d}.pkl"), "rb") as f:
                    loader_kpa = pickle.load(f).astype(np.float64) / 2.7125  # the loader's conversion
                np.testing.assert_allclose(s.pressure(i), loader_kpa, rtol=1e-5, atol=1e-5, err_msg=f"sample {i}")
                jpeg = cv2.cvtColor(cv2.imread(os.path.join(seq, "camera_0", f"{t:05d}.jpg")), cv2.COLOR_BGR2RGB)
                mine = s.image(i, 0, crop="paper", size=(480, 384))
                self.assertEqual(mine.shape, jpeg.shape)
                # JPEG's error is the only difference: the reader's image, encoded as the export encodes
                # (quality 95), decodes to the exported file's pixels.
                ok, encoded = cv2.imencode(".jpg", cv2.cvtColor(mine, cv2.COLOR_RGB2BGR), [cv2.IMWRITE_JPEG_QUALITY, 95])
                again = cv2.cvtColor(cv2.imdecode(encoded, cv2.IMREAD_COLOR), cv2.COLOR_BGR2RGB)
                self.assertLessEqual(float(np.percentile(np.abs(again.astype(np.int16) - jpeg), 99.9)), 1.0,
                                     f"sample {i}: the exported image is not the reader's")
                worst_mean = max(worst_mean, float(np.abs(mine.astype(np.int16) - jpeg).mean()))
            print(f"export and reader: {len(samples)} samples, pressure equal, worst mean image difference "
                  f"{worst_mean:.2f} of 255 (JPEG quality 95)")


class DatasetTest(unittest.TestCase):
    """pvcap.Dataset over `pvcap dataset`'s folder: the catalogue, the splits, and a withdrawn
    participant never yielded."""

    def test_catalogue_splits_and_withdrawal(self):
        folder = only_session()
        with tempfile.TemporaryDirectory(prefix="pvcap-py-dataset-") as work:
            ds = os.path.join(work, "ds")
            pvcap_run("dataset", "init", ds, "--protocol", os.path.join(FIXTURE, "protocol.yaml"), "--sessions",
                      os.path.join(FIXTURE, "sessions"), "--participants", "P017")
            with self.assertRaises(pvcap.StoreError) as e:
                pvcap.Dataset(ds)
            self.assertIn("dataset status", str(e.exception), "no catalogue yet: the message says what to run")
            subprocess.run([PVCAP, "--log-level", "warn", "dataset", "status", ds], capture_output=True)
            d = pvcap.Dataset(ds)
            self.assertEqual([s["folder"] for s in d.sessions], [folder])
            self.assertEqual(d.participants(), ["P017"])
            self.assertIn(d.sessions[0]["qa"], ("clean", "lossy"))
            with self.assertRaises(pvcap.StoreError):
                d.folders(split="train")  # no splits yet
            pvcap_run("dataset", "split", ds, "--test", "0", "--val", "0")
            d = pvcap.Dataset(ds)
            self.assertEqual(d.folders(split="train"), [folder])
            self.assertEqual(d.folders(split="test"), [])
            pvcap_run("dataset", "withdraw", ds, "P017", "--reason", "test")
            d = pvcap.Dataset(ds)
            self.assertEqual(d.withdrawn, ["P017"])
            self.assertEqual(d.sessions, [], "a withdrawn participant is never listed")
            self.assertTrue(os.path.isdir(folder), "withdrawing without --purge deletes nothing")


class InstallTest(unittest.TestCase):
    """The documented install into a fresh virtual environment (docs/python.md)."""

    def test_install_into_a_venv(self):
        if not BUILD:
            self.skipTest("PVCAP_BUILD_DIR not set")
        with tempfile.TemporaryDirectory(prefix="pvcap-py-venv-") as venv:
            subprocess.run(["/usr/bin/python3", "-m", "venv", "--system-site-packages", "--without-pip", venv],
                           check=True)
            subprocess.run(["cmake", "--install", BUILD, "--component", "python", "--prefix", venv], check=True,
                           capture_output=True)
            env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
            r = subprocess.run([os.path.join(venv, "bin", "python"), "-c",
                                "import pvcap, pvcap.torch; print(pvcap.__file__)"],
                               capture_output=True, text=True, env=env, cwd=venv)
            self.assertEqual(r.returncode, 0, r.stderr)
            self.assertTrue(r.stdout.strip().startswith(venv), r.stdout)


if __name__ == "__main__":
    unittest.main(verbosity=2)
