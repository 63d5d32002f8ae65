#!/usr/bin/env python3
"""A tiny make_dataset.py-shaped folder for the training tools' tests (no ../shared needed):
4 crops of 128x96 (smooth gradients, 2 panoramas: one indoor, one outdoor) with 3 lights, an
ambient and a 32x16 radiance map each (values up to 2e4), and a checkpoint holding one
features.* tensor (and one other) for --init.

    tiny_dataset.py OUT_DIR ENCODER.pt
"""
import json
import os
import sys

import numpy as np
import torch
from PIL import Image

out, enc = sys.argv[1:]
os.makedirs(out + "/crops")
rng = np.random.default_rng(7)
rows = []
for i, (pano, scene) in enumerate([("train/a.exr", "indoor")] * 2 + [("train/b.exr", "outdoor")] * 2):
    img = (rng.random((96, 128, 3)) * 8 + np.linspace(0, 180, 128)[None, :, None]
           + np.linspace(0, 60, 96)[:, None, None] * (i + 1) / 4).astype(np.uint8)
    Image.fromarray(img).save(f"{out}/crops/c{i}.png")
    m = rng.random((16, 32, 3)) ** 6 * 2e4
    lights = [{"dir": list(map(float, v / np.linalg.norm(v))), "distance_m": 2.5,
               "solid_angle_sr": 0.3 + k, "rgb": [5.0 + k, 4.0, 3.0]}
              for k, v in enumerate(rng.normal(size=(3, 3)))]
    obj = {"lights": lights, "ambient": [0.1, 0.2, 0.3], "image": f"c{i}.png",
           "radiance_map": {"width": 32, "height": 16, "frame": "crop camera",
                            "rgb": [float(f"{v:.9g}") for v in m.reshape(-1)]}}
    with open(f"{out}/crops/c{i}.json", "w") as f:
        json.dump(obj, f)
    rows.append(f"crops/c{i}.png\tcrops/c{i}.json\t{pano}\t{scene}\n")
with open(out + "/index.tsv", "w") as f:
    f.write("png\tjson\tpanorama\tscene\n" + "".join(rows))
torch.save({"model": {"features.conv0.weight": torch.randn(8, 3, 3, 3),
                      "features.norm0.num_batches_tracked": torch.tensor(5),
                      "head.weight": torch.randn(2, 2)}}, enc)
