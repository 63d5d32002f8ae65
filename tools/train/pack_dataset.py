#!/usr/bin/env python3
"""Packs a make_dataset.py folder small enough to travel to a remote GPU, and unpacks it there.

    pack_dataset.py pack   --data DIR --out PACK [--quality 90] [--init ENCODER.pt]
    pack_dataset.py unpack PACK --out DIR [--init-out ENCODER.pt]
    pack_dataset.py pack-net CKPT STEM          # STEM.part0, STEM.part1, ... (<= 15 MiB each)
    pack_dataset.py unpack-net STEM OUT.pt      # a train.py checkpoint again (float32)

A machine lent for training may take only tens of MiB (docs/TRAINING.md, "Training on a remote
GPU"): 4,800 crops of 256 x 192 as PNG are 390 MB with their ground truth, most of it the PNGs
and the 32 x 16 maps written as JSON text. The pack holds

- crops.zip: each crop as lossy WebP (--quality, default 90: about 7.5 KB a crop), stored in
  one zip file (one file instead of thousands: a device call counts every file's overhead);
- gt.json.xz: every crop's ground-truth JSON, except the radiance map's numbers;
- maps.npy.xz: the radiance maps as float16 log1p(radiance), [N, H, W, 3]: the log1p that
  train.py's map loss compares is kept to 2^-11 of itself (the radiance to 0.05% x its log1p,
  0.5% at 10^4);
- index.tsv: the source index with the crops' new names;
- encoder.pt.xz (with --init): a distill.py / train.py checkpoint's features.* tensors in
  float16 (the training start; --init-out writes them back as float32 where train.py --init
  reads them).

unpack writes a folder train.py reads like the original: index.tsv, crops/*.webp, one JSON per
crop. pack-net brings a trained network back the same way: a train.py checkpoint's network (no
optimizer, no training-only head) with its tensors of 4096 values or more as float16, split
into parts of at most 15 MiB (17.4 MB in two parts for the 96x128 or 192x256 network);
unpack-net joins them into a checkpoint train.py --export-only exports. A network trained on a
pack is not the one the PNGs give: the pixels carry WebP's loss, the maps and the encoder
float16's rounding, and the network brought back float16's rounding of its large tensors.
tools/train/remote_run.sh runs the whole round on the remote machine.
"""

import argparse
import io
import json
import lzma
import os
import sys
import zipfile

import numpy as np
from PIL import Image

HEADER = "png\tjson\tpanorama\tscene"


def read_rows(data):
    path = os.path.join(data, "index.tsv")
    if not os.path.isfile(path):
        raise ValueError(f"{data}: not a make_dataset.py folder or pack (no index.tsv)")
    with open(path, encoding="utf-8") as f:
        lines = [ln.rstrip("\n") for ln in f]
    if not lines or lines[0] != HEADER:
        raise ValueError(f"{path}: not a make_dataset.py index (header {HEADER!r})")
    rows = [ln.split("\t") for ln in lines[1:] if ln]
    for i, r in enumerate(rows):
        if len(r) != 4:
            raise ValueError(f"{path}: line {i + 2}: expected 4 columns, got {len(r)}")
    return rows


