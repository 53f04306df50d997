#!/usr/bin/python3
"""Training-read speed (docs/python.md): crops of 480x384 with their pressure, in a shuffled order, per
second on one core, read three ways in the same run:
  raw        pvcap.torch.PressureDataset on the session as recorded (raw Bayer video)
  compacted  the same on its compacted copy (`pvcap compact`)
  cached     the raw store through PressureDataset's crop cache (cache=DIR), once filled
  jpeg       the same takes exported (`pvcap export --crop-paper`) and read as PressureVision's loader
             reads them: the JPEG, the force pickle, and the force warped into the crop by the
             layout's homography
and the resident memory of this process and of a DataLoader-like worker forked from it. Run by bench/python_reader_bench.sh, which makes the
three; or by hand:

  PYTHONPATH=build/python /usr/bin/python3 bench/python_reader_bench.py RAW COMPACTED EXPORT [ITEMS]
"""
import glob
import json
import multiprocessing
import os
import pickle
import random
import resource
import sys
import tempfile
import time

import cv2
import numpy as np
import torch

from pvcap.torch import PressureDataset

SIZE = (480, 384)


def rate(read, indices):
    read(indices[0])  # opens the handles; not timed
    t0 = time.process_time()
    for i in indices[1:]:
        read(i)
    return (len(indices) - 1) / (time.process_time() - t0)  # per second of CPU: per core


def loader_items(export):
    """(jpeg, pickle, homography) per exported frame, as the released loader finds them."""
    items = []
    for meta_path in sorted(glob.glob(os.path.join(export, "*", "*", "metadata.json"))):
        seq = os.path.dirname(meta_path)
        with open(meta_path) as f:
            meta = json.load(f)
        for c in range(meta["num_cameras"]):
            cal = meta["camera_calibrations"][str(c)]
            mvm = np.array(cal["ModelViewMatrix"], dtype=np.float64)
            rvec, _ = cv2.Rodrigues(mvm[:3, :3])
            K = np.array([[cal["fx"], 0, cal["cx"]], [0, cal["fy"], cal["cy"]], [0, 0, 1]], dtype=np.float64)
            world = np.array([[0.149, -0.001, 0.251], [0.014, -0.001, 0.251], [0.014, -0.001, 0.016],
                              [0.149, -0.001, 0.016]])
            points, _ = cv2.projectPoints(world, rvec, mvm[:3, 3] / 1000.0, K, np.array([]))
            H, _ = cv2.findHomography(np.array([[185, 0], [185, 105], [0, 105], [0, 0]], dtype=np.float64),
                                      points.reshape(-1, 2))
            for t in range(meta["num_frames"]):
                items.append((os.path.join(seq, f"camera_{c}", f"{t:05d}.jpg"),
                              os.path.join(seq, "force", f"{t:05d}.pkl"), H))
    return items


def read_like_the_loader(item):
    jpg, pkl, H = item
    image = cv2.cvtColor(cv2.imread(jpg), cv2.COLOR_BGR2RGB)
    with open(pkl, "rb") as f:
        kpa = pickle.load(f).astype(np.float32) / 2.7125
    pressure = cv2.warpPerspective(kpa, H, (image.shape[1], image.shape[0]))
    # The same tensors as PressureDataset's item: channels first, contiguous.
    return torch.from_numpy(image).permute(2, 0, 1).contiguous(), torch.from_numpy(pressure)


def smaps_mb():
    """This process's resident memory, its proportional share and what is its own (MB)."""
    out = {}
    with open("/proc/self/smaps_rollup") as f:
        for line in f:
            key, _, value = line.partition(":")
            if key in ("Rss", "Pss", "Private_Clean", "Private_Dirty"):
                out[key] = int(value.split()[0]) / 1024
    return out["Rss"], out["Pss"], out["Private_Clean"] + out["Private_Dirty"]


def worker_memory(folder, n, answer):
    """What a DataLoader worker holds: forked from a process with torch loaded, it reads n items."""
    ds = PressureDataset(folder, crop="paper", size=SIZE)
    rng = random.Random(1)
    for _ in range(n):
        ds[rng.randrange(len(ds))]
    answer.put(smaps_mb())


def main():
    raw, compacted, export = sys.argv[1:4]
    n = int(sys.argv[4]) if len(sys.argv) > 4 else 300
    torch.set_num_threads(1)
    rng = random.Random(0)
    figures = {}
    for name, folder in (("raw", raw), ("compacted", compacted)):
        ds = PressureDataset(folder, crop="paper", size=SIZE)
        order = [rng.randrange(len(ds)) for _ in range(n + 1)]
        figures[name] = rate(lambda i: ds[i], order)
        print(f"  {name}: {len(ds)} items, {figures[name]:.0f} crops/s per core", flush=True)
    # The crop cache: a first epoch reads the store and writes each crop, the next reads the cache.
    with tempfile.TemporaryDirectory(prefix="pvcap-crop-cache-") as cache:
        ds = PressureDataset(raw, crop="paper", size=SIZE, cache=cache)
        order = [rng.randrange(len(ds)) for _ in range(n + 1)]
        figures["first epoch"] = rate(lambda i: ds[i], order)
        figures["cached"] = rate(lambda i: ds[i], order)
        print(f"  raw through the crop cache: {figures['first epoch']:.0f} crops/s per core while it fills, "
              f"{figures['cached']:.0f} once filled", flush=True)
    items = loader_items(export)
    order = [rng.randrange(len(items)) for _ in range(n + 1)]
    figures["jpeg"] = rate(lambda i: read_like_the_loader(items[i]), order)
    rss_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    fork = multiprocessing.get_context("fork")
    answer = fork.Queue()
    worker = fork.Process(target=worker_memory, args=(raw, n, answer))
    worker.start()
    w_rss, w_pss, w_private = answer.get()
    worker.join()
    print(f"  a worker after {n} raw items: resident {w_rss:.0f} MB, its share {w_pss:.0f} MB, its own "
          f"{w_private:.0f} MB")
    print(f"python reader, crops of {SIZE[0]}x{SIZE[1]} with their pressure, shuffled, per core: raw store "
          f"{figures['raw']:.0f}/s, compacted {figures['compacted']:.0f}/s, raw through the crop cache "
          f"{figures['cached']:.0f}/s ({figures['first epoch']:.0f}/s while it fills), exported JPEGs read as the "
          f"loader reads them {figures['jpeg']:.0f}/s (cache/JPEGs {figures['cached'] / figures['jpeg']:.2f}x); "
          f"resident memory: this process at most {rss_mb:.0f} MB, a worker {w_rss:.0f} MB ({w_private:.0f} MB "
          f"its own)")


if __name__ == "__main__":
    main()
