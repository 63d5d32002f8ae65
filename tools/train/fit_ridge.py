#!/usr/bin/python3
"""Baseline (d) of `parlight eval`: a linear (ridge) model from a crop's coarse log pixels to one
light and an ambient, fit on the training crops of make_dataset.py and stored as a small JSON file
that light/ridge.c loads (docs/EVAL.md, "(d) ridge").

    tools/train/fit_ridge.py --data /work/cache/d48 --out models/parlight-ridge.json
                             [--val-panos N] [--folds 5] [--lambdas 0.1,0.316,...] [--force]
    tools/train/fit_ridge.py --predict MODEL.json IMAGE.png --gamma G    (the lighting, as JSON)
    tools/train/fit_ridge.py --golden DIR                (tests/data/ridge: test_ridge.c's numbers)

Features (definition 1; light/ridge.h says the same): the crop's 8-bit RGB linearised per channel
as (v / 255)^gamma with the crop's gamma, averaged over a grid of cols x rows = 16 x 12 cells,
cell (i, j) being the pixels x in [floor(i W / cols), floor((i + 1) W / cols)) and y in
[floor(j H / rows), floor((j + 1) H / rows)) of a W x H image (W >= cols, H >= rows), then
log(max(mean, floor)) with floor = 1e-4: 576 values in the order row j (top first), column i
(left first), channel (R, G, B). The model is y = bias + W f (the standardisation of the fit is
folded into W and bias).

Outputs (10, in the crop's camera frame: x right, y up, looking along -z, on the crop's scale):
the ground truth's primary light (pl_lighting_primary: the light with the largest luminance x
SG integral, the first on ties) as its unit direction (3), log of its peak colour (3, each
channel floored at 1e-4), log of its solid angle (1); and the log of the ambient (3, floored at
1e-4). A crop whose ground truth has no light trains only the ambient outputs.

Fit: ridge regression per group of outputs (direction; log colour + log solid angle; log
ambient), each on standardised features with an unpenalised intercept, its lambda chosen from a
grid by grouped k-fold cross-validation over panoramas (a panorama's crops are all in one fold;
folds by name hash) as the lowest mean squared error of the group; the median angle of the
cross-validated primary direction is reported for every lambda. Then one fit on all the crops
given. Only training panoramas are accepted: the shared train/ ones and those of a
make_dataset.py --panos folder (a dataset row elsewhere, a train/ crop made from a panorama
outside a train/ folder, or a crop of the shared eval/ panoramas, is refused); --val-panos N leaves out train.py's held-out validation panoramas
(train.held_out_panoramas, the same rooms as `train.py --val-panos N`). Deterministic: one BLAS
thread, fixed folds, the same file for the same data.
"""

import argparse
import hashlib
import json
import math
import os
import sys

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # one summation order: the same bits each run
os.environ.setdefault("OMP_NUM_THREADS", "1")
import numpy as np  # noqa: E402
from PIL import Image  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
SHARED_HDRI = os.path.join(os.environ.get("PL_SHARED") or os.path.join(os.path.dirname(ROOT),
                                                                     "shared"), "data", "hdri")

FORMAT = "parlight-ridge"
VERSION = 1          # the file's layout
DEFINITION = 1       # the features' and outputs' meaning (light/ridge.h PL_RIDGE_DEFINITION)
GRID = (16, 12)      # cols, rows
FLOOR = 1e-4         # of cell means, light colours and ambient before the log
OUTPUTS = ["dir_x", "dir_y", "dir_z", "log_rgb_r", "log_rgb_g", "log_rgb_b",
           "log_solid_angle_sr", "log_ambient_r", "log_ambient_g", "log_ambient_b"]
