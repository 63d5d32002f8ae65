#!/usr/bin/python3
"""Radiance .hdr reading for the tools and tests (numpy only, no torch): what port/hdr_io.c
writes, decoded as its reader decodes it. tools/train/sg.py and tests/viewer_check.py use it."""

import numpy as np


def read_rgbe(path):
    """A Radiance .hdr (as port/hdr_io.c writes it: -Y H +X W, new-style RLE or flat) as a
    float32 [H, W, 3] array; m, e decodes as (m + 0.5) * 2^(e - 136), e = 0 as 0."""
    with open(path, "rb") as f:
        data = f.read()
    if not (data.startswith(b"#?RADIANCE") or data.startswith(b"#?RGBE")):
        raise ValueError(f"{path}: not a Radiance file")
    pos = data.index(b"\n\n") + 2
    end = data.index(b"\n", pos)
    parts = data[pos:end].split()
    if len(parts) != 4 or parts[0] != b"-Y" or parts[2] != b"+X":
        raise ValueError(f"{path}: unsupported resolution line {data[pos:end]!r}")
    h, w = int(parts[1]), int(parts[3])
    pos = end + 1
    img = np.zeros((h, w, 4), np.uint8)
    for y in range(h):
        if (8 <= w < 32768 and data[pos] == 2 and data[pos + 1] == 2
                and (data[pos + 2] << 8 | data[pos + 3]) == w):
            pos += 4
            for c in range(4):
                x = 0
                while x < w:
                    n = data[pos]
                    pos += 1
                    if n > 128:
                        n -= 128
                        img[y, x:x + n, c] = data[pos]
                        pos += 1
                    else:
                        img[y, x:x + n, c] = np.frombuffer(data, np.uint8, n, pos)
                        pos += n
                    x += n
        else:
            img[y] = np.frombuffer(data, np.uint8, 4 * w, pos).reshape(w, 4)
            pos += 4 * w
    e = img[..., 3].astype(np.int32)
    scale = np.where(e > 0, np.ldexp(1.0, e - 136), 0.0)
    return ((img[..., :3].astype(np.float64) + 0.5) * scale[..., None]).astype(np.float32)
