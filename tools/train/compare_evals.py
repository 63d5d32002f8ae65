#!/usr/bin/env python3
"""Paired comparison of two models scored on the same crops by `parlight eval --json`.

    compare_evals.py A.json B.json [--method model] [--boot 2000] [--seed 0] [--json]

The pooled median of `parlight eval` can jump across a gap between panoramas for a small change
(models/MODEL_CARD.md, "The 100-panorama retrain": 0.263 -> 0.328 si-RMSE while B was lower on 34
of the 64 crops). This reads both files' per-crop rows, refuses files whose crops differ
(panorama, yaw, exposure scale), and prints per score:

  rmse, si_rmse   how many crops B is lower / higher on, the median over crops of log(B / A)
                  (negative: B better) with a 95% interval from resampling whole panoramas
                  (crops of one room are not independent), and both pooled medians;
  angle_deg       the same with the difference B - A in degrees;

the angle's tail (how many crops are off by more than 90 deg and how many within 45 deg, in A
and in B: a change can cut the worst answers and leave the median where it was, MODEL_CARD
"Direction first through the whole network"), and per panorama the medians of both. When both
files have eval's `primary_in_view` flags (since 2026-12-04), the angle is also compared on the
crops whose true primary light is in view and on those where it is outside the crop (most of
them). When both have eval's key light over each room's views (`key_light_angle_deg`, since
2026-12-07: docs/EVAL.md), it prints in how many rooms B's fused key light is closer and farther,
and the median over rooms of both. A score eval wrote as null (the angle of a crop whose panorama has no extracted light) is
left out of every figure, as eval's own statistics leave out non-finite values. --method names
the row of each file to compare (model, ambient, brightest, ridge; default model, so two models'
files). Standard library only.
"""
import argparse
import json
import math
import random
import sys

SCORES = ("rmse", "si_rmse", "angle_deg")


