#!/usr/bin/python3
"""Differentiable spherical-Gaussian environment maps in PyTorch: the paper's eq. (4) exactly as
light/sg.c computes it (docs/LIGHTING.md), for the training loss of tools/train/train.py.

    L(u) = sum_i c_i exp((l_i . u - 1) / sigma_i) + a,   sigma_i = s_i / (4 pi)

on the W x W/2 equirectangular grid of light/equirect.c (pixel centres at +0.5, longitude 0 at the
image centre = -z, latitude +pi/2 at the top; dir = (sin phi cos theta, sin theta, -cos phi cos
theta)). With prefilter_sigma = 0 this is pl_envmap_from_lights (tests/test_train_sg.sh compares
the two). Training uses prefilter_sigma > 0: each lobe is widened to sigma + sigma_k with its
peak scaled by sigma / (sigma + sigma_k), which keeps its energy (for narrow lobes) and is the
SG approximation of blurring the map with a pixel-sized kernel — a lobe narrower than a pixel
(a 0.0002 sr sun) would otherwise fall between the point samples of a small map.

Run as a program to render a lights JSON into a float32 .npy (for checks):
    tools/train/sg.py --lights L.json --width 128 --out map.npy
or compare with `parlight render`'s Radiance .hdr output:
    tools/train/sg.py --lights L.json --compare-hdr map.hdr
"""

import argparse
import json
import math
import os
import sys

import numpy as np
import torch

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
from rgbe import read_rgbe  # noqa: E402,F401  (sg.read_rgbe: the tests' name for it)

FOUR_PI = 4.0 * math.pi


def equirect_dirs(width, dtype=torch.float32):
    """[H, W, 3] unit directions of the pixel centres of a W x W/2 panorama (light/equirect.c)."""
    if width < 2 or width % 2:
        raise ValueError(f"environment map width {width}: expected an even number >= 2")
    h = width // 2
    x = torch.arange(width, dtype=torch.float64) + 0.5
    y = torch.arange(h, dtype=torch.float64) + 0.5
    phi = (x / width - 0.5) * 2.0 * math.pi
    theta = (0.5 - y / h) * math.pi
    ct = torch.cos(theta).view(h, 1)
    d = torch.stack([torch.sin(phi).view(1, width) * ct,
                     torch.sin(theta).view(h, 1).expand(h, width),
                     -torch.cos(phi).view(1, width) * ct], dim=-1)
    return d.to(dtype)


def pixel_sigma(width):
    """A lobe width (sigma) of about a pixel: its standard deviation sqrt(sigma) is half the
    pixel spacing 2 pi / W."""
    return (math.pi / width) ** 2


def render(dirs, size, rgb, udirs, ambient=None, mask=None, prefilter_sigma=0.0):
    """SG environment maps [B, H, W, 3].

    dirs [B, N, 3] unit vectors, size [B, N] solid angles (sr, > 0), rgb [B, N, 3] peak radiance,
    udirs [H, W, 3] from equirect_dirs, ambient [B, 3] or None (no ambient), mask [B, N] (1 =
    light present, 0 = padding) or None."""
    sigma = size / FOUR_PI
    if prefilter_sigma > 0:
        wide = sigma + prefilter_sigma
        rgb = rgb * (sigma / wide).unsqueeze(-1)
        sigma = wide
    dot = torch.einsum("bnk,hwk->bnhw", dirs, udirs)
    w = torch.exp((dot - 1.0) / sigma[:, :, None, None])
    if mask is not None:
        w = w * mask[:, :, None, None]
    out = torch.einsum("bnhw,bnc->bhwc", w, rgb)
    if ambient is not None:
        out = out + ambient[:, None, None, :]
    return out


def sphere_normals(size, dtype=torch.float32):
    """[P, 3] normals of the pixels of a size x size sphere render that lie on the sphere, in
    row order (pl_sphere_mask: orthographic camera looking along -z, n.z >= 0)."""
    c = (torch.arange(size, dtype=torch.float64) + 0.5) * 2.0 / size - 1.0
    sx = c.view(1, size).expand(size, size)
    sy = -c.view(size, 1).expand(size, size)
    r2 = sx * sx + sy * sy
    on = r2 <= 1.0
    n = torch.stack([sx[on], sy[on], torch.sqrt(1.0 - r2[on])], dim=-1)
    return n.to(dtype)


def diffuse_operator(width, normals, dtype=torch.float32):
    """[H*W, P] weights that turn a W x W/2 map's pixels into the white Lambertian sphere's
    radiance at `normals` ((1/pi) int L max(0, n.u) du), normalised per normal as
    pl_render_sphere_envmap does (sum w L dw / sum w dw), so a constant map renders exactly."""
    u = equirect_dirs(width, torch.float64)
    h = width // 2
    theta = (0.5 - (torch.arange(h, dtype=torch.float64) + 0.5) / h) * math.pi
    dw = (torch.cos(theta) * (2.0 * math.pi / width) * (math.pi / h)).view(h, 1).expand(h, width)
    w = torch.clamp(u.reshape(-1, 3) @ normals.to(torch.float64).T, min=0.0) * dw.reshape(-1, 1)
    return (w / w.sum(0, keepdim=True)).to(dtype)


def diffuse(maps, op):
    """[B, P, 3] diffuse sphere radiance of maps [B, H, W, 3] through diffuse_operator's op."""
    b, h, w, c = maps.shape
    return torch.einsum("bqc,qp->bpc", maps.reshape(b, h * w, c), op)


