#!/usr/bin/env bash
# Golden test: the C float path (pl_model_load + pl_estimate_rgb8) against PyTorch float64 on the
# same seeded weights and the same frames, for N = 2, 3 and 5.
#   tools/golden.py writes the seeded model and the reference outputs (unfolded model, float64);
#   $BUILD/tests/golden_check compares z (relative L2) and every head (relative per element with
#   a floor, see tests/golden_check.c) with tolerance 1e-4.
# Frames: tests/data/golden-frames/*.png (256x192; PL_GOLDEN_FRAMES=DIR overrides). PL_GOLDEN_N
# (default "2 3 5") and PL_GOLDEN_MAX_FRAMES (default all) narrow the run: the Arm boards' qemu
# runs use N = 3 and 2 frames (boards/*.mk BOARD_TEST_ENV), as the network is ~30x slower there. A negative
# control (a frame checked against another frame's reference) must fail, so the check can fail.
# Env: BUILD, PL_TEST_TMP (set by tests/run.sh). Exit 0 pass, 1 fail, 77 skip.
set -u
cd "$(dirname "$0")/.."
BUILD=${BUILD:-build}
TMP=${PL_TEST_TMP:-$(mktemp -d)}/golden
FRAMES_DIR=${PL_GOLDEN_FRAMES:-tests/data/golden-frames}
SEED=1234
PY=/usr/bin/python3
CHECK=$BUILD/tests/golden_check

if ! "$PY" -c 'import torch, torchvision, PIL, numpy' 2>/dev/null; then
    echo "skip: $PY lacks torch/torchvision/PIL/numpy (tools/install-deps.sh installs them)"
    exit 77
fi
if [ ! -x "$CHECK" ]; then
    echo "FAIL: $CHECK is not built (make BUILD=$BUILD tests)"
    exit 1
fi
shopt -s nullglob
frames=("$FRAMES_DIR"/*.png)
NS=${PL_GOLDEN_N:-2 3 5}
MAXF=${PL_GOLDEN_MAX_FRAMES:-0}
[ "$MAXF" -gt 0 ] 2>/dev/null && [ ${#frames[@]} -gt "$MAXF" ] && frames=("${frames[@]:0:$MAXF}")
if [ ${#frames[@]} -eq 0 ]; then
    echo "FAIL: no golden frames: $FRAMES_DIR/*.png is empty (256x192 PNG crops expected)"
    exit 1
fi
mkdir -p "$TMP"

fail=0
printf '%-3s %-28s %-10s %-10s %-10s %-10s %-10s %-10s %s\n' \
    N frame z dir distance size rgb ambient result
for n in $NS; do
    if ! "$PY" tools/golden.py --n-lights $n --seed $SEED --frames "${frames[@]}" --out "$TMP" \
            --force >"$TMP/golden-n$n.log" 2>&1; then
        echo "FAIL: tools/golden.py --n-lights $n:"
        sed 's/^/    /' "$TMP/golden-n$n.log"
        fail=1
        continue
    fi
    for f in "${frames[@]}"; do
        stem=$(basename "$f" .png)
        log="$TMP/check-n$n-$stem.log"
        "$CHECK" "$TMP/model-n$n.plm" "$f" "$TMP/ref-n$n-$stem.f32" >"$log" 2>&1
        rc=$?
        # one row: the error column of each output line of golden_check
        errs=$(awk '$1 ~ /^(z|dir|distance|size|rgb|ambient)$/ {printf "%-10s ", $2}' "$log")
        if [ $rc -eq 0 ]; then
            printf '%-3s %-28s %s%s\n' "$n" "$stem" "$errs" pass
        else
            printf '%-3s %-28s %s%s\n' "$n" "$stem" "$errs" "FAIL (exit $rc)"
            sed 's/^/    /' "$log"
            fail=1
        fi
    done
done

# Negative control: the first frame against the last frame's reference (or, with one frame,
# against its reference from another N's model) must be rejected.
last=$(basename "${frames[-1]}" .png)
first=${frames[0]}
if [ ${#frames[@]} -gt 1 ]; then
    ref="$TMP/ref-n3-$last.f32"
else
    ref="$TMP/ref-n2-$last.f32"
fi
if [ -f "$TMP/model-n3.plm" ] && [ -f "$ref" ]; then
    if "$CHECK" "$TMP/model-n3.plm" "$first" "$ref" >"$TMP/negative.log" 2>&1; then
        echo "FAIL: negative control passed: golden_check accepted $first against $ref"
        fail=1
    else
        echo "negative control rejected as it should ($(basename "$first") vs $(basename "$ref"))"
    fi
fi

if [ $fail -ne 0 ]; then
    echo "golden: FAIL"
    exit 1
fi
echo "golden: all ${#frames[@]} frames within 1e-4 for N = $NS"
