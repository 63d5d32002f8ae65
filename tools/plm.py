#!/usr/bin/python3
"""Writer and validating reader of .plm model files (docs/FORMAT.md).

    write_plm(path, meta, tensors, force=False)   meta: {key: value}, tensors: [(name, ndarray)]
    encode_plm(meta, tensors) -> bytes
    read_plm(path) -> (meta: dict, tensors: {name: ndarray}, info: dict)   raises PlmError

The reader checks every rule of docs/FORMAT.md that the C loader (model/plm.c) checks about the
container (header, metadata syntax and required keys, table entries, alignment, bounds, overlap,
finiteness, CRC); tensor names and shapes of the architecture are checked by
tools/export.py:expected_shapes. Run this file for a self-test.
"""

import hashlib
import os
import re
import struct
import sys
import tempfile
import zlib

import numpy as np

MAGIC = b"PLMODEL\0"
VERSION = 1
HEADER_SIZE = 64
ENTRY_SIZE = 128
ALIGN = 64
MAX_META = 65536
MAX_TENSORS = 4096
NAME_BYTES = 64

# dtype code <-> numpy little-endian dtype
DTYPES = {1: np.dtype("<f4"), 2: np.dtype("i1"), 3: np.dtype("<i4"), 4: np.dtype("u1")}
_KIND_CODES = {("f", 4): 1, ("i", 1): 2, ("i", 4): 3, ("u", 1): 4}

REQUIRED_KEYS = ("arch", "precision", "n_lights", "input_h", "input_w", "mean", "std", "bands",
                 "fc", "dist_hidden")
_NAME_RE = re.compile(r"[A-Za-z0-9_.]+\Z")
_KEY_RE = re.compile(r"[^\s=]+\Z")

_HEADER = struct.Struct("<8sIIQQIIQQII")    # magic .. reserved, 64 bytes
_ENTRY = struct.Struct("<64sII4IQQfi16s")   # name .. reserved, 128 bytes
assert _HEADER.size == HEADER_SIZE and _ENTRY.size == ENTRY_SIZE


class PlmError(ValueError):
    """A .plm file (or what is about to be written) breaks docs/FORMAT.md."""


CRC_OFFSET = 56


def file_sha256(path):
    """Hex sha256 of a file's bytes (what the tools key caches and provenance by), read in 1 MiB
    blocks."""
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def file_crc(buf):
    """CRC-32 of the whole file except the 4-byte crc32 field itself (docs/FORMAT.md)."""
    buf = memoryview(buf)
    return zlib.crc32(buf[CRC_OFFSET + 4:], zlib.crc32(buf[:CRC_OFFSET])) & 0xFFFFFFFF


def _align(n):
    return (n + ALIGN - 1) // ALIGN * ALIGN


def _meta_text(meta):
    lines = []
    for k, v in meta.items():
        k, v = str(k), str(v)
        if not _KEY_RE.match(k):
            raise PlmError(f"metadata key {k!r}: must be non-empty, without '=' or whitespace")
        if "\n" in v or "\0" in v:
            raise PlmError(f"metadata value of {k!r} contains a newline or NUL")
        lines.append(f"{k}={v}\n")
    data = "".join(lines).encode("utf-8")
    if not 1 <= len(data) <= MAX_META:
        raise PlmError(f"metadata is {len(data)} bytes, must be 1..{MAX_META}")
    return data


def encode_plm(meta, tensors, quant=None):
    """The bytes of a .plm file. `tensors`: ordered (name, ndarray) pairs; `quant`: optional
    {name: (scale, zero_point)} for integer tensors (float tensors get 0, 0)."""
    quant = quant or {}
    meta_bytes = _meta_text(meta)
    n = len(tensors)
    if not 1 <= n <= MAX_TENSORS:
        raise PlmError(f"{n} tensors, must be 1..{MAX_TENSORS}")
    table_offset = _align(HEADER_SIZE + len(meta_bytes))
    data_offset = _align(table_offset + ENTRY_SIZE * n)
    entries, blobs, seen = [], [], set()
    offset = data_offset
    for name, arr in tensors:
        if not _NAME_RE.match(name) or len(name.encode()) >= NAME_BYTES:
            raise PlmError(f"tensor name {name!r}: must be [A-Za-z0-9_.], under {NAME_BYTES} bytes")
        if name in seen:
            raise PlmError(f"tensor name {name!r} appears twice")
        seen.add(name)
        arr = np.asarray(arr)
        code = _KIND_CODES.get((arr.dtype.kind, arr.dtype.itemsize))
        if code is None:
            raise PlmError(f"tensor {name!r}: dtype {arr.dtype} not storable (f32, s8, s32, u8)")
        if not 1 <= arr.ndim <= 4 or min(arr.shape) < 1:
            raise PlmError(f"tensor {name!r}: shape {arr.shape}, need 1..4 dims each >= 1")
        if code == 1 and not np.isfinite(arr).all():
            raise PlmError(f"tensor {name!r} has NaN or Inf")
        blob = np.ascontiguousarray(arr, dtype=DTYPES[code]).tobytes()
        scale, zp = quant.get(name, (0.0, 0))
        dims = list(arr.shape) + [0] * (4 - arr.ndim)
        entries.append(_ENTRY.pack(name.encode().ljust(NAME_BYTES, b"\0"), code, arr.ndim, *dims,
                                   offset, len(blob), float(scale), int(zp), b"\0" * 16))
        blobs.append((offset, blob))
        offset = _align(offset + len(blob))
    file_size = blobs[-1][0] + len(blobs[-1][1])
    buf = bytearray(file_size)
    buf[HEADER_SIZE:HEADER_SIZE + len(meta_bytes)] = meta_bytes
    buf[table_offset:table_offset + ENTRY_SIZE * n] = b"".join(entries)
    for off, blob in blobs:
        buf[off:off + len(blob)] = blob
    buf[:HEADER_SIZE] = _HEADER.pack(MAGIC, VERSION, HEADER_SIZE, file_size, HEADER_SIZE,
                                     len(meta_bytes), n, table_offset, data_offset, 0, 0)
    struct.pack_into("<I", buf, CRC_OFFSET, file_crc(buf))
    return bytes(buf)