def lights_from_json(obj, max_lights=16, normalize=True):
    """(dirs [N,3], size [N], rgb [N,3], distance [N], ambient [3]) float64 tensors of a lights
    JSON object (docs/LIGHTING.md), validated; dir normalised as light/lights_json.c does."""
    if not isinstance(obj, dict) or not isinstance(obj.get("lights"), list):
        raise ValueError("lights JSON: expected an object with a 'lights' array")
    lights = obj["lights"]
    if len(lights) > max_lights:
        raise ValueError(f"lights JSON: {len(lights)} lights, at most {max_lights}")

    def nums(v, n, what, lo=None):
        if not isinstance(v, list) or len(v) != n or not all(
                isinstance(t, (int, float)) and not isinstance(t, bool) and math.isfinite(t)
                for t in v):
            raise ValueError(f"lights JSON: {what}: expected {n} finite numbers")
        if lo is not None and any(t < lo for t in v):
            raise ValueError(f"lights JSON: {what}: expected numbers >= {lo}")
        return [float(t) for t in v]

    dirs, size, rgb, dist = [], [], [], []
    for i, li in enumerate(lights):
        if not isinstance(li, dict):
            raise ValueError(f"lights JSON: lights[{i}]: expected an object")
        d = nums(li.get("dir"), 3, f"lights[{i}].dir")
        n = math.sqrt(sum(t * t for t in d))
        if n == 0:
            raise ValueError(f"lights JSON: lights[{i}].dir is zero")
        dirs.append([t / n for t in d] if normalize else d)
        s = nums([li.get("solid_angle_sr")], 1, f"lights[{i}].solid_angle_sr")[0]
        dd = nums([li.get("distance_m")], 1, f"lights[{i}].distance_m")[0]
        if s <= 0 or dd <= 0:
            raise ValueError(f"lights JSON: lights[{i}]: solid_angle_sr and distance_m must be > 0")
        size.append(s)
        dist.append(dd)
        rgb.append(nums(li.get("rgb"), 3, f"lights[{i}].rgb", 0.0))
    amb = nums(obj.get("ambient"), 3, "ambient", 0.0)
    t = lambda v, shape: torch.tensor(v, dtype=torch.float64).reshape(shape)  # noqa: E731
    n = len(lights)
    return t(dirs, (n, 3)), t(size, (n,)), t(rgb, (n, 3)), t(dist, (n,)), t(amb, (3,))


def c_rounded(obj):
    """The lights JSON with every number rounded as light/lights_json.c stores it: float32
    values, the direction normalised in double from its float32 components and rounded again.
    (A lobe of 0.0005 sr has sharpness 25000: float32 rounding of l moves its tail by ~1%.)"""
    f32 = lambda v: float(np.float32(v))  # noqa: E731
    out = {"lights": [], "ambient": [f32(v) for v in obj["ambient"]]}
    for li in obj["lights"]:
        d = [f32(v) for v in li["dir"]]
        n = np.sqrt(sum(v * v for v in d))
        out["lights"].append({"dir": [f32(v / n) for v in d] if n > 0 else d,
                              "distance_m": f32(li["distance_m"]),
                              "solid_angle_sr": f32(li["solid_angle_sr"]),
                              "rgb": [f32(v) for v in li["rgb"]]})
    return out


def render_json(obj, width, prefilter_sigma=0.0):
    """float64 [H, W, 3] map of a lights JSON object (with its ambient), as pl_envmap_from_lights
    computes it from the float32 values it stores (c_rounded)."""
    lights_from_json(obj)   # validates before c_rounded touches it
    dirs, size, rgb, _, amb = lights_from_json(c_rounded(obj), normalize=False)
    with torch.no_grad():
        return render(dirs[None], size[None], rgb[None], equirect_dirs(width, torch.float64),
                      amb[None], prefilter_sigma=prefilter_sigma)[0]


def main(argv=None):
    ap = argparse.ArgumentParser(description="Render a lights JSON to an SG environment map "
                                 "(eq. 4) in PyTorch, or compare with parlight render's .hdr.")
    ap.add_argument("--lights", required=True)
    ap.add_argument("--width", type=int, default=128)
    ap.add_argument("--out", help="write the map as float32 .npy [H, W, 3]")
    ap.add_argument("--compare-hdr", metavar="HDR",
                    help="compare with this .hdr (parlight render --width W): exit 1 if any pixel "
                    "differs by more than the RGBE quantisation (0.8%% of its largest channel)")
    args = ap.parse_args(argv)
    try:
        with open(args.lights, encoding="utf-8") as f:
            obj = json.load(f)
        if args.compare_hdr:
            ref = read_rgbe(args.compare_hdr).astype(np.float64)
            width = ref.shape[1]
            got = render_json(obj, width).numpy()
            if ref.shape != got.shape:
                raise ValueError(f"{args.compare_hdr}: {ref.shape[1]}x{ref.shape[0]}, expected "
                                 f"{got.shape[1]}x{got.shape[0]}")
            tol = 0.008 * got.max(axis=-1, keepdims=True) + 1e-30
            err = np.abs(got - ref)
            worst = float((err / tol).max())
            rel = float(err.max() / max(got.max(), 1e-30))
            print(f"sg.py vs {args.compare_hdr}: {width}x{width // 2}, max |diff| / tolerance "
                  f"{worst:.3f}, max |diff| / map max {rel:.2e}, map max {got.max():.6g}")
            return 0 if worst <= 1.0 else 1
        m = render_json(obj, args.width).numpy().astype(np.float32)
        if args.out:
            np.save(args.out, m)
        print(f"{args.width}x{args.width // 2} map, max {m.max():.6g}, mean {m.mean():.6g}")
    except (OSError, ValueError) as e:
        print(f"sg.py: {e}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
