#!/usr/bin/env python3
"""Where a model's lights point, and whether it knows which of them is the primary one, from the
per-crop lights of `parlight eval --json`.

    light_placement.py EVAL.json [EVAL.json ...] [--estimate estimate] [--draws 200] [--seed 0]
                       [--json]

eval scores one direction per crop, the primary light's (the light of most energy, luminance x
the spherical Gaussian's integral, light/sg.c), and a miss there has two causes that call for
different fixes: no light points near the true primary, or one does but is not the brightest.
Per file, over the crops whose ground truth has a light:

  primary       median angle of the estimate's primary light to the true primary (eval's angle);
  best of N     median angle of the estimate's closest light to the true primary, and how many
                crops have one within 45 deg;
  rank          how often the closest light is the estimate's 1st, 2nd, ... by energy: uniform
                means the ranking carries nothing about which light is the true primary;
  other room    the same two medians with each crop's estimate swapped for the estimate of a
                random crop of another panorama (--draws times, the 2.5-97.5% range of the
                medians over draws): what the answers are worth without this crop. A model whose
                best-of-N is no lower than the other-room figure places its lights as it would
                in any room;
  slots         per output light (the heads' light 1, 2, ...): its mean direction over all crops
                and the median angle of its directions to that mean. A few degrees means the head
                puts that light in one place whatever the frame, and only its colour and size
                (hence which light is the primary) follow the image.

Directions are compared in each crop's camera frame; eval's crops share the pitch (0 unless
--pitch was given), so "up" is the same in every crop and the other-room control keeps what the
answers know about up and down. --estimate names the row of lights (estimate, ridge_estimate).
"""
import argparse
import json
import math
import random
import sys

from compare_evals import median
from fit_ridge import luminance, sg_integral


def energy(light):
    """pl_light_energy: luminance x pl_sg_integral(solid angle) (fit_ridge.py's, as its primary)."""
    return luminance(light["rgb"]) * sg_integral(light["solid_angle_sr"])


def angle(a, b):
    na = math.sqrt(sum(x * x for x in a))
    nb = math.sqrt(sum(x * x for x in b))
    if not (na > 0 and nb > 0):
        return float("nan")
    c = sum(x * y for x, y in zip(a, b)) / (na * nb)
    return math.degrees(math.acos(max(-1.0, min(1.0, c))))


def by_energy(lights):
    """Indices of the lights, most energy first (ties: the first light, as pl_lighting_primary)."""
    return sorted(range(len(lights)), key=lambda i: (-energy(lights[i]), i))


def scores(gt_dir, lights):
    """(primary angle, best-of-N angle, energy rank of the closest light) of one estimate."""
    order = by_energy(lights)
    angles = [angle(lights[i]["dir"], gt_dir) for i in order]
    best = min(range(len(angles)), key=lambda k: angles[k])
    return angles[0], angles[best], best


def load(path, row):
    """[(panorama index, true primary direction, estimated lights)] of an eval file."""
    try:
        with open(path) as f:
            d = json.load(f)
    except OSError as e:
        sys.exit(f"light_placement.py: {path}: {e.strerror}")
    except ValueError as e:
        sys.exit(f"light_placement.py: {path}: not JSON ({e})")
    if not isinstance(d, dict) or not isinstance(d.get("panoramas"), list):
        sys.exit(f"light_placement.py: {path}: not `parlight eval --json` output (no panoramas)")
    crops = []
    for pi, p in enumerate(d["panoramas"]):
        for c in p.get("crops", []):
            if row not in c or "ground_truth" not in c:
                sys.exit(f"light_placement.py: {path}: a crop of {p.get('file')} has no "
                         f"'{row}' or 'ground_truth' lights (eval before 2026-12-04?)")
            try:
                gt, est = c["ground_truth"]["lights"], c[row]["lights"]
                for light in gt + est:
                    energy(light)
                    if len(light["dir"]) != 3:
                        raise ValueError("a direction without 3 components")
            except (KeyError, TypeError, ValueError) as e:
                sys.exit(f"light_placement.py: {path}: a crop of {p.get('file')}: malformed "
                         f"lights ({type(e).__name__}: {e})")
            if not gt or not est:
                continue
            crops.append((pi, gt[by_energy(gt)[0]]["dir"], est))
    if len({pi for pi, _, _ in crops}) < 2:
        sys.exit(f"light_placement.py: {path}: needs crops with lights in at least 2 panoramas")
    return crops


