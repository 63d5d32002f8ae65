#!/usr/bin/python3
"""Procedurally lit rooms rendered to HDR panoramas: synthetic indoor training data.

    tools/train/synth_rooms.py --out DIR [--rooms N (80)] [--seed S (1)] [--width W (1024)]
                               [--first K (0)] [--quiet]

The real data has 27 indoor panoramas; this makes more indoor scenes with the project's own code.
Each room is drawn from a seed (`draw_room`, a pure function of seed and room index, so adding
rooms never changes the ones already made) and rendered by `render_room`:

- geometry: an axis-aligned box room, 3-9 m by 3-9 m, 2.4-3.6 m high, y up; the camera 1.1-1.7 m
  above the floor, at least 0.6 m from every wall; 0-8 pieces of furniture (boxes standing on the
  floor: tables, cabinets, sofas, shelves against a wall), never around the camera;
- materials: Lambertian; walls in one paint (one accent wall sometimes) with a skirting board, a
  door, pictures; floor planks, tiles or carpet; a white-ish ceiling; all with value noise;
- lights, 1-5, at least one: ceiling panels (Lambertian rectangles), bare bulbs (spheres, isotropic)
  and windows (Lambertian rectangles in a wall, sky-coloured); each light's flux is drawn over
  3 stops, its colour from warm to cool white;
- shading: direct light from every light (a rectangle by 9 stratified samples, a bulb by its
  centre) with shadows cast by the furniture, plus one constant indirect term per surface, the
  enclosure estimate rho * (rho_mean / (1 - rho_mean)) * E_mean / pi (E_mean: the direct
  irradiance averaged over the room's surfaces), so walls far from every light are not black;
- the panorama: a ray per pixel from the camera (the equirectangular mapping of light/equirect.c:
  the image centre looks along -z), showing the emitters' radiance where a ray meets one.

Output under DIR (refused if DIR/MANIFEST.tsv exists unless it was made with the same seed and
width, in which case missing rooms are added and existing ones are kept):
    synth/room_NNNN.hdr    the panorama, Radiance RGBE (flat scanlines), width x width/2
    synth/room_NNNN.json   the room as drawn (geometry, materials, lights in world metres and
                           their directions from the camera)
    MANIFEST.tsv           file, scene (indoor), license, source: what make_dataset.py --synthetic
                           reads
    synth.json             seed, width, rooms, tool version

Units are arbitrary (each crop is auto-exposed); only ratios matter.
"""

import argparse
import json
import math
import os
import sys

import numpy as np

VERSION = 1   # bump when draw_room or render_room changes what a seed means
EPS = 1e-4

# surface ids: room faces, then furniture boxes from FURN0 on (6 faces each are one id per box)
FLOOR, CEIL, WX0, WX1, WZ0, WZ1 = range(6)
FURN0 = 6

WHITES = {"warm": (1.0, 0.74, 0.46), "neutral": (1.0, 0.88, 0.74), "cool": (0.93, 0.97, 1.0)}
SKY = (0.78, 0.88, 1.0)


def luminance(c):
    c = np.asarray(c, np.float64)
    return 0.2126 * c[..., 0] + 0.7152 * c[..., 1] + 0.0722 * c[..., 2]


def unit_lum(c):
    """c scaled to luminance 1."""
    c = np.asarray(c, np.float64)
    return c / luminance(c)


# ---- drawing a room ---------------------------------------------------------------------------

def hsv(h, s, v):
    """An RGB triple from hue (0-1), saturation and value (the usual hexcone)."""
    i = int(h * 6.0) % 6
    f = h * 6.0 - math.floor(h * 6.0)
    p, q, t = v * (1 - s), v * (1 - s * f), v * (1 - s * (1 - f))
    return [(v, t, p), (q, v, p), (p, v, t), (p, q, v), (t, p, v), (v, p, q)][i]


