#!/usr/bin/env bash
# The PyTorch SG environment map of the training loss (tools/train/sg.py, eq. 4) against the C
# one (`parlight render --lights L.json --out map.hdr`, pl_envmap_from_lights): every pixel within
# the RGBE quantisation of the .hdr file (0.8% of the pixel's largest channel), for the ground
# truth of the sample frames (tests/data/frames-gt) and for a synthetic set of lights on the
# axes and near the poles and the seam, at widths 64 and 256. Negative control: the same lights
# mirrored in x must NOT match (so the comparison can fail).
# The diffuse sphere of the training's render loss (sg.diffuse over a 256-wide SG map) against
# the C analytic one (`parlight render --sphere diffuse --size 32`, pl_render_sphere_lights):
# relative RMSE <= 1% each (the map's sampling and the RGBE file); the first set mirrored must
# be off by more than 10%.
# Env: BUILD, PL_TEST_TMP (set by tests/run.sh). Exit 0 pass, 1 fail, 77 skip.
set -u
cd "$(dirname "$0")/.."
PY=/usr/bin/python3
BUILD=${BUILD:-build}
TMP=${PL_TEST_TMP:-$(mktemp -d)}/train_sg
mkdir -p "$TMP"
if ! "$PY" -c 'import torch, numpy' 2>/dev/null; then
    echo "skip: $PY lacks torch/numpy (tools/install-deps.sh installs them)"
    exit 77
fi
[ -x "$BUILD/parlight" ] || { echo "FAIL: no $BUILD/parlight (build first)"; exit 1; }
fail() { echo "FAIL: $*"; exit 1; }

cat >"$TMP/axes.json" <<'EOF'
{"lights": [
 {"dir": [1, 0, 0], "distance_m": 2, "solid_angle_sr": 0.05, "rgb": [40, 20, 10]},
 {"dir": [0, 0.999, -0.04], "distance_m": 1.2, "solid_angle_sr": 0.3, "rgb": [5, 6, 7]},
 {"dir": [-0.05, 0.2, 0.98], "distance_m": 3, "solid_angle_sr": 0.8, "rgb": [1, 2, 3]},
 {"dir": [0.3, -0.5, -0.8], "distance_m": 2.5, "solid_angle_sr": 0.01, "rgb": [300, 250, 200]}],
 "ambient": [0.1, 0.2, 0.3]}
EOF
"$PY" - "$TMP/axes.json" "$TMP/mirror.json" <<'EOF' || fail "cannot write the mirrored lights"
import json, sys
d = json.load(open(sys.argv[1]))
for li in d["lights"]:
    li["dir"][0] = -li["dir"][0]
json.dump(d, open(sys.argv[2], "w"))
EOF