GROUPS = {"dir": [0, 1, 2], "light": [3, 4, 5, 6], "ambient": [7, 8, 9]}
LAMBDAS = [round(10 ** (e / 2), 6) for e in range(-2, 11)]  # 0.1 .. 1e5, half decades
# predict(): what light/ridge.c does with the outputs (its PL_RIDGE_* constants)
DISTANCE_M = 2.0
LOG_MAX = 30.0                        # log colour / ambient clamped to [-LOG_MAX, LOG_MAX]
SR_RANGE = (1e-6, 4 * math.pi)       # solid angle clamped to it
DIR_EPS = 1e-6                       # a direction shorter than this becomes (0, 1, 0)


# ---- features and targets ---------------------------------------------------------------------

def features(u8, gamma, grid=GRID, floor=FLOOR):
    """The feature vector (float64, 3 cols rows) of an 8-bit RGB image [H, W, 3]."""
    h, w = u8.shape[:2]
    cols, rows = grid
    if u8.ndim != 3 or u8.shape[2] != 3 or u8.dtype != np.uint8:
        raise ValueError(f"image {u8.shape} {u8.dtype}: expected 8-bit RGB")
    if w < cols or h < rows:
        raise ValueError(f"image {w}x{h}: smaller than the {cols}x{rows} grid")
    lut = np.array([(v / 255.0) ** gamma for v in range(256)])  # libm pow, as light/ridge.c
    lin = lut[u8]
    xs = [i * w // cols for i in range(cols)]
    ys = [j * h // rows for j in range(rows)]
    s = np.add.reduceat(np.add.reduceat(lin, ys, axis=0), xs, axis=1)
    cw = np.diff(xs + [w]).astype(np.float64)
    ch = np.diff(ys + [h]).astype(np.float64)
    mean = s / (ch[:, None, None] * cw[None, :, None])
    return np.log(np.maximum(mean, floor)).reshape(-1)


def luminance(c):
    return 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]


def sg_integral(sr):
    """light/sg.c pl_sg_integral: 2 pi sigma (1 - exp(-2 / sigma)), sigma = sr / 4 pi."""
    sigma = sr / (4 * math.pi)
    return 2 * math.pi * sigma * -math.expm1(-2 / sigma) if sigma > 0 else 0.0


def primary(lights):
    """Index of pl_lighting_primary's light: the largest luminance(rgb) x SG integral, the first
    on ties; None without lights."""
    best, best_e = None, -1.0
    for i, li in enumerate(lights):
        e = luminance(li["rgb"]) * sg_integral(li["solid_angle_sr"])
        if not e == e:
            e = 0.0
        if e > best_e:
            best, best_e = i, e
    return best


def targets(gt):
    """(y [10], has_light): the outputs' ground truth of one crop's JSON (light outputs NaN
    without a light)."""
    y = np.full(len(OUTPUTS), np.nan)
    amb = gt["ambient"]
    y[7:10] = [math.log(max(float(a), FLOOR)) for a in amb]
    i = primary(gt["lights"])
    if i is None:
        return y, False
    li = gt["lights"][i]
    d = np.array(li["dir"], dtype=np.float64)
    y[0:3] = d / np.linalg.norm(d)
    y[3:6] = [math.log(max(float(c), FLOOR)) for c in li["rgb"]]
    y[6] = math.log(float(li["solid_angle_sr"]))
    return y, True


def check_numbers(v, n, what, lo=None):
    if not isinstance(v, list) or len(v) != n or not all(
            isinstance(t, (int, float)) and not isinstance(t, bool) and math.isfinite(t) for t in v):
        raise ValueError(f"{what}: expected {n} finite numbers")
    if lo is not None and any(t < lo for t in v):
        raise ValueError(f"{what}: expected numbers >= {lo}")


def read_crop(data, png, js, pano):
    """(features, targets, has_light) of one dataset row, with its ground truth checked."""
    path = os.path.join(data, js)
    with open(path, encoding="utf-8") as f:
        gt = json.load(f)
    ds = gt.get("dataset") or {}
    if ds.get("panorama") != pano:
        raise ValueError(f"{path}: dataset.panorama {ds.get('panorama')!r}, index.tsv says {pano!r}")
    src = gt.get("source", "")
    if pano.startswith("panos/"):
        # a user's folder (make_dataset.py --panos): anything but the shared eval/ panoramas
        evald = os.path.realpath(os.path.join(SHARED_HDRI, "eval"))
        if os.path.realpath(src).startswith(evald + os.sep):
            raise ValueError(f"{path}: made from {src!r}, an evaluation panorama")
    elif os.path.basename(os.path.dirname(src)) != "train":
        raise ValueError(f"{path}: made from {src!r}, not a panorama in a train/ folder")
    g = gt.get("gamma")
    if not isinstance(g, (int, float)) or not 0.2 <= g <= 5:
        raise ValueError(f"{path}: gamma {g!r}: expected a number in 0.2..5")
    check_numbers(gt.get("ambient"), 3, f"{path}: ambient", 0.0)
    if not isinstance(gt.get("lights"), list):
        raise ValueError(f"{path}: no 'lights' array")
    for k, li in enumerate(gt["lights"]):
        check_numbers(li.get("dir"), 3, f"{path}: lights[{k}].dir")
        check_numbers(li.get("rgb"), 3, f"{path}: lights[{k}].rgb", 0.0)
        check_numbers([li.get("solid_angle_sr")], 1, f"{path}: lights[{k}].solid_angle_sr")
        if li["solid_angle_sr"] <= 0 or not any(li["dir"]):
            raise ValueError(f"{path}: lights[{k}]: zero direction or solid angle <= 0")
    with Image.open(os.path.join(data, png)) as im:
        u8 = np.asarray(im.convert("RGB"))
    if (u8.shape[1], u8.shape[0]) != (gt.get("width"), gt.get("height")):
        raise ValueError(f"{png}: {u8.shape[1]}x{u8.shape[0]}, its JSON says "
                         f"{gt.get('width')}x{gt.get('height')}")
    y, has = targets(gt)
    return features(u8, float(g)), y, has


def read_dataset(data, val_panos):
    """Features X [M, 576], targets Y [M, 10], has_light [M], panorama and indoor flag (scene
    not outdoor) per crop, the held-out panoramas, the index's sha256 and the dataset's
    configuration."""
    index = os.path.join(data, "index.tsv")
    with open(index, encoding="utf-8") as f:
        lines = [ln.rstrip("\n").split("\t") for ln in f]
    if not lines or lines[0][:4] != ["png", "json", "panorama", "scene"]:
        raise ValueError(f"{index}: expected the header png, json, panorama, scene")
    rows = lines[1:]
    if not rows:
        raise ValueError(f"{index}: no crops")
    for i, r in enumerate(rows, 2):
        if len(r) < 4 or ".." in r[2] or not (
                (r[2].startswith("train/") and "/" not in r[2][6:]) or r[2].startswith("panos/")):
            raise ValueError(f"{index}:{i}: panorama {r[2] if len(r) > 2 else r!r} is not under "
                             "train/ or a make_dataset.py --panos folder (the ridge baseline is "
                             "fit on training panoramas only)")
    held = set()
    if val_panos:
        sys.path.insert(0, HERE)
        import train  # noqa: E402  (torch, only for the split)
        held = train.held_out_panoramas(rows, val_panos)
    X, Y, H, P, IN = [], [], [], [], []
    for png, js, pano, scene in (r[:4] for r in rows):
        if pano in held:
            continue
        f, y, has = read_crop(data, png, js, pano)
        X.append(f)
        Y.append(y)
        H.append(has)
        P.append(pano)
        IN.append(scene != "outdoor")
    with open(index, "rb") as f:
        digest = hashlib.sha256(f.read()).hexdigest()
    cfg = None
    cfg_path = os.path.join(data, "dataset.json")
    if os.path.exists(cfg_path):
        with open(cfg_path, encoding="utf-8") as f:
            cfg = json.load(f)
    return (np.array(X), np.array(Y), np.array(H, dtype=bool), P, np.array(IN, dtype=bool),
            sorted(held), digest, cfg)


# ---- ridge ------------------------------------------------------------------------------------

class Ridge:
    """Ridge regressions of Y on X for several lambdas from one eigendecomposition: standardised
    features (constant ones left at 0), centred targets, intercept unpenalised."""

    def __init__(self, X, Y):
        self.mu = X.mean(0)
        sd = X.std(0)
        self.sd = np.where(sd > 1e-12, sd, 1.0)
        Z = (X - self.mu) / self.sd
        self.ym = Y.mean(0)
        self.e, self.V = np.linalg.eigh(Z.T @ Z)
        self.VtZtY = self.V.T @ (Z.T @ (Y - self.ym))

    def raw(self, lam):
        """(W [d, k], b [k]) on the raw features: y = x W + b."""
        W = self.V @ (self.VtZtY / (self.e + lam)[:, None]) / self.sd[:, None]
        return W, self.ym - self.mu @ W


def folds_of(panos, k):
    """Fold index per crop: panoramas sorted by the sha256 of their name, dealt round-robin."""
    names = sorted(set(panos), key=lambda p: hashlib.sha256(p.encode()).hexdigest())
    fold = {p: i % k for i, p in enumerate(names)}
    return np.array([fold[p] for p in panos])


def angles_deg(pred, truth):
    n = np.linalg.norm(pred, axis=1)
    n = np.where(n > DIR_EPS, n, 1.0)
    d = np.where((np.linalg.norm(pred, axis=1) > DIR_EPS)[:, None], pred / n[:, None],
                 np.array([0.0, 1.0, 0.0]))
    return np.degrees(np.arccos(np.clip((d * truth).sum(1), -1, 1)))


def cross_validate(X, Y, has, indoor, fold, lambdas):
    """Per lambda, the cross-validated MSE of each group and the median angle of the primary
    direction (pooled over folds), also over the indoor crops alone."""
    k = int(fold.max()) + 1
    pred = {g: np.full((len(lambdas),) + Y[:, idx].shape, np.nan) for g, idx in GROUPS.items()}
    for f in range(k):
        tr, te = fold != f, fold == f
        for g, idx in GROUPS.items():
            rows = tr & has if g != "ambient" else tr
            test = te & has if g != "ambient" else te
            if rows.sum() < 2 or test.sum() == 0:
                continue
            r = Ridge(X[rows], Y[rows][:, idx])
            for li, lam in enumerate(lambdas):
                W, b = r.raw(lam)
                pred[g][li][test] = X[test] @ W + b
    scores = []
    for li, lam in enumerate(lambdas):
        s = {"lambda": lam}
        for g, idx in GROUPS.items():
            sel = has if g != "ambient" else np.ones(len(has), bool)
            err = (pred[g][li][sel] - Y[sel][:, idx]) ** 2
            s[f"mse_{g}"] = float(np.mean(err))
        a = angles_deg(pred["dir"][li][has], Y[has][:, 0:3])
        s["median_angle_deg"] = float(np.median(a))
        s["q1_angle_deg"], s["q3_angle_deg"] = (float(v) for v in np.percentile(a, [25, 75]))
        ind = indoor[has]
        s["median_angle_deg_indoor"] = float(np.median(a[ind])) if ind.any() else None
        scores.append(s)
    return scores


def fit(X, Y, has, lam):
    """(weights [10][576], bias [10]) with lambda lam[g] for each group."""
    W = np.zeros((X.shape[1], len(OUTPUTS)))
    b = np.zeros(len(OUTPUTS))
    for g, idx in GROUPS.items():
        rows = has if g != "ambient" else np.ones(len(has), bool)
        Wg, bg = Ridge(X[rows], Y[rows][:, idx]).raw(lam[g])
        W[:, idx], b[idx] = Wg, bg
    return W.T, b


# ---- the file ---------------------------------------------------------------------------------

def model_dict(weights, bias, extra):
    d = {"format": FORMAT, "version": VERSION,
         "features": {"definition": DEFINITION, "grid": list(GRID), "floor": FLOOR,
                      "n": 3 * GRID[0] * GRID[1],
                      "text": "per channel (v/255)^gamma with the crop's gamma; mean over cell "
                              "(i, j) = pixels x in [floor(i W/cols), floor((i+1) W/cols)), y in "
                              "[floor(j H/rows), floor((j+1) H/rows)); log(max(mean, floor)); "
                              "order row j, column i, channel RGB; y = bias + weights . f"},
         "outputs": OUTPUTS,
         "bias": [float(v) for v in bias],
         "weights": [[float(v) for v in row] for row in weights]}
    d.update(extra)
    return d


def load_model(path):
    with open(path, encoding="utf-8") as f:
        m = json.load(f)
    if m.get("format") != FORMAT or m.get("version") != VERSION or \
            m.get("features", {}).get("definition") != DEFINITION:
        raise ValueError(f"{path}: not a {FORMAT} file of version {VERSION}, definition "
                         f"{DEFINITION}")
    return m


def outputs(m, f):
    return np.array(m["bias"]) + np.array(m["weights"]) @ f


def lighting(y):
    """What light/ridge.c makes of the outputs: a lights-JSON object (docs/LIGHTING.md)."""
    d = np.array(y[0:3])
    n = float(np.linalg.norm(d))
    d = d / n if n > DIR_EPS else np.array([0.0, 1.0, 0.0])
    clamp = lambda v: min(max(float(v), -LOG_MAX), LOG_MAX)  # noqa: E731
    rgb = [math.exp(clamp(v)) for v in y[3:6]]
    sr = min(max(math.exp(clamp(y[6])), SR_RANGE[0]), SR_RANGE[1])
    amb = [math.exp(clamp(v)) for v in y[7:10]]
    return {"lights": [{"dir": [float(v) for v in d], "distance_m": DISTANCE_M,
                        "solid_angle_sr": sr, "rgb": rgb}], "ambient": amb}


def write_json(path, obj, force):
    if os.path.exists(path) and not force:
        raise ValueError(f"{path} exists (--force to replace it)")
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    tmp = path + ".tmp"
    with open(tmp, "w", encoding="utf-8") as f:
        json.dump(obj, f, allow_nan=False, indent=None, separators=(",", ":"))
        f.write("\n")
    os.replace(tmp, path)


# ---- golden data for tests/test_ridge.c ---------------------------------------------------------

def golden_image(w, h):
    """The synthetic image test_ridge.c makes too: v = (37 x + 91 y + 53 c + 11 x y) mod 256,
    except a black 5 x 4 corner (cells below the floor) and a saturated band (y = h - 1)."""
    img = np.zeros((h, w, 3), np.uint8)
    for y in range(h):
        for x in range(w):
            for c in range(3):
                v = (37 * x + 91 * y + 53 * c + 11 * x * y) % 256
                if x < 5 and y < 4:
                    v = 0
                if y == h - 1:
                    v = 255
                img[y, x, c] = v
    return img


def golden(out_dir):
    """A small random model and the features, outputs and lighting of golden_image on it."""
    rng = np.random.default_rng(20261203)
    n = 3 * GRID[0] * GRID[1]
    rnd6 = np.vectorize(lambda v: float(f"{v:.6g}"))  # a smaller file; the numbers are exact
    weights = rnd6(rng.normal(0, 0.02, (len(OUTPUTS), n)))
    bias = rnd6(rng.normal(0, 0.5, len(OUTPUTS)))
    made = ("tools/train/fit_ridge.py --golden " + os.path.relpath(out_dir, ROOT) +
            ": weights N(0, 0.02) and bias N(0, 0.5) from numpy default_rng(20261203) rounded "
            f"to 6 digits, numpy {np.__version__}; never edit by hand")
    model = model_dict(weights, bias, {"fit": {"tool": made}})
    write_json(os.path.join(out_dir, "model.json"), model, True)
    model = load_model(os.path.join(out_dir, "model.json"))  # the numbers as the C side reads them
    cases = []
    for w, h, gamma in ((35, 27, 2.2), (16, 12, 1.8), (64, 48, 2.6)):
        f = features(golden_image(w, h), gamma)
        y = outputs(model, f)
        cases.append({"width": w, "height": h, "gamma": gamma, "features": [float(v) for v in f],
                      "outputs": [float(v) for v in y], "lighting": lighting(y)})
    # outputs at the edges of predict's rules: a zero and a tiny direction, clamped logs
    edge = [[0, 0, 0, 0, 0, 0, 0, 0, 0, 0],
            [1e-7, -2e-7, 0, 40, -40, 1, -20, 31, -31, 0.5],
            [0.3, -4, 2, -1, 2, 3, 5, -2, -3, -4],
            [-1, 0.5, -0.25, 0, 0, 0, -100, 0, 0, 0]]
    write_json(os.path.join(out_dir, "golden.json"),
               {"made_by": made, "model": "model.json", "cases": cases,
                "lighting_cases": [{"outputs": y, "lighting": lighting(np.array(y, float))}
                                   for y in edge]}, True)
    print(f"{out_dir}: model.json, golden.json ({len(cases)} cases)")


# ---- main -------------------------------------------------------------------------------------

def main(argv=None):
    ap = argparse.ArgumentParser(description="Fit baseline (d) of parlight eval, a ridge "
                                 "regression on coarse log pixels (docs/EVAL.md).")
    ap.add_argument("--data", help="make_dataset.py folder (index.tsv, crops/)")
    ap.add_argument("--out", help="the model file to write (JSON)")
    ap.add_argument("--val-panos", type=int, default=0, metavar="N",
                    help="leave out train.py's N held-out validation panoramas")
    ap.add_argument("--folds", type=int, default=5, help="cross-validation folds (default 5)")
    ap.add_argument("--lambdas", help="comma-separated lambda grid (default 0.1 .. 1e5, half "
                    "decades)")
    ap.add_argument("--force", action="store_true", help="replace --out")
    ap.add_argument("--predict", nargs=2, metavar=("MODEL", "IMAGE"),
                    help="print the model's lighting for an image (with --gamma)")
    ap.add_argument("--gamma", type=float, default=2.2)
    ap.add_argument("--golden", metavar="DIR", help="write test_ridge.c's golden data to DIR")
    args = ap.parse_args(argv)
    try:
        if args.golden:
            golden(args.golden)
            return 0
        if args.predict:
            m = load_model(args.predict[0])
            with Image.open(args.predict[1]) as im:
                u8 = np.asarray(im.convert("RGB"))
            y = outputs(m, features(u8, args.gamma, tuple(m["features"]["grid"]),
                                    m["features"]["floor"]))
            print(json.dumps(lighting(y)))
            return 0
        if not args.data or not args.out:
            raise ValueError("--data and --out are required (see --help)")
        if os.path.exists(args.out) and not args.force:
            raise ValueError(f"{args.out} exists (--force to replace it)")
        if not 2 <= args.folds <= 100:
            raise ValueError(f"--folds {args.folds}: expected 2..100")
        if args.val_panos < 0:
            raise ValueError(f"--val-panos {args.val_panos}: expected >= 0")
        lambdas = LAMBDAS
        if args.lambdas:
            lambdas = [float(v) for v in args.lambdas.split(",")]
            if not lambdas or not all(math.isfinite(v) and v > 0 for v in lambdas):
                raise ValueError(f"--lambdas {args.lambdas}: expected numbers > 0")
        X, Y, has, panos, indoor, held, digest, cfg = read_dataset(args.data, args.val_panos)
        n_pano = len(set(panos))
        if n_pano < 2:
            raise ValueError(f"{args.data}: {n_pano} panorama left; cross-validation needs 2")
        if has.sum() < 2:
            raise ValueError(f"{args.data}: fewer than 2 crops with a ground-truth light")
        k = min(args.folds, n_pano)
        fold = folds_of(panos, k)
        scores = cross_validate(X, Y, has, indoor, fold, lambdas)
        chosen, edge = {}, []
        for g in GROUPS:
            best = min(range(len(lambdas)), key=lambda i: (scores[i][f"mse_{g}"], i))
            chosen[g] = lambdas[best]
            if len(lambdas) > 1 and best in (0, len(lambdas) - 1):
                edge.append(g)
        best_dir = scores[lambdas.index(chosen["dir"])]
        print(f"{len(panos)} crops of {n_pano} panoramas ({int(has.sum())} with a light), "
              f"{k}-fold cross-validation over panoramas"
              + (f", {len(held)} held out (--val-panos {args.val_panos})" if held else ""))
        ind = lambda v: "-" if v is None else f"{v:.1f}"  # noqa: E731
        print(f"  {'lambda':>10}  {'mse dir':>9}  {'mse light':>9}  {'mse amb':>9}  "
              "angle deg median [q1, q3]  indoor median")
        for s in scores:
            print(f"  {s['lambda']:10.4g}  {s['mse_dir']:9.4f}  {s['mse_light']:9.4f}  "
                  f"{s['mse_ambient']:9.4f}  {s['median_angle_deg']:5.1f} "
                  f"[{s['q1_angle_deg']:5.1f}, {s['q3_angle_deg']:5.1f}]      "
                  f"{ind(s['median_angle_deg_indoor'])}")
        print("chosen lambda: " + ", ".join(f"{g} {v:g}" for g, v in chosen.items()) +
              f"; cross-validated median angle {best_dir['median_angle_deg']:.1f} deg "
              f"({ind(best_dir['median_angle_deg_indoor'])} on indoor crops)")
        for g in edge:
            print(f"warning: the {g} lambda is at the edge of the grid", file=sys.stderr)
        weights, bias = fit(X, Y, has, chosen)
        y_in = X @ weights.T + bias
        in_angle = float(np.median(angles_deg(y_in[has][:, 0:3], Y[has][:, 0:3])))
        extra = {
            "lambda": chosen,
            "cv": {"folds": k, "grouped_by": "panorama", "fold_rule": "panoramas sorted by "
                   "sha256 of the name, dealt round-robin", "criterion": "lowest mean squared "
                   "error of each group's outputs", "groups": {g: [OUTPUTS[i] for i in idx]
                                                             for g, idx in GROUPS.items()},
                   "scores": scores, "median_angle_deg": best_dir["median_angle_deg"],
                   "median_angle_deg_indoor": best_dir["median_angle_deg_indoor"]},
            "fit": {"tool": "tools/train/fit_ridge.py", "dataset": os.path.abspath(args.data),
                    "index_sha256": digest, "dataset_config": cfg, "val_panos": args.val_panos,
                    "held_out": held, "panoramas": sorted(set(panos)), "n_crops": len(panos),
                    "n_crops_with_light": int(has.sum()),
                    "in_sample_median_angle_deg": in_angle,
                    "light_targets": "pl_lighting_primary's light of the ground truth; crops "
                                     "without one train the ambient outputs only"}}
        write_json(args.out, model_dict(weights, bias, extra), args.force)
        print(f"{args.out}: {len(OUTPUTS)} x ({X.shape[1]} + 1) weights; in-sample median angle "
              f"{in_angle:.1f} deg")
    except (OSError, ValueError, KeyError, TypeError) as e:
        print(f"fit_ridge: {e}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