def draw_room(seed, index):
    """The room `index` of `seed`: a dict of plain numbers (JSON-ready)."""
    rng = np.random.default_rng([seed, index, 0x5eed])
    u = lambda lo, hi: float(rng.uniform(lo, hi))
    size = [u(3.0, 9.0), u(2.4, 3.6), u(3.0, 9.0)]
    cam = [u(0.6, size[0] - 0.6), u(1.1, 1.7), u(0.6, size[2] - 0.6)]

    def paint():
        return list(hsv(u(0, 1), u(0.0, 0.35) ** 1.5, u(0.35, 0.85)))

    wall = paint()
    walls = [wall] * 4
    if rng.random() < 0.3:
        walls = list(walls)
        walls[int(rng.integers(4))] = list(hsv(u(0, 1), u(0.2, 0.6), u(0.2, 0.7)))
    kind = ["planks", "tiles", "carpet"][int(rng.integers(3))]
    if kind == "planks":
        floor = list(hsv(u(0.04, 0.11), u(0.35, 0.75), u(0.15, 0.6)))
    elif kind == "tiles":
        floor = list(hsv(u(0, 1), u(0.0, 0.2), u(0.2, 0.85)))
    else:
        floor = list(hsv(u(0, 1), u(0.1, 0.5), u(0.1, 0.5)))
    room = {"size": size, "camera": cam,
            "materials": {"walls": walls, "floor": floor, "floor_kind": kind,
                          "plank_or_tile_m": u(0.12, 0.6), "plank_axis": int(rng.integers(2)),
                          "ceiling": list(hsv(u(0, 1), u(0, 0.08), u(0.6, 0.88))),
                          "skirting": [u(0.05, 0.12)] + (list(hsv(0, 0, u(0.05, 0.9)))),
                          "noise_seed": int(rng.integers(1 << 30))},
            "doors": [], "pictures": [], "furniture": [], "lights": []}

    def wall_point(w, width, lo_y, hi_y):
        """A rectangle (centre along the wall, bottom, top) of width `width` on wall w."""
        length = size[2] if w in (WX0, WX1) else size[0]
        c = u(width / 2 + 0.1, max(width / 2 + 0.11, length - width / 2 - 0.1))
        return {"wall": w, "centre": c, "half": width / 2, "y0": lo_y, "y1": hi_y}

    for _ in range(int(rng.integers(0, 2)) + 1):
        d = wall_point(int(rng.integers(2, 6)), 0.9, 0.0, 2.1)
        d["color"] = list(hsv(u(0.03, 0.12), u(0.1, 0.6), u(0.1, 0.7)))
        room["doors"].append(d)
    for _ in range(int(rng.integers(0, 4))):
        w = u(0.3, 1.4)
        y0 = u(1.0, 1.6)
        p = wall_point(int(rng.integers(2, 6)), w, y0, min(size[1] - 0.2, y0 + u(0.3, 1.0)))
        p["color"] = list(hsv(u(0, 1), u(0.1, 0.9), u(0.05, 0.9)))
        room["pictures"].append(p)

    for _ in range(int(rng.integers(0, 9))):
        tall = rng.random() < 0.25
        if tall:   # a shelf against a wall
            w, d, h = u(0.6, 2.0), u(0.3, 0.45), u(1.6, 2.2)
        else:
            w, d, h = u(0.4, 2.0), u(0.4, 1.2), u(0.4, 1.1)
        if rng.random() < 0.5:
            w, d = d, w
        x0 = u(0.0, size[0] - w)
        z0 = u(0.0, size[2] - d)
        if tall:   # push it to the nearest wall
            if min(x0, size[0] - w - x0) < min(z0, size[2] - d - z0):
                x0 = 0.0 if x0 < size[0] - w - x0 else size[0] - w
            else:
                z0 = 0.0 if z0 < size[2] - d - z0 else size[2] - d
        lo, hi = [x0, 0.0, z0], [x0 + w, h, z0 + d]
        if all(lo[a] - 0.4 < cam[a] < hi[a] + 0.4 for a in (0, 2)):
            continue   # never around or next to the camera
        room["furniture"].append({"lo": lo, "hi": hi,
                                  "color": list(hsv(u(0, 1), u(0.0, 0.7), u(0.08, 0.8)))})

    def colour():
        return WHITES[["warm", "neutral", "cool"][int(rng.integers(3))]]

    flux0 = 10 ** u(-0.5, 0.5)   # the room's overall level (the crops are auto-exposed anyway)
    lights = []
    if rng.random() < 0.45:   # windows
        for _ in range(int(rng.integers(1, 3))):
            width = u(0.7, 2.4)
            y0 = u(0.5, 1.1)
            wp = wall_point(int(rng.integers(2, 6)), width, y0, min(size[1] - 0.15, y0 + u(0.9, 1.8)))
            wp.update({"type": "window", "flux": flux0 * 10 ** u(0.2, 0.9),
                       "color": list(unit_lum(np.array(SKY) * (1 + u(-0.1, 0.1))))})
            lights.append(wp)
    if rng.random() < 0.6:   # ceiling panels, in a row or a grid
        nx, nz = int(rng.integers(1, 3)), int(rng.integers(1, 3))
        hx, hz = u(0.15, 0.6), u(0.15, 0.6)
        col, f = colour(), flux0 * 10 ** u(-0.3, 0.5)
        for i in range(nx):
            for k in range(nz):
                lights.append({"type": "panel", "centre": [size[0] * (i + 0.5) / nx, size[1],
                                                           size[2] * (k + 0.5) / nz],
                               "half": [hx, hz], "flux": f / (nx * nz) * (1 + u(-0.1, 0.1)),
                               "color": list(unit_lum(col))})
    if rng.random() < 0.6 or not lights:   # bare bulbs: pendants or lamps
        for _ in range(int(rng.integers(1, 3))):
            r = u(0.03, 0.1)
            pos = [u(0.4, size[0] - 0.4), u(1.0, size[1] - 0.35), u(0.4, size[2] - 0.4)]
            if math.dist(pos, cam) < 0.8 or any(
                    all(f["lo"][a] - r < pos[a] < f["hi"][a] + r for a in range(3))
                    for f in room["furniture"]):
                continue
            lights.append({"type": "bulb", "centre": pos, "radius": r,
                           "flux": flux0 * 10 ** u(-0.6, 0.3), "color": list(unit_lum(colour()))})
    if not lights:   # every bulb fell next to the camera or in furniture: one pendant
        lights.append({"type": "bulb", "centre": [size[0] / 2, size[1] - 0.5, size[2] / 2],
                       "radius": 0.06, "flux": flux0, "color": list(unit_lum(WHITES["warm"]))})
        if math.dist(lights[0]["centre"], cam) < 0.8:
            lights[0]["centre"][0] = cam[0] + (1.0 if cam[0] < size[0] / 2 else -1.0)
    room["lights"] = lights
    c = np.array(cam)
    for light in lights:   # for the record: where each light is seen from the camera
        v = emitter_centre(room, light) - c
        light["direction_from_camera"] = list(v / np.linalg.norm(v))
    return room


