#!/usr/bin/env bash
# Under a qemu-aarch64 runner (make test BOARD=rpi4|rpi5|jetson-orin), the Arm int8 kernels on
# the CPU models the board's own -cpu does not cover: `-cpu max` (Armv8.6+ with i8mm, so the
# usmmla kernel runs: no board's model has it) and `-cpu cortex-a72` (NEON only: the dispatcher
# must fall back to the smull/sadalp kernel and refuse dotprod/i8mm with a message). Runs
# tests/test_kernels_simd_s8.c under each (tolerance 0 against the reference kernels) and checks
# which paths ran; then, under -cpu max, `parlight estimate` with PARLIGHT_ISA=i8mm gives the
# same JSON as PARLIGHT_ISA=ref on a 96x128 int8 model (one frame: the reference path is slow
# under TCG). Skipped without a qemu-aarch64 runner
# (tests/test_kernels_simd_s8 and tests/test_isa_exact.sh cover the native paths).
set -u
fail() { echo "FAIL: $*"; exit 1; }
case "${PL_RUNNER:-}" in
*qemu-aarch64*) ;;
*) echo "skip: needs a qemu-aarch64 runner (make test BOARD=rpi5)"; exit 77 ;;
esac
# the real build folder (run.sh's $BUILD holds wrappers for the runner's -cpu and links)
REAL=$(dirname "$(readlink -f "$BUILD/features")")
[ -x "$REAL/tests/test_kernels_simd_s8" ] || fail "no $REAL/tests/test_kernels_simd_s8"
T="$PL_TEST_TMP/arm_cpus"
mkdir -p "$T"
on_cpu() { # on_cpu CPU PROGRAM ARGS...: the runner with another -cpu
    local cpu=$1
    shift
    # shellcheck disable=SC2086
    $(sed -E "s/-cpu [^ ]+/-cpu $cpu/" <<<"$PL_RUNNER") "$@"
}

on_cpu max "$REAL/tests/test_kernels_simd_s8" >"$T/max" 2>&1 ||
    fail "-cpu max: $(tail -5 "$T/max")"
for p in neon dotprod i8mm; do
    grep -q "^path $p: ok" "$T/max" || fail "-cpu max: path $p did not run: $(cat "$T/max")"
done
echo "-cpu max: $(grep -c '^path [a-z0-9]*: ok' "$T/max") Arm paths bit-exact (neon, dotprod, i8mm)"

on_cpu cortex-a72 "$REAL/tests/test_kernels_simd_s8" >"$T/a72" 2>&1 ||
    fail "-cpu cortex-a72: $(tail -5 "$T/a72")"
grep -q "^path neon: ok" "$T/a72" || fail "-cpu cortex-a72: neon did not run: $(cat "$T/a72")"
grep -q "^path dotprod: not available" "$T/a72" ||
    fail "-cpu cortex-a72 offers dotprod: $(cat "$T/a72")"
echo "-cpu cortex-a72: neon bit-exact, dotprod and i8mm refused"

# end to end on i8mm: the int8 network's JSON equals the reference kernels' (a small model and
# one frame: the reference path is slow under TCG; one thread: qemu-aarch64 7.2 hangs in
# pthread_create on this machine's kernel, docs/PORTING.md)
M=build/models/seeded-n3-96x128.plm
F=tests/data/frames/warehouse-tubes.jpg
[ -f "$M" ] || fail "no $M (make test exports it)"
Q="$T/q96.plm"
on_cpu max "$REAL/parlight" quantize --model "$M" --calib "$F" --method minmax \
    --out "$Q" >/dev/null 2>"$T/err" || fail "quantize: $(cat "$T/err")"
strip() { sed -E 's/"timing_ms":\{[^}]*\},?//; s/"t_ns":[0-9]+,?//' "$1"; }
for isa in ref i8mm; do
    PARLIGHT_ISA=$isa on_cpu max "$REAL/parlight" estimate --model "$Q" --input "$F" \
        --threads 1 >"$T/$isa.jsonl" 2>"$T/err" || fail "estimate under $isa: $(cat "$T/err")"
done
[ "$(wc -l <"$T/i8mm.jsonl")" -eq 1 ] || fail "i8mm: $(wc -l <"$T/i8mm.jsonl") lines, expected 1"
cmp -s <(strip "$T/ref.jsonl") <(strip "$T/i8mm.jsonl") ||
    fail "-cpu max: PARLIGHT_ISA=i8mm differs from ref"
PARLIGHT_ISA=i8mm on_cpu max "$REAL/parlight" info --model "$Q" | grep -q "nn_conv_packed_s8_4x16c8__neoni8mm" ||
    fail "info under i8mm does not name nn_conv_packed_s8_4x16c8__neoni8mm"
echo "-cpu max: i8mm estimate identical to ref (96x128, one frame)"
