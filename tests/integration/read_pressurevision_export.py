#!/usr/bin/python3
"""Reads a pvcap export as PressureVisionDB's loaders would, using only the layout's contract
(../shared/specs/pressurevision-dataset.md sections 1 and 2.1): json, pickle, numpy, OpenCV.

usage: read_pressurevision_export.py EXPORT_DIR RIG_TRUTH_JSON
Prints one JSON object: per sequence its frames, each frame's total pressure (kPa summed over the
185 x 105 grid) and, per camera, how far the layout's homography puts the sensor grid's corners from
the simulator's truth (px). Exits 1 with a message when the layout is broken."""
import json
import os
import pickle
import sys

import cv2
import numpy as np

SENSOR_CORNERS = np.array([[185, 0], [185, 105], [0, 105], [0, 0]], dtype=np.float64)  # the loaders' order
# The loaders' pad: 235 x 135 mm at fixed points of the original rig's world (metres).
WORLD_CORNERS = np.array([[0.149, -0.001, 0.251], [0.014, -0.001, 0.251],
                          [0.014, -0.001, 0.016], [0.149, -0.001, 0.016]], dtype=np.float64)


def fail(message):
    print(message, file=sys.stderr)
    sys.exit(1)


def loader_homography(cal):
    """get_sensel_homography, as section 2.1 describes it."""
    mvm = np.array(cal["ModelViewMatrix"], dtype=np.float64)
    rvec, _ = cv2.Rodrigues(mvm[:3, :3])
    tvec = mvm[:3, 3] / 1000.0
    K = np.array([[cal["fx"], 0, cal["cx"]], [0, cal["fy"], cal["cy"]], [0, 0, 1]], dtype=np.float64)
    points, _ = cv2.projectPoints(WORLD_CORNERS, rvec, tvec, K, np.array([]))
    H, _ = cv2.findHomography(SENSOR_CORNERS, points.reshape(-1, 2))
    return H


def corner_error(H, truth):
    """Max distance (px) of the homography's images of the grid corners from the truth's."""
    mapped = cv2.perspectiveTransform(SENSOR_CORNERS.reshape(-1, 1, 2), H).reshape(-1, 2)
    # The truth lists (0,0), (185,0), (185,105), (0,105).
    expected = np.array([truth[1], truth[2], truth[3], truth[0]], dtype=np.float64)
    return float(np.max(np.linalg.norm(mapped - expected, axis=1)))


def main():
    root, truth_path = sys.argv[1], sys.argv[2]
    truth = json.load(open(truth_path))
    corners = [c["pad_corners_px"] for c in truth["cameras"]]
    out = {"participants": json.load(open(os.path.join(root, "participants.json"))), "sequences": []}
    for participant in sorted(os.listdir(root)):
        pdir = os.path.join(root, participant)
        if not os.path.isdir(pdir):
            continue
        for sequence in sorted(os.listdir(pdir)):
            sdir = os.path.join(pdir, sequence)
            plus = os.path.exists(os.path.join(sdir, "meta.json"))
            meta = json.load(open(os.path.join(sdir, "meta.json" if plus else "metadata.json")))
            n = meta["num_frames"]
            if len(meta["timesteps"]) != n:
                fail(f"{sdir}: {len(meta['timesteps'])} timesteps for {n} frames")
            cameras = meta["camera_ids"] if plus else list(range(meta["num_cameras"]))
            seq = {"participant": participant, "sequence": sequence, "num_frames": n, "timesteps": meta["timesteps"],
                   "force_kpa_sums": [], "corner_error_px": {}, "image_size": None}
            for t in range(n):
                for c in cameras:
                    img = cv2.imread(os.path.join(sdir, f"camera_{c}", f"{t:05d}.jpg"))
                    if img is None:
                        fail(f"{sdir}: camera_{c}/{t:05d}.jpg is missing or unreadable")
                    seq["image_size"] = [img.shape[1], img.shape[0]]
                with open(os.path.join(sdir, "force", f"{t:05d}.pkl"), "rb") as f:
                    force = pickle.load(f)
                if not isinstance(force, np.ndarray) or force.shape != (105, 185):
                    fail(f"{sdir}: force/{t:05d}.pkl is not a 105 x 185 array")
                seq["force_kpa_sums"].append(float((force.astype(np.float64) / 2.7125).sum()))
            for c in cameras:
                if plus:
                    errors = []
                    for t in range(n):
                        cal = meta["camera_calibrations"][str(c)][str(t)]
                        errors.append(corner_error(np.array(cal["homography"], dtype=np.float64), corners[c]))
                        imgpts = np.array(cal["imgpts"], dtype=np.float64)
                        expected = np.array([corners[c][1], corners[c][2], corners[c][3], corners[c][0]])
                        errors.append(float(np.max(np.linalg.norm(imgpts - expected, axis=1))))
                    seq["corner_error_px"][str(c)] = max(errors)
                else:
                    H = loader_homography(meta["camera_calibrations"][str(c)])
                    seq["corner_error_px"][str(c)] = corner_error(H, corners[c])
            seq["participant_keys"] = meta["participant"]
            out["sequences"].append(seq)
    print(json.dumps(out))


if __name__ == "__main__":
    main()
