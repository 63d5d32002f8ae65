#!/usr/bin/python3
"""Fits the intensity anchor (docs/LIGHTING.md, "Intensity anchor") of a model to held-out crops.

    build/parlight eval --model M.plm --hdr HELD_OUT_DIR --crops 16 --anchor off --json > E.json
    tools/train/fit_anchor.py E.json [--w 0,0.25,0.5,0.75,1] [--b=-2:2:0.25]
                              [--lopo] [--write IN.plm OUT.plm]... [--force]

The anchor scales an estimate by c = 2^(w ev + b), ev = the crop's frame_ev (log2 of the frame's
mean luminance over the estimate's). For every (w, b) of the grid this prints the median RMSE
over the crops of E.json, computed exactly from what `parlight eval` records per crop, without
running the network again: the residual of the least-squares fit is orthogonal to the render, so

    RMSE(c)^2 = si_rmse^2 + (c - alpha)^2 render_rms^2,   alpha = 2^scale_ev.

--lopo also says how well such a fit carries to a panorama it has not seen: for each panorama of
E.json, (w, b) fit on the others' crops scores that panorama's crops; the median over all crops
is printed beside the in-sample one (a fit on a handful of panoramas can look better than it is).

It picks the (w, b) with the lowest median RMSE (ties: the smaller w, then the smaller |b|) and,
with --write, copies IN.plm to OUT.plm with `intensity_anchor=w,b,gamma` (and a line saying how it
was fit) in its metadata; repeat --write for the float and the int8 file of one network. OUT is
never replaced without --force. E.json must be made with --anchor off (its estimates are the
network's own); crops without a frame_ev (a black frame or estimate) keep c = 1, as in C.
"""

import argparse
import json
import math
import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
import plm  # noqa: E402  (tools/plm.py)


def parse_list(text, what):
    try:
        if ":" in text:
            lo, hi, step = (float(x) for x in text.split(":"))
            if not step > 0 or hi < lo or (hi - lo) / step > 1000:
                raise ValueError
            n = int(round((hi - lo) / step))
            return [round(lo + i * step, 9) for i in range(n + 1)]
        return [float(x) for x in text.split(",")]
    except ValueError:
        raise SystemExit(f"fit_anchor: {what} '{text}': expected a,b,c or lo:hi:step") from None


def load_crops(path):
    """[(rmse, si, alpha, rms, frame_ev or None, panorama)] of the model on every crop, and the
    gamma."""
    try:
        with open(path) as f:
            d = json.load(f)
    except (OSError, ValueError) as e:
        raise SystemExit(f"fit_anchor: {path}: {e}") from None
    an = d.get("intensity_anchor")
    if not isinstance(an, dict) or "panoramas" not in d:
        raise SystemExit(f"fit_anchor: {path}: not the --json output of a parlight eval that "
                         "records the intensity anchor")
    if an.get("w") != 0 or an.get("b") != 0:
        raise SystemExit(f"fit_anchor: {path}: made with the anchor w={an.get('w')} "
                         f"b={an.get('b')}; run parlight eval with --anchor off")
    crops = []
    for p in d["panoramas"]:
        for i, c in enumerate(p["crops"]):
            m = c["model"]
            where = f"{path}: {p['file']} crop {i}"
            if m.get("render_rms") is None or m.get("rmse") is None or m.get("si_rmse") is None:
                raise SystemExit(f"fit_anchor: {where}: no rmse/si_rmse/render_rms")
            rmse, si, rms = m["rmse"], m["si_rmse"], m["render_rms"]
            alpha = 2.0 ** m["scale_ev"] if m.get("scale_ev") is not None else 1.0
            # the record must reproduce its own RMSE at c = 1, or the maths below is off
            if abs(at_scale(si, alpha, rms, 1.0) - rmse) > 1e-4 * max(rmse, 1e-3):
                raise SystemExit(f"fit_anchor: {where}: rmse {rmse} does not follow from si_rmse, "
                                 f"scale_ev and render_rms ({at_scale(si, alpha, rms, 1.0)})")
            crops.append((rmse, si, alpha, rms, c.get("frame_ev"), p.get("file", "")))
    if not crops:
        raise SystemExit(f"fit_anchor: {path}: no crops")
    return crops, float(an.get("gamma", 2.2))


def at_scale(si, alpha, rms, c):
    return math.sqrt(si * si + (c - alpha) ** 2 * rms * rms)


