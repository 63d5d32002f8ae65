#!/usr/bin/env bash
# The training tools end to end on tiny inputs (tools/train/): make_dataset.py on 1 train
# panorama (6 crops of 128x96 by parlight crop; resumable: a rerun changes nothing; deterministic:
# a second folder with the same seed holds the same bytes; another seed in the same folder is
# refused); --synthetic adds a synth_rooms.py room's crops without changing the real ones, never
# held out, and refuses a folder it did not make or other rooms in the same dataset; then
# train.py at 96x128, batch 2: 2 step-1 batches (loss finite), a resume from the
# checkpoint to 4 batches that ends with the same weights as 4 batches in one go, the rest of
# step 1 and step 2, the export (.plm), --ema (resumes, never feeds back, ends step 1 on
# the average), --bf16's note on CPUs without bf16, --w-map,
# --sphere-truth map and --w-primary (resume, the auxiliary head is not exported; the
# primary-light loss on known cases),
# and the exported model in C (parlight info, estimate)
# against the checkpoint in PyTorch on one crop (tools/train/check_export.py, relative 1e-3);
# tools/train/int8_sim.py on its int8 quantisations against parlight qcheck.
# Env: BUILD, PL_SHARED, PL_TEST_TMP (set by tests/run.sh). Exit 0 pass, 1 fail, 77 skip.
set -u
cd "$(dirname "$0")/.."
PY=/usr/bin/python3
BUILD=${BUILD:-build}
PL_SHARED=${PL_SHARED:-$(cd .. && pwd)/shared}
TMP=${PL_TEST_TMP:-$(mktemp -d)}/train_smoke
rm -rf "$TMP"
mkdir -p "$TMP"
if ! "$PY" -c 'import torch, torchvision, numpy, PIL' 2>/dev/null; then
    echo "skip: $PY lacks torch/torchvision/numpy/PIL (tools/install-deps.sh installs them)"
    exit 77
fi
if [ ! -f "$PL_SHARED/data/hdri/MANIFEST.tsv" ]; then
    echo "skip: no $PL_SHARED/data/hdri/MANIFEST.tsv (the shared panoramas)"
    exit 77
fi
[ -x "$BUILD/parlight" ] || { echo "FAIL: no $BUILD/parlight (build first)"; exit 1; }
fail() { echo "FAIL: $*"; exit 1; }

DS=("$PY" tools/train/make_dataset.py --hdri "$PL_SHARED/data/hdri" --parlight "$BUILD/parlight"
    --limit 1 --crops-per-pano 6 --size 128x96 --seed 5 --quiet)
