"""A PyTorch Dataset over pvcap sessions: one camera's image of a 15 Hz sample and the pressure
projected into that image, as PressureVisionNet learns from them.

    from pvcap.torch import PressureDataset
    ds = PressureDataset("lab-dataset", split="train", crop="paper", size=(480, 384))
    item = ds[0]   # image uint8 [T, 3, H, W], pressure float32 [T, H, W] (kPa), force float32 [T] (N),
                   # participant, action, hand, force_level, tick int64 [T], session, camera, sample

Windows are asked in ticks of the 15 Hz grid (ticks=[-2, -1, 0]): a sample is an item only when
every tick of its window has a sample with that camera's frame and a pressure frame. Each process
(DataLoader workers included) opens its own read-only handles: nothing is shared across a fork.

A raw 1080p frame costs ~10 ms to decode whole (its lossless codec cannot decode only a crop), so the
store gives ~60 crops per second per core; with cache=DIR each crop is kept the first time it is read,
bit-exact (the store's pixels after demosaic, crop and resize, as an uncompressed .npy), and later
epochs read those (docs/python.md, figures).
"""
import hashlib
import os

import numpy as np
import torch
import torch.utils.data

from . import Dataset, Session, StoreError

__all__ = ["PressureDataset"]


def _session_folders(source, split, qa):
    if isinstance(source, (list, tuple)):
        if split is not None:
            raise ValueError("split applies to a dataset folder, not to a list of sessions")
        return [os.path.abspath(os.fspath(s)) for s in source]
    path = os.path.abspath(os.fspath(source))
    if os.path.isfile(os.path.join(path, "dataset.yaml")):
        return Dataset(path).folders(split=split, qa=qa)
    if os.path.isfile(os.path.join(path, "session.db")):
        if split is not None:
            raise ValueError("split applies to a dataset folder, not to one session")
        return [path]
    raise StoreError(f"{path}: neither a session folder (session.db) nor a dataset folder (dataset.yaml)")