def median(v):
    s = sorted(v)
    n = len(s)
    return s[n // 2] if n % 2 else 0.5 * (s[n // 2 - 1] + s[n // 2])


def score(crops, w, b):
    """Median RMSE and median scale EV (after the anchor) over the crops."""
    ev = [math.log2(alpha / c) if alpha > 0 else 0.0
          for c, (_r, _si, alpha, *_x) in zip(scales(crops, w, b), crops)]
    return median(rmses(crops, w, b)), median(ev)


def scales(crops, w, b):
    return [2.0 ** (w * fev + b) if fev is not None else 1.0 for *_x, fev, _pano in crops]


def rmses(crops, w, b):
    """Each crop's RMSE with the anchor (w, b)."""
    return [at_scale(si, alpha, rms, c)
            for c, (_r, si, alpha, rms, *_x) in zip(scales(crops, w, b), crops)]


def fit(crops, ws, bs, rows=None):
    """The grid's best (median RMSE, w, b); ties: the smaller w, then the smaller |b|. With
    rows (a list), each w's row of median RMSEs is appended to it."""
    best = None
    for w in ws:
        row = []
        for b in bs:
            m, _ = score(crops, w, b)
            row.append(m)
            key = (round(m, 12), w, abs(b))
            if best is None or key < best[0]:
                best = (key, w, b, m)
        if rows is not None:
            rows.append((w, row))
    return best[3], best[1], best[2]


def lopo(crops, ws, bs):
    """Leave one panorama out: each panorama's crops at the (w, b) fit on the others'."""
    out, fits = [], []
    panos = sorted({c[-1] for c in crops})
    for p in panos:
        rest = [c for c in crops if c[-1] != p]
        held = [c for c in crops if c[-1] == p]
        _, w, b = fit(rest, ws, bs)
        fits.append((p, w, b))
        out += rmses(held, w, b)
    return median(out), fits


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("eval_json")
    ap.add_argument("--w", default="0,0.25,0.5,0.75,1", help="grid of w in 0..1")
    ap.add_argument("--b", default="-2:2:0.25",
                    help="grid of b (stops) in -8..8, as --b=LO:HI:STEP or --b=a,b,c")
    ap.add_argument("--write", nargs=2, action="append", default=[], metavar=("IN", "OUT"))
    ap.add_argument("--force", action="store_true", help="replace an existing OUT")
    ap.add_argument("--lopo", action="store_true",
                    help="also score a fit on all panoramas but one on the one left out")
    a = ap.parse_args(argv)
    ws, bs = parse_list(a.w, "--w"), parse_list(a.b, "--b")
    if not all(0 <= w <= 1 for w in ws) or not all(-8 <= b <= 8 for b in bs):
        raise SystemExit("fit_anchor: --w must lie in 0..1 and --b in -8..8")
    crops, gamma = load_crops(a.eval_json)

    base, base_ev = score(crops, 0.0, 0.0)
    print(f"{a.eval_json}: {len(crops)} crops; median RMSE without the anchor {base:.4f} "
          f"(scale EV {base_ev:+.2f})")
    print("median RMSE, rows w, columns b (stops):")
    print("  w \\ b " + "".join(f"{b:>8.2f}" for b in bs))
    rows = []
    m, w, b = fit(crops, ws, bs, rows)
    for rw, row in rows:
        print(f"  {rw:5.2f} " + "".join(f"{x:8.4f}" for x in row))
    _, ev = score(crops, w, b)
    print(f"best: w {w:g}, b {b:g}: median RMSE {m:.4f} (scale EV {ev:+.2f}), "
          f"{100 * (m / base - 1):+.1f}% against no anchor")
    if a.lopo:
        npano = len({c[-1] for c in crops})
        if npano < 2:
            raise SystemExit("fit_anchor: --lopo needs crops of at least two panoramas")
        lm, fits = lopo(crops, ws, bs)
        print(f"leave one panorama out ({npano} panoramas): median RMSE {lm:.4f}, "
              f"{100 * (lm / base - 1):+.1f}% against no anchor")
        for p, fw, fb in fits:
            print(f"  without {p}: w {fw:g}, b {fb:g}")

    for src, dst in a.write:
        try:
            meta, tensors, info = plm.read_plm(src)
        except (OSError, plm.PlmError) as e:
            raise SystemExit(f"fit_anchor: {src}: {e}") from None
        meta = dict(meta)
        meta["intensity_anchor"] = f"{w:g},{b:g},{gamma:g}"
        meta["intensity_anchor_fit"] = (
            f"tools/train/fit_anchor.py on {os.path.basename(a.eval_json)} ({len(crops)} crops): "
            f"median RMSE {base:.4f} -> {m:.4f}")
        quant = {n: (e["scale"], e["zero_point"]) for n, e in info["entries"].items()}
        try:
            plm.write_plm(dst, meta, list(tensors.items()), quant, force=a.force)
        except FileExistsError as e:
            raise SystemExit(f"fit_anchor: {e}") from None
        except (OSError, plm.PlmError) as e:
            raise SystemExit(f"fit_anchor: {dst}: {e}") from None
        print(f"wrote {dst}: intensity_anchor={meta['intensity_anchor']}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