def pack(data, out, quality, init):
    if os.path.exists(out) and os.listdir(out):
        raise ValueError(f"{out}: exists and is not empty (choose a new folder)")
    rows = read_rows(data)
    os.makedirs(out, exist_ok=True)
    gts, maps, new_rows = [], [], []
    zf = zipfile.ZipFile(os.path.join(out, "crops.zip"), "w", zipfile.ZIP_STORED)
    for png, js, pano, scene in rows:
        name = os.path.splitext(os.path.basename(png))[0] + ".webp"
        buf = io.BytesIO()
        with Image.open(os.path.join(data, png)) as im:
            im.convert("RGB").save(buf, "WEBP", quality=quality, method=6)
        zf.writestr("crops/" + name, buf.getvalue())
        with open(os.path.join(data, js), encoding="utf-8") as f:
            obj = json.load(f)
        rm = obj.get("radiance_map")
        if not isinstance(rm, dict) or not isinstance(rm.get("rgb"), list):
            raise ValueError(f"{js}: no radiance_map (make the dataset with --gt-map)")
        w, h = rm["width"], rm["height"]
        a = np.asarray(rm["rgb"], np.float64).reshape(h, w, 3)
        if not np.isfinite(a).all() or (a < 0).any() or np.log1p(a).max() > 60000:
            raise ValueError(f"{js}: radiance_map has negative, non-finite or huge values")
        maps.append(np.log1p(a).astype(np.float16))
        obj["radiance_map"] = {k: v for k, v in rm.items() if k != "rgb"}
        gts.append(obj)
        new_rows.append(["crops/" + name, "crops/" + os.path.splitext(name)[0] + ".json",
                         pano, scene])
    zf.close()
    if len({m.shape for m in maps}) != 1:
        raise ValueError(f"{data}: the crops' radiance maps differ in size")
    with lzma.open(os.path.join(out, "gt.json.xz"), "wt", encoding="utf-8", preset=9) as f:
        json.dump(gts, f, separators=(",", ":"))
    buf = io.BytesIO()
    np.save(buf, np.stack(maps))
    with lzma.open(os.path.join(out, "maps.npy.xz"), "wb", preset=9) as f:
        f.write(buf.getvalue())
    with open(os.path.join(out, "index.tsv"), "w", encoding="utf-8") as f:
        f.write(HEADER + "\n" + "".join("\t".join(r) + "\n" for r in new_rows))
    if init:
        import torch
        ck = torch.load(init, map_location="cpu", weights_only=False)
        sd = ck.get("model") if isinstance(ck, dict) else None
        feats = {k: v.half() if v.is_floating_point() else v
                 for k, v in (sd or {}).items() if k.startswith("features.")}
        if not feats:
            raise ValueError(f"{init}: no features.* tensors in its 'model'")
        buf = io.BytesIO()
        torch.save({"model": feats, "source": os.path.basename(init)}, buf)
        with lzma.open(os.path.join(out, "encoder.pt.xz"), "wb", preset=9) as f:
            f.write(buf.getvalue())
    return len(rows)


def unpack(src, out, init_out):
    if os.path.exists(out) and os.listdir(out):
        raise ValueError(f"{out}: exists and is not empty (choose a new folder)")
    rows = read_rows(src)
    with lzma.open(os.path.join(src, "gt.json.xz"), "rt", encoding="utf-8") as f:
        gts = json.load(f)
    with lzma.open(os.path.join(src, "maps.npy.xz"), "rb") as f:
        maps = np.load(io.BytesIO(f.read()))
    if not (len(gts) == len(rows) == maps.shape[0]):
        raise ValueError(f"{src}: {len(rows)} index rows, {len(gts)} ground truths, "
                         f"{maps.shape[0]} maps")
    os.makedirs(out, exist_ok=True)
    try:
        zf = zipfile.ZipFile(os.path.join(src, "crops.zip"))
    except zipfile.BadZipFile as e:
        raise ValueError(f"{src}/crops.zip: {e}") from None
    with zf:
        names = set(zf.namelist())
        missing = [r[0] for r in rows if r[0] not in names]
        if missing:
            raise ValueError(f"{src}/crops.zip: no {missing[0]} ({len(missing)} crops missing)")
        zf.extractall(out, [r[0] for r in rows])
    for (_img, js, _pano, _scene), obj, m in zip(rows, gts, maps):
        obj["radiance_map"]["rgb"] = np.expm1(m.astype(np.float32)).reshape(-1).tolist()
        with open(os.path.join(out, js), "w", encoding="utf-8") as f:
            json.dump(obj, f)
    with open(os.path.join(out, "index.tsv"), "w", encoding="utf-8") as f:
        f.write(HEADER + "\n" + "".join("\t".join(r) + "\n" for r in rows))
    if init_out:
        import torch
        with lzma.open(os.path.join(src, "encoder.pt.xz"), "rb") as f:
            ck = torch.load(io.BytesIO(f.read()), map_location="cpu", weights_only=False)
        torch.save({"model": {k: v.float() if v.is_floating_point() else v
                              for k, v in ck["model"].items()}, "source": ck.get("source")},
                   init_out)
    return len(rows)


