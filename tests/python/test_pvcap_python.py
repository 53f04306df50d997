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


def init_dataset(ds):
    """`pvcap dataset init` over the fixture's sessions, its one participant P017."""
    pvcap_run("dataset", "init", ds, "--protocol", os.path.join(FIXTURE, "protocol.yaml"), "--sessions",
              os.path.join(FIXTURE, "sessions"), "--participants", "P017")


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


# PressureVision's released reader (facebookresearch/PressureVision recording/sequence_reader.py:
# get_sensel_homography, get_force_warped_to_img, crop_img; spec section 2), as it computes the
# pressure a network trains on from an exported take. The image size is the camera's own: the
# released reader fixes 1920x1080, which this rig's 960x540 cameras are not.
PV_SENSOR_CORNERS = np.array([[185, 0], [185, 105], [0, 105], [0, 0]], dtype=np.float64)
PV_WORLD_CORNERS = np.array([[0.149, -0.001, 0.251], [0.014, -0.001, 0.251],
                             [0.014, -0.001, 0.016], [0.149, -0.001, 0.016]], dtype=np.float64)


def pv_homography(cal):
    mvm = np.array(cal["ModelViewMatrix"], dtype=np.float64)
    rvec, _ = cv2.Rodrigues(mvm[:3, :3])
    K = np.array([[cal["fx"], 0, cal["cx"]], [0, cal["fy"], cal["cy"]], [0, 0, 1]], dtype=np.float64)
    points, _ = cv2.projectPoints(PV_WORLD_CORNERS, rvec, mvm[:3, 3] / 1000.0, K, np.array([]))
    H, _ = cv2.findHomography(PV_SENSOR_CORNERS, points[:, 0, :])
    return H, points[:, 0, :]


def pv_crop(img, sensel_points, margin=50, net=(480, 384)):
    min_xy = sensel_points.min(axis=0) - margin
    max_xy = sensel_points.max(axis=0) + margin
    center_xy = np.round((min_xy + max_xy) / 2).astype(int)
    span_x, span_y = (max_xy[0] - min_xy[0]) / 2, (max_xy[1] - min_xy[1]) / 2
    if span_x * net[1] / net[0] > span_y:
        span_y = span_x * net[1] / net[0]
    else:
        span_x = span_y * net[0] / net[1]
    min_x, max_x = max(int(center_xy[0] - span_x), 0), min(int(center_xy[0] + span_x), img.shape[1])
    min_y, max_y = max(int(center_xy[1] - span_y), 0), min(int(center_xy[1] + span_y), img.shape[0])
    return cv2.resize(img[min_y:max_y, min_x:max_x, ...], net), (min_x, min_y, max_x - min_x, max_y - min_y)


def centroid(p):
    ys, xs = np.mgrid[0:p.shape[0], 0:p.shape[1]]
    w = float(p.sum())
    return np.array([float((xs * p).sum()) / w, float((ys * p).sum()) / w])


