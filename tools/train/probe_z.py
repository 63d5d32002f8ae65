#!/usr/bin/python3
"""Does a network's latent z carry the primary light's direction to rooms it has not seen? A linear
probe: a ridge regression from z (the layer the fc and the lighting heads read) to the ground
truth's primary-light direction, fit on a make_dataset.py folder's training crops, scored by
grouped cross-validation over those panoramas and on a second set of crops (typically `eval/`'s).

    tools/train/probe_z.py --model M.plm --data DATASET --score-hdr DIR [--crops 8]
                           [--eval-json EVAL.json] [--folds 5] [--work DIR] [--json OUT]
                           [--parlight build/parlight] [--zdump build/tools/zdump] [--threads 1]

z is what the C executor computes (build/tools/zdump, tools/train/zdump.c: the same bytes for a
float or an int8 model as `parlight estimate` reads), for each training crop and its mirror image
(the mirror trains with the direction's x negated, as train.py's flips do). The scoring crops are
`parlight crop --batch N` of every panorama in --score-hdr: the crops `parlight eval --crops N`
scores (640x480, fov 60, pitch 0, N yaws). Targets, folds and the ridge are fit_ridge.py's
(the primary light is pl_lighting_primary's; folds by panorama; standardised features, intercept
unpenalised; lambda = n x {0.01, 0.1, 1, 10}, chosen by the cross-validated median angle).

Printed (and with --json written): the cross-validated median angle against each fold's constant
answer (its training crops' mean direction), and on the scoring crops the probe's median angle
against the training mean direction and "straight up"; with --eval-json (`parlight eval --json`
of the same model on the same panoramas and --crops) also the network's own primary light per
crop, and the paired median difference probe - network. A probe that does no better than the
network's heads on the scoring rooms says no linear readout of z does better there; one well
ahead of them says the heads lose a cue z has. The probe bounds what z holds from below only:
nonlinear heads can beat it (MODEL_CARD.md, "What the encoder knows").

z is cached in --work (default DATASET/probe-<model sha256 prefix>/), keyed by the model's and the
crop lists' sha256; rerunning reuses it. One BLAS thread: the same numbers each run.
"""

import argparse
import glob
import hashlib
import json
import os
import subprocess
import sys

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")
import numpy as np  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.dirname(HERE))
import fit_ridge  # noqa: E402
import plm  # noqa: E402

LAMBDAS = (0.01, 0.1, 1.0, 10.0)   # times the number of training rows


class Ridge:
    """fit_ridge.Ridge's regression (standardised features, centred targets, intercept
    unpenalised; raw(lam) gives W, b on the raw features), solved per lambda instead of through
    one eigendecomposition: with 3,072 features a linear solve per lambda is several times
    cheaper than eigh. Fewer rows than features: through the n x n Gram matrix,
    W = Z^T (Z Z^T + lambda)^-1 Y (the same regression)."""

    def __init__(self, X, Y):
        self.mu = X.mean(0)
        sd = X.std(0)
        self.sd = np.where(sd > 1e-12, sd, 1.0)
        self.Z = (X - self.mu) / self.sd
        self.ym = Y.mean(0)
        self.Yc = Y - self.ym
        self.dual = len(X) < X.shape[1]
        self.G = self.Z @ self.Z.T if self.dual else self.Z.T @ self.Z
        self.ZtY = None if self.dual else self.Z.T @ self.Yc

    def raw(self, lam):
        eye = lam * np.eye(len(self.G))
        if self.dual:
            W = self.Z.T @ np.linalg.solve(self.G + eye, self.Yc)
        else:
            W = np.linalg.solve(self.G + eye, self.ZtY)
        W = W / self.sd[:, None]
        return W, self.ym - self.mu @ W