def write_plm(path, meta, tensors, quant=None, force=False):
    """Writes atomically (temporary file in the same folder, then link/rename). Refuses to replace
    an existing file unless `force`: raises FileExistsError."""
    data = encode_plm(meta, tensors, quant)
    folder = os.path.dirname(os.path.abspath(path))
    if not force and os.path.lexists(path):
        raise FileExistsError(f"{path} exists (use --force to replace it)")
    fd, tmp = tempfile.mkstemp(prefix=".plm-", dir=folder)
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
        os.chmod(tmp, 0o644)
        if force:
            os.replace(tmp, path)
        else:
            os.link(tmp, path)   # fails if `path` appeared meanwhile: never clobbers
            os.unlink(tmp)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise
    return len(data)


def decode_plm(buf, where="<bytes>"):
    """Validates `buf` as a .plm file; returns (meta, tensors, info). Raises PlmError."""
    def fail(msg):
        raise PlmError(f"{where}: {msg}")

    buf = memoryview(buf)
    size = len(buf)
    if size < HEADER_SIZE:
        fail(f"{size} bytes, shorter than the {HEADER_SIZE}-byte header")
    (magic, version, header_size, file_size, meta_offset, meta_size, n, table_offset, data_offset,
     crc, reserved) = _HEADER.unpack_from(buf, 0)
    if magic != MAGIC:
        fail(f"bad magic {bytes(magic)!r}, expected {MAGIC!r}")
    if version != VERSION:
        fail(f"version {version}, expected {VERSION}")
    if header_size != HEADER_SIZE:
        fail(f"header_size {header_size}, expected {HEADER_SIZE}")
    if file_size != size:
        fail(f"header file_size {file_size} but the file has {size} bytes")
    if meta_offset != HEADER_SIZE:
        fail(f"meta_offset {meta_offset}, expected {HEADER_SIZE}")
    if not 1 <= meta_size <= MAX_META:
        fail(f"meta_size {meta_size}, must be 1..{MAX_META}")
    if not 1 <= n <= MAX_TENSORS:
        fail(f"n_tensors {n}, must be 1..{MAX_TENSORS}")
    if table_offset % ALIGN or table_offset < meta_offset + meta_size:
        fail(f"table_offset {table_offset}: must be 64-aligned and >= {meta_offset + meta_size}")
    if data_offset % ALIGN or data_offset < table_offset + ENTRY_SIZE * n:
        fail(f"data_offset {data_offset}: must be 64-aligned and >= {table_offset + ENTRY_SIZE * n}")
    if data_offset > size:
        fail(f"data_offset {data_offset} past the end of the file ({size} bytes)")
    if reserved != 0:
        fail(f"header reserved field is {reserved}, expected 0")
    actual = file_crc(buf)
    if actual != crc:
        fail(f"CRC-32 mismatch: header says {crc:08x}, the file gives {actual:08x}")

    raw = bytes(buf[meta_offset:meta_offset + meta_size])
    if b"\0" in raw:
        fail("metadata contains a NUL byte")
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as e:
        fail(f"metadata is not UTF-8 ({e})")
    meta = {}
    for i, line in enumerate(text.split("\n")):
        if line == "" and i == len(text.split("\n")) - 1:
            break
        key, eq, value = line.partition("=")
        if not eq or not key:
            fail(f"metadata line {i + 1} {line!r}: expected key=value")
        if key in meta:
            fail(f"metadata key {key!r} appears twice")
        meta[key] = value
    for key in REQUIRED_KEYS:
        if key not in meta:
            fail(f"metadata lacks the required key {key!r}")

    tensors, spans, entries = {}, [], {}
    for i in range(n):
        off = table_offset + ENTRY_SIZE * i
        (name_b, code, ndim, d0, d1, d2, d3, t_off, t_size, scale, zp,
         t_res) = _ENTRY.unpack_from(buf, off)
        label = f"tensor entry {i}"
        end = name_b.find(b"\0")
        if end <= 0:
            fail(f"{label}: name empty or not NUL-terminated")
        if name_b[end:].strip(b"\0"):
            fail(f"{label}: bytes after the name's NUL are not zero")
        name = name_b[:end].decode("ascii", "replace")
        if not _NAME_RE.match(name):
            fail(f"{label}: name {name!r} has characters outside [A-Za-z0-9_.]")
        label = f"tensor '{name}'"
        if name in tensors:
            fail(f"{label} appears twice")
        if code not in DTYPES:
            fail(f"{label}: dtype {code}, expected 1 (f32), 2 (s8), 3 (s32) or 4 (u8)")
        if not 1 <= ndim <= 4:
            fail(f"{label}: ndim {ndim}, must be 1..4")
        dims = (d0, d1, d2, d3)
        if any(d < 1 for d in dims[:ndim]) or any(d != 0 for d in dims[ndim:]):
            fail(f"{label}: dims {dims} with ndim {ndim}: the first ndim must be >= 1, the rest 0")
        if t_off % ALIGN or t_off < data_offset:
            fail(f"{label}: offset {t_off} must be 64-aligned and >= data_offset {data_offset}")
        expect = int(np.prod(dims[:ndim], dtype=object)) * DTYPES[code].itemsize
        if t_size != expect:
            fail(f"{label}: size {t_size}, expected {expect} for dims {dims[:ndim]}")
        if t_off + t_size > size:
            fail(f"{label}: bytes [{t_off}, {t_off + t_size}) run past the end ({size})")
        if t_res.strip(b"\0"):
            fail(f"{label}: reserved bytes are not zero")
        # float tensors carry no quantisation, except that an int8 model's activation entries
        # ({L}.out, f32 scales) keep the kernel's output offset in zero_point (docs/FORMAT.md)
        if code == 1 and (scale != 0 or (zp != 0 and not name.endswith(".out"))):
            fail(f"{label}: float tensor with scale {scale} / zero_point {zp}, expected 0")
        arr = np.frombuffer(buf, dtype=DTYPES[code], count=t_size // DTYPES[code].itemsize,
                            offset=t_off).reshape(dims[:ndim])
        if code == 1 and not np.isfinite(arr).all():
            fail(f"{label} has NaN or Inf")
        tensors[name] = arr
        entries[name] = {"dtype": code, "offset": t_off, "size": t_size, "scale": scale,
                         "zero_point": zp}
        spans.append((t_off, t_off + t_size, name))
    spans.sort()
    for (a0, a1, an), (b0, _, bn) in zip(spans, spans[1:]):
        if b0 < a1:
            fail(f"tensors '{an}' [{a0}, {a1}) and '{bn}' (from {b0}) overlap")
    info = {"file_size": size, "n_tensors": n, "meta_size": meta_size, "table_offset": table_offset,
            "data_offset": data_offset, "crc32": crc, "entries": entries}
    return meta, tensors, info


