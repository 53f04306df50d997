#!/usr/bin/python3
"""pvcap.torch.PressureDataset on the export fixture's session (see test_pvcap_python.py), with
Debian's python3-torch: items, windows in ticks, labels, and a DataLoader with workers."""
import glob
import os
import tempfile
import unittest

import numpy as np
import torch
from torch.utils.data import DataLoader

import pvcap
from pvcap.torch import PressureDataset
from pvcap_fixture import only_session


def order(loader):
    return [(s, int(i), c) for batch in loader for s, i, c in zip(batch["session"], batch["sample"], batch["camera"])]


class PressureDatasetTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.folder = only_session()
        cls.ds = PressureDataset(cls.folder, cameras=["cam0", 1], crop="paper", size=(96, 80), ticks=[-1, 0])

    def test_items(self):
        ds, s = self.ds, pvcap.Session(self.folder)
        self.assertGreater(len(ds), 50)
        item = ds[len(ds) // 2]
        self.assertEqual(item["image"].shape, (2, 3, 80, 96))
        self.assertEqual(item["image"].dtype, torch.uint8)
        self.assertEqual(item["pressure"].shape, (2, 80, 96))
        self.assertEqual(item["pressure"].dtype, torch.float32)
        self.assertEqual(item["force"].shape, (2,))
        t = item["tick"].tolist()
        self.assertEqual(t[1] - t[0], 1, "the window is in ticks")
        self.assertEqual(item["participant"], "P017")
        self.assertIn(item["hand"], ("left", "right"))
        self.assertIn(item["force_level"], ("low", "high"))
        self.assertIn(item["camera"], ("cam0", "cam1"))
        # The item's last frame is the sample's, as the reader gives it.
        i, cam = item["sample"], s.camera_index(item["camera"])
        np.testing.assert_array_equal(item["image"][1].permute(1, 2, 0).numpy(),
                                      s.image(i, cam, crop="paper", size=(96, 80)))
        np.testing.assert_array_equal(item["pressure"][1].numpy(),
                                      s.pressure_in_camera(i, cam, crop="paper", size=(96, 80)))
        self.assertAlmostEqual(float(item["force"][1]), s.force(i), places=4)
        # Only samples of takes that are done, and the labels are their take's.
        take = s.take_of(i)
        self.assertEqual((take["hand"], take["force_level"]), (item["hand"], item["force_level"]))

    def test_takes_filter(self):
        high = PressureDataset(self.folder, cameras=[0], crop="paper", size=(96, 80),
                               takes=lambda t: t["force_level"] == "high")
        self.assertGreater(len(high), 10)
        self.assertTrue(all(high[k]["force_level"] == "high" for k in range(0, len(high), 7)))

    def test_a_dataloader_with_workers_is_deterministic_for_a_seed(self):
        def loader(seed):
            g = torch.Generator()
            g.manual_seed(seed)
            return DataLoader(self.ds, batch_size=8, shuffle=True, num_workers=2, generator=g)

        first = order(loader(7))
        self.assertEqual(len(first), len(self.ds))
        self.assertEqual(sorted(first), sorted(set(first)), "each item once")
        self.assertEqual(order(loader(7)), first, "the same seed, the same order")
        self.assertNotEqual(order(loader(8)), first)
        batch = next(iter(loader(7)))
        self.assertEqual(batch["image"].shape, (8, 2, 3, 80, 96))

    def test_the_crop_cache_keeps_each_crop_once_bit_exact(self):
        with tempfile.TemporaryDirectory(prefix="pvcap-py-cache-") as cache:
            cached = PressureDataset(self.folder, cameras=["cam0", 1], crop="paper", size=(96, 80), ticks=[-1, 0],
                                     cache=cache)
            picks = [len(cached) // 3, len(cached) // 2, len(cached) - 1]
            first = [cached[k] for k in picks]  # the first epoch: read from the store, kept
            files = glob.glob(os.path.join(cache, "*", "*.npy"))
            self.assertEqual(len(files), 2 * len(picks), "one file per crop read (windows of two ticks)")
            again = [cached[k] for k in picks]  # a later epoch: read from the cache
            self.assertEqual(len(glob.glob(os.path.join(cache, "*", "*.npy"))), 2 * len(picks), "read from the cache")
            for k, a, b in zip(picks, first, again):
                plain = self.ds[k]  # the store's item, no cache
                for item in (a, b):
                    self.assertEqual(item["image"].dtype, torch.uint8)
                    self.assertTrue(torch.equal(item["image"], plain["image"]), f"item {k}: not the store's pixels")
                    self.assertTrue(torch.equal(item["pressure"], plain["pressure"]))
            # A damaged cached crop is named, with what to do, never read as pixels.
            with open(files[0], "r+b") as f:
                f.truncate(20)
            fresh = PressureDataset(self.folder, cameras=["cam0", 1], crop="paper", size=(96, 80), ticks=[-1, 0],
                                    cache=cache)
            with self.assertRaises(pvcap.StoreError) as e:
                for k in picks:
                    fresh[k]
            self.assertIn("damaged cache", str(e.exception))

    def test_a_camera_without_a_paper_crop_or_a_wrong_source_is_named(self):
        with self.assertRaises(pvcap.StoreError) as e:
            PressureDataset("/nonexistent", crop="paper")
        self.assertIn("/nonexistent", str(e.exception))
        with self.assertRaises(ValueError):
            PressureDataset(self.folder, split="train")


if __name__ == "__main__":
    unittest.main(verbosity=2)