def latents(args, work, name, pngs, model_sha):
    """z [len(pngs), 2, D] (the image, its mirror) through zdump, cached in work."""
    lst = "\n".join(pngs) + "\n"
    key = hashlib.sha256((model_sha + lst).encode()).hexdigest()[:16]
    out = os.path.join(work, f"z-{name}-{key}.f32")
    if not os.path.exists(out):
        lpath = os.path.join(work, f"{name}.lst")
        with open(lpath, "w", encoding="utf-8") as f:
            f.write(lst)
        r = subprocess.run([args.zdump, args.model, lpath, out + ".tmp", str(args.threads)],
                           capture_output=True, text=True)
        if r.returncode != 0:
            if os.path.exists(out + ".tmp"):
                os.remove(out + ".tmp")
            raise ValueError(f"zdump on the {name} crops: {r.stderr.strip()}")
        os.replace(out + ".tmp", out)
    z = np.fromfile(out, dtype=np.float32)
    if len(pngs) == 0 or z.size % (2 * len(pngs)):
        raise ValueError(f"{out}: {z.size} values for {len(pngs)} crops")
    return z.reshape(len(pngs), 2, -1).astype(np.float64)


def score_crops(args, work):
    """(png paths, unit primary directions [n, 3], names) of --score-hdr's panoramas' batch crops
    that have a light."""
    panos = sorted(p for p in glob.glob(os.path.join(args.score_hdr, "*"))
                   if p.lower().endswith((".exr", ".hdr")))
    if not panos:
        raise ValueError(f"{args.score_hdr}: no .exr or .hdr panoramas")
    cdir = os.path.join(work, f"score-crops{args.crops}")
    os.makedirs(cdir, exist_ok=True)
    for p in panos:
        stem = os.path.splitext(os.path.basename(p))[0]
        if len(glob.glob(os.path.join(cdir, stem + "_yaw*.json"))) != args.crops:
            r = subprocess.run([args.parlight, "crop", "--hdr", p, "--batch", str(args.crops),
                                "--out-dir", cdir], capture_output=True, text=True)
            if r.returncode != 0:
                raise ValueError(f"parlight crop {p}: {r.stderr.strip()}")
    pngs, dirs, names = [], [], []
    for js in sorted(glob.glob(os.path.join(cdir, "*_yaw*.json"))):
        with open(js, encoding="utf-8") as f:
            y, has = fit_ridge.targets(json.load(f))
        if has:
            pngs.append(js[:-5] + ".png")
            dirs.append(y[0:3])
            names.append(os.path.basename(js)[:-5])
    return pngs, np.array(dirs), names