# ---- geometry ---------------------------------------------------------------------------------

WALL_FRAME = {  # wall id -> (axis it is on, its coordinate side 0|1, axis along it, inward normal)
    WX0: (0, 0, 2, (1, 0, 0)), WX1: (0, 1, 2, (-1, 0, 0)),
    WZ0: (2, 0, 0, (0, 0, 1)), WZ1: (2, 1, 0, (0, 0, -1))}


def wall_rect(room, r):
    """A wall rectangle's (centre [3], axis-along unit [3], half-length, y0, y1, normal [3])."""
    axis, side, along, n = WALL_FRAME[r["wall"]]
    c = np.zeros(3)
    c[axis] = room["size"][axis] * side
    c[along] = r["centre"]
    c[1] = (r["y0"] + r["y1"]) / 2
    a = np.zeros(3)
    a[along] = 1.0
    return c, a, r["half"], r["y0"], r["y1"], np.array(n, np.float64)


def emitter_centre(room, light):
    if light["type"] == "window":
        return wall_rect(room, light)[0]
    return np.array(light["centre"], np.float64)


def light_samples(room, light, grid=3):
    """(points [S,3], normals [S,3] or None, weights [S,3]): each sample's contribution to the
    irradiance at a point is weight * cos_p * cos_l / d^2 (cos_l = 1 without normals)."""
    col = np.array(light["color"], np.float64)
    if light["type"] == "bulb":
        # isotropic: intensity I = flux / (4 pi), the same for every direction
        return (np.array([light["centre"]], np.float64), None,
                (light["flux"] / (4 * math.pi) * col)[None])
    g = (np.arange(grid) + 0.5) / grid * 2 - 1          # stratified, cell centres in [-1, 1]
    s, t = [m.ravel() for m in np.meshgrid(g, g)]
    if light["type"] == "panel":
        c = np.array(light["centre"], np.float64)
        hx, hz = light["half"]
        pts = np.stack([c[0] + s * hx, np.full_like(s, c[1]), c[2] + t * hz], 1)
        n = np.array([0.0, -1.0, 0.0])
    else:
        c, a, half, y0, y1, n = wall_rect(room, light)
        pts = c + s[:, None] * half * a + (t[:, None] * (y1 - y0) / 2) * np.array([0, 1.0, 0])
    # Lambertian emitter of flux F: radiance L = F / (pi A); per sample L * A / S
    w = light["flux"] / math.pi / len(s) * col
    return pts, np.broadcast_to(n, pts.shape), np.broadcast_to(w, pts.shape)