"${DS[@]}" --out "$TMP/data" >/dev/null || fail "make_dataset.py"
[ "$(ls "$TMP"/data/crops/*.png | wc -l)" -eq 6 ] || fail "expected 6 crops"
[ "$(ls "$TMP"/data/crops/*.json | wc -l)" -eq 6 ] || fail "expected 6 ground-truth files"
[ "$(wc -l <"$TMP/data/index.tsv")" -eq 7 ] || fail "index.tsv: expected a header and 6 rows"
grep -q $'\teval/' "$TMP/data/index.tsv" && fail "an eval/ panorama in the training index"
sum1=$(cat "$TMP"/data/crops/* | sha256sum)
"${DS[@]}" --out "$TMP/data" >/dev/null || fail "make_dataset.py rerun"
[ "$(cat "$TMP"/data/crops/* | sha256sum)" = "$sum1" ] || fail "a rerun changed the crops"
rm "$TMP"/data/crops/*_k002.json
"${DS[@]}" --out "$TMP/data" >/dev/null || fail "make_dataset.py resume"
[ "$(cat "$TMP"/data/crops/* | sha256sum)" = "$sum1" ] || fail "resumed crop differs"
"${DS[@]}" --out "$TMP/data2" >/dev/null || fail "make_dataset.py second folder"
[ "$(cat "$TMP"/data2/crops/* | sha256sum)" = "$sum1" ] || fail "same seed, different bytes"
"${DS[@]}" --seed 6 --out "$TMP/data" >"$TMP/seed.log" 2>&1 &&
    fail "another seed was accepted in the same folder"
grep -q "another configuration" "$TMP/seed.log" || fail "no reason given: $(cat "$TMP/seed.log")"
"$PY" - "$TMP/data" <<'EOF' || fail "ground truth check"
import json, glob, math, sys
for p in glob.glob(sys.argv[1] + "/crops/*.json"):
    d = json.load(open(p))
    assert d["width"] == 128 and d["height"] == 96, p
    assert d["dataset"]["panorama"].startswith("train/"), p
    assert d["lights"] and all(abs(math.hypot(*l["dir"]) - 1) < 1e-5 for l in d["lights"]), p
    assert d["exposure_scale"] > 0 and 1.8 <= d["gamma"] <= 2.6, p
EOF
echo "dataset: 6 crops, resumable, deterministic"
# synthetic rooms (tools/train/synth_rooms.py) join a dataset with --synthetic: their crops are
# indexed after the real ones, change none of them and are never held out
"$PY" tools/train/synth_rooms.py --out "$TMP/rooms" --rooms 1 --width 256 --quiet ||
    fail "synth_rooms.py"
"${DS[@]}" --out "$TMP/data4" --synthetic "$TMP/rooms" --synthetic-crops 2 >/dev/null ||
    fail "make_dataset.py --synthetic"
[ "$(grep -c $'\tsynth/room_0000.hdr\tindoor$' "$TMP/data4/index.tsv")" -eq 2 ] ||
    fail "index.tsv: expected 2 synthetic crops: $(cat "$TMP/data4/index.tsv")"
[ "$(wc -l <"$TMP/data4/index.tsv")" -eq 9 ] || fail "index.tsv: expected 6 real + 2 synthetic rows"
for f in "$TMP"/data/crops/*; do
    cmp -s "$f" "$TMP/data4/crops/${f##*/}" || fail "adding rooms changed a real crop: ${f##*/}"
done
"${DS[@]}" --out "$TMP/data5" --synthetic "$TMP/data" >"$TMP/s.log" 2>&1 &&
    fail "--synthetic accepted a folder synth_rooms.py did not make"
grep -q "no readable synth.json" "$TMP/s.log" || fail "no reason: $(cat "$TMP/s.log")"
"$PY" tools/train/synth_rooms.py --out "$TMP/rooms2" --rooms 1 --width 256 --seed 2 --quiet ||
    fail "synth_rooms.py --seed 2"
"${DS[@]}" --out "$TMP/data4" --synthetic "$TMP/rooms2" >"$TMP/s.log" 2>&1 &&
    fail "crops of other rooms were accepted into the same folder"
grep -q "holds crops of the rooms in" "$TMP/s.log" || fail "no reason: $(cat "$TMP/s.log")"
"$PY" - "$TMP/data4" <<'EOF' || fail "synthetic crops in training"
import json, sys
sys.path[:0] = ["tools/train", "tools"]
import train
imgs, gt, val, held, _ = train.load_dataset(sys.argv[1], (96, 128), 0)
assert len(imgs) == 8 and not val.any() and held == [], (len(imgs), held)
d = json.load(open(sys.argv[1] + "/crops/synth_room_0000_k001.json"))
assert d["dataset"]["panorama"] == "synth/room_0000.hdr" and d["lights"], d["dataset"]
try:
    train.load_dataset(sys.argv[1], (96, 128), 1)   # 1 real panorama: none left to train on
    raise SystemExit("--val-panos 1 accepted with one real panorama")
except ValueError as e:
    assert "only 1 real panoramas" in str(e), e
print("synthetic: 2 crops join training; the one real panorama is all --val-panos can take")
EOF

TR=("$PY" tools/train/train.py --data "$TMP/data" --input 96x128 --batch 2 --val-panos 0
    --step1-epochs 3 --step2-epochs 2 --map-width 32 --threads 1)
"${TR[@]}" --ckpt-dir "$TMP/ck" --log "$TMP/log" --max-steps 2 >/dev/null || fail "train 2 steps"
grep -q "stopped at --max-steps 2" "$TMP/log" || fail "no stop line in $(cat "$TMP/log")"
loss=$(sed -n 's/.*stopped at --max-steps 2, loss \([^ ]*\).*/\1/p' "$TMP/log")
"$PY" -c "import math,sys; x=float(sys.argv[1]); sys.exit(0 if math.isfinite(x) and x>0 else 1)" \
    "$loss" || fail "step-1 loss $loss is not finite and positive"
echo "2 step-1 batches: loss $loss"
"${TR[@]}" --ckpt-dir "$TMP/ck" --log "$TMP/log" --max-steps 4 >/dev/null || fail "resume"
grep -q "resumed .*step 1 epoch 0 batch 2" "$TMP/log" || fail "no resume line in $(cat "$TMP/log")"
"${TR[@]}" --ckpt-dir "$TMP/ck2" --log "$TMP/log2" --max-steps 4 >/dev/null || fail "4 in one go"
"$PY" - "$TMP/ck/last.pt" "$TMP/ck2/last.pt" <<'EOF' || fail "resumed weights differ"
import sys, torch
a, b = (torch.load(p, map_location="cpu") for p in sys.argv[1:3])
assert a["state"]["steps"] == b["state"]["steps"] == 4, (a["state"], b["state"])
worst = max(float((a["model"][k].float() - b["model"][k].float()).abs().max()) for k in a["model"])
print(f"resumed vs uninterrupted after 4 batches: max |weight difference| {worst:.3g}")
assert worst <= 1e-5, worst
EOF
# the regularisers (--z-dropout, --erase) draw from seeded generators: a resumed run stays
# bit-identical, and they change what is learnt
# resume_pair DIR WHAT FLAGS...: 2 step-1 batches into $TMP/DIR, a resume to 4 there, and 4 in
# one go into $TMP/DIR2, all with FLAGS
resume_pair() {
    local d=$1 what=$2
    shift 2
    "${TR[@]}" "$@" --ckpt-dir "$TMP/$d" --log "$TMP/log-$d" --max-steps 2 >/dev/null ||
        fail "$what: 2 steps"
    "${TR[@]}" "$@" --ckpt-dir "$TMP/$d" --log "$TMP/log-$d" --max-steps 4 >/dev/null ||
        fail "$what: resume"
    "${TR[@]}" "$@" --ckpt-dir "$TMP/${d}2" --log "$TMP/log-${d}2" --max-steps 4 >/dev/null ||
        fail "$what: 4 in one go"
}
resume_pair ckr regularised --z-dropout 0.3 --erase 0.9
"${TR[@]}" --z-dropout 0.3 --ckpt-dir "$TMP/ckr" --log "$TMP/logr" --max-steps 5 >"$TMP/r.log" 2>&1 &&
    fail "resumed with another --erase"
grep -q "another configuration (erase differ)" "$TMP/r.log" || fail "no reason: $(cat "$TMP/r.log")"
"${TR[@]}" --erase 1 --ckpt-dir "$TMP/ckr3" --log "$TMP/logr3" >"$TMP/r.log" 2>&1 &&
    fail "--erase 1 accepted"
grep -q "expected a probability" "$TMP/r.log" || fail "no reason: $(cat "$TMP/r.log")"
"$PY" - "$TMP/ckr/last.pt" "$TMP/ckr2/last.pt" "$TMP/ck2/last.pt" <<'EOF' || fail "regularised resume"
import sys, torch
a, b, plain = (torch.load(p, map_location="cpu")["model"] for p in sys.argv[1:4])
worst = max(float((a[k].float() - b[k].float()).abs().max()) for k in a)
moved = max(float((a[k].float() - plain[k].float()).abs().max()) for k in a)
print(f"regularised: resumed vs uninterrupted {worst:.3g}, vs unregularised {moved:.3g}")
assert worst <= 1e-5 and moved > 1e-4, (worst, moved)
EOF
"$PY" - <<'EOF' || fail "erase_batch"
import sys, torch
sys.path[:0] = ["tools/train", "tools"]
import train
u8 = torch.zeros(64, 96, 128, 3, dtype=torch.uint8)
u8[:, :, 64:] = 200                      # mean colour 100
on, prm = train.erase_params(64, 0.5, torch.Generator().manual_seed(3))
out = train.erase_batch(u8, on, prm)
frac = (out != u8).any(-1).float().mean(dim=(1, 2))
assert torch.equal(u8[~on], out[~on]) and 16 < int(on.sum()) < 48, int(on.sum())
for b in torch.nonzero(on).flatten().tolist():
    changed = (out[b] != u8[b]).any(-1)
    assert (out[b][changed] == 100).all(), b
    # the rectangle covers 5-25% of the image (pixels already at the mean do not show)
    assert (out[b] == 100).all(-1).float().mean() <= 0.26 and frac[b] <= 0.26, b
assert float(frac[on].max()) > 0.05
print(f"erase_batch: {int(on.sum())} of 64 images erased, {float(frac[on].mean()):.3f} of the area")
EOF
"${TR[@]}" --ckpt-dir "$TMP/ck" --log "$TMP/log" --export "$TMP/m.plm" >/dev/null ||
    fail "finish steps 1 and 2 and export"
grep -q "step2 epoch 2/2" "$TMP/log" || fail "no step-2 epoch in $(cat "$TMP/log")"
[ -f "$TMP/ck/step1.pt" ] && [ -f "$TMP/ck/final.pt" ] || fail "missing step1.pt / final.pt"
"$BUILD/parlight" info --model "$TMP/m.plm" >"$TMP/info" || fail "parlight info"
grep -q "128 x 96" "$TMP/info" || fail "input size not 128 x 96: $(cat "$TMP/info")"
grep -q "trained by tools/train/train.py" "$TMP/info" || fail "no provenance: $(cat "$TMP/info")"
grep -q "torch [^ ,]* on 1 thread(s)" "$TMP/info" || fail "provenance lacks the threads: $(cat "$TMP/info")"
f=$(ls "$TMP"/data/crops/*.png | head -1)
"$PY" tools/train/check_export.py --ckpt "$TMP/ck/final.pt" --plm "$TMP/m.plm" --frame "$f" \
    --parlight "$BUILD/parlight" || fail "C and PyTorch disagree"
"$PY" tools/train/train.py --export-only "$TMP/ck/step1.pt" "$TMP/s1.plm" >/dev/null ||
    fail "--export-only"
"$BUILD/parlight" info --model "$TMP/s1.plm" >/dev/null || fail "step1 export does not load"

# --- --ema: the moving average of the step-1 weights. It resumes bit-identically, never feeds
# back (the run's own weights stay those of the plain run: step1_raw.pt = its step1.pt), step 1
# ends on it (step1.pt, what step 2 and the export start from), and it follows its formula ---
EMA=(--ema 0.9)
resume_pair cke --ema "${EMA[@]}"
"$PY" - "$TMP/cke/last.pt" "$TMP/cke2/last.pt" "$TMP/ck2/last.pt" <<'EOF' || fail "--ema resume"
import sys, torch
a, b, plain = (torch.load(p, map_location="cpu") for p in sys.argv[1:4])
d = lambda x, y: max(float((x[k].float() - y[k].float()).abs().max()) for k in x)  # noqa: E731
assert d(a["ema"], b["ema"]) <= 1e-6, "resumed average differs"
assert d(a["model"], plain["model"]) <= 1e-5, "the average fed back into the weights"
assert d(a["ema"], a["model"]) > 1e-4, "the average is the weights"
print(f"--ema: resumed vs uninterrupted average {d(a['ema'], b['ema']):.3g}, "
      f"average vs weights {d(a['ema'], a['model']):.3g}")
EOF
"${TR[@]}" "${EMA[@]}" --ckpt-dir "$TMP/cke" --log "$TMP/loge" --export "$TMP/me.plm" >/dev/null ||
    fail "--ema: finish and export"
grep -q "step1 epoch 3/3 .* val [^ ]* (average [^ ]*)" "$TMP/loge" ||
    fail "--ema: no average validation loss in $(cat "$TMP/loge")"
"$BUILD/parlight" info --model "$TMP/me.plm" | grep -q "moving average (decay 0.9)" ||
    fail "--ema: provenance does not say so"
# a step 2 from the average says so; one from the run's own weights does not
for s1 in step1 step1_raw; do
    "${TR[@]}" --ckpt-dir "$TMP/cke-$s1" --log "$TMP/loge-$s1" --step2-from "$TMP/cke/$s1.pt" \
        --export "$TMP/me-$s1.plm" >/dev/null || fail "--step2-from $s1.pt"
done
"$BUILD/parlight" info --model "$TMP/me-step1.plm" | grep -q "moving average (decay 0.9)" ||
    fail "--ema: a step 2 from step1.pt does not say it starts from the average"
"$BUILD/parlight" info --model "$TMP/me-step1_raw.plm" | grep -q "moving average" &&
    fail "--ema: a step 2 from step1_raw.pt claims the average"
"${TR[@]}" --ema 1 --ckpt-dir "$TMP/cke3" --log "$TMP/loge3" >"$TMP/e.log" 2>&1 && fail "--ema 1 accepted"
grep -q "expected a decay in \[0, 1)" "$TMP/e.log" || fail "no reason: $(cat "$TMP/e.log")"
"$PY" - "$TMP/cke" "$TMP/ck/step1.pt" <<'EOF' || fail "--ema step 1"
import sys, torch
sys.path[:0] = ["tools/train", "tools"]
import train
raw, avg, plain = (torch.load(p, map_location="cpu") for p in
                   (sys.argv[1] + "/step1_raw.pt", sys.argv[1] + "/step1.pt", sys.argv[2]))
d = lambda x, y: max(float((x[k].float() - y[k].float()).abs().max()) for k in x)  # noqa: E731
assert d(raw["model"], plain["model"]) <= 1e-5, "step1_raw.pt is not the plain run's step 1"
assert d(avg["model"], raw["model"]) > 1e-4, "step1.pt is not the average"
# the formula: d_t = min(D, (1 + t) / (10 + t)); batch counts copied; the pairs, gathered once,
# follow the network as it changes in place
torch.manual_seed(0)
net, ema = torch.nn.BatchNorm1d(3), torch.nn.BatchNorm1d(3)
ema.load_state_dict(net.state_dict())
pairs = train.ema_pairs(ema, net)
want = net.weight.detach().clone()
for t in range(30):
    with torch.no_grad():
        net.weight.add_(torch.randn(3))
    net(torch.randn(8, 3))   # moves running_mean and num_batches_tracked
    train.ema_update(pairs, t, 0.9)
    dt = min(0.9, (1 + t) / (10 + t))
    want = dt * want + (1 - dt) * net.weight.detach()
assert torch.allclose(ema.weight, want, atol=1e-6), (ema.weight, want)
assert int(ema.num_batches_tracked) == 30 and not torch.equal(ema.running_mean, net.running_mean)
print("--ema: step1_raw.pt is the plain run's step 1, step1.pt the average; formula checked")
EOF

# --- --bf16 on a CPU without native bf16 (avx512_bf16, amx_bf16) says it will be slow ---
"$PY" - "$TMP" <<'EOF' || fail "cpu_bf16_note"
import os, sys, torch
sys.path[:0] = ["tools/train", "tools"]
import train
cpu = torch.device("cpu")
def info(flags):
    p = os.path.join(sys.argv[1], "cpuinfo")
    with open(p, "w") as f:
        f.write("processor\t: 0\nflags\t\t: " + flags + "\n")
    return p
assert "slower" in train.cpu_bf16_note(cpu, True, info("fpu sse2 avx2 fma"))
for flags in ("fpu avx512f avx512_bf16", "fpu amx_bf16 amx_tile"):
    assert train.cpu_bf16_note(cpu, True, info(flags)) is None, flags
assert train.cpu_bf16_note(cpu, False, info("fpu avx2")) is None
assert train.cpu_bf16_note(cpu, True, os.path.join(sys.argv[1], "missing")) is None
print("--bf16 note: on AVX2 alone, not with avx512_bf16 or amx_bf16, not without --bf16")
EOF

# --- dense supervision: --w-map (an auxiliary head regressing the crop's radiance map from the
# 512-d vector), --w-src (a second one: a distribution over the map's pixels trained towards
# their share of its light energy) and --sphere-truth map (the diffuse-sphere truth lit by the
# real panorama). They resume bit-identically, the heads train and their losses are logged, the
# export leaves them out (the same tensors as a plain export, and C agrees with the checkpoint),
# and a dataset without radiance maps is refused ---
DENSE=(--w-map 1 --w-src 1 --sphere-truth map --w-d1 5 --step2-loss render --w-primary 1)
resume_pair ckm dense "${DENSE[@]}"
"$PY" - "$TMP/ckm/last.pt" "$TMP/ckm2/last.pt" <<'EOF' || fail "dense resume"
import sys, torch
a, b = (torch.load(p, map_location="cpu")["model"] for p in sys.argv[1:3])
assert "aux_map.lin.weight" in a and "aux_src.lin.weight" in a, "an auxiliary head is missing"
worst = max(float((a[k].float() - b[k].float()).abs().max()) for k in a)
assert worst <= 1e-6, f"resumed vs uninterrupted: {worst}"
print(f"--w-map --w-src --sphere-truth map: resumed vs uninterrupted {worst:.3g}")
EOF
grep -q " aux " "$TMP/log-ckm" || fail "--w-map: no auxiliary loss in $(cat "$TMP/log-ckm")"
grep -q " primary " "$TMP/log-ckm" || fail "--w-primary: no primary loss in $(cat "$TMP/log-ckm")"
grep -q " src " "$TMP/log-ckm" || fail "--w-src: no source loss in $(cat "$TMP/log-ckm")"
"$PY" - <<'EOF' || fail "source_loss"
# the source term: each pixel's share of the map's energy weighs luminance by the row's solid
# angle; the KL is 0 for logits equal to the log shares, grows as they part, ignores the map's
# scale, and against a uniform distribution is log(8) - H(p)
import sys, torch
sys.path.insert(0, "tools/train")
import train
wts = train.map_weights(2, 4)
m = torch.zeros(1, 2, 4, 3)
m[0, 0, 1] = 1.0                       # one white pixel in the upper row
m[0, 1, 2] = torch.tensor([0., 0, 3])  # a blue one in the lower (luminance 0.0722 x 3)
p = train.source_share(m, wts)
e1, e2 = float(wts[0, 0, 0]), 3 * 0.0722 * float(wts[1, 0, 0])
assert abs(float(p[0, 0, 1]) - e1 / (e1 + e2)) < 1e-6 and abs(float(p.sum()) - 1) < 1e-6, p
logits = torch.log(p.clamp_min(1e-12))
assert float(train.source_loss(logits, m, wts)) < 1e-5
assert float(train.source_loss(logits, m * 1000, wts)) < 1e-5
nz = p[p > 0]
kl_uniform = float((nz * torch.log(8 * nz)).sum())
assert abs(float(train.source_loss(torch.zeros(1, 2, 4), m, wts)) - kl_uniform) < 1e-5
worse = logits.clone()
worse[0, 0, 1] -= 2
assert float(train.source_loss(worse, m, wts)) > 0.01
print("source_loss: energy shares, 0 at them, scale-free, log 8 - H against uniform")
EOF
"$PY" - <<'EOF' || fail "primary_loss"
# the primary-light loss: 0 when the most energetic predicted light points at the truth's primary,
# 2 when it points away, and the lights' energies (not their order) decide which is primary
import sys, torch
sys.path.insert(0, "tools/train")
import train
gt = {"dir": torch.tensor([[[0., 1, 0], [1, 0, 0]]]), "size": torch.tensor([[0.1, 0.1]]),
      "rgb": torch.tensor([[[1., 1, 1], [50, 50, 50]]]), "mask": torch.ones(1, 2)}
up, right, left = [0., 1, 0], [1., 0, 0], [-1., 0, 0]
def out(dirs, bright):
    rgb = torch.full((1, 3, 3), 1e-3)
    rgb[0, bright] = 1e3
    return {"dir": torch.tensor([dirs]), "size": torch.full((1, 3), 0.1), "rgb": rgb}
assert float(train.primary_loss(out([up, right, left], 1), gt)) < 1e-5
assert abs(float(train.primary_loss(out([up, right, left], 2), gt)) - 2) < 1e-5
assert float(train.primary_loss(out([up, right, left], 0), gt)) > 0.99
gt["mask"][:] = 0
assert float(train.primary_loss(out([up, right, left], 2), gt)) == 0.0
EOF
"$PY" - <<'EOF' || fail "rank_loss"
# the brightness-order loss: small when the predicted light nearest the truth's brighter light is
# the brighter one, large when the order is reversed, log 2 at a tie, 0 pairs (no loss) when all
# predicted lights stand for one truth light; it moves energies, never directions
import math, sys, torch
sys.path.insert(0, "tools/train")
import train
gt = {"dir": torch.tensor([[[0., 1, 0], [1, 0, 0], [0, 0, 1]]]), "size": torch.tensor([[0.1] * 3]),
      "rgb": torch.tensor([[[1., 1, 1], [50, 50, 50], [5, 5, 5]]]), "mask": torch.ones(1, 3)}
up, right, front = [0., 1, 0], [1., 0, 0], [0., 0.1, 1]
def out(dirs, levels):
    rgb = torch.tensor(levels, dtype=torch.float32)[None, :, None].repeat(1, 1, 3)
    return {"dir": torch.nn.functional.normalize(torch.tensor([dirs]), dim=-1).requires_grad_(),
            "size": torch.full((1, 3), 0.1), "rgb": rgb.requires_grad_()}
good = float(train.rank_loss(out([up, right, front], [1, 50, 5]), gt))
bad = float(train.rank_loss(out([up, right, front], [50, 1, 5]), gt))
tie = float(train.rank_loss(out([up, right, front], [7, 7, 7]), gt))
assert good < 0.1 and bad > 1.0 and abs(tie - math.log(2)) < 1e-5, (good, bad, tie)
o = out([up, up, up], [1, 50, 5])
assert float(train.rank_loss(o, gt)) == 0.0
o = out([up, right, front], [50, 1, 5])
train.rank_loss(o, gt).backward()
assert o["dir"].grad is None or float(o["dir"].grad.abs().max()) == 0.0
assert float(o["rgb"].grad[0, 0].sum()) > 0 and float(o["rgb"].grad[0, 1].sum()) < 0
gt["mask"][:] = 0
assert float(train.rank_loss(out([up, right, front], [50, 1, 5]), gt)) == 0.0
print("rank_loss: order right < log 2 = tie < order wrong; no pairs, no loss; no direction moves")
EOF
"${TR[@]}" "${DENSE[@]}" --ckpt-dir "$TMP/ckm" --log "$TMP/log-ckm" --export "$TMP/mm.plm" \
    >/dev/null || fail "dense: finish and export"
[ "$(stat -c %s "$TMP/mm.plm")" = "$(stat -c %s "$TMP/m.plm")" ] ||
    fail "the export with --w-map --w-src differs in size from a plain one (auxiliary head exported?)"
"$PY" tools/train/check_export.py --ckpt "$TMP/ckm/final.pt" --plm "$TMP/mm.plm" --frame "$f" \
    --parlight "$BUILD/parlight" >/dev/null || fail "dense: C and PyTorch disagree"
"${DS[@]}" --gt-map 0 --out "$TMP/data-nomap" >/dev/null || fail "make_dataset.py --gt-map 0"
"${TR[@]}" --data "$TMP/data-nomap" --w-map 1 --ckpt-dir "$TMP/ckm3" --log "$TMP/logm3" \
    >"$TMP/m.log" 2>&1 && fail "--w-map accepted a dataset without radiance maps"
grep -q "no radiance_map" "$TMP/m.log" || fail "no reason: $(cat "$TMP/m.log")"
echo "dense supervision: resumes, trains the head, exports without it"

# --- tools/train/int8_sim.py: its simulation of the int8 executor tracks what qcheck measures
# (z's SQNR within 3 dB), with and without kept-float layers ---
for kf in "" transition3,fc; do
    "$BUILD/parlight" quantize --model "$TMP/m.plm" --calib tests/data/frames \
        ${kf:+--keep-float $kf} --out "$TMP/q8.plm" --force 2>/dev/null || fail "quantize ($kf)"
    "$BUILD/parlight" qcheck --float "$TMP/m.plm" --int8 "$TMP/q8.plm" --no-noise-floor --json \
        --input tests/data/golden-frames >"$TMP/qc.json" || fail "qcheck ($kf)"
    "$PY" tools/train/int8_sim.py --ckpt "$TMP/ck/final.pt" --int8 "$TMP/q8.plm" --threads 1 \
        --frames tests/data/golden-frames >"$TMP/sim.txt" || fail "int8_sim ($kf)"
    "$PY" - "$TMP/qc.json" "$TMP/sim.txt" "$kf" <<'PY' || fail "int8_sim against qcheck ($kf): $(cat "$TMP/sim.txt")"
import json, sys
z_c = {l["name"]: l["sqnr_db"] for l in json.load(open(sys.argv[1]))["layers"]}["z"]
lines = open(sys.argv[2]).read().splitlines()
assert ("kept float: " + (", ".join(sorted(sys.argv[3].split(","))) or "none")) in lines[0], lines[0]
z_sim = float([l for l in lines if l.split()[0] == "all"][0].split()[1])
assert abs(z_sim - z_c) <= 3, (z_sim, z_c)
assert len(lines) == 3 + 2 + 10, len(lines)
print("int8_sim: z %.1f dB, qcheck %.1f dB (%s)" % (z_sim, z_c, sys.argv[3] or "all int8"))
PY
done

# --- the diffuse-sphere terms: step 2 from a step-1 checkpoint with --step2-loss render moves
# only the heads step 2 trains; step 1 with --w-d1 logs the term ---
"${TR[@]}" --ckpt-dir "$TMP/ck3" --log "$TMP/log3" --step2-from "$TMP/ck/step1.pt" \
    --step2-loss render --w-d 2 >/dev/null || fail "--step2-from --step2-loss render"
grep -q "step2 epoch 2/2 .* sphere [0-9]" "$TMP/log3" || fail "no sphere term in $(cat "$TMP/log3")"
"$PY" - "$TMP/ck/step1.pt" "$TMP/ck3/final.pt" <<'EOF' || fail "--step2-from trained the wrong part"
import sys, torch
a, b = (torch.load(p, map_location="cpu")["model"] for p in sys.argv[1:3])
moved = {k.split(".")[0] for k in a if not torch.equal(a[k], b[k])}
assert moved and moved <= {"head_size", "head_rgb", "head_ambient"}, moved
print(f"step 2 (render) from step1.pt moved {sorted(moved)} only")
EOF
"${TR[@]}" --ckpt-dir "$TMP/ck4" --log "$TMP/log4" --step1-epochs 1 --step2-epochs 0 --w-d1 5 \
    >/dev/null || fail "--w-d1"
grep -q "step1 epoch 1/1 .* sphere [0-9]" "$TMP/log4" || fail "no sphere term in $(cat "$TMP/log4")"
# --init --init-all starts from the whole network (one step of lr 1e-12 later: the same weights)
"${TR[@]}" --ckpt-dir "$TMP/ck5" --log "$TMP/log5" --init "$TMP/ck/final.pt" --init-all \
    --lr 1e-12 --max-steps 1 >/dev/null || fail "--init-all"
"$PY" - "$TMP/ck/final.pt" "$TMP/ck5/last.pt" <<'EOF' || fail "--init-all did not load the network"
import sys, torch
a, b = (torch.load(p, map_location="cpu")["model"] for p in sys.argv[1:3])
keys = [k for k in a if "running" not in k and "num_batches" not in k]
worst = max(float((a[k].float() - b[k].float()).abs().max()) for k in keys)
assert worst < 1e-6 and any(k.startswith("head_rgb") for k in keys), worst
print(f"--init-all: max |weight difference| after one step of lr 1e-12: {worst:.2g}")
EOF
# --train-scenes indoor drops the outdoor crops from training: a copy of the data whose index
# calls its first 4 crops outdoor and the last 2 indoor trains on 2 crops; all-outdoor is refused
mkdir -p "$TMP/data3"
ln -s "$(cd "$TMP/data/crops" && pwd)" "$TMP/data3/crops"
awk -F'\t' -v OFS='\t' 'NR > 1 { $4 = NR <= 5 ? "outdoor" : "indoor" } 1' "$TMP/data/index.tsv" \
    >"$TMP/data3/index.tsv"
"${TR[@]}" --data "$TMP/data3" --ckpt-dir "$TMP/ck6" --log "$TMP/log6" --train-scenes indoor \
    --max-steps 1 >/dev/null || fail "--train-scenes indoor"
grep -q "start: 2 train + 0 val crops" "$TMP/log6" || fail "indoor crops: $(head -1 "$TMP/log6")"
awk -F'\t' -v OFS='\t' 'NR > 1 { $4 = "outdoor" } 1' "$TMP/data/index.tsv" >"$TMP/data3/index.tsv"
"${TR[@]}" --data "$TMP/data3" --ckpt-dir "$TMP/ck7" --log "$TMP/log7" --train-scenes indoor \
    --max-steps 1 >"$TMP/out7" 2>&1 && fail "--train-scenes indoor on outdoor crops ran"
grep -q "no training crops of scenes 'indoor'" "$TMP/out7" || fail "no reason: $(cat "$TMP/out7")"
echo "ok"
