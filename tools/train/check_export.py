#!/usr/bin/python3
"""Checks that an exported .plm gives in C what its training checkpoint gives in PyTorch.

    tools/train/check_export.py --ckpt CKPT --plm MODEL.plm --frame F.png [--parlight build/parlight]
                                [--tol 1e-3]

Runs the checkpoint's ParLightNet (unfolded, float64, eval mode, as tools/golden.py does) on the
frame's u8 pixels (a PNG of exactly the model's input size, read as golden.read_frame reads it),
and `parlight estimate --model MODEL.plm --input F.png`; compares every output (dir, distance,
solid_angle_sr, rgb, ambient) by its relative L2 error. Exit 0 when all are within --tol.
"""

import argparse
import json
import os
import subprocess
import sys

import numpy as np
import torch

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.dirname(HERE))
import golden  # noqa: E402
import train  # noqa: E402
from model import ParLightNet, preprocess  # noqa: E402


def main(argv=None):
    ap = argparse.ArgumentParser(description="Compare an exported .plm (C) with its checkpoint "
                                 "(PyTorch float64) on one frame.")
    ap.add_argument("--ckpt", required=True)
    ap.add_argument("--plm", required=True)
    ap.add_argument("--frame", required=True, help="PNG of exactly the model input size")
    ap.add_argument("--parlight", default=os.path.join(os.path.dirname(HERE), "..",
                                                      os.environ.get("BUILD", "build"), "parlight"))
    ap.add_argument("--tol", type=float, default=1e-3)
    args = ap.parse_args(argv)
    try:
        ck = train.load_ckpt(args.ckpt)
        cfg = ck["config"]
        model = ParLightNet(cfg["n_lights"], tuple(cfg["input"]))
        # train.py's auxiliary heads (--w-map, --w-src) are training only: never exported
        model.load_state_dict(train.without_aux(ck["model"]))
        model = model.double().eval()
        h, w = cfg["input"]
        frame = golden.read_frame(args.frame, h, w)
        with torch.no_grad():
            ref = model(preprocess(frame, dtype=torch.float64))
        r = subprocess.run([args.parlight, "estimate", "--model", args.plm, "--input", args.frame,
                            "--anchor", "off"], capture_output=True, text=True)
        if r.returncode != 0:
            raise RuntimeError(f"parlight estimate: exit {r.returncode}: {r.stderr.strip()}")
        got = json.loads(r.stdout.splitlines()[0])
    except (OSError, ValueError, RuntimeError, KeyError, IndexError) as e:
        print(f"check_export: {e}", file=sys.stderr)
        return 1
    lights = got["lights"]
    pairs = {
        "dir": (np.array([li["dir"] for li in lights]), ref["dir"][0].numpy()),
        "distance": (np.array([li["distance_m"] for li in lights]), ref["distance"][0].numpy()),
        "size": (np.array([li["solid_angle_sr"] for li in lights]), ref["size"][0].numpy()),
        "rgb": (np.array([li["rgb"] for li in lights]), ref["rgb"][0].numpy()),
        "ambient": (np.array(got["ambient"]), ref["ambient"][0].numpy()),
    }
    worst = 0.0
    parts = []
    for k, (c, p) in pairs.items():
        if c.shape != p.shape:
            print(f"check_export: {k}: C gives shape {c.shape}, PyTorch {p.shape}", file=sys.stderr)
            return 1
        e = float(np.linalg.norm(c - p) / max(np.linalg.norm(p), 1e-30))
        worst = max(worst, e)
        parts.append(f"{k} {e:.2e}")
    ok = worst <= args.tol
    print(f"C vs PyTorch float64 on {os.path.basename(args.frame)} (relative L2): "
          + ", ".join(parts) + f" -> {'ok' if ok else 'FAIL'} (tol {args.tol:g})")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