def emitter_radiance(room, light):
    col = np.array(light["color"], np.float64)
    if light["type"] == "bulb":
        r = light["radius"]
        return light["flux"] / (4 * math.pi) / (math.pi * r * r) * col
    if light["type"] == "panel":
        area = 4 * light["half"][0] * light["half"][1]
    else:
        area = 2 * light["half"] * (light["y1"] - light["y0"])
    return light["flux"] / (math.pi * area) * col


def boxes(room):
    """The furniture boxes' corners: lo, hi [B, 3] (B = 0 in an empty room)."""
    f = room["furniture"]
    return (np.array([b["lo"] for b in f], np.float64).reshape(-1, 3),
            np.array([b["hi"] for b in f], np.float64).reshape(-1, 3))


def ray_columns(p, v):
    """Rays p + t v ([N, 3]) as the slab test reads them: p's columns and 1/v's, contiguous 1-D
    arrays (components of v under 1e-9 made 1e-9: no 0 * inf)."""
    v = np.where(np.abs(v) < 1e-9, 1e-9, v)
    return ([np.ascontiguousarray(p[:, a]) for a in range(3)],
            [np.ascontiguousarray(1.0 / v[:, a]) for a in range(3)])


def slab(rays, lo, hi, t_lo, with_axis=False):
    """The slab test of rays (ray_columns) against the box lo..hi ([3]), one axis at a time:
    (entry t, exit t, entry axis or None), each [N], with the entry t at least t_lo. A ray
    meets the box where entry <= exit."""
    pc, ic = rays
    tmin = np.full(pc[0].shape[0], t_lo)
    tmax = np.full(pc[0].shape[0], np.inf)
    axis = np.zeros(pc[0].shape[0], np.int64) if with_axis else None
    for a in range(3):
        t1 = (lo[a] - pc[a]) * ic[a]
        t2 = (hi[a] - pc[a]) * ic[a]
        near = np.minimum(t1, t2)
        if with_axis:
            axis[near > tmin] = a
        np.maximum(tmin, near, out=tmin)
        np.minimum(tmax, np.maximum(t1, t2), out=tmax)
    return tmin, tmax, axis


def ray_boxes(o, d, bxs):
    """Nearest entry (t [N], box index [N] or -1, entry axis [N]) of rays o + t d into the
    boxes bxs = (lo, hi) [B, 3]; a ray that starts inside a box does not hit it."""
    best = np.full(d.shape[0], np.inf)
    which = np.full(d.shape[0], -1)
    axis = np.zeros(d.shape[0], np.int64)
    rays = ray_columns(o, d)
    for i, (lo, hi) in enumerate(zip(*bxs)):
        tmin, tmax, ax = slab(rays, lo, hi, -np.inf, with_axis=True)
        hit = (tmax >= tmin) & (tmin > EPS) & (tmin < best)
        best = np.where(hit, tmin, best)
        which = np.where(hit, i, which)
        axis = np.where(hit, ax, axis)
    return best, which, axis