n=0
pairs=()
for L in "$TMP/axes.json" tests/data/frames-gt/*.json; do
    for W in 64 256; do
        n=$((n + 1))
        "$BUILD/parlight" render --lights "$L" --out "$TMP/m$n.hdr" --width $W --force >/dev/null ||
            fail "parlight render $L"
        pairs+=("$L" "$TMP/m$n.hdr")
    done
done
# one Python process for all maps (tools/train/sg.py --compare-hdr does one pair per process)
"$PY" - "${pairs[@]}" <<'EOF' || fail "sg.py differs from parlight render (see above)"
import sys
sys.path.insert(0, "tools/train")
import sg
args = sys.argv[1:]
bad = [(j, m) for j, m in zip(args[::2], args[1::2]) if sg.main(["--lights", j, "--compare-hdr", m])]
for j, m in bad:
    print(f"differs: {j} vs {m}")
sys.exit(1 if bad else 0)
EOF
"$BUILD/parlight" render --lights "$TMP/axes.json" --out "$TMP/m.hdr" --width 64 --force >/dev/null
if "$PY" tools/train/sg.py --lights "$TMP/mirror.json" --compare-hdr "$TMP/m.hdr" >/dev/null; then
    fail "mirrored lights matched the C map: the comparison cannot fail"
fi
spheres=()
for L in "$TMP/axes.json" tests/data/frames-gt/*.json; do
    n=$((n + 1))
    "$BUILD/parlight" render --lights "$L" --sphere diffuse --size 32 --out "$TMP/s$n.hdr" \
        --force >/dev/null || fail "parlight render --sphere diffuse $L"
    spheres+=("$L" "$TMP/s$n.hdr")
done
"$PY" - "$TMP/mirror.json" "${spheres[@]}" <<'EOF' || fail "sg.diffuse differs from parlight render --sphere diffuse (see above)"
import json, sys
import torch
sys.path.insert(0, "tools/train")
import sg
nrm = sg.sphere_normals(32, torch.float64)
op = sg.diffuse_operator(256, nrm, torch.float64)
c = (torch.arange(32, dtype=torch.float64) + 0.5) / 16 - 1
on = (c.view(1, -1) ** 2 + c.view(-1, 1) ** 2) <= 1
mirror, args = sys.argv[1], sys.argv[2:]
ok = nrm.shape[0] == int(on.sum())
for i, (L, ref_path) in enumerate(zip(args[::2], args[1::2])):
    want = torch.from_numpy(sg.read_rgbe(ref_path).astype("float64"))[on]
    def rel(path):
        got = sg.diffuse(sg.render_json(json.load(open(path)), 256, sg.pixel_sigma(256))[None], op)[0]
        return float(torch.sqrt(((got - want) ** 2).mean()) / torch.sqrt((want ** 2).mean()))
    r = rel(L)
    print(f"sg.diffuse vs parlight render --sphere diffuse: relative RMSE {r:.4f} ({L})")
    ok &= r <= 0.01
    if i == 0:
        rm = rel(mirror)
        print(f"  mirrored lights: relative RMSE {rm:.4f} (must exceed 0.1)")
        ok &= rm > 0.1
sys.exit(0 if ok else 1)
EOF
# train.py's sphere_l2 with --sphere-metric relative: 0 for the truth itself, quadratic in the
# error, unchanged when both lightings are scaled together (per crop), and it punishes twice the
# truth more than half of it
"$PY" - <<'EOF' || fail "sphere_l2 --sphere-metric relative"
import sys
sys.path.insert(0, "tools/train")
import torch, sg, train
torch.manual_seed(3)
w = 32
udirs, op = sg.equirect_dirs(w), sg.diffuse_operator(w, sg.sphere_normals(8))
d = torch.nn.functional.normalize(torch.randn(4, 3, 3), dim=-1)
size, rgb = torch.rand(4, 3) * 0.5 + 0.05, torch.rand(4, 3, 3) * 30
amb = torch.rand(4, 3)
m = sg.render(d, size, rgb, udirs)
cfg = {"sphere_metric": "relative", "radiance": "log"}
L = lambda k, s=1.0: float(train.sphere_l2(k * s * m, k * s * amb, s * m, {"ambient": s * amb},
                                           (udirs, op, None, None), cfg))
checks = {"truth": L(1) < 1e-12, "quadratic": abs(L(3) - 4 * L(2)) < 1e-4 * L(3),
          "per-crop scale": abs(L(2, 10.0) - L(2)) < 1e-4 * L(2), "bright > dark": L(2) > L(0.5)}
print("  relative sphere loss:", ", ".join(f"{k} {'ok' if v else 'FAILED'}" for k, v in checks.items()))
# --sphere-truth map: the truth sphere is lit by the crop's map (here the lights' own map plus
# the ambient): 0 for the same lighting, > 0 for another, and it reads the map, not the lights
cfg = {"sphere_metric": "log", "radiance": "log", "sphere_truth": "map"}
gt = {"map": m + amb[:, None, None, :], "ambient": torch.zeros(4, 3)}
M = lambda k: float(train.sphere_l2(k * m, k * amb, None, gt, (udirs, op, op, None), cfg))
mchecks = {"truth": M(1) < 1e-10, "other": M(2) > 1e-3,
           "lights ignored": float(train.sphere_l2(m, amb, 5 * m, gt, (udirs, op, op, None),
                                                   cfg)) < 1e-10}
print("  sphere truth from the map:", ", ".join(f"{k} {'ok' if v else 'FAILED'}"
                                               for k, v in mchecks.items()))
sys.exit(0 if all(checks.values()) and all(mchecks.values()) else 1)
EOF
echo "ok: $n maps and spheres match parlight render; mirrored lights are rejected"
