#!/usr/bin/env bash
# The whole training path of docs/TRAINING.md on a few panoramas, on the CPU, as a user with their
# own panoramas runs it: a folder of equirectangular HDR files (3 of the shared train/ panoramas,
# linked into a user-style folder with a subfolder, an .exr among them, one file that is not a
# panorama) -> make_dataset.py --panos (crops + ground truth with radiance maps; the bad file
# reported and left out; a rerun resumes and changes nothing) -> distill.py (1 epoch) ->
# train.py steps 1 and 2 with the dense supervision (--w-map, --sphere-truth map), --stream ->
# the export (C agrees with PyTorch) -> the intensity anchor fitted on `parlight eval --anchor
# off` of a held-out panorama -> heads.py (fc and heads on the frozen encoder with the
# primary-light loss; resumable) -> parlight quantize (int8) -> the ridge baseline (d) fitted on the
# crops (fit_ridge.py) -> `parlight eval --json` of the float and int8 models with (d) beside. Also: make_dataset.py refuses the shared eval/ folder, and train.py
# --device cuda is refused with a reason where there is no CUDA device.
# Needs ../shared (panoramas and the MobileNetV2 teacher). ~3 minutes on 2 cores.
# Env: BUILD, PL_SHARED, PL_TEST_TMP (set by tests/run.sh). Exit 0 pass, 1 fail, 77 skip.
set -u
cd "$(dirname "$0")/.."
PY=/usr/bin/python3
BUILD=${BUILD:-build}
PL_SHARED=${PL_SHARED:-$(cd .. && pwd)/shared}
export PL_SHARED
TMP=${PL_TEST_TMP:-$(mktemp -d)}/training_path
rm -rf "$TMP"
mkdir -p "$TMP"
if ! "$PY" -c 'import torch, torchvision, numpy, PIL' 2>/dev/null; then
    echo "skip: $PY lacks torch/torchvision/numpy/PIL (tools/install-deps.sh installs them)"
    exit 77
fi
H=$PL_SHARED/data/hdri
TEACHER=$PL_SHARED/data/pretrained/mobilenet_v2_1.0_224_quant.tflite
for f in "$H/train/brown_photostudio_03.exr" "$H/train/lythwood_room.hdr" \
    "$H/train/pine_attic.hdr" "$H/train/comfy_cafe.hdr" "$TEACHER"; do
    [ -f "$f" ] || { echo "skip: no $f (the shared panoramas and teacher)"; exit 77; }
done
[ -x "$BUILD/parlight" ] || { echo "FAIL: no $BUILD/parlight (build first)"; exit 1; }
fail() { echo "FAIL: $*"; exit 1; }