def occluded(p, q, bxs):
    """[N] bool: whether the segment p -> q (q [3]) crosses one of the boxes bxs = (lo, hi)."""
    rays = ray_columns(p, q - p)
    out = np.zeros(p.shape[0], bool)
    for lo, hi in zip(*bxs):
        tmin, tmax, _ = slab(rays, lo, hi, EPS)
        out |= np.minimum(tmax, 1 - EPS) >= tmin
    return out


def direct_irradiance(p, n, samples, bxs):
    """[N,3] irradiance at points p with normals n from all lights' samples, with shadows."""
    e = np.zeros_like(p)
    any_box = bxs[0].shape[0] > 0
    for pts, nl, w in samples:
        for j in range(pts.shape[0]):
            v = pts[j] - p
            d2 = np.einsum("ij,ij->i", v, v)
            inv_d = 1.0 / np.sqrt(np.maximum(d2, 1e-12))
            cos_p = np.maximum(np.einsum("ij,ij->i", n, v) * inv_d, 0.0)
            if nl is None:
                cos_l = 1.0
                d2 = np.maximum(d2, 0.05 ** 2)
            else:
                cos_l = np.maximum(-(v @ nl[j]) * inv_d, 0.0)
                d2 = np.maximum(d2, 0.1 ** 2)
            g = cos_p * cos_l / d2
            live = g > 0
            if any_box and live.any():
                idx = np.nonzero(live)[0]
                blocked = occluded(p[idx] + n[idx] * 1e-3, pts[j], bxs)
                g[idx[blocked]] = 0.0
            e += g[:, None] * w[j]
    return e


# ---- materials --------------------------------------------------------------------------------

def value_noise(x, y, cell, seed):
    """Smooth noise in [-1, 1] over the plane (bilinear between random lattice values)."""
    table = np.random.default_rng(seed).uniform(-1, 1, (257, 257))
    fx, fy = x / cell, y / cell
    ix, iy = np.floor(fx).astype(np.int64), np.floor(fy).astype(np.int64)
    tx, ty = fx - ix, fy - iy
    tx, ty = tx * tx * (3 - 2 * tx), ty * ty * (3 - 2 * ty)
    ix, iy = ix % 256, iy % 256
    a = table[ix, iy] * (1 - tx) + table[ix + 1, iy] * tx
    b = table[ix, iy + 1] * (1 - tx) + table[ix + 1, iy + 1] * tx
    return a * (1 - ty) + b * ty


def hash01(i, j, seed):
    """A repeatable pseudo-random value in [0, 1) per integer cell (i, j)."""
    h = (i.astype(np.int64) * 73856093) ^ (j.astype(np.int64) * 19349663) ^ seed
    h = (h ^ (h >> 13)) * 1274126177
    return ((h ^ (h >> 16)) & 0xFFFF) / 65536.0


