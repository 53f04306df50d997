"""pvcap's store from Python: recorded sessions and datasets, read through pvcap's own C++ reader.

    import pvcap
    s = pvcap.Session("sessions/20261202-101500_P017")
    s.participant["code"], [c["name"] for c in s.cameras], len(s)
    rgb = s.image(0, camera=0, crop="paper", size=(480, 384))   # uint8 (384, 480, 3), RGB
    kpa = s.pressure(0)                                          # float32 (105, 185), kPa, the sensor's grid
    in_image = s.pressure_in_camera(0, 0, crop="paper", size=(480, 384))  # kPa in that image

    d = pvcap.Dataset("lab-dataset")            # a `pvcap dataset` folder: catalogue, splits, withdrawals
    d.folders(split="train")

pvcap.torch.PressureDataset turns either into a PyTorch Dataset (docs/python.md). Opening a session
never writes it. Errors of the store raise pvcap.StoreError with the reader's message.
"""
import json
import os

from ._pvcap import SessionHandle as _SessionHandle
from ._pvcap import StoreError
from ._pvcap import open_dataset as _open_dataset

__all__ = ["Session", "Dataset", "StoreError", "QA_VERDICTS"]

# pvcap verify's exit code as the catalogue keeps it, by name.
QA_VERDICTS = {0: "clean", 3: "lossy", 1: "failed"}


class Session:
    """One recorded session folder: its participant, cameras, takes and 15 Hz samples.

    samples: dict of numpy arrays, one entry per sample: index, tick, t_ns (session clock),
    pressure_sequence (-1: no pressure frame paired), cameras_present (samples x cameras, bool).
    takes: list of dicts (step, sequence, action, hand, force_level, status, first_sample,
    end_sample, check_ok, check_problems, mean_newtons, peak_newtons) in protocol order.
    """

    def __init__(self, path):
        self.path = os.path.abspath(os.fspath(path))
        self._open()

    def _open(self):
        self._handle = _SessionHandle(self.path)
        self._pid = os.getpid()
        info = self._handle.info()
        self.info = info
        self.participant = info["participant"]
        self.conditions = info["conditions"]
        self.cameras = self._handle.cameras()
        self.samples = self._handle.samples()
        self.takes = self._handle.takes()

    # A Session crosses a fork or a pickle by its path: each process opens its own read-only handles.
    def __getstate__(self):
        return {"path": self.path}

    def __setstate__(self, state):
        self.path = state["path"]
        self._open()

    def _h(self):
        if self._pid != os.getpid():
            self._open()
        return self._handle

    def __len__(self):
        return len(self.samples["index"])

    def __repr__(self):
        who = self.participant["code"] if self.participant else "no participant"
        return f"pvcap.Session({self.path!r}: {who}, {len(self.cameras)} cameras, {len(self)} samples)"

    def camera_index(self, camera):
        """A camera by its index or its name."""
        if isinstance(camera, int):
            if not 0 <= camera < len(self.cameras):
                raise StoreError(f"{self.path}: no camera {camera} (the session has {len(self.cameras)})")
            return camera
        for k, c in enumerate(self.cameras):
            if c["name"] == camera:
                return k
        names = ", ".join(c["name"] for c in self.cameras)
        raise StoreError(f"{self.path}: no camera named {camera!r} (cameras: {names})")

    def take_of(self, sample):
        """The take (a dict of self.takes) whose samples hold `sample`, or None."""
        for t in self.takes:
            if t["first_sample"] is not None and t["first_sample"] <= sample < t["end_sample"]:
                return t
        return None

    def image(self, sample, camera, crop=None, size=None):
        """RGB uint8 (H, W, 3): crop None (whole), "paper" or (x, y, w, h); size (width, height).
        None when the sample holds no stored frame of that camera."""
        return self._h().image(int(sample), self.camera_index(camera), crop, size)

    def pressure(self, sample):
        """float32 (105, 185): kPa on the sensor's grid (None when no pressure frame is paired)."""
        return self._h().pressure(int(sample))

    def pressure_in_camera(self, sample, camera, crop=None, size=None):
        """float32 kPa in the camera's image (through its pad calibration; force conserved on the pad),
        cut and sized as image() is."""
        return self.pressure_and_force_in_camera(sample, camera, crop, size)[0]

    def pressure_and_force_in_camera(self, sample, camera, crop=None, size=None):
        """(pressure_in_camera(...), force(sample)) from one read of the pressure frame."""
        return self._h().pressure_and_force_in_camera(int(sample), self.camera_index(camera), crop, size)

    def force(self, sample):
        """Total force of the sample's pressure, in newtons (0 when none is paired)."""
        return self._h().force(int(sample))

    def crop_box(self, camera, crop="paper"):
        """(x, y, width, height) that `crop` cuts from the camera's image."""
        return self._h().crop_box(self.camera_index(camera), crop)


class Dataset:
    """A `pvcap dataset` folder: its catalogue's sessions (as `pvcap dataset status` last saw
    them), their QA verdicts and splits. A participant who withdrew is never listed."""

    def __init__(self, path):
        self.path = os.path.abspath(os.fspath(path))
        d = _open_dataset(self.path)
        self.name = d["name"]
        self.withdrawn = list(d["withdrawn"])
        self.has_splits = d["has_splits"]
        self.sessions = []
        for s in d["sessions"]:
            s = dict(s)
            s["qa"] = QA_VERDICTS.get(s["verify_exit"], "failed")
            s["facts"] = json.loads(s.pop("facts_json") or "{}")
            self.sessions.append(s)

    def __repr__(self):
        return f"pvcap.Dataset({self.path!r}: {self.name}, {len(self.sessions)} sessions)"

    def participants(self, split=None):
        return sorted({s["participant"] for s in self._select(split, None)})

    def folders(self, split=None, qa=("clean", "lossy")):
        """Session folders, optionally of one split ("train", "val", "test") and with a QA verdict
        in `qa` (default: every session verify could read; "failed" ones are left out)."""
        return [s["folder"] for s in self._select(split, qa)]

    def _select(self, split, qa):
        if split is not None:
            if split not in ("train", "val", "test"):
                raise ValueError(f"split must be 'train', 'val' or 'test'; got {split!r}")
            if not self.has_splits:
                raise StoreError(f"{self.path}: has no splits.json yet: run `pvcap dataset split {self.path}`")
        return [s for s in self.sessions
                if (split is None or s["split"] == split) and (qa is None or s["qa"] in qa)]