def read_plm(path):
    with open(path, "rb") as f:
        buf = f.read()
    return decode_plm(buf, path)


def _self_test():
    meta = {"arch": "densenet121-parametric", "precision": "fp32", "n_lights": 3, "input_h": 192,
            "input_w": 256, "mean": "0.485,0.456,0.406", "std": "0.229,0.224,0.225", "bands": 3,
            "fc": 512, "dist_hidden": 64}
    rng = np.random.default_rng(0)
    tensors = [("a.weight", rng.standard_normal((5, 3, 2, 2)).astype(np.float32)),
               ("b", np.arange(7, dtype=np.int8)), ("c", np.arange(3, dtype=np.int32))]
    data = encode_plm(meta, tensors, quant={"b": (0.5, -3)})
    m, t, info = decode_plm(data)
    assert m == {k: str(v) for k, v in meta.items()}
    for name, arr in tensors:
        assert t[name].dtype == arr.dtype and np.array_equal(t[name], arr), name
        assert info["entries"][name]["offset"] % ALIGN == 0
    assert info["entries"]["b"]["scale"] == 0.5 and info["entries"]["b"]["zero_point"] == -3
    # every single-byte corruption past the header is caught by the CRC; header fields by checks
    for pos in (0, 9, 20, 33, 60, 64, 200, len(data) - 1):
        bad = bytearray(data)
        bad[pos] ^= 0x01
        try:
            decode_plm(bytes(bad))
        except PlmError:
            continue
        raise AssertionError(f"flipped byte {pos} not detected")
    try:
        decode_plm(data[:-1])
        raise AssertionError("truncation not detected")
    except PlmError:
        pass
    print("plm self-test ok")


if __name__ == "__main__":
    if len(sys.argv) == 2:
        m, t, info = read_plm(sys.argv[1])
        for k, v in m.items():
            print(f"{k}={v}")
        print(f"{info['n_tensors']} tensors, {info['file_size']} bytes, crc32 {info['crc32']:08x}")
    else:
        _self_test()
