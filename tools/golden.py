#!/usr/bin/python3
"""Golden reference data for the C executor: a seeded model file and PyTorch float64 outputs.

    tools/golden.py --n-lights 3 --seed 1234 --frames a.png b.png --out DIR [--force]

writes into DIR
    model-nN.plm             the seeded model, written exactly as `tools/export.py --seed` does
                             (same functions: build_seeded, folded tensors, metadata, writer)
    ref-nN-<stem>.f32        per frame: little-endian float32
                             z[3072], dir[3N], distance[N], size[N], rgb[3N], ambient[3]
                             (dir and rgb light-major: light i at [3i, 3i+3))
    golden-nN.json           how it was made: command, seed, torch version, frames with sha256,
                             layout, date
The reference is the UNFOLDED model (tools/model.py) run in float64 on the frame's u8 pixels
normalised by model.preprocess; frames must already be input_w x input_h pixels so that no
resize differs between C and Python. tests/golden_check.c compares the C outputs with these.
"""

import argparse
import datetime
import hashlib
import json
import os
import sys

import numpy as np
import torch
from PIL import Image

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import export  # noqa: E402
import plm  # noqa: E402
from model import preprocess  # noqa: E402

LAYOUT = ("z", "dir", "distance", "size", "rgb", "ambient")


def read_frame(path, h, w):
    """u8 RGB [h, w, 3] of an 8-bit PNG of exactly w x h pixels. PNG only, 8 bits per sample:
    lossy decoders and 16-bit scaling may differ between PIL and OpenCV by a code value."""
    with open(path, "rb") as f:
        head = f.read(26)
    if len(head) < 26 or head[:8] != b"\x89PNG\r\n\x1a\n" or head[12:16] != b"IHDR":
        raise ValueError(f"{path}: not a PNG file (golden frames must be PNG)")
    if head[24] != 8:
        raise ValueError(f"{path}: {head[24]}-bit PNG, golden frames must have 8 bits per sample")
    with Image.open(path) as im:
        if im.size != (w, h):
            raise ValueError(f"{path}: {im.size[0]}x{im.size[1]} pixels, the model input is "
                             f"{w}x{h} (golden frames are used as they are, never resized)")
        if im.mode not in ("RGB", "RGBA", "L", "LA", "P"):
            raise ValueError(f"{path}: PNG mode {im.mode}, expected RGB, RGBA, gray or palette")
        # as port/image_io.cpp: gray expanded to RGB, alpha dropped (not composited)
        rgb = im.convert("RGBA").convert("RGB") if im.mode == "P" else im.convert("RGB")
        return np.array(rgb, dtype=np.uint8)


def reference(model, frame):
    """The unfolded model's outputs in float64 for one u8 frame, flattened in LAYOUT order."""
    with torch.no_grad():
        out = model(preprocess(frame, dtype=torch.float64))
    return np.concatenate([out[k][0].flatten().numpy() for k in LAYOUT])


def main(argv=None):
    ap = argparse.ArgumentParser(description="Write a seeded model and PyTorch float64 reference "
                                 "outputs for the golden test (tests/test_golden.sh).")
    ap.add_argument("--n-lights", type=int, required=True, choices=(2, 3, 5))
    ap.add_argument("--seed", type=int, required=True)
    ap.add_argument("--frames", nargs="+", required=True, metavar="PNG",
                    help="frames of exactly the model input size (default 256x192)")
    ap.add_argument("--out", required=True, metavar="DIR", help="output folder (created)")
    ap.add_argument("--input", type=export.parse_hw, default=(192, 256), metavar="HxW")
    ap.add_argument("--force", action="store_true", help="replace existing outputs")
    args = ap.parse_args(argv)
    n = args.n_lights
    h, w = args.input

    try:
        stems = [os.path.splitext(os.path.basename(f))[0] for f in args.frames]
        if len(set(stems)) != len(stems):
            raise ValueError("two frames have the same name stem; their outputs would collide")
        frames = [read_frame(f, h, w) for f in args.frames]
        os.makedirs(args.out, exist_ok=True)
        model_path = os.path.join(args.out, f"model-n{n}.plm")
        ref_paths = [os.path.join(args.out, f"ref-n{n}-{s}.f32") for s in stems]
        json_path = os.path.join(args.out, f"golden-n{n}.json")
        if not args.force:
            for p in [model_path, json_path] + ref_paths:
                if os.path.lexists(p):
                    raise FileExistsError(f"{p} exists (use --force to replace)")

        model = export.build_seeded(n, args.seed, (h, w))
        tensors = export.checked_tensors(model)
        meta = export.metadata(model, export.seeded_provenance(args.seed))
        plm.write_plm(model_path, meta, tensors, force=args.force)

        model = model.double().eval()
        records = []
        for path, frame, ref_path in zip(args.frames, frames, ref_paths):
            ref = reference(model, frame)
            if not np.isfinite(ref).all():
                raise RuntimeError(f"{path}: non-finite reference output")
            ref.astype("<f4").tofile(ref_path)
            with open(path, "rb") as f:
                digest = hashlib.sha256(f.read()).hexdigest()
            records.append({"frame": os.path.basename(path), "sha256": digest,
                            "ref": os.path.basename(ref_path), "values": int(ref.size)})
            print(f"{ref_path}: {ref.size} values")
    except (OSError, ValueError, RuntimeError, plm.PlmError) as e:
        print(f"golden: {e}", file=sys.stderr)
        return 1

    sizes = {"z": 3072, "dir": 3 * n, "distance": n, "size": n, "rgb": 3 * n, "ambient": 3}
    with open(model_path, "rb") as f:
        model_sha = hashlib.sha256(f.read()).hexdigest()
    info = {
        "command": " ".join(["tools/golden.py"] + (sys.argv[1:] if argv is None else list(argv))),
        "seed": args.seed,
        "n_lights": n,
        "input_hw": [h, w],
        "torch": torch.__version__,
        "numpy": np.__version__,
        "model": {"file": os.path.basename(model_path), "sha256": model_sha,
                  "provenance": meta["provenance"]},
        "reference": "tools/model.py ParLightNet, unfolded, float64, eval mode; frames as u8 "
                     "RGB normalised by model.preprocess, no resize",
        "layout": [{"name": k, "count": sizes[k]} for k in LAYOUT],
        "dtype": "float32 little-endian",
        "frames": records,
        "date": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ"),
    }
    tmp = json_path + ".tmp"
    with open(tmp, "w") as f:
        json.dump(info, f, indent=1)
        f.write("\n")
    os.replace(tmp, json_path)
    return 0


if __name__ == "__main__":
    sys.exit(main())