def placement(crops, draws, seed):
    n_lights = max(len(L) for _, _, L in crops)
    s = [scores(g, L) for _, g, L in crops]
    rank = [0] * n_lights
    for _, _, r in s:
        rank[r] += 1
    rng = random.Random(seed)
    others = {pi: [k for k, (pj, _, _) in enumerate(crops) if pj != pi] for pi, _, _ in crops}
    ctl_best, ctl_primary = [], []
    for _ in range(draws):
        t = [scores(g, crops[rng.choice(others[pi])][2]) for pi, g, _ in crops]
        ctl_best.append(median(x[1] for x in t))
        ctl_primary.append(median(x[0] for x in t))

    slots = []
    for i in range(n_lights):
        dirs = [L[i]["dir"] for _, _, L in crops if i < len(L)]
        m = [sum(v[k] for v in dirs) / len(dirs) for k in range(3)]
        r = math.sqrt(sum(x * x for x in m))
        slots.append({"mean_dir": [x / r for x in m] if r > 0 else [0.0, 0.0, 0.0],
                      "resultant": r, "median_angle_deg": median(angle(v, m) for v in dirs)})

    def span(v):
        v = sorted(v)
        return [v[int(0.025 * (len(v) - 1))], v[int(round(0.975 * (len(v) - 1)))]]

    return {
        "crops": len(crops),
        "primary_deg": median(x[0] for x in s),
        "best_of_n_deg": median(x[1] for x in s),
        "best_within_45": sum(x[1] <= 45 for x in s),
        "closest_rank": rank,
        "slots": slots,
        "other_room": {"draws": draws, "best_of_n_deg": median(ctl_best),
                       "best_of_n_range": span(ctl_best), "primary_deg": median(ctl_primary),
                       "primary_range": span(ctl_primary)},
    }


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("files", nargs="+", metavar="EVAL.json")
    ap.add_argument("--estimate", default="estimate", help="the row of lights (default estimate)")
    ap.add_argument("--draws", type=int, default=200)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--json", action="store_true", help="one JSON object per file")
    a = ap.parse_args()
    if a.draws < 1:
        sys.exit("light_placement.py: --draws must be at least 1")
    for path in a.files:
        r = placement(load(path, a.estimate), a.draws, a.seed)
        if a.json:
            print(json.dumps({"file": path, **r}))
            continue
        o = r["other_room"]
        print(f"{path}: {r['crops']} crops")
        print(f"  primary      {r['primary_deg']:6.1f} deg   other room {o['primary_deg']:6.1f} "
              f"[{o['primary_range'][0]:.1f}, {o['primary_range'][1]:.1f}]")
        print(f"  best of N    {r['best_of_n_deg']:6.1f} deg   other room {o['best_of_n_deg']:6.1f} "
              f"[{o['best_of_n_range'][0]:.1f}, {o['best_of_n_range'][1]:.1f}]; "
              f"{r['best_within_45']} crops within 45 deg")
        print("  the closest light is the estimate's " +
              ", ".join(f"#{k + 1} in {c}" for k, c in enumerate(r["closest_rank"])) +
              " crops (by energy)")
        print("  slots: " + "; ".join(
            f"light {k + 1} ({d['mean_dir'][0]:.2f}, {d['mean_dir'][1]:.2f}, {d['mean_dir'][2]:.2f}) "
            f"+-{d['median_angle_deg']:.1f} deg" for k, d in enumerate(r["slots"])))


if __name__ == "__main__":
    main()
