#!/usr/bin/python3
"""Writes the seed corpora of the libFuzzer targets (tests/fuzz/corpus/<target>/, docs/TESTING.md).

    /usr/bin/python3 tools/fuzz-corpus.py [--out tests/fuzz/corpus]

Small valid inputs of every kind each target reads, made from the tree's fixtures so that a
seed is a few KB: the fuzzer mutates from there. Deterministic (same bytes on every run).
  plm          the shipped models' metadata with their first tensors cut to <= 64 elements
               (fp32 and int8: f32, s8, s32, u8 tensors, quantisation scales)
  lights_json  tests/data/frames-gt files, a minimal lighting, an estimate-style line, escapes
  hdr          Radiance RGBE: flat, new-style RLE, old-style RLE, +Y orientation, EXPOSURE line
  exr          OpenEXR written here by hand (the format is small): scanline half RGB, float RGB
               with ZIPS compression, luminance Y, tiled RGB
  image        JPEG (baseline, progressive, grey, CMYK, EXIF orientation 6) and PNG (RGB, grey,
               palette with tRNS, RGBA, 16-bit), from a tests/data/frames frame cut to 16x12
Only the seeds are written here: regression inputs (crash-*) in the same folders are kept.
"""

import argparse
import io
import json
import os
import struct
import sys
import zlib

import numpy as np
from PIL import Image

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "tools"))
import plm  # noqa: E402


def write(folder, name, data):
    os.makedirs(folder, exist_ok=True)
    with open(os.path.join(folder, name), "wb") as f:
        f.write(data)


def plm_seeds(out):
    for src, name in (("models/parlight-n3.plm", "fp32.plm"),
                      ("models/parlight-n3-int8.plm", "int8.plm")):
        meta, tensors, info = plm.read_plm(os.path.join(ROOT, src))
        meta = {k: v for k, v in meta.items() if not k.startswith("provenance")
                and not k.endswith("_fit")}
        small, quant = [], {}
        for tname in list(tensors)[:8]:
            a = tensors[tname].reshape(-1)[:64]
            small.append((tname, a))
            e = info["entries"][tname]
            if e["scale"] or e["zero_point"]:
                quant[tname] = (e["scale"], e["zero_point"])
        write(out, name, plm.encode_plm(meta, small, quant))


def json_seeds(out):
    gt = os.path.join(ROOT, "tests/data/frames-gt")
    for name in ("studio-softbox.json", "esplanade-spots.json"):
        with open(os.path.join(gt, name), "rb") as f:
            write(out, name, f.read())
    write(out, "minimal.json", b'{"lights":[],"ambient":[0,0,0]}')
    write(out, "estimate-line.json",
          b'{"frame":1,"t_ms":12.5,"lights":[{"dir":[0,1,0],"distance_m":2.5,'
          b'"solid_angle_sr":0.1,"rgb":[1e3,2.5e-3,0]}],"ambient":[0.1,0.2,0.3],'
          b'"sh":[[1,2,3],[4,5,6]],"primary":{"dir":[0,1,0]},"ok":true,"none":null}')
    write(out, "escapes.json",
          b'{"note":"tab\\t nl\\n \\u00e9 \\ud83d\\ude00 \\"q\\" \\\\","lights":[{"dir":'
          b'[-1e-3,0.5,-0.25],"distance_m":1E+1,"solid_angle_sr":3.5e-2,"rgb":[0.0,1,2]}],'
          b'"ambient":[1,1,1],"deep":[[[[{"a":[]}]]]]}')


def rgbe(rgb):
    """float RGB (h, w, 3) -> RGBE bytes (h, w, 4), as Radiance's float2rgbe."""
    v = rgb.max(axis=2)
    m, e = np.frexp(v)
    scale = np.where(v > 1e-32, m * 256.0 / np.where(v > 0, v, 1), 0)
    out = np.zeros(rgb.shape[:2] + (4,), np.uint8)
    out[..., :3] = np.clip(rgb * scale[..., None], 0, 255).astype(np.uint8)
    out[..., 3] = np.where(v > 1e-32, e + 128, 0).astype(np.uint8)
    return out