class SamePressureAsTheReleasedCode(unittest.TestCase):
    """The pressure in a camera's paper crop, computed from the exported take as PressureVision's
    released reader computes it, against pvcap's `pressure_in_camera` and the torch dataset's item.
    pvcap differs from the released code in one documented way: the released homography takes the
    grid's edges (0..185) to the pad's corners but warps cell *centres* sitting at those integer
    coordinates, which puts the pressure half a cell towards the grid's origin; pvcap puts each
    cell's centre where it is. With that half cell given back, the two agree within interpolation
    (one resample into the crop against PressureVision's warp at full size, then a resize)."""

    def test_the_released_readers_pressure_equals_pvcaps_but_for_its_half_cell(self):
        from pvcap.torch import PressureDataset
        folder = only_session()
        s = pvcap.Session(folder)
        take = s.takes[3]  # left hand, high force
        with tempfile.TemporaryDirectory(prefix="pvcap-py-released-") as out:
            pvcap_run("export", folder, "--layout", "pressurevision", "--out", out, "--take", take["sequence"],
                      "--cameras", "0")
            metas = glob.glob(os.path.join(out, "*", "*", "metadata.json"))
            self.assertEqual(len(metas), 1, metas)
            seq = os.path.dirname(metas[0])
            with open(metas[0]) as f:
                meta = json.load(f)
            H, corners = pv_homography(meta["camera_calibrations"]["0"])
            width, height = s.cameras[0]["width"], s.cameras[0]["height"]
            half_cell = np.array([[1, 0, 0.5], [0, 1, 0.5], [0, 0, 1]])
            torch_ds = PressureDataset(folder, cameras=[0], crop="paper", size=(480, 384))
            item_of = {int(torch_ds[k]["sample"]): k for k in range(len(torch_ds))}
            compared, items, worst_sum, worst_shift, worst_diff = 0, 0, 0.0, 0.0, 0.0
            # How far the released reader's corners lie from pvcap's (the export's fitted pose): the
            # contact's place can differ by as much, in the crop's pixels.
            measured = np.array(s.cameras[0]["calibration"]["pad_corners_px"], dtype=np.float64)
            released_corners = cv2.perspectiveTransform(
                np.array([[[0.0, 0.0], [185.0, 0.0], [185.0, 105.0], [0.0, 105.0]]]), H)[0]
            corner_px = float(np.max(np.linalg.norm(released_corners - measured, axis=1)))
            for t, i in enumerate(meta["pvcap"]["samples"]):
                with open(os.path.join(seq, "force", f"{t:05d}.pkl"), "rb") as f:
                    kpa = (pickle.load(f) / 2.7125).astype(np.float32)  # util.convert_counts_to_kPa
                if s.force(i) < 2.0:
                    continue  # a firm press: a contact large enough to place to a tenth of a pixel
                released, box = pv_crop(cv2.warpPerspective(kpa, H, (width, height)), corners)
                centred, _ = pv_crop(cv2.warpPerspective(kpa, H @ half_cell, (width, height)), corners)
                # The export's pose puts the released reader's corners within a pixel of pvcap's
                # measured ones, so its crop box within a pixel or two of pvcap's paper crop.
                paper = s.crop_box(0, "paper")
                self.assertLessEqual(max(abs(a - b) for a, b in zip(box, paper)), 3, f"{box} against {paper}")
                # pvcap's pressure in the released reader's own box, and its paper crop's (the
                # torch dataset's item yields exactly that).
                mine = s.pressure_in_camera(i, 0, crop=tuple(int(v) for v in box), size=(480, 384))
                self.assertEqual(mine.shape, released.shape)
                if i in item_of:
                    item = torch_ds[item_of[i]]
                    np.testing.assert_array_equal(item["pressure"][0].numpy(),
                                                  s.pressure_in_camera(i, 0, crop="paper", size=(480, 384)))
                    items += 1
                # Equal to the released code with the half cell given back: the total (pvcap scales
                # it to the sensor's force; the released warp does not), the place and the values.
                ratio = float(mine.sum()) / float(centred.sum())
                shift = float(np.linalg.norm(centroid(mine) - centroid(centred)))
                diff = float(np.abs(mine - centred).sum()) / float(centred.sum())
                self.assertLess(abs(ratio - 1), 0.02, f"sample {i}: total {ratio:.4f}x the released code's")
                self.assertLess(shift, 0.2 + corner_px * 480.0 / box[2],
                                f"sample {i}: {shift:.3f} px from the released code's (corners {corner_px:.2f} px apart)")
                self.assertLess(diff, 0.06, f"sample {i}: values differ by {diff:.1%} of the total")
                # And the released code itself sits half a cell off: its contact is where pvcap's
                # would be with the grid moved by half a cell.
                released_shift = centroid(released) - centroid(centred)
                expected = cv2.perspectiveTransform(np.array([[[100.0, 50.0]]]), H)[0, 0] - \
                    cv2.perspectiveTransform(np.array([[[100.5, 50.5]]]), H)[0, 0]
                scale = np.array([480.0 / box[2], 384.0 / box[3]])
                np.testing.assert_allclose(released_shift, expected * scale, atol=0.15,
                                           err_msg=f"sample {i}: the released code's half cell")
                worst_sum, worst_shift, worst_diff = max(worst_sum, abs(ratio - 1)), max(worst_shift, shift), \
                    max(worst_diff, diff)
                compared += 1
            self.assertGreater(compared, 3, "firm presses in the take")
            self.assertGreater(items, 0, "the torch dataset's items of the take")
            print(f"released code against pvcap: {compared} samples; total within {worst_sum:.2%}, place within "
                  f"{worst_shift:.3f} px, values within {worst_diff:.1%} of the total (half a cell given back; the "
                  f"export's corners {corner_px:.2f} px from pvcap's)")