def median(v):
    """Median of the finite values (NaN when there are none)."""
    v = sorted(x for x in v if math.isfinite(x))
    n = len(v)
    if n == 0:
        return float("nan")
    return v[n // 2] if n % 2 else 0.5 * (v[n // 2 - 1] + v[n // 2])


def load(path, method):
    """[(panorama, [(key, {score: value}), ...]), ...] of one eval file."""
    try:
        with open(path) as f:
            d = json.load(f)
    except (OSError, ValueError) as e:
        raise SystemExit(f"compare_evals: {path}: {e}") from None
    if not isinstance(d, dict) or not isinstance(d.get("panoramas"), list):
        raise SystemExit(f"compare_evals: {path}: not `parlight eval --json` output (no panoramas)")
    out = []
    for p in d["panoramas"]:
        rows = []
        for c in p.get("crops") or []:
            m = c.get(method)
            if not isinstance(m, dict) or any(
                    s not in m or not (m[s] is None or isinstance(m[s], (int, float))) for s in SCORES):
                raise SystemExit(f"compare_evals: {path}: {p.get('file')} yaw {c.get('yaw_deg')}: "
                                 f"no {method} scores")
            sc = {s: math.nan if m[s] is None else float(m[s]) for s in SCORES}
            sc["in_view"] = c.get("primary_in_view")
            rows.append(((c.get("yaw_deg"), c.get("exposure_scale")), sc))
        if not rows:
            raise SystemExit(f"compare_evals: {path}: {p.get('file')}: no per-crop rows")
        # the key light over the room's views: None when the file has none (before 2026-12-07, or
        # not for this row), NaN when eval wrote null
        kl = p.get("key_light_angle_deg")
        key = None
        if isinstance(kl, dict) and method in kl:
            v = kl[method]
            if not (v is None or isinstance(v, (int, float))):
                raise SystemExit(f"compare_evals: {path}: {p.get('file')}: key_light_angle_deg "
                                 f"{v!r} is not a number")
            key = math.nan if v is None else float(v)
        out.append((p.get("file"), rows, key))
    return out


def paired(a, b, pa, pb):
    if [p[0] for p in a] != [p[0] for p in b]:
        raise SystemExit(f"compare_evals: {pa} and {pb} score different panoramas: "
                         f"{[p[0] for p in a]} against {[p[0] for p in b]}")
    pairs = []
    for (pano, ra, _), (_, rb, _) in zip(a, b):
        if [k for k, _ in ra] != [k for k, _ in rb]:
            raise SystemExit(f"compare_evals: {pano}: {pa} and {pb} score different crops "
                             "(crops per panorama, yaw or exposure differ)")
        pairs.append((pano, [(x, y) for (_, x), (_, y) in zip(ra, rb)]))
    return pairs


def effect(score, x, y):
    if score == "angle_deg":
        return y - x
    if not (x > 0 and y > 0):      # also NaN (null in the file)
        return math.nan
    return math.log(y / x)


def score_stats(pairs, s, boot_n, rng, keep=lambda x: True):
    """Counts, median effect with its panorama-resampled 95% interval and pooled medians of score
    s over the crop pairs whose A row passes keep."""
    eff = [[effect(s, x[s], y[s]) for x, y in r if keep(x)] for _, r in pairs]
    eff = [e for e in eff if e]
    xs = [x[s] for _, r in pairs for x, _ in r if keep(x)]
    ys = [y[s] for _, r in pairs for x, y in r if keep(x)]
    boot = []
    for _ in range(boot_n if eff else 0):
        pick = [eff[rng.randrange(len(eff))] for _ in eff]
        m = median([e for r in pick for e in r])
        if math.isfinite(m):
            boot.append(m)
    boot.sort()
    ci = ([boot[int(0.025 * (len(boot) - 1))], boot[int(math.ceil(0.975 * (len(boot) - 1)))]]
          if boot else [float("nan")] * 2)
    return {"crops": len(xs), "panoramas": len(eff),
            "b_lower": sum(y < x for x, y in zip(xs, ys)), "b_higher": sum(y > x for x, y in zip(xs, ys)),
            "median_effect": median([e for r in eff for e in r]), "ci95": ci,
            "effect": "B - A (deg)" if s == "angle_deg" else "log(B / A)",
            "median_a": median(xs), "median_b": median(ys)}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("a", help="parlight eval --json of model A")
    ap.add_argument("b", help="parlight eval --json of model B (same panoramas, --crops)")
    ap.add_argument("--method", default="model", help="row to compare (default model)")
    ap.add_argument("--boot", type=int, default=2000, help="panorama resamples (default 2000)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--json", action="store_true", help="one JSON object instead of the table")
    a = ap.parse_args(argv)
    if a.boot < 0:
        raise SystemExit(f"compare_evals: --boot {a.boot}: expected 0 or more")
    la, lb = load(a.a, a.method), load(a.b, a.method)
    pairs = paired(la, lb, a.a, a.b)
    rng = random.Random(a.seed)
    res = {"a": a.a, "b": a.b, "method": a.method, "panoramas": len(pairs),
           "crops": sum(len(r) for _, r in pairs), "scores": {}, "per_panorama": []}
    for s in SCORES:
        res["scores"][s] = score_stats(pairs, s, a.boot, rng)
    flags = [(x["in_view"], y["in_view"]) for _, r in pairs for x, y in r]
    # split only when both files have the flags (files written before 2026-12-04 have none)
    if any(fa is not None for fa, _ in flags) and any(fb is not None for _, fb in flags):
        if any(fa != fb for fa, fb in flags):
            raise SystemExit(f"compare_evals: {a.a} and {a.b} disagree on which crops have the "
                             "primary light in view (different ground truths)")
        for key, want in (("angle_deg in view", True), ("angle_deg out of view", False)):
            res["scores"][key] = score_stats(pairs, "angle_deg", a.boot, rng,
                                             keep=lambda x, w=want: x["in_view"] is w)
    cols = ([x["angle_deg"] for _, r in pairs for x, _ in r],
            [y["angle_deg"] for _, r in pairs for _, y in r])   # NaN (null) counts in neither
    res["angle_tail"] = {"over_90": [sum(v > 90 for v in c) for c in cols],
                         "within_45": [sum(v <= 45 for v in c) for c in cols]}
    for pano, r in pairs:
        res["per_panorama"].append({"file": pano, **{
            s: [median([x[s] for x, _ in r]), median([y[s] for _, y in r])] for s in SCORES}})
    keys = [(ka, kb) for (_, _, ka), (_, _, kb) in zip(la, lb)]
    if all(ka is not None and kb is not None for ka, kb in keys):
        both = [(ka, kb) for ka, kb in keys if not (math.isnan(ka) or math.isnan(kb))]
        res["key_light"] = {"rooms": len(both), "b_closer": sum(kb < ka for ka, kb in both),
                            "b_farther": sum(kb > ka for ka, kb in both),
                            "median_a": median([ka for ka, _ in both]),
                            "median_b": median([kb for _, kb in both])}
        for p, (ka, kb) in zip(res["per_panorama"], keys):
            p["key_light_angle_deg"] = [ka, kb]
    if a.json:
        json.dump(res, sys.stdout, indent=1)
        print()
        return 0
    print(f"A: {a.a}\nB: {a.b}\n{res['crops']} crops of {res['panoramas']} panoramas, "
          f"row '{a.method}'; 95% intervals from {a.boot} resamples of whole panoramas")
    print(f"  {'score':10s} {'B lower':>8s} {'B higher':>9s}   median effect [95% interval]"
          "          pooled median A -> B")
    for s, v in res["scores"].items():
        unit = "deg" if s.startswith("angle_deg") else "log"
        if s.startswith("angle_deg "):
            print(f"  {s} ({v['crops']} crops of {v['panoramas']} panoramas):")
            s = ""
        print(f"  {s:10s} {v['b_lower']:8d} {v['b_higher']:9d}   {v['median_effect']:+8.4f} {unit} "
              f"[{v['ci95'][0]:+.4f}, {v['ci95'][1]:+.4f}]    {v['median_a']:.4g} -> {v['median_b']:.4g}")
    t = res["angle_tail"]
    print(f"  angle tail: crops over 90 deg {t['over_90'][0]} -> {t['over_90'][1]}, "
          f"within 45 deg {t['within_45'][0]} -> {t['within_45'][1]}")
    k = res.get("key_light")
    if k:
        print(f"  key light over each room's views (deg): B closer in {k['b_closer']}, farther in "
              f"{k['b_farther']} of {k['rooms']} rooms; median over rooms "
              f"{k['median_a']:.4g} -> {k['median_b']:.4g}")
    print("  per panorama (medians, A -> B):")
    for p in res["per_panorama"]:
        print(f"    {p['file']:32s} " + "  ".join(
            f"{s} {p[s][0]:.4g} -> {p[s][1]:.4g}" for s in SCORES) + (
            f"  key light {p['key_light_angle_deg'][0]:.4g} -> {p['key_light_angle_deg'][1]:.4g}"
            if "key_light_angle_deg" in p else ""))
    return 0


if __name__ == "__main__":
    sys.exit(main())