def albedo(room, surf, p):
    """[N,3] albedo at points p of surfaces surf (room faces and furniture ids)."""
    m = room["materials"]
    seed = m["noise_seed"]
    rho = np.zeros_like(p)
    x, y, z = p[:, 0], p[:, 1], p[:, 2]
    # floor
    f = surf == FLOOR
    if f.any():
        a, b = (x[f], z[f]) if m["plank_axis"] == 0 else (z[f], x[f])
        size = m["plank_or_tile_m"]
        base = np.array(m["floor"])
        if m["floor_kind"] == "planks":
            row = np.floor(b / size)
            seg = np.floor((a + hash01(row, row, seed) * 3.0) / 1.8)
            k = 0.75 + 0.5 * hash01(row, seg, seed)
            k *= 1 + 0.15 * value_noise(a * 6, b * 40, 1.0, seed + 1)   # grain
            gap = (b / size - row < 0.04)
            k = np.where(gap, 0.45, k)
        elif m["floor_kind"] == "tiles":
            i, j = np.floor(a / size), np.floor(b / size)
            k = 0.85 + 0.3 * hash01(i, j, seed)
            fa, fb = a / size - i, b / size - j
            k = np.where((fa < 0.03) | (fb < 0.03), 0.6, k)
        else:
            k = 1 + 0.2 * value_noise(a, b, 0.05, seed + 2)
        rho[f] = base * k[:, None]
    c = surf == CEIL
    if c.any():
        rho[c] = np.array(m["ceiling"]) * (1 + 0.05 * value_noise(x[c], z[c], 0.7, seed + 3))[:, None]
    for w in (WX0, WX1, WZ0, WZ1):
        s = surf == w
        if not s.any():
            continue
        axis, side, along, _ = WALL_FRAME[w]
        a = p[s, along]
        k = (1 + 0.06 * value_noise(a, y[s], 0.6, seed + 4 + w)
             + 0.03 * value_noise(a, y[s], 0.05, seed + 30 + w))[:, None]
        col = np.array(m["walls"][w - WX0]) * k
        h = m["skirting"][0]
        col[y[s] < h] = np.array(m["skirting"][1:])
        for r in room["doors"] + room["pictures"]:
            if r["wall"] != w:
                continue
            inside = (np.abs(a - r["centre"]) < r["half"]) & (y[s] >= r["y0"]) & (y[s] <= r["y1"])
            col[inside] = np.array(r["color"]) * (1 + 0.2 * value_noise(
                a[inside], y[s][inside], 0.2, seed + 11))[:, None]
        rho[s] = col
    for i, fur in enumerate(room["furniture"]):
        s = surf == FURN0 + i
        if s.any():
            rho[s] = np.array(fur["color"]) * (1 + 0.1 * value_noise(
                x[s] + z[s], y[s], 0.15, seed + 20 + i))[:, None]
    return np.clip(rho, 0.01, 0.95)


# ---- rendering --------------------------------------------------------------------------------

def equirect_dirs(width):
    """[H*W, 3] pixel-centre directions (light/equirect.c; tools/train/sg.py: equirect_dirs)."""
    h = width // 2
    phi = ((np.arange(width) + 0.5) / width - 0.5) * 2 * math.pi
    theta = (0.5 - (np.arange(h) + 0.5) / h) * math.pi
    ct = np.cos(theta)[:, None]
    d = np.stack([np.sin(phi)[None] * ct, np.broadcast_to(np.sin(theta)[:, None], (h, width)),
                  -np.cos(phi)[None] * ct], -1)
    return d.reshape(-1, 3)


def room_hits(room, o, d, bxs):
    """Nearest surface along rays o + t d from inside the room: (t [N], surf [N], normal [N,3])."""
    size = np.array(room["size"])
    with np.errstate(divide="ignore", invalid="ignore"):
        t_axes = np.where(d > 0, (size - o) / d, np.where(d < 0, -o / d, np.inf))
    ax = np.argmin(t_axes, axis=1)
    t = t_axes[np.arange(len(d)), ax]
    pos = d[np.arange(len(d)), ax] > 0
    surf = np.select([ax == 1, ax == 0, ax == 2],
                     [np.where(pos, CEIL, FLOOR), np.where(pos, WX1, WX0),
                      np.where(pos, WZ1, WZ0)])
    normal = np.zeros_like(d)
    normal[np.arange(len(d)), ax] = np.where(pos, -1.0, 1.0)
    bt, bi, bax = ray_boxes(o, d, bxs)
    closer = bt < t
    t = np.where(closer, bt, t)
    surf = np.where(closer, FURN0 + bi, surf)
    nb = np.zeros_like(d)
    nb[np.arange(len(d)), bax] = -np.sign(d[np.arange(len(d)), bax])
    normal = np.where(closer[:, None], nb, normal)
    return t, surf, normal