class PressureDataset(torch.utils.data.Dataset):
    """source: a session folder, a list of them, or a `pvcap dataset` folder (then split and qa
    choose its sessions). cameras: indexes or names (default: every camera of each session).
    crop: None, "paper" or (x, y, w, h); size: (width, height) or None. ticks: the window, in
    ticks relative to the item's sample. takes: None (every sample in a take that is done, or
    every sample of a session without a protocol) or a function of a take's dict returning
    whether its samples are used. transform: applied to each item's dict. cache: a folder where each
    crop is kept once read, bit-exact (every epoch sees the store's own pixels; shared safely by
    workers and by datasets of other crops)."""

    def __init__(self, source, split=None, cameras=None, crop="paper", size=(480, 384), ticks=(0,), takes=None,
                 transform=None, qa=("clean", "lossy"), cache=None):
        self.folders = _session_folders(source, split, qa)
        if not self.folders:
            raise StoreError(f"{os.fspath(source)}: no session to read (split {split!r}, qa {qa!r})")
        self.crop, self.size, self.transform = crop, (tuple(size) if size is not None else None), transform
        self.cache = os.path.abspath(os.fspath(cache)) if cache else None
        self._cache_dirs = {}
        self.ticks = [int(t) for t in ticks]
        if not self.ticks:
            raise ValueError("ticks must name at least one tick, e.g. [0]")
        self._sessions, self._pid = {}, os.getpid()
        items, self._labels, self._by_tick = [], [], []
        for s_index, folder in enumerate(self.folders):
            s = self._session(s_index)
            cams = [s.camera_index(c) for c in cameras] if cameras is not None else range(len(s.cameras))
            for c in cams:
                if crop is not None:
                    s.crop_box(c, crop)  # a camera the crop cannot cut is named now, not in a worker
            items += self._items_of(s_index, s, list(cams), takes)
        self._items = np.asarray(items, dtype=np.int64).reshape(-1, 4)

    def _items_of(self, s_index, s, cams, takes):
        samples = s.samples
        n = len(samples["index"])
        tick_of = samples["tick"]
        by_tick = {int(t): i for i, t in enumerate(tick_of)}
        self._by_tick.append(by_tick)
        has_pressure = samples["pressure_sequence"] >= 0
        present = samples["cameras_present"]
        out = []
        spans = []
        if s.takes:
            for t in s.takes:
                if t["first_sample"] is None:
                    continue
                chosen = takes(t) if takes is not None else t["status"] == "done"
                if chosen:
                    spans.append((t["first_sample"], min(t["end_sample"], n), t))
        elif takes is None:
            spans.append((0, n, None))
        for first, end, take in spans:
            label = len(self._labels)
            self._labels.append({
                "participant": s.participant["code"] if s.participant else "",
                "action": take["action"] if take else "",
                "hand": take["hand"] if take else "",
                "force_level": take["force_level"] if take else "",
            })
            for i in range(first, end):
                window = [by_tick.get(int(tick_of[i]) + d) for d in self.ticks]
                if any(w is None or not has_pressure[w] for w in window):
                    continue
                for c in cams:
                    if all(present[w, c] for w in window):
                        out.append((s_index, i, c, label))
        return out

    def _session(self, s_index):
        # Handles opened in another process (the parent of a DataLoader worker) are not used here.
        if self._pid != os.getpid():
            self._sessions, self._pid = {}, os.getpid()
        s = self._sessions.get(s_index)
        if s is None:
            s = self._sessions[s_index] = Session(self.folders[s_index])
        return s

    def _image(self, s_index, s, sample, camera):
        if self.cache is None:
            return s.image(sample, camera, self.crop, self.size)
        folder = self._cache_dirs.get((s_index, camera))
        if folder is None:
            # Named by what the pixels depend on: the session, the camera, the box the crop resolves to
            # (a new pad calibration moves it) and the size; "raw1" is the files' kind (bit-exact crops).
            box = tuple(s.crop_box(camera, self.crop))
            key = f"{s.path}|{s.cameras[camera]['name']}|{box}|{self.size}|raw1"
            folder = os.path.join(self.cache, hashlib.sha1(key.encode()).hexdigest()[:20])
            os.makedirs(folder, exist_ok=True)
            self._cache_dirs[(s_index, camera)] = folder
        path = os.path.join(folder, f"{sample:08d}.npy")
        try:
            rgb = np.load(path, allow_pickle=False)
        except FileNotFoundError:
            rgb = s.image(sample, camera, self.crop, self.size)
            tmp = f"{path}.{os.getpid()}.tmp"  # whole or not at all: workers may race on one crop
            with open(tmp, "wb") as f:
                np.save(f, rgb, allow_pickle=False)
            os.replace(tmp, path)
            return rgb
        except (ValueError, EOFError, OSError) as e:
            raise StoreError(f"{path}: not a cached crop ({e}): a damaged cache, remove {self.cache}") from None
        if rgb.dtype != np.uint8 or rgb.ndim != 3 or rgb.shape[2] != 3:
            raise StoreError(f"{path}: a cached crop of {rgb.dtype} {rgb.shape}, not an RGB image: a damaged cache, "
                             f"remove {self.cache}")
        return rgb

    def __getstate__(self):
        state = dict(self.__dict__)
        state["_sessions"] = {}
        return state

    def __len__(self):
        return len(self._items)

    def __getitem__(self, index):
        s_index, i, camera, label = (int(v) for v in self._items[index])
        s = self._session(s_index)
        tick = int(s.samples["tick"][i])
        window = [self._by_tick[s_index][tick + d] for d in self.ticks]
        images, pressures, forces = [], [], []
        for w in window:
            images.append(self._image(s_index, s, w, camera))
            pressure, force = s.pressure_and_force_in_camera(w, camera, self.crop, self.size)
            pressures.append(pressure)
            forces.append(force)
        item = {
            "image": torch.from_numpy(np.stack(images)).permute(0, 3, 1, 2).contiguous(),
            "pressure": torch.from_numpy(np.stack(pressures)),
            "force": torch.tensor(forces, dtype=torch.float32),
            "tick": torch.tensor([tick + d for d in self.ticks], dtype=torch.int64),
            "session": s.path,
            "camera": s.cameras[camera]["name"],
            "sample": i,
            **self._labels[label],
        }
        return self.transform(item) if self.transform is not None else item