PART = 15 << 20


def pack_net(ckpt, stem):
    import torch
    import train    # torch and the checkpoint helpers: only where a network is packed
    ck = train.load_ckpt(ckpt)
    if not isinstance(ck, dict) or not isinstance(ck.get("model"), dict) or "config" not in ck:
        raise ValueError(f"{ckpt}: not a train.py checkpoint (no model/config)")
    sd = {k: (v.half() if v.is_floating_point() and v.numel() >= 4096 else v)
          for k, v in train.without_aux(ck["model"]).items()}
    buf = io.BytesIO()
    torch.save({"model": sd, "config": ck["config"], "state": ck.get("state", {}),
                "packed_from": os.path.basename(ckpt)}, buf)
    b = buf.getvalue()
    for i in range(0, len(b), PART):
        with open(f"{stem}.part{i // PART}", "wb") as f:
            f.write(b[i:i + PART])
    return (len(b) + PART - 1) // PART


def unpack_net(stem, out):
    import torch
    if os.path.lexists(out):
        raise ValueError(f"{out} exists; not replacing it")
    parts, i = [], 0
    while os.path.isfile(f"{stem}.part{i}"):
        parts.append(f"{stem}.part{i}")
        i += 1
    if not parts:
        raise ValueError(f"{stem}.part0: no such file")
    b = b"".join(open(p, "rb").read() for p in parts)
    try:
        ck = torch.load(io.BytesIO(b), map_location="cpu", weights_only=False)
    except Exception as e:  # a missing or damaged part: pickle / zip errors of many types
        raise ValueError(f"{stem}.part0..{len(parts) - 1}: not a pack-net network "
                         f"({type(e).__name__}: {e})") from None
    ck["model"] = {k: (v.float() if v.dtype == torch.float16 else v)
                   for k, v in ck["model"].items()}
    torch.save(ck, out)
    return len(parts)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    p = sub.add_parser("pack")
    p.add_argument("--data", required=True, help="a make_dataset.py folder (with --gt-map)")
    p.add_argument("--out", required=True, help="a new folder for the pack")
    p.add_argument("--quality", type=int, default=90, help="WebP quality, 1..100 (default 90)")
    p.add_argument("--init", help="a checkpoint whose features.* tensors travel as float16")
    u = sub.add_parser("unpack")
    u.add_argument("pack")
    u.add_argument("--out", required=True, help="a new folder for the dataset")
    u.add_argument("--init-out", help="write the pack's encoder here as float32")
    pn = sub.add_parser("pack-net")
    pn.add_argument("ckpt", help="a train.py checkpoint (final.pt)")
    pn.add_argument("stem", help="the parts are written as STEM.part0, STEM.part1, ...")
    un = sub.add_parser("unpack-net")
    un.add_argument("stem")
    un.add_argument("out", help="the checkpoint to write (float32; not replaced)")
    args = ap.parse_args(argv)
    try:
        if args.cmd == "pack-net":
            print(f"pack_dataset: {pack_net(args.ckpt, args.stem)} parts", file=sys.stderr)
            return 0
        if args.cmd == "unpack-net":
            print(f"pack_dataset: joined {unpack_net(args.stem, args.out)} parts", file=sys.stderr)
            return 0
        if args.cmd == "pack":
            if not 1 <= args.quality <= 100:
                raise ValueError(f"--quality {args.quality}: expected 1..100")
            n = pack(args.data, args.out, args.quality, args.init)
        else:
            if args.init_out and not os.path.isfile(os.path.join(args.pack, "encoder.pt.xz")):
                raise ValueError(f"{args.pack}: --init-out, but the pack holds no encoder.pt.xz")
            n = unpack(args.pack, args.out, args.init_out)
    except (OSError, ValueError, KeyError, lzma.LZMAError, zipfile.BadZipFile) as e:
        print(f"pack_dataset: {e}", file=sys.stderr)
        return 1
    print(f"pack_dataset: {args.cmd}ed {n} crops", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
