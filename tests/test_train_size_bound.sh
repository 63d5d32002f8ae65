#!/usr/bin/env bash
# train.py --step1-max-size (the docstring's "Small lights in step 1"): bound_size keeps small
# solid angles (within 1%) and bounds large ones below S; a step-1 run with the bound logs
# another loss than one without from the same start, and the exported network is unchanged in
# shape (the bound is the loss's view only); resuming a run under another bound is refused, and
# a bound outside [0, 4 pi] or not a number is refused by name. On a tiny made-up dataset
# (tests/tiny_dataset.py): no ../shared needed.
set -u
cd "$(dirname "$0")/.."
PY=/usr/bin/python3
T=${PL_TEST_TMP:-$(mktemp -d)}/train_size_bound
"$PY" -c 'import torch, torchvision, numpy, PIL' 2>/dev/null ||
    { echo "skip: $PY lacks torch/torchvision/numpy/PIL"; exit 77; }
rm -rf "$T"
mkdir -p "$T"
EXPECT_TIMEOUT=300
. "$(dirname "$0")/cli_helpers.sh"
"$PY" tests/tiny_dataset.py "$T/data" "$T/enc.pt" || { echo "FAIL: tests/tiny_dataset.py"; exit 1; }

"$PY" - <<'PY' && ok "bound_size" || fail "bound_size"
import sys
sys.path.insert(0, "tools/train")
import torch
import train
s = torch.tensor([[0.001, 0.02, 0.5, 3.0, 100.0]])
b = train.bound_size({"size": s, "dir": None}, 0.5)["size"]
assert torch.all(b <= 0.5) and torch.all(b > 0), b
assert abs(float(b[0, 0]) / 0.001 - 1) < 0.01 and abs(float(b[0, 1]) / 0.02 - 1) < 0.01, b
assert float(b[0, 3]) > 0.49 and float(b[0, 2]) < float(b[0, 3]), b
PY

A=(--data "$T/data" --input 96x128 --batch 2 --step1-epochs 1 --step2-epochs 0 --w-d1 20
   --threads 1 --max-steps 2 --val-panos 0 --seed 3)
TR=("$PY" tools/train/train.py)
expect 0 "" -- "${TR[@]}" "${A[@]}" --ckpt-dir "$T/free" --log "$T/free.log"
expect 0 "" -- "${TR[@]}" "${A[@]}" --step1-max-size 0.5 --ckpt-dir "$T/bound" --log "$T/bound.log"
lf=$(grep -o 'loss [0-9.e+-]*$' "$T/free.log" | tail -n 1)
lb=$(grep -o 'loss [0-9.e+-]*$' "$T/bound.log" | tail -n 1)
[ -n "$lf" ] && [ -n "$lb" ] && [ "$lf" != "$lb" ] && ok "bounded loss ($lb) differs from the free one ($lf)" ||
    fail "step-1 losses: free '$lf', bounded '$lb'"
grep -q '"step1_max_size": 0.5' "$T/bound.log" || fail "the bound is not in the logged config"
expect 1 "step1_max_size" -- "${TR[@]}" "${A[@]}" --step1-max-size 0.25 --ckpt-dir "$T/bound" \
    --log "$T/bound.log"
expect 0 "" -- "${TR[@]}" --export-only "$T/bound/last.pt" "$T/bound.plm"
expect 0 "" -- "${TR[@]}" --export-only "$T/free/last.pt" "$T/free.plm"
[ "$(stat -c %s "$T/bound.plm")" -gt 1000000 ] || fail "no export of the bounded run"
for v in -1 13 nan; do
    expect 1 "--step1-max-size .*: expected steradians" -- "${TR[@]}" "${A[@]}" \
        --step1-max-size "$v" --ckpt-dir "$T/x$v" --log "$T/x.log"
done
finish
