#!/usr/bin/python3
"""Writes small hostile image files ("decode bombs") for tests/test_decode_bombs.sh: each declares a
size far beyond what its bytes hold, so that a decoder that trusts the header before checking it
allocates gigabytes. Usage: decode_bombs.py OUTDIR. Files (a few KB each, made at test time and
never committed):

  rgbe_4to1.hdr   Radiance RGBE 32768x8192: one pixel per row, then old-style run codes
                  (1,1,1,n) repeating it to the end of the row: 12 bytes a row, ~98 KB.
  rgbe_2to1.hdr   the same at 23168x11584 (2:1, just under 2^28 pixels): ~139 KB.
  rgbe_ok.hdr     a legitimate 2:1 panorama, 2048x1024, same encoding, with one bright light.
  tiff_30k.tif    TIFF 30000x30000 RGB, deflate: every strip points at the same compressed
                  block of zeros (~9.5 KB; OpenCV's default limit of 2^30 pixels lets it through).
  tiff_12k.tif    the same at 12000x12000 (~4 KB).
  tiff_ok.tif     a legitimate 4096x3072 TIFF made the same way.
  tiff_72m.tif    9000x8000 (72 M pixels): over the default read limit, fine with --max-pixels.
  ras_big.ras     Sun raster 9000x9000 with no pixel data (OpenCV's own header check).
  exr_tiny.exr    15 bytes: the OpenEXR magic, version 2, and seven zero bytes (no channels).
  exr_attr.exr    15 bytes: one attribute 'a' of empty type declaring 1.77 GB of value (the
                  C++ reader reserves that much before finding the file ends).
  exr_huge.exr    a complete-looking scanline EXR header declaring a 30000x15000 data window.
  exr_2to1.exr    the same at 16384x8192 (2:1, 128 M pixels: over the default read limit).
"""
import struct
import sys
import zlib
import os


def rgbe_rows(w, h, pixel=b"\x80\x80\x80\x81", bright=None):
    """Flat scanlines: one literal pixel, then old-style runs (1,1,1,n << 8k) up to the width."""
    rows = []
    rest = w - 1
    codes = b""
    shift = 0
    while rest > 0:
        codes += bytes([1, 1, 1, (rest >> shift) & 255])
        rest -= ((rest >> shift) & 255) << shift
        shift += 8
    plain = pixel + codes
    for y in range(h):
        if bright is not None and y == bright[1]:
            x = bright[0]
            # the bright pixel at x: literal pixels up to it, then a run to the end
            row = b""
            for i in range(x):
                row += pixel
            row += b"\xff\xf0\xc0\x88"
            r = w - x - 1
            sh = 0
            while r > 0:
                row += bytes([1, 1, 1, (r >> sh) & 255])
                r -= ((r >> sh) & 255) << sh
                sh += 8
            rows.append(row)
        else:
            rows.append(plain)
    return b"".join(rows)


def rgbe(path, w, h, bright=None):
    head = b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y %d +X %d\n" % (h, w)
    with open(path, "wb") as f:
        f.write(head + rgbe_rows(w, h, bright=bright))