def rle_new(px):
    """One new-style RLE scanline: 2 2 hi lo, then each channel as runs / literals."""
    w = px.shape[0]
    b = bytearray([2, 2, w >> 8, w & 255])
    for c in range(4):
        ch, i = px[:, c], 0
        while i < w:
            run = 1
            while i + run < w and run < 127 and ch[i + run] == ch[i]:
                run += 1
            if run >= 3:
                b += bytes([128 + run, ch[i]])
                i += run
            else:
                n = 1
                while i + n < w and n < 128 and not (i + n + 2 < w and ch[i + n] == ch[i + n + 1]
                                                     == ch[i + n + 2]):
                    n += 1
                b += bytes([n]) + bytes(ch[i:i + n])
                i += n
    return bytes(b)


def hdr_seeds(out):
    rng = np.random.default_rng(25)
    img = rng.random((4, 8, 3)).astype(np.float32) * 4
    img[:, 2:6] = [0.5, 1.0, 2.0]  # runs for the RLE
    px = rgbe(img)
    head = b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n"
    write(out, "flat.hdr", head + b"-Y 4 +X 8\n" + px.tobytes())
    write(out, "rle.hdr", head + b"-Y 4 +X 8\n" + b"".join(rle_new(row) for row in px))
    write(out, "flipped.hdr", b"#?RGBE\nEXPOSURE=1.5\nFORMAT=32-bit_rle_rgbe\n\n+Y 4 +X 8\n"
          + px.tobytes())
    old = bytearray()
    for row in px:  # old-style: a pixel, then 1 1 1 n repeats it n times
        old += bytes(row[0]) + bytes([1, 1, 1, 3]) + row[4:].tobytes()
    write(out, "old-rle.hdr", head + b"-Y 4 +X 8\n" + bytes(old))


def exr_attr(name, typ, value):
    return name.encode() + b"\0" + typ.encode() + b"\0" + struct.pack("<i", len(value)) + value


def exr_header(channels, w, h, compression, tiled=None):
    chl = b"".join(n.encode() + b"\0" + struct.pack("<iB3xii", t, 0, s, s)
                   for n, t, s in channels) + b"\0"
    box = struct.pack("<iiii", 0, 0, w - 1, h - 1)
    attrs = [exr_attr("channels", "chlist", chl),
             exr_attr("compression", "compression", bytes([compression])),
             exr_attr("dataWindow", "box2i", box), exr_attr("displayWindow", "box2i", box),
             exr_attr("lineOrder", "lineOrder", b"\0"),
             exr_attr("pixelAspectRatio", "float", struct.pack("<f", 1)),
             exr_attr("screenWindowCenter", "v2f", struct.pack("<ff", 0, 0)),
             exr_attr("screenWindowWidth", "float", struct.pack("<f", 1))]
    if tiled:
        attrs.append(exr_attr("tiles", "tiledesc", struct.pack("<IIB", tiled[0], tiled[1], 0)))
    version = 2 | (0x200 if tiled else 0)
    return b"\x76\x2f\x31\x01" + struct.pack("<I", version) + b"".join(attrs) + b"\0"


def exr_zip(raw):
    """OpenEXR's ZIP: bytes split even/odd, then a delta predictor, then zlib."""
    t = np.frombuffer(raw, np.uint8)
    t = np.concatenate([t[0::2], t[1::2]]).astype(np.int32)
    d = t.copy()
    d[1:] = (t[1:] - t[:-1] + 128 + 256) & 255
    return zlib.compress(d.astype(np.uint8).tobytes())