def shade(room, p, n, surf, samples, bxs):
    """[N,3] outgoing radiance of Lambertian points: direct + the enclosure's indirect term."""
    rho = albedo(room, surf, p)
    e = direct_irradiance(p, n, samples, bxs)
    return rho / math.pi * (e + room["_indirect"])


def indirect_irradiance(room, samples, n_pts=600):
    """The constant indirect irradiance [3] of the enclosure estimate (module docstring)."""
    rng = np.random.default_rng([room["materials"]["noise_seed"], 7])
    d = rng.normal(size=(n_pts, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    o = np.broadcast_to(np.array(room["camera"], np.float64), d.shape)
    # surface points seen from the camera in random directions stand in for the room's surfaces;
    # each weighted by t^2 / |cos| (the solid angle -> area Jacobian), so big faces count more
    bxs = boxes(room)
    t, surf, n = room_hits(room, o, d, bxs)
    p = o + d * t[:, None]
    cosv = np.abs(np.einsum("ij,ij->i", n, d))
    wgt = t * t / np.maximum(cosv, 0.05)
    e = direct_irradiance(p, n, samples, bxs)
    rho = albedo(room, surf, p)
    e_mean = (e * wgt[:, None]).sum(0) / wgt.sum()
    rho_mean = np.clip((rho * wgt[:, None]).sum(0) / wgt.sum(), 0.0, 0.9)
    return rho_mean / (1 - rho_mean) * e_mean


def render_room(room, width):
    """The room's panorama from its camera: float32 [width/2, width, 3], linear radiance."""
    d = equirect_dirs(width)
    o = np.broadcast_to(np.array(room["camera"], np.float64), d.shape)
    samples = [light_samples(room, light) for light in room["lights"]]
    room = dict(room, _indirect=indirect_irradiance(room, samples))
    bxs = boxes(room)
    img = np.zeros_like(d)
    for lo in range(0, d.shape[0], 65536):   # in blocks: bounded memory at any width
        sl = slice(lo, lo + 65536)
        t, surf, n = room_hits(room, o[sl], d[sl], bxs)
        p = o[sl] + d[sl] * t[:, None]
        out = shade(room, p, n, surf, samples, bxs)
        for light in room["lights"]:   # emitters seen directly
            rad = emitter_radiance(room, light)
            if light["type"] == "bulb":
                c = np.array(light["centre"])
                oc = o[sl] - c
                b = np.einsum("ij,ij->i", oc, d[sl])
                disc = b * b - (np.einsum("ij,ij->i", oc, oc) - light["radius"] ** 2)
                ts = -b - np.sqrt(np.maximum(disc, 0))
                hit = (disc > 0) & (ts > 0) & (ts < t)
            elif light["type"] == "panel":
                cx, _, cz = light["centre"]
                hx, hz = light["half"]
                hit = ((surf == CEIL) & (np.abs(p[:, 0] - cx) < hx) & (np.abs(p[:, 2] - cz) < hz))
            else:
                c, a, half, y0, y1, _ = wall_rect(room, light)
                hit = ((surf == light["wall"]) & (np.abs((p - c) @ a) < half) &
                       (p[:, 1] >= y0) & (p[:, 1] <= y1))
            out[hit] = rad
        img[sl] = out
    return img.reshape(width // 2, width, 3).astype(np.float32)


# ---- files ------------------------------------------------------------------------------------

def write_rgbe(path, img):
    """Radiance .hdr with flat (uncompressed) scanlines, the standard -Y H +X W orientation."""
    v = np.maximum(img.astype(np.float64), 0.0)
    m = v.max(axis=2)
    mant, ex = np.frexp(m)
    scale = np.where(m > 1e-32, mant * 256.0 / np.where(m > 1e-32, m, 1.0), 0.0)
    rgbe = np.zeros(img.shape[:2] + (4,), np.uint8)
    rgbe[..., :3] = np.minimum(v * scale[..., None], 255).astype(np.uint8)
    rgbe[..., 3] = np.where(m > 1e-32, ex + 128, 0).astype(np.uint8)
    h, w = img.shape[:2]
    tmp = path + ".tmp"
    with open(tmp, "wb") as f:
        f.write(b"#?RADIANCE\n# parlight tools/train/synth_rooms.py\nFORMAT=32-bit_rle_rgbe\n\n")
        f.write(f"-Y {h} +X {w}\n".encode())
        f.write(rgbe.tobytes())
    os.replace(tmp, path)


def main(argv=None):
    ap = argparse.ArgumentParser(description="Procedurally lit rooms rendered to HDR panoramas "
                                 "(synthetic indoor training data; resumable, deterministic).")
    ap.add_argument("--out", required=True, help="output folder")
    ap.add_argument("--rooms", type=int, default=80, help="how many rooms (default 80)")
    ap.add_argument("--first", type=int, default=0, help="index of the first room (default 0)")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--width", type=int, default=1024, help="panorama width (even, 64..8192)")
    ap.add_argument("--quiet", action="store_true")
    args = ap.parse_args(argv)
    try:
        if not 1 <= args.rooms <= 100000:
            raise ValueError(f"--rooms {args.rooms}: expected 1..100000")
        if not 0 <= args.first <= 1000000:
            raise ValueError(f"--first {args.first}: expected 0..1000000")
        if not 64 <= args.width <= 8192 or args.width % 2:
            raise ValueError(f"--width {args.width}: expected an even number in 64..8192")
        cfg = {"tool": "tools/train/synth_rooms.py", "version": VERSION, "seed": args.seed,
               "width": args.width}
        cfg_path = os.path.join(args.out, "synth.json")
        man_path = os.path.join(args.out, "MANIFEST.tsv")
        old_rooms = []
        if os.path.exists(cfg_path) or os.path.exists(man_path):
            try:
                with open(cfg_path, encoding="utf-8") as f:
                    old = json.load(f)
            except (OSError, ValueError) as e:
                raise ValueError(f"{args.out} holds a MANIFEST.tsv but no readable synth.json "
                                 f"({e}); not writing into it") from None
            if {k: old.get(k) for k in cfg} != cfg:
                raise ValueError(f"{cfg_path}: made with another seed, width or version; use "
                                 "another --out (or delete the folder)")
            old_rooms = old.get("rooms", [])
        os.makedirs(os.path.join(args.out, "synth"), exist_ok=True)   # after the checks above
        wanted = list(range(args.first, args.first + args.rooms))
        for done, i in enumerate(wanted, 1):
            stem = os.path.join(args.out, "synth", f"room_{i:04d}")
            if os.path.exists(stem + ".json") and os.path.exists(stem + ".hdr"):
                continue
            room = draw_room(args.seed, i)
            write_rgbe(stem + ".hdr", render_room(room, args.width))
            with open(stem + ".json.tmp", "w", encoding="utf-8") as f:
                json.dump(dict(room, index=i, seed=args.seed, version=VERSION), f, indent=1)
            os.replace(stem + ".json.tmp", stem + ".json")   # last: marks the room complete
            if not args.quiet:
                print(f"{done}/{len(wanted)} rooms", flush=True)
        rooms = sorted(set(old_rooms) | set(wanted))
        with open(cfg_path + ".tmp", "w", encoding="utf-8") as f:
            json.dump(dict(cfg, rooms=rooms), f)
        os.replace(cfg_path + ".tmp", cfg_path)
        with open(man_path + ".tmp", "w", encoding="utf-8") as f:
            f.write("file\tscene\tlicense\tsource\n")
            for i in rooms:
                f.write(f"synth/room_{i:04d}.hdr\tindoor\tgenerated\t"
                        f"tools/train/synth_rooms.py seed {args.seed} v{VERSION}\n")
        os.replace(man_path + ".tmp", man_path)
    except (OSError, ValueError) as e:
        print(f"synth_rooms: {e}", file=sys.stderr)
        return 1
    if not args.quiet:
        print(f"{args.out}: {len(rooms)} rooms")
    return 0


if __name__ == "__main__":
    sys.exit(main())