def tiff(path, w, h, rows_per_strip):
    """Little-endian RGB TIFF, Adobe deflate; all strips share one compressed block of zeros."""
    block = zlib.compress(bytes(w * 3 * rows_per_strip), 9)
    n = (h + rows_per_strip - 1) // rows_per_strip
    entries = 10
    ifd_off = 8
    ifd_len = 2 + 12 * entries + 4
    bps_off = ifd_off + ifd_len
    offs_off = bps_off + 6
    counts_off = offs_off + 4 * n
    data_off = counts_off + 4 * n
    SHORT, LONG = 3, 4

    def tag(t, typ, count, value):
        if typ == SHORT and count == 1:
            return struct.pack("<HHIHH", t, typ, count, value, 0)
        return struct.pack("<HHII", t, typ, count, value)

    ifd = struct.pack("<H", entries)
    ifd += tag(256, LONG, 1, w)
    ifd += tag(257, LONG, 1, h)
    ifd += tag(258, SHORT, 3, bps_off)
    ifd += tag(259, SHORT, 1, 8)  # Adobe deflate
    ifd += tag(262, SHORT, 1, 2)  # RGB
    ifd += tag(273, LONG, n, offs_off)
    ifd += tag(277, SHORT, 1, 3)
    ifd += tag(278, LONG, 1, rows_per_strip)
    ifd += tag(279, LONG, n, counts_off)
    ifd += tag(284, SHORT, 1, 1)
    ifd += struct.pack("<I", 0)
    out = b"II*\0" + struct.pack("<I", ifd_off) + ifd + struct.pack("<HHH", 8, 8, 8)
    out += struct.pack("<%dI" % n, *([data_off] * n))
    out += struct.pack("<%dI" % n, *([len(block)] * n))
    out += block
    with open(path, "wb") as f:
        f.write(out)


def exr_attr(name, typ, value):
    return name.encode() + b"\0" + typ.encode() + b"\0" + struct.pack("<i", len(value)) + value


def exr_huge(path, w, h):
    """A scanline, uncompressed EXR header with R,G,B half channels and a w x h data window,
    followed by a line-offset table for only the first chunk (the file stops there)."""
    chans = b""
    for c in (b"B", b"G", b"R"):
        chans += c + b"\0" + struct.pack("<iBBBBii", 1, 0, 0, 0, 0, 1, 1)
    chans += b"\0"
    box = struct.pack("<iiii", 0, 0, w - 1, h - 1)
    hd = exr_attr("channels", "chlist", chans)
    hd += exr_attr("compression", "compression", b"\0")
    hd += exr_attr("dataWindow", "box2i", box)
    hd += exr_attr("displayWindow", "box2i", box)
    hd += exr_attr("lineOrder", "lineOrder", b"\0")
    hd += exr_attr("pixelAspectRatio", "float", struct.pack("<f", 1.0))
    hd += exr_attr("screenWindowCenter", "v2f", struct.pack("<ff", 0, 0))
    hd += exr_attr("screenWindowWidth", "float", struct.pack("<f", 1.0))
    hd += b"\0"
    with open(path, "wb") as f:
        f.write(b"\x76\x2f\x31\x01" + struct.pack("<I", 2) + hd + struct.pack("<Q", 0))


def main():
    out = sys.argv[1]
    os.makedirs(out, exist_ok=True)
    rgbe(os.path.join(out, "rgbe_4to1.hdr"), 32768, 8192)
    rgbe(os.path.join(out, "rgbe_2to1.hdr"), 23168, 11584)
    rgbe(os.path.join(out, "rgbe_ok.hdr"), 2048, 1024, bright=(700, 300))
    tiff(os.path.join(out, "tiff_30k.tif"), 30000, 30000, 50)
    tiff(os.path.join(out, "tiff_12k.tif"), 12000, 12000, 32)
    tiff(os.path.join(out, "tiff_ok.tif"), 4096, 3072, 64)
    tiff(os.path.join(out, "tiff_72m.tif"), 9000, 8000, 32)
    with open(os.path.join(out, "ras_big.ras"), "wb") as f:
        f.write(struct.pack(">8I", 0x59A66A95, 9000, 9000, 24, 9000 * 9000 * 3, 1, 0, 0) + bytes(64))
    with open(os.path.join(out, "exr_tiny.exr"), "wb") as f:
        f.write(b"\x76\x2f\x31\x01" + struct.pack("<I", 2) + b"\0" * 7)
    with open(os.path.join(out, "exr_attr.exr"), "wb") as f:
        f.write(b"\x76\x2f\x31\x01" + struct.pack("<I", 2) + b"a\0\0" + struct.pack("<i", 1770000000))
    exr_huge(os.path.join(out, "exr_huge.exr"), 30000, 15000)
    exr_huge(os.path.join(out, "exr_2to1.exr"), 16384, 8192)


if __name__ == "__main__":
    main()
