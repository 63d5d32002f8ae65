#!/usr/bin/env python3
"""The key light over partial looks around a room, from the per-crop lights of `parlight eval
--json` (models/MODEL_CARD.md, "The key light over views": its sweep table).

    fuse_sweeps.py EVAL.json [--views 8,4,3,2] [--estimate model|ridge] [--json]

An AR user does not always turn all the way round. eval's crops of a panorama are views at yaws
360/C degrees apart (C crops a panorama); a sweep of k views is k consecutive crops (every start
for k < C, one sweep for k = C). Each sweep's key light is fused by the rule of light/fuse.h
(tests/fuse_ref.py, the same rule written again in Python: each view's lights turned into world
space by its yaw, at unit light energy) and its angle to the room's primary light compared with
the median of the same crops' single-frame angles (eval's own). Per k it prints the median over
the sweeps of both, and in how many sweeps the fused key light is closer. Needs the eval file of
one model, written with its crops (`--json`); the ridge's lights with --estimate ridge.

It also prints what the intensity over the same views would give ("Intensity over views", rule
s43 in the model card; measured, not built): each view's total energy (lights and ambient)
divided by its exposure (the crop's exposure_scale, which an app knows from the camera),
averaged in log over the sweep, times the crop's own exposure. The RMSE at that intensity is
exact from eval's si_rmse, scale_ev and render_rms (docs/EVAL.md); per k, the median over every
(sweep, crop) against the crops' own RMSE, and in how many rooms its median is lower."""
import argparse
import json
import math
import os
import statistics
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "tests"))
from fuse_ref import angle_deg, energy, key_light, lum, sg_integral, yaw_to_world  # noqa: E402


def total_energy(lighting):
    """Lights and ambient: sum of c_i I(s_i) + 4 pi a, in luminance."""
    return (sum(lum(l["rgb"]) * sg_integral(l["solid_angle_sr"]) for l in lighting["lights"]) +
            4 * math.pi * lum(lighting["ambient"]))


def rmse_at(scores, c):
    """RMSE of a crop's lighting scaled by c: si^2 + (c - alpha)^2 render_rms^2 (docs/EVAL.md)."""
    alpha = 2.0 ** scores["scale_ev"]
    return math.sqrt(scores["si_rmse"] ** 2 + (c - alpha) ** 2 * scores["render_rms"] ** 2)


def intensity_sweeps(ev, k, lights_key, score_key):
    """Per panorama, the (own RMSE, RMSE at the intensity over the sweep) of every crop of every
    sweep of k views."""
    rooms = []
    for p in ev["panoramas"]:
        cs = sorted(p["crops"], key=lambda c: c["yaw_deg"])
        n = len(cs)
        r = [math.log2(total_energy(c[lights_key]) / c["exposure_scale"]) for c in cs]
        pairs = []
        for s in ([0] if k == n else range(n)):
            idx = [(s + i) % n for i in range(k)]
            mean = sum(r[i] for i in idx) / k
            for i in idx:
                sc = cs[i][score_key]
                if sc["scale_ev"] is None or sc["rmse"] is None:
                    continue
                pairs.append((sc["rmse"], rmse_at(sc, 2.0 ** (mean - r[i]))))
        rooms.append(pairs)
    return rooms


def sweeps(ev, k, lights_key, angle_key):
    """(fused angle, median single-frame angle) of every sweep of k views in every panorama."""
    out = []
    for p in ev["panoramas"]:
        cs = sorted(p["crops"], key=lambda c: c["yaw_deg"])
        n = len(cs)
        if k > n:
            raise ValueError(f"{p.get('file', '?')}: {n} crops, fewer than {k} views")
        gt = cs[0]["ground_truth"]["lights"]
        if not gt:
            continue
        truth = yaw_to_world(cs[0]["yaw_deg"], max(gt, key=energy)["dir"])
        step = 360.0 / n
        for s in ([0] if k == n else range(n)):
            sub = [cs[(s + i) % n] for i in range(k)]
            views = {round(c["yaw_deg"] / step) % n:
                     [dict(l, dir=yaw_to_world(c["yaw_deg"], l["dir"]))
                      for l in c[lights_key]["lights"]] for c in sub}
            key = key_light(views)
            if key is None:
                continue
            single = statistics.median(c[angle_key]["angle_deg"] for c in sub)
            out.append((angle_deg(key, truth), single))
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("eval_json")
    ap.add_argument("--views", default="8,4,3,2", help="sweep sizes, comma-separated")
    ap.add_argument("--estimate", choices=("model", "ridge"), default="model",
                    help="whose lights: the model's (default) or baseline (d)'s")
    ap.add_argument("--json", action="store_true", help="one JSON object instead of the table")
    a = ap.parse_args()
    try:
        ev = json.load(open(a.eval_json))
        ks = [int(v) for v in a.views.split(",")]
        if not ks or min(ks) < 1:
            raise ValueError("--views: sizes >= 1 expected")
        if not ev.get("panoramas") or "crops" not in ev["panoramas"][0]:
            raise ValueError("no panoramas with crops: write it with `parlight eval ... --json`")
        lights_key = "estimate" if a.estimate == "model" else "ridge_estimate"
        if lights_key not in ev["panoramas"][0]["crops"][0]:
            raise ValueError(f"the crops carry no {lights_key!r} lights")
        rows = []
        for k in ks:
            r = sweeps(ev, k, lights_key, a.estimate)
            if not r:
                raise ValueError("no crop's ground truth has a light")
            rooms = [x for x in intensity_sweeps(ev, k, lights_key, a.estimate) if x]
            pooled = [x for room in rooms for x in room]
            rows.append({"views": k, "sweeps": len(r),
                         "fused_median_deg": statistics.median(f for f, _ in r),
                         "single_median_deg": statistics.median(s for _, s in r),
                         "fused_closer": sum(f < s for f, s in r),
                         "rmse_own_median": statistics.median(o for o, _ in pooled),
                         "rmse_views_median": statistics.median(v for _, v in pooled),
                         "rooms": len(rooms),
                         "rooms_rmse_lower": sum(statistics.median(v for _, v in room) <
                                                 statistics.median(o for o, _ in room)
                                                 for room in rooms)})
    except (OSError, ValueError, KeyError, TypeError) as e:
        sys.exit(f"fuse_sweeps.py: {a.eval_json}: {e}")
    if a.json:
        print(json.dumps({"file": a.eval_json, "estimate": a.estimate, "rows": rows}))
        return
    print("views  sweeps  fused (median)  single frames (median)  fused closer  "
          "RMSE own  intensity over views  rooms lower")
    for r in rows:
        print(f"{r['views']:5d}  {r['sweeps']:6d}  {r['fused_median_deg']:13.1f}°  "
              f"{r['single_median_deg']:22.1f}°  {r['fused_closer']:5d} / {r['sweeps']:<4d}  "
              f"{r['rmse_own_median']:8.4f}  {r['rmse_views_median']:20.4f}  "
              f"{r['rooms_rmse_lower']:5d} / {r['rooms']}")


if __name__ == "__main__":
    main()
