#!/usr/bin/env bash
# tools/train/distill.py end to end on tiny inputs: 8 crops of 2 train panoramas (one held out),
# the shared MobileNetV2 as teacher; 1 epoch (loss finite, teacher maps cached), a resume to 2
# epochs that ends with the same weights as 2 epochs in one go (and reuses the cache), refusals
# with a reason (another --seed or --input into the same --out, a file that is not a checkpoint,
# fewer crops than a batch; --device cuda where there is none), --stream and --device cpu giving the
# same weights as the crops held in memory, and train.py --init taking the encoder from it.
# Needs ../shared (the panoramas and data/pretrained/mobilenet_v2_1.0_224_quant.tflite).
# Env: BUILD, PL_SHARED, PL_TEST_TMP (set by tests/run.sh). Exit 0 pass, 1 fail, 77 skip.
set -u
cd "$(dirname "$0")/.."
PY=/usr/bin/python3
BUILD=${BUILD:-build}
PL_SHARED=${PL_SHARED:-$(cd .. && pwd)/shared}
export PL_SHARED
TMP=${PL_TEST_TMP:-$(mktemp -d)}/distill
rm -rf "$TMP"
mkdir -p "$TMP"
if ! "$PY" -c 'import torch, torchvision, numpy, PIL' 2>/dev/null; then
    echo "skip: $PY lacks torch/torchvision/numpy/PIL (tools/install-deps.sh installs them)"
    exit 77
fi
TEACHER=$PL_SHARED/data/pretrained/mobilenet_v2_1.0_224_quant.tflite
for f in "$PL_SHARED/data/hdri/MANIFEST.tsv" "$TEACHER"; do
    [ -f "$f" ] || { echo "skip: no $f (the shared data)"; exit 77; }
done
[ -x "$BUILD/parlight" ] || { echo "FAIL: no $BUILD/parlight (build first)"; exit 1; }
fail() { echo "FAIL: $*"; exit 1; }

"$PY" tools/train/make_dataset.py --hdri "$PL_SHARED/data/hdri" --parlight "$BUILD/parlight" \
    --limit 2 --crops-per-pano 4 --size 128x96 --seed 3 --quiet --out "$TMP/data" >/dev/null ||
    fail "make_dataset.py"
D=("$PY" tools/train/distill.py --data "$TMP/data" --teacher "$TEACHER" --input 96x128
   --batch 2 --val-panos 1 --threads 1)
"${D[@]}" --epochs 1 --out "$TMP/a/enc.pt" >"$TMP/a.log" 2>&1 || fail "1 epoch: $(cat "$TMP/a.log")"
log=$TMP/a/enc-log.txt
grep -q "teacher maps of 8 crops x2" "$log" || fail "no teacher-map line in $(cat "$log")"
loss=$(sed -n 's/.*distill epoch 1\/1 loss \([^ ]*\) val \([^ ]*\).*/\1 \2/p' "$log")
"$PY" -c "import math,sys; sys.exit(0 if all(math.isfinite(float(x)) and float(x)>0 for x in sys.argv[1:]) else 1)" \
    $loss || fail "epoch 1 loss/val '$loss' not finite and positive"
echo "1 epoch: loss / val $loss"

"${D[@]}" --epochs 2 --out "$TMP/a/enc.pt" >"$TMP/a.log" 2>&1 || fail "resume: $(cat "$TMP/a.log")"
grep -q "resumed .* at epoch 1" "$log" || fail "no resume line in $(cat "$log")"
[ "$(grep -c 'teacher maps' "$log")" -eq 1 ] || fail "the resume recomputed the teacher maps"
"${D[@]}" --epochs 2 --out "$TMP/b/enc.pt" >"$TMP/b.log" 2>&1 || fail "2 in one go: $(cat "$TMP/b.log")"
"$PY" - "$TMP/a/enc.pt" "$TMP/b/enc.pt" <<'EOF' || fail "resumed weights differ"
import sys, torch
a, b = (torch.load(p, map_location="cpu") for p in sys.argv[1:3])
assert a["state"]["epoch"] == b["state"]["epoch"] == 2, (a["state"], b["state"])
assert a["config"]["threads"] == [1] and len(a["config"]["teacher_sha256"]) == 64, a["config"]
worst = max(float((a[m][k].float() - b[m][k].float()).abs().max())
            for m in ("model", "proj") for k in a[m])