def exr_scanlines(channels, planes, w, h, compression):
    """planes: {name: (h, w) array of the channel's dtype}; one line per chunk (NONE, ZIPS)."""
    head = exr_header(channels, w, h, compression)
    table_at = len(head)
    chunks, offs = [], []
    pos = table_at + 8 * h
    for y in range(h):
        raw = b"".join(planes[n][y].tobytes() for n, _, _ in channels)
        data = exr_zip(raw) if compression == 2 else raw
        if len(data) >= len(raw):
            data = raw  # OpenEXR stores a chunk raw when compression does not shrink it
        c = struct.pack("<ii", y, len(data)) + data
        offs.append(pos)
        chunks.append(c)
        pos += len(c)
    return head + struct.pack("<%dQ" % h, *offs) + b"".join(chunks)


def exr_seeds(out):
    rng = np.random.default_rng(25)
    w, h = 8, 4
    rgb = {c: (rng.random((h, w)) * 4).astype(np.float16) for c in "RGB"}
    half = [(c, 1, 1) for c in "BGR"]  # channels sorted by name, as OpenEXR stores them
    write(out, "half-none.exr", exr_scanlines(half, rgb, w, h, 0))
    rgbf = {c: v.astype(np.float32) for c, v in rgb.items()}
    rgbf["R"][:, :4] = 1.0  # something for ZIP to shrink
    write(out, "float-zips.exr", exr_scanlines([(c, 2, 1) for c in "BGR"], rgbf, w, h, 2))
    write(out, "luma-none.exr", exr_scanlines([("Y", 1, 1)], {"Y": rgb["G"]}, w, h, 0))
    tw, th = 4, 4
    head = exr_header(half, w, h, 0, (tw, th))
    ntiles = (w // tw) * (h // th)
    pos, offs, chunks = len(head) + 8 * ntiles, [], []
    for ty in range(h // th):
        for tx in range(w // tw):
            data = b"".join(rgb[c][ty * th + y, tx * tw:(tx + 1) * tw].tobytes()
                            for y in range(th) for c in "BGR")
            chunk = struct.pack("<iiiii", tx, ty, 0, 0, len(data)) + data
            offs.append(pos)
            chunks.append(chunk)
            pos += len(chunk)
    write(out, "tiled-half.exr", head + struct.pack("<%dQ" % ntiles, *offs) + b"".join(chunks))


def image_seeds(out):
    src = Image.open(os.path.join(ROOT, "tests/data/frames/lab-lamps.jpg")).convert("RGB")
    small = src.resize((16, 12), Image.BILINEAR)

    def save(img, name, **kw):
        b = io.BytesIO()
        img.save(b, **kw)
        write(out, name, b.getvalue())

    save(small, "baseline.jpg", format="JPEG", quality=75)
    save(small, "progressive.jpg", format="JPEG", quality=60, progressive=True)
    save(small.convert("L"), "grey.jpg", format="JPEG", quality=75)
    save(small.convert("CMYK"), "cmyk.jpg", format="JPEG", quality=75)
    exif = Image.Exif()
    exif[0x0112] = 6
    save(small, "exif-rot6.jpg", format="JPEG", quality=75, exif=exif.tobytes())
    save(small, "rgb.png", format="PNG")
    save(small.convert("L"), "grey.png", format="PNG")
    pal = small.convert("P", palette=Image.ADAPTIVE, colors=8)
    save(pal, "palette-trns.png", format="PNG", transparency=0)
    rgba = small.copy()
    rgba.putalpha(200)
    save(rgba, "rgba.png", format="PNG")
    g16 = Image.fromarray((np.asarray(small.convert("L"), np.uint16) * 257), mode="I;16")
    save(g16, "grey16.png", format="PNG")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", default=os.path.join(ROOT, "tests/fuzz/corpus"))
    a = ap.parse_args()
    plm_seeds(os.path.join(a.out, "plm"))
    json_seeds(os.path.join(a.out, "lights_json"))
    hdr_seeds(os.path.join(a.out, "hdr"))
    exr_seeds(os.path.join(a.out, "exr"))
    image_seeds(os.path.join(a.out, "image"))


if __name__ == "__main__":
    main()