class DatasetTest(unittest.TestCase):
    """pvcap.Dataset over `pvcap dataset`'s folder: the catalogue, the splits, and a withdrawn
    participant never yielded."""

    def test_catalogue_splits_and_withdrawal(self):
        folder = only_session()
        with tempfile.TemporaryDirectory(prefix="pvcap-py-dataset-") as work:
            ds = os.path.join(work, "ds")
            init_dataset(ds)
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


class ReadersNeverWriteTest(unittest.TestCase):
    """A dataset as training nodes mount it, read-only: pvcap.Dataset, pvcap.Session and the torch
    dataset read it, and every file is byte-identical afterwards; a catalogue of another version is an
    error naming the command that rebuilds it, never zero sessions."""

    def test_a_read_only_mount_reads_and_is_left_byte_identical(self):
        folder = only_session()
        with tempfile.TemporaryDirectory(prefix="pvcap-py-ro-") as work:
            ds = os.path.join(work, "ds")
            init_dataset(ds)
            pvcap_run("dataset", "status", ds)
            before = (folder_fingerprint(ds), folder_fingerprint(folder))
            # In a mount namespace of its own, both folders bound onto themselves read-only: nothing
            # outside this process's namespace sees the change, and it ends with the process.
            reader = (
                "import pvcap, sys\n"
                "from pvcap.torch import PressureDataset\n"
                "d = pvcap.Dataset(sys.argv[1])\n"
                "assert [s['folder'] for s in d.sessions] == [sys.argv[2]], d.sessions\n"
                "s = pvcap.Session(sys.argv[2])\n"
                "i = len(s) // 2\n"
                "assert s.image(i, 0, crop='paper').ndim == 3\n"
                "assert s.pressure_in_camera(i, 0, crop='paper').ndim == 2\n"
                "t = PressureDataset(sys.argv[1], cameras=[0], size=(96, 80))\n"
                "assert len(t) > 10 and t[len(t) // 2]['image'].shape == (1, 3, 80, 96)\n"
                "try:\n"
                "    open(sys.argv[2] + '/probe', 'w')\n"
                "    raise SystemExit('the mount is not read-only')\n"
                "except OSError:\n"
                "    pass\n"
                "print('read', len(d.sessions), 'session,', len(s), 'samples,', len(t), 'items')\n")
            script = ("set -e; for f in \"$1\" \"$2\"; do mount --bind \"$f\" \"$f\"; "
                      "mount -o remount,bind,ro \"$f\" \"$f\"; done; "
                      "exec /usr/bin/python3 -c \"$3\" \"$1\" \"$2\"")
            r = subprocess.run(["unshare", "-m", "--propagation", "private", "sh", "-c", script, "sh", ds, folder,
                                reader], capture_output=True, text=True)
            self.assertEqual(r.returncode, 0, f"reading behind a read-only mount failed:\n{r.stdout}\n{r.stderr}")
            self.assertIn("read 1 session", r.stdout)
            self.assertEqual((folder_fingerprint(ds), folder_fingerprint(folder)), before,
                             "a reader changed the dataset or the session")

    def test_a_catalogue_of_another_version_is_an_error_naming_the_rebuild(self):
        import sqlite3
        only_session()
        with tempfile.TemporaryDirectory(prefix="pvcap-py-catver-") as work:
            ds = os.path.join(work, "ds")
            init_dataset(ds)
            pvcap_run("dataset", "status", ds)
            self.assertEqual(len(pvcap.Dataset(ds).sessions), 1)
            con = sqlite3.connect(os.path.join(ds, "catalog.db"))
            con.execute("PRAGMA user_version = 999")
            con.close()
            before = folder_fingerprint(ds)
            with self.assertRaises(pvcap.StoreError) as e:
                pvcap.Dataset(ds)
            self.assertIn("version 999", str(e.exception))
            self.assertIn(f"pvcap dataset status {ds}", str(e.exception))
            self.assertEqual(folder_fingerprint(ds), before, "the reader rebuilt or changed the catalogue")
            pvcap_run("dataset", "status", ds)  # the command it names rebuilds it
            self.assertEqual(len(pvcap.Dataset(ds).sessions), 1)


class InstallTest(unittest.TestCase):
    """The documented install into a fresh virtual environment (docs/python.md)."""

    def test_install_into_a_venv(self):
        self.assertTrue(BUILD, "PVCAP_BUILD_DIR names the build folder to install from (ctest sets it)")
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
