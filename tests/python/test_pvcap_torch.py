#!/usr/bin/python3
"""pvcap.torch.PressureDataset on the export fixture's session (see test_pvcap_python.py), with
Debian's python3-torch: items, windows in ticks, labels, and a DataLoader with workers."""
import glob
import os
import tempfile
import unittest

import cv2
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

    def test_the_crop_cache_keeps_each_crop_once_as_a_jpeg(self):
        with tempfile.TemporaryDirectory(prefix="pvcap-py-cache-") as cache:
            cached = PressureDataset(self.folder, cameras=["cam0", 1], crop="paper", size=(96, 80), ticks=[-1, 0],
                                     cache=cache)
            k = len(cached) // 3
            first = cached[k]
            files = glob.glob(os.path.join(cache, "*", "*.jpg"))
            self.assertEqual(len(files), 2, "one JPEG per crop read (a window of two ticks)")
            again = cached[k]
            torch.testing.assert_close(again["image"], first["image"], rtol=0, atol=0)
            self.assertEqual(len(glob.glob(os.path.join(cache, "*", "*.jpg"))), 2, "read from the cache")
            plain = self.ds[k]
            # The store's crop, through JPEG at quality 95: the cache's pixels.
            for t in range(2):
                rgb = plain["image"][t].permute(1, 2, 0).numpy()
                ok, jpeg = cv2.imencode(".jpg", cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR), [cv2.IMWRITE_JPEG_QUALITY, 95])
                expected = cv2.cvtColor(cv2.imdecode(jpeg, cv2.IMREAD_COLOR), cv2.COLOR_BGR2RGB)
                np.testing.assert_array_equal(first["image"][t].permute(1, 2, 0).numpy(), expected)
            torch.testing.assert_close(first["pressure"], plain["pressure"])

    def test_a_camera_without_a_paper_crop_or_a_wrong_source_is_named(self):
        with self.assertRaises(pvcap.StoreError) as e:
            PressureDataset("/nonexistent", crop="paper")
        self.assertIn("/nonexistent", str(e.exception))
        with self.assertRaises(ValueError):
            PressureDataset(self.folder, split="train")


if __name__ == "__main__":
    unittest.main(verbosity=2)