print(f"resumed vs uninterrupted after 2 epochs: max |weight difference| {worst:.3g}")
assert worst == 0, worst
EOF
# --stream (crops decoded at each use) and --device cpu: the same weights as in memory
"${D[@]}" --epochs 2 --stream --device cpu --out "$TMP/s/enc.pt" >"$TMP/s.log" 2>&1 ||
    fail "--stream: $(cat "$TMP/s.log")"
"$PY" - "$TMP/s/enc.pt" "$TMP/b/enc.pt" <<'EOF' || fail "--stream weights differ"
import sys, torch
a, b = (torch.load(p, map_location="cpu") for p in sys.argv[1:3])
worst = max(float((a[m][k].float() - b[m][k].float()).abs().max())
            for m in ("model", "proj") for k in a[m])
assert worst == 0, worst
print("--stream --device cpu: the same weights as in memory")
EOF

refused() {   # refused WHAT REASON ARGS...: distill.py must exit 1 naming REASON, no traceback
    local what=$1 reason=$2
    shift 2
    "$@" >"$TMP/r.log" 2>&1 && fail "$what was accepted"
    grep -q "$reason" "$TMP/r.log" || fail "$what: no reason given: $(cat "$TMP/r.log")"
    grep -q Traceback "$TMP/r.log" && fail "$what: a traceback: $(cat "$TMP/r.log")"
    echo "refused: $what"
}
refused "another --seed into the same --out" "another configuration (seed differ)" \
    "${D[@]}" --epochs 3 --seed 4 --out "$TMP/a/enc.pt"
refused "another --input into the same --out" "another configuration (input differ" \
    "${D[@]}" --epochs 3 --input 128x160 --out "$TMP/a/enc.pt"
mkdir -p "$TMP/c"
head -c 1000 "$TMP/a/enc.pt" >"$TMP/c/enc.pt"
refused "a truncated checkpoint" "cannot read checkpoint" "${D[@]}" --epochs 1 --out "$TMP/c/enc.pt"
echo '{}' >"$TMP/c/other.pt"
refused "a file that is not a checkpoint" "cannot read checkpoint\|not a distill.py checkpoint" \
    "${D[@]}" --epochs 1 --out "$TMP/c/other.pt"
refused "more crops per batch than there are" "fewer than one batch" \
    "${D[@]}" --epochs 1 --batch 16 --out "$TMP/c/big.pt"
cmp -s <(head -c 1000 "$TMP/a/enc.pt") "$TMP/c/enc.pt" || fail "a refused run changed its --out"

"$PY" tools/train/train.py --data "$TMP/data" --input 96x128 --batch 2 --val-panos 1 \
    --step1-epochs 1 --step2-epochs 0 --map-width 32 --threads 1 --max-steps 1 \
    --init "$TMP/a/enc.pt" --ckpt-dir "$TMP/t" --log "$TMP/t/log.txt" >"$TMP/t.log" 2>&1 ||
    fail "train.py --init: $(cat "$TMP/t.log")"
"$PY" - "$TMP/a/enc.pt" "$TMP/t/last.pt" <<'EOF' || fail "train.py did not start from the encoder"
import sys, torch
enc, run = (torch.load(p, map_location="cpu") for p in sys.argv[1:3])
assert run["config"]["init"].endswith("enc.pt"), run["config"]["init"]
k = "features.conv0.weight"   # the first layer: one step of Adam moves it by at most ~lr
d = float((enc["model"][k] - run["model"][k]).abs().max())
assert 0 < d <= 2e-3, d
print(f"train.py --init: step 1 starts from the distilled encoder (first layer moved {d:.2g})")
EOF
if ! "$PY" -c 'import torch, sys; sys.exit(torch.cuda.is_available())'; then
    echo "(CUDA available: the --device cuda refusal is not checked)"
else
    refused "--device cuda without CUDA" "sees no CUDA device" "${D[@]}" --epochs 1 --device cuda \
        --out "$TMP/c/cuda.pt"
fi
echo "distill.py: ok"