def network_angles(path, names):
    """The network's primary-light angle of each named crop in a `parlight eval --json` file."""
    with open(path, encoding="utf-8") as f:
        ev = json.load(f)
    got = {}
    for p in ev["panoramas"]:
        stem = os.path.splitext(p["file"])[0]
        for c in p["crops"]:
            got[f"{stem}_yaw{int(round(c['yaw_deg'])) % 360:03d}"] = c["model"]["angle_deg"]
    missing = [n for n in names if n not in got]
    if missing:
        raise ValueError(f"{path}: no crop {missing[0]} (same panoramas and --crops?)")
    return np.array([got[n] for n in names])


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--model", required=True)
    ap.add_argument("--data", required=True, help="a make_dataset.py folder (training crops)")
    ap.add_argument("--score-hdr", required=True, help="folder of panoramas to score on")
    ap.add_argument("--crops", type=int, default=8)
    ap.add_argument("--eval-json", help="parlight eval --json of --model on --score-hdr")
    ap.add_argument("--folds", type=int, default=5)
    ap.add_argument("--work")
    ap.add_argument("--json", help="write the figures here")
    ap.add_argument("--parlight", default=os.path.join(ROOT, "build", "parlight"))
    ap.add_argument("--zdump", default=os.path.join(ROOT, "build", "tools", "zdump"))
    ap.add_argument("--threads", type=int, default=1)
    args = ap.parse_args(argv)
    try:
        if not 1 <= args.crops <= 360:
            raise ValueError(f"--crops {args.crops}: expected 1..360")
        if args.folds < 2:
            raise ValueError(f"--folds {args.folds}: expected >= 2")
        for exe in (args.parlight, args.zdump):
            if not os.access(exe, os.X_OK):
                raise ValueError(f"{exe}: not built (make {os.path.relpath(exe, ROOT)})")
        model_sha = plm.file_sha256(args.model)
        work = args.work or os.path.join(args.data, f"probe-{model_sha[:12]}")
        os.makedirs(work, exist_ok=True)

        _, Y, has, panos, _, _, _, _ = fit_ridge.read_dataset(args.data, 0)
        with open(os.path.join(args.data, "index.tsv"), encoding="utf-8") as f:
            pngs = [os.path.join(os.path.abspath(args.data), r.split("\t")[0])
                    for r in f.read().splitlines()[1:]]
        k = min(args.folds, len(set(panos)))
        if k < 2:
            raise ValueError(f"{args.data}: crops of {len(set(panos))} panorama(s); the "
                             "cross-validation needs 2")
        z = latents(args, work, "train", pngs, model_sha)[has]
        d = Y[has][:, 0:3]
        fold = fit_ridge.folds_of([p for p, h in zip(panos, has) if h], k)
        X = np.concatenate([z[:, 0], z[:, 1]])               # the crops, then their mirrors
        T = np.concatenate([d, d * [-1.0, 1.0, 1.0]])
        F = np.concatenate([fold, fold])

        cv = {lam: np.zeros(len(T)) for lam in LAMBDAS}
        const = np.zeros(len(T))
        for f in range(k):
            tr, te = F != f, F == f
            r = Ridge(X[tr], T[tr])
            for lam in LAMBDAS:
                W, b = r.raw(lam * tr.sum())
                cv[lam][te] = fit_ridge.angles_deg(X[te] @ W + b, T[te])
            const[te] = fit_ridge.angles_deg(np.tile(T[tr].mean(0), (te.sum(), 1)), T[te])
        med = {lam: float(np.median(a)) for lam, a in cv.items()}
        lam = min(LAMBDAS, key=lambda v: med[v])

        spng, sdir, names = score_crops(args, work)
        if not names:
            raise ValueError(f"{args.score_hdr}: no scoring crop has a light")
        sz = latents(args, work, "score", spng, model_sha)[:, 0]
        W, b = Ridge(X, T).raw(lam * len(X))
        probe = fit_ridge.angles_deg(sz @ W + b, sdir)
        mean = fit_ridge.angles_deg(np.tile(T.mean(0), (len(sdir), 1)), sdir)
        up = fit_ridge.angles_deg(np.tile([0.0, 1.0, 0.0], (len(sdir), 1)), sdir)
        res = {"model": args.model, "model_sha256": model_sha, "data": args.data,
               "train_crops": int(has.sum()), "panoramas": len(set(panos)), "folds": k,
               "features": int(X.shape[1]),
               "cv_median_angle_deg": {str(v): med[v] for v in LAMBDAS}, "lambda": lam,
               "cv_constant_median_angle_deg": float(np.median(const)),
               "score_hdr": args.score_hdr, "score_crops": len(names),
               "probe_median_angle_deg": float(np.median(probe)),
               "probe_within_45": int((probe <= 45).sum()), "probe_over_90": int((probe > 90).sum()),
               "mean_direction_median_angle_deg": float(np.median(mean)),
               "straight_up_median_angle_deg": float(np.median(up))}
        print(f"probe of z ({X.shape[1]} values) -> primary direction: {has.sum()} training "
              f"crops and their mirrors, {len(set(panos))} panoramas, {k}-fold cross-validation")
        for v in LAMBDAS:
            print(f"  lambda {v:g} x n: CV median angle {med[v]:.1f} deg")
        print(f"  chosen lambda {lam:g} x n; each fold's training mean direction: "
              f"{res['cv_constant_median_angle_deg']:.1f} deg")
        print(f"{len(names)} crops of {args.score_hdr} (--crops {args.crops}): probe "
              f"{res['probe_median_angle_deg']:.1f} deg (within 45: {res['probe_within_45']}, over "
              f"90: {res['probe_over_90']}), training mean direction "
              f"{res['mean_direction_median_angle_deg']:.1f}, straight up "
              f"{res['straight_up_median_angle_deg']:.1f}")
        if args.eval_json:
            net = network_angles(args.eval_json, names)
            res["network_median_angle_deg"] = float(np.median(net))
            res["paired_probe_minus_network_deg"] = float(np.median(probe - net))
            print(f"  the network's own primary light: {np.median(net):.1f} deg; paired median "
                  f"probe - network {res['paired_probe_minus_network_deg']:+.1f} deg")
        if args.json:
            with open(args.json, "w", encoding="utf-8") as f:
                json.dump(res, f, indent=1)
                f.write("\n")
    except (OSError, ValueError, KeyError, json.JSONDecodeError) as e:
        print(f"probe_z: {e}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
