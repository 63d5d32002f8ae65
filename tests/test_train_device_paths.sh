#!/usr/bin/env bash
# train.py's GPU-side paths, checked on the CPU (tools/train/train.py docstring, "Data and
# devices"): with the loss sums kept on the device (lazy_sums, what --device cuda does) step 1
# ends with the same weights and the same logged sums as the per-batch path, across an epoch end
# and --max-steps; a non-finite loss stops the lazy run with the batches named and nothing saved
# (the per-batch path names the batch); --channels-last trains to the same weights within
# rounding, its checkpoints hold the default layout and export; CropImages.to_device keeps the
# crops where they are over its budget. On a tiny made-up dataset (tests/tiny_dataset.py): no
# ../shared needed.
set -u
cd "$(dirname "$0")/.."
PY=/usr/bin/python3
T=${PL_TEST_TMP:-$(mktemp -d)}/train_device_paths
"$PY" -c 'import torch, torchvision, numpy, PIL' 2>/dev/null ||
    { echo "skip: $PY lacks torch/torchvision/numpy/PIL"; exit 77; }
rm -rf "$T"
mkdir -p "$T"
EXPECT_TIMEOUT=300
. "$(dirname "$0")/cli_helpers.sh"
"$PY" tests/tiny_dataset.py "$T/data" "$T/enc.pt" || { echo "FAIL: tests/tiny_dataset.py"; exit 1; }

# run NAME LAZY NAN_AT [flags]: train.py's main with lazy_sums forced and the step-1 loss made
# NaN at its NAN_AT-th call (0: never)
cat >"$T/run.py" <<'PY'
import sys
sys.path.insert(0, "tools/train")
import train
name, lazy, nan_at = sys.argv[1], sys.argv[2] == "1", int(sys.argv[3])
train.lazy_sums = lambda cfg: lazy
real, calls = train.step1_loss, [0]
def step1_loss(*a, **k):
    loss, parts = real(*a, **k)
    calls[0] += 1
    return (loss * float("nan") if calls[0] == nan_at else loss), parts
train.step1_loss = step1_loss
sys.exit(train.main(sys.argv[4:]))
PY
A=(--data "$T/data" --input 96x128 --batch 2 --step1-epochs 2 --step2-epochs 0 --w-map 1
   --w-d1 20 --threads 1 --max-steps 3 --val-panos 0 --bf16 --seed 3)
run() { local n=$1; shift 3; expect "$RC" "$PAT" -- "$PY" "$T/run.py" "$n" "$L" "$N" "$@" "${A[@]}" \
        --ckpt-dir "$T/$n" --log "$T/$n.log"; }
RC=0 PAT="" L=0 N=0 run eager 0 0
RC=0 PAT="" L=1 N=0 run lazy 1 0
RC=0 PAT="" L=0 N=0 run cl 0 0 --channels-last
RC=1 PAT="epoch 0 batches 0-1: a loss was not finite" L=1 N=2 run lazynan 1 2
RC=1 PAT="epoch 0 batch 1: loss is nan" L=0 N=2 run eagernan 0 2
[ -e "$T/lazynan/last.pt" ] && fail "the lazy run saved a checkpoint after a non-finite loss"
[ -e "$T/eagernan/last.pt" ] && fail "the per-batch run saved a checkpoint after a non-finite loss"

"$PY" - "$T" <<'PY' && ok "lazy = per-batch; channels-last within rounding" || fail "the paths differ"
import sys
sys.path.insert(0, "tools/train")
import torch
import train
t = sys.argv[1]
e, l, c = (torch.load(f"{t}/{n}/last.pt", weights_only=False) for n in ("eager", "lazy", "cl"))
assert e["state"]["steps"] == 3 and e["state"]["epoch"] == 1, e["state"]
for k, v in e["model"].items():
    assert torch.equal(v, l["model"][k]), f"lazy: {k}"
    assert c["model"][k].is_contiguous(), f"channels-last checkpoint: {k} not contiguous"
    if v.is_floating_point():
        d = float((v - c["model"][k]).abs().max()) / (float(v.abs().max()) + 1e-12)
        assert d < 1e-2, (k, d)
se, sl = e["state"]["sums"], l["state"]["sums"]
assert set(se) == set(sl) and se["n"] == sl["n"] == 1, (se, sl)
for k in se:
    assert abs(se[k] - sl[k]) <= 1e-9 * abs(se[k]), (k, se[k], sl[k])
ep = [ln.split(" val ")[0].split(" lr ")[1] for ln in open(f"{t}/eager.log") if "step1 epoch 1/2" in ln]
lp = [ln.split(" val ")[0].split(" lr ")[1] for ln in open(f"{t}/lazy.log") if "step1 epoch 1/2" in ln]
assert ep == lp and len(ep) == 1, (ep, lp)
imgs = train.CropImages([f"{t}/data/crops/c0.png", f"{t}/data/crops/c1.png"], (96, 128))
assert not imgs.to_device(torch.device("cpu"), 2 * 96 * 128 * 3 - 1)
assert imgs.to_device(torch.device("cpu"), 2 * 96 * 128 * 3)
PY
expect 0 "" -- "$PY" tools/train/train.py --export-only "$T/cl/last.pt" "$T/cl.plm"
[ -s "$T/cl.plm" ] || fail "no export of the channels-last checkpoint"
finish