# a user's folder: nested, mixed formats, one file that is not a 2:1 panorama
P=$TMP/my-panos
mkdir -p "$P/flat2"
ln -s "$H/train/brown_photostudio_03.exr" "$P/studio.exr"
ln -s "$H/train/lythwood_room.hdr" "$P/flat2/living.hdr"
ln -s "$H/train/pine_attic.hdr" "$P/flat2/attic.hdr"
"$PY" - "$P/square.hdr" <<'EOF'
# a 4 x 4 RGBE file: readable, not 2:1
import sys
with open(sys.argv[1], "wb") as f:
    f.write(b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 4 +X 4\n" + bytes([128, 128, 128, 129]) * 16)
EOF
DS=("$PY" tools/train/make_dataset.py --panos "$P" --scene indoor --crops-per-pano 4
    --size 128x96 --gt-map 16 --jobs 2 --parlight "$BUILD/parlight" --quiet --out "$TMP/data")
"${DS[@]}" 2>"$TMP/ds.err" >/dev/null || fail "make_dataset.py --panos: $(cat "$TMP/ds.err")"
grep -q "skipped panos/square.hdr" "$TMP/ds.err" || fail "the non-panorama was not reported: $(cat "$TMP/ds.err")"
[ "$(wc -l <"$TMP/data/index.tsv")" -eq 13 ] || fail "index.tsv: expected 12 crops"
grep -q $'\tpanos/flat2/attic.hdr\tindoor' "$TMP/data/index.tsv" || fail "no panos/ rows in the index"
sum1=$(cat "$TMP"/data/crops/* | sha256sum)
"${DS[@]}" >/dev/null 2>&1 || fail "make_dataset.py --panos rerun"
[ "$(cat "$TMP"/data/crops/* | sha256sum)" = "$sum1" ] || fail "a rerun changed the crops"
"$PY" tools/train/make_dataset.py --panos "$H/eval" --out "$TMP/evalds" --parlight "$BUILD/parlight" \
    >"$TMP/e.log" 2>&1 && fail "the shared eval/ folder was accepted"
grep -q "never trained on" "$TMP/e.log" || fail "no reason: $(cat "$TMP/e.log")"
echo "make_dataset.py --panos: 12 crops of 3 panoramas, the non-panorama reported, resumable"

"$PY" tools/train/distill.py --data "$TMP/data" --teacher "$TEACHER" --input 96x128 --batch 4 \
    --epochs 1 --threads 1 --val-panos 1 --out "$TMP/enc/enc.pt" --stream >"$TMP/d.log" 2>&1 ||
    fail "distill.py: $(cat "$TMP/d.log")"
TR=("$PY" tools/train/train.py --data "$TMP/data" --input 96x128 --batch 4 --val-panos 1
    --step1-epochs 1 --step2-epochs 1 --threads 1 --w-d1 5 --step2-loss render
    --train-scenes indoor --w-map 1 --sphere-truth map --stream)
"${TR[@]}" --init "$TMP/enc/enc.pt" --ckpt-dir "$TMP/run" --log "$TMP/run/log.txt" \
    --export "$TMP/m.plm" >"$TMP/t.log" 2>&1 || fail "train.py: $(cat "$TMP/t.log")"
grep -q " aux " "$TMP/run/log.txt" || fail "no auxiliary loss logged"
"${TR[@]}" --device cuda --ckpt-dir "$TMP/cuda" --log "$TMP/cuda.txt" >"$TMP/c.log" 2>&1 &&
    ! "$PY" -c 'import torch, sys; sys.exit(torch.cuda.is_available())' &&
    fail "--device cuda accepted without CUDA"
"$PY" -c 'import torch, sys; sys.exit(torch.cuda.is_available())' &&
    { grep -q "sees no CUDA device" "$TMP/c.log" || fail "--device cuda: no reason: $(cat "$TMP/c.log")"; }
f=$(ls "$TMP"/data/crops/*.png | head -1)
"$PY" tools/train/check_export.py --ckpt "$TMP/run/final.pt" --plm "$TMP/m.plm" --frame "$f" \
    --parlight "$BUILD/parlight" >/dev/null || fail "C and PyTorch disagree on the export"
echo "distill.py, train.py (dense supervision, streamed), export: ok"

# the held-out panorama of --val-panos 1, scored by parlight eval, fits the anchor
held=$("$PY" -c "import torch; print(torch.load('$TMP/run/final.pt', map_location='cpu')['config']['held_out'][0])")
V=$TMP/val
mkdir -p "$V"
ln -s "$P/${held#panos/}" "$V/"
"$BUILD/parlight" eval --model "$TMP/m.plm" --hdr "$V" --crops 2 --anchor off --json \
    >"$TMP/raw.json" || fail "parlight eval --anchor off"
"$PY" tools/train/fit_anchor.py "$TMP/raw.json" --write "$TMP/m.plm" "$TMP/ma.plm" \
    >"$TMP/a.log" 2>&1 || fail "fit_anchor.py: $(cat "$TMP/a.log")"
"$BUILD/parlight" info --model "$TMP/ma.plm" | grep -q "anchor" || fail "no anchor in the model"
# direction first: fc and heads retrained on the frozen encoder with the primary-light loss and
# noise on z, then one step-2 epoch; a run stopped after epoch 1 and rerun ends with the same
# bytes as one uninterrupted run (the cached latents reused from another work folder, the noise
# a function of seed and epoch)
HD=("$PY" tools/train/heads.py --model "$TMP/ma.plm" --data "$TMP/data" --val-panos 1 --batch 4
    --threads 1 --epochs 2 --step2-epochs 1 --z-noise 0.05)
"${HD[@]}" --out "$TMP/mh.plm" --work "$TMP/hw" >"$TMP/h.log" 2>&1 ||
    fail "heads.py: $(cat "$TMP/h.log")"
grep -q "primary angle median" "$TMP/h.log" || fail "heads.py: no validation angle logged"
grep -q "step 2 epoch 1/1" "$TMP/h.log" || fail "heads.py: no step-2 epoch logged"
# heads_resumes CACHE WORK ONE_RUN CMD...: CMD stopped after step-1 epoch 1 and rerun, in a new
# work folder that holds only WORK's cached CACHE (z.pt or v3.pt), resumes without recomputing
# the cache and ends with the bytes of ONE_RUN, the .plm of one uninterrupted run
heads_resumes() {
    local cache=$1 work=$2 want=$3
    shift 3
    mkdir -p "$work.r" && cp "$work/$cache" "$work.r/"
    "$@" --out "$want.r" --work "$work.r" --epochs 1 --step2-epochs 0 >"$work.r.log" 2>&1 &&
        "$@" --out "$want.r" --work "$work.r" --force >>"$work.r.log" 2>&1 ||
        fail "heads.py resume ($cache): $(cat "$work.r.log")"
    grep -q "crops and their mirrors through" "$work.r.log" &&
        fail "heads.py recomputed the cached $cache"
    grep -q "resumed" "$work.r.log" || fail "heads.py did not resume ($cache)"
    cmp -s "$want" "$want.r" || fail "heads.py: resumed run differs from one run ($cache)"
}
heads_resumes z.pt "$TMP/hw" "$TMP/mh.plm" "${HD[@]}"
"${HD[@]}" --out "$TMP/mh.plm" --work "$TMP/hw" >"$TMP/h3.log" 2>&1 &&
    fail "heads.py replaced an existing model without --force"
grep -q "use --force" "$TMP/h3.log" || fail "heads.py: no reason: $(cat "$TMP/h3.log")"
"${HD[@]}" --out "$TMP/mh3.plm" --work "$TMP/hw" --z-noise 0.1 >"$TMP/h4.log" 2>&1 &&
    fail "heads.py resumed a checkpoint made with another --z-noise"
grep -q "z_noise" "$TMP/h4.log" || fail "heads.py: no reason: $(cat "$TMP/h4.log")"
"${HD[@]}" --out "$TMP/mh3.plm" --z-noise 3 >"$TMP/h4.log" 2>&1 && fail "heads.py took --z-noise 3"
grep -q -- "--z-noise 3" "$TMP/h4.log" || fail "heads.py: no reason: $(cat "$TMP/h4.log")"
"$PY" - "$TMP/ma.plm" "$TMP/mh.plm" <<'EOF' || fail "heads.py changed more than fc and heads"
import sys
sys.path.insert(0, "tools")
import numpy as np, plm
ma, ta, _ = plm.read_plm(sys.argv[1])
mh, th, _ = plm.read_plm(sys.argv[2])
assert list(ta) == list(th), "tensor order"
heads = ("fc.", "head_dir.", "head_size.", "head_rgb.", "head_ambient.")
for k in ta:
    same = np.array_equal(ta[k], th[k])
    assert same != k.startswith(heads), k
assert {k: v for k, v in ma.items() if k != "provenance"} == \
    {k: v for k, v in mh.items() if k != "provenance"}, "metadata (the anchor) changed"
assert "heads.py" in mh["provenance"]
EOF
echo "heads.py (frozen encoder, primary-light loss, z noise, step 2): resumes bit-identically," \
    "changes only fc and heads"
# block 4 trained with the heads on cached transition3 maps, with the brightness-order term and
# weight decay: resumes bit-identically, changes block 4, norm5, fc and heads only, and C runs
# the result
HB=("$PY" tools/train/heads.py --model "$TMP/ma.plm" --data "$TMP/data" --val-panos 1 --batch 4
    --threads 1 --epochs 2 --step2-epochs 1 --w-primary 0 --w-rank 1 --train-block4
    --weight-decay 0.1)
"${HB[@]}" --out "$TMP/mb.plm" --work "$TMP/hb" >"$TMP/hb.log" 2>&1 ||
    fail "heads.py --train-block4: $(cat "$TMP/hb.log")"
grep -q "block-3 maps of" "$TMP/hb.log" || fail "heads.py --train-block4: no block-3 maps cached"
grep -q " rank " "$TMP/hb.log" || fail "heads.py --w-rank: no rank term logged"
heads_resumes v3.pt "$TMP/hb" "$TMP/mb.plm" "${HB[@]}"
"${HB[@]}" --out "$TMP/mb3.plm" --work "$TMP/hb" --w-rank 0 >"$TMP/hb3.log" 2>&1 &&
    fail "heads.py resumed a checkpoint made with another --w-rank"
"${HB[@]}" --out "$TMP/mb3.plm" --z-noise 0.1 >"$TMP/hb3.log" 2>&1 &&
    fail "heads.py took --train-block4 with --z-noise"
grep -q "do not combine" "$TMP/hb3.log" || fail "heads.py: no reason: $(cat "$TMP/hb3.log")"
"$BUILD/parlight" estimate --model "$TMP/mb.plm" --input "$f" --anchor off >"$TMP/mb.json" \
    2>"$TMP/mb.err" || fail "parlight estimate on the block-4 model: $(cat "$TMP/mb.err")"
"$PY" - "$TMP/ma.plm" "$TMP/mb.plm" "$f" "$TMP/mb.json" <<'EOF' ||
import json, sys
sys.path.insert(0, "tools")
import numpy as np, torch, export, golden, plm
from model import preprocess
ma, ta, _ = plm.read_plm(sys.argv[1])
mb, tb, _ = plm.read_plm(sys.argv[2])
assert list(ta) == list(tb), "tensor order"
trained = ("fc.", "head_dir.", "head_size.", "head_rgb.", "head_ambient.", "denseblock4.", "norm5.")
for k in ta:
    assert np.array_equal(ta[k], tb[k]) != k.startswith(trained), k
assert "block 4" in mb["provenance"] and "w_rank 1" in mb["provenance"]
assert "weight decay 0.1" in mb["provenance"]
# C against the folded network in float64 on the same frame
t = {k: torch.from_numpy(np.array(v)).double() for k, v in tb.items()}
x = preprocess(golden.read_frame(sys.argv[3], int(mb["input_h"]), int(mb["input_w"])),
               dtype=torch.float64)
with torch.no_grad():
    ref = export.folded_forward(t, x, int(mb["n_lights"]))
got = json.loads(open(sys.argv[4]).readline())
c = np.array([li["dir"] for li in got["lights"]])
e = np.linalg.norm(c - ref["dir"][0].numpy()) / np.linalg.norm(ref["dir"][0].numpy())
assert e < 1e-3, f"C and PyTorch directions differ by {e:.2e}"
EOF
    fail "heads.py --train-block4: wrong tensors changed, or C disagrees"
echo "heads.py --train-block4 --w-rank --weight-decay: resumes bit-identically, changes only" \
    "block 4, norm5, fc and heads; C runs it"
mkdir -p "$TMP/calib"
"$BUILD/parlight" crop --hdr "$H/train/comfy_cafe.hdr" --batch 4 --out-dir "$TMP/calib" \
    --format jpg >/dev/null || fail "calibration frames"
rm -f "$TMP"/calib/*.json
"$BUILD/parlight" quantize --model "$TMP/mh.plm" --calib "$TMP/calib" --out "$TMP/m8.plm" \
    >"$TMP/q.log" 2>&1 || fail "parlight quantize: $(cat "$TMP/q.log")"
# heads trained half on the int8 executor's latents (zdump): m8's trunk is ma's, quantised
"$PY" tools/train/heads.py --model "$TMP/ma.plm" --data "$TMP/data" --int8 "$TMP/m8.plm" \
    --zdump "$BUILD/tools/zdump" --batch 4 --threads 1 --epochs 1 --out "$TMP/mq.plm" \
    --work "$TMP/hq" >"$TMP/hq.log" 2>&1 || fail "heads.py --int8: $(cat "$TMP/hq.log")"
grep -q "int8 latents done" "$TMP/hq.log" || fail "heads.py --int8: no int8 latents computed"
"$PY" - "$TMP/hq" <<'EOF' || fail "heads.py --int8: the int8 latents are not the float ones + int8 error"
import sys, torch
z = torch.load(sys.argv[1] + "/z.pt", weights_only=False)["z"]
z8 = torch.load(sys.argv[1] + "/z8.pt", weights_only=False)["z"]
assert z8.shape == z.shape and bool(torch.isfinite(z8).all()), (z8.shape, z.shape)
for f in (0, 1):     # a model trained 2 epochs on 12 crops and calibrated on 4 frames: coarse
    err = float((z8[f] - z[f]).norm() / z[f].norm())
    assert 0 < err < 0.5, (f, err)
EOF
# zdump of the float model is PyTorch's z, crop for crop and mirror for mirror (the C executor
# within 1e-3 of PyTorch's, tools/train/check_export.py)
tail -n +2 "$TMP/data/index.tsv" | cut -f1 | sed "s|^|$TMP/data/|" >"$TMP/zl.txt"
"$BUILD/tools/zdump" "$TMP/ma.plm" "$TMP/zl.txt" "$TMP/zf.f32" 1 || fail "zdump of the float model"
"$PY" - "$TMP/hq" "$TMP/zf.f32" <<'EOF' || fail "zdump's float z is not PyTorch's"
import sys, numpy as np, torch
z = torch.load(sys.argv[1] + "/z.pt", weights_only=False)["z"].numpy()
c = np.fromfile(sys.argv[2], np.float32).reshape(z.shape[1], 2, z.shape[2]).transpose(1, 0, 2)
for f in (0, 1):
    err = np.linalg.norm(c[f] - z[f]) / np.linalg.norm(z[f])
    other = np.linalg.norm(c[f] - z[1 - f]) / np.linalg.norm(z[f])
    assert err < 0.02 and other > 2 * err, (f, err, other)
EOF
"$PY" tools/train/heads.py --model "$TMP/ma.plm" --data "$TMP/data" --int8 "$TMP/ma.plm" \
    --epochs 1 --out "$TMP/mq2.plm" --work "$TMP/hq2" >"$TMP/hq2.log" 2>&1 &&
    fail "heads.py took a float model as --int8"
grep -q "expected int8" "$TMP/hq2.log" || fail "heads.py --int8 float: $(cat "$TMP/hq2.log")"
ls "$TMP"/calib/*.jpg | head -n 1 >"$TMP/zl.txt" && echo "$TMP/missing.png" >>"$TMP/zl.txt"
"$BUILD/tools/zdump" "$TMP/m8.plm" "$TMP/zl.txt" "$TMP/z.f32" 2>"$TMP/zd.err" &&
    fail "zdump took a missing image"
grep -q "line 2: .*missing.png" "$TMP/zd.err" || fail "zdump: no reason: $(cat "$TMP/zd.err")"
[ -e "$TMP/z.f32" ] && fail "zdump left a partial output"
echo x >"$TMP/z.f32"
"$BUILD/tools/zdump" "$TMP/m8.plm" "$TMP/zl.txt" "$TMP/z.f32" 2>"$TMP/zd.err" &&
    fail "zdump replaced an existing file"
[ "$(cat "$TMP/z.f32")" = x ] && grep -q "not replacing" "$TMP/zd.err" ||
    fail "zdump: existing output: $(cat "$TMP/zd.err")"
echo "heads.py --int8 (latents by zdump): cached, close to the float ones; zdump refuses bad input"
"$PY" tools/train/fit_ridge.py --data "$TMP/data" --val-panos 1 --out "$TMP/ridge.json" \
    >"$TMP/r.log" 2>&1 || fail "fit_ridge.py on a --panos dataset: $(cat "$TMP/r.log")"
for m in ma mh m8; do
    "$BUILD/parlight" eval --model "$TMP/$m.plm" --hdr "$V" --crops 2 --json \
        --ridge "$TMP/ridge.json" >"$TMP/$m.json" || fail "parlight eval $m"
    "$PY" - "$TMP/$m.json" <<'EOF' || fail "eval JSON of $m"
import json, math, sys
d = json.load(open(sys.argv[1]))
assert d["n_panoramas"] == 1, d["n_panoramas"]
s = json.dumps(d)
assert '"model"' in s, "no model scores"
assert d["methods"]["ridge"]["angle_deg"]["n"] == 2, "no (d) ridge scores"
EOF
done
echo "anchor, int8 and parlight eval of the trained model: ok"
