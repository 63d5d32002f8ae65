#!/usr/bin/env bash
# Runs the whole suite: every compiled tests/test_*.c program and every tests/test_*.sh script.
# Exit status 0 = pass, 77 = skip (with a reason on its output), anything else = fail.
# Prints one line per test and closes with "N passed, M failed, K skipped"; exits 1 on any failure.
# Environment: BUILD (default build), PL_SHARED (default ../shared, beside the repo),
# TEST_FILTER (a grep pattern on test names), PL_TEST_JOBS (tests run at once; default: the
#   number of CPUs, at most 4; 1 runs them one after another),
# PL_RUNNER: a command prefix that runs the build's programs, for a cross build (`make test
#   BOARD=rpi5` sets it to the board's BOARD_RUNNER, e.g. "qemu-aarch64 -cpu cortex-a76 -L
#   /usr/aarch64-linux-gnu"). C tests run under it; shell tests get a BUILD folder of wrappers
#   that run $BUILD/parlight and $BUILD/tests/* under it. Tests named by PL_RUNNER_SKIP (a grep
#   pattern; default: the camera rig, which boots native binaries in a VM) skip under a runner.
# PL_SAN=1 (make test SAN=1, build-san/): the build has ASan and UBSan; the tests san_skip names
#   skip with their reason (Python-only work, VMs, timings), everything else runs.
# Needs: a test that needs an optional library of the build says so in its first 20 lines with
#   a line "needs: opencv" (or openexr, libjpeg, libpng, libcamera; several allowed); run.sh
#   skips it when $BUILD/features (written by the Makefile) lacks one.
set -u
cd "$(dirname "$0")/.."
export BUILD=${BUILD:-build}
export PL_SHARED=${PL_SHARED:-$(cd .. && pwd)/shared}
export PL_TEST_TMP=$(mktemp -d "${TMPDIR:-/tmp}/parlight-test.XXXXXX")
# On exit (an interrupt included) the tests still running stop with the runner.
trap 'kill $(jobs -p) 2>/dev/null; wait; rm -rf "$PL_TEST_TMP"' EXIT

RUNNER=${PL_RUNNER:-}
RUNNER_SKIP=${PL_RUNNER_SKIP:-^test_camera_}
FEATURES=" $(cat "$BUILD/features" 2>/dev/null) "
SH_BUILD=$BUILD
if [ -n "$RUNNER" ]; then
    # A BUILD folder for the shell tests: wrappers that run each program under the runner,
    # links for everything else.
    SH_BUILD="$PL_TEST_TMP/build-run"
    mkdir -p "$SH_BUILD/tests"
    abs=$(cd "$BUILD" && pwd)
    for f in "$abs"/* "$abs"/tests/*; do
        [ -d "$f" ] && continue
        rel=${f#"$abs"/}
        if [ -x "$f" ] && [ "$(head -c 4 "$f" | od -An -c | tr -d ' ')" = '177ELF' ]; then
            printf '#!/bin/sh\nexec %s %q "$@"\n' "$RUNNER" "$f" >"$SH_BUILD/$rel"
            chmod +x "$SH_BUILD/$rel"
        else
            ln -s "$f" "$SH_BUILD/$rel"
        fi
    done
    for d in "$abs"/*/; do [ -e "$SH_BUILD/$(basename "$d")" ] || ln -s "$d" "$SH_BUILD/$(basename "$d")"; done
    echo "runner: $RUNNER"
fi

# The optional libraries a test needs ("needs: a b" in its first lines) that this build lacks.
missing_needs() {
    local src=$1 need out=""
    [ -f "$src" ] || return 0
    for need in $(head -n 20 "$src" | sed -n 's/.*needs: *\([a-z0-9 ]*\).*/\1/p'); do
        [[ $FEATURES == *" $need "* ]] || out+="$need "
    done
    echo -n "$out"
}

# Why a test does not run under the sanitizers (empty: it runs). Only tests whose C part is tiny
# or covered elsewhere, or which cannot run sanitized builds, are here.
san_skip() {
    case $1 in
        test_camera_uvc.sh | test_camera_vivid.sh)
            echo "boots a QEMU guest that runs the build's programs; the guest has no sanitizer runtime" ;;
        test_train_smoke.sh | test_training_path.sh | test_distill.sh)
            echo "PyTorch training end to end; the C commands it calls (crop, estimate, eval) run in the CLI tests" ;;
        test_export.sh | test_synth_rooms.sh | test_pack_dataset.sh | test_train_device_paths.sh | \
            test_train_size_bound.sh)
            echo "Python only (tools/export.py, tools/train/): nothing sanitized to run" ;;
        test_bench_cli.sh)
            echo "times parlight against PyTorch and ONNX Runtime: sanitized timings mean nothing" ;;
    esac
}

tests=()
for t in "$BUILD"/tests/test_*; do [ -x "$t" ] && tests+=("$t"); done
for t in tests/test_*.sh; do [ -f "$t" ] && tests+=("$t"); done

# Tests that run with no other test beside them, first: the camera rig boots a QEMU (TCG) guest
# whose UVC gadget must answer the host driver's control requests in time; beside another test
# on top of other load it missed the MJPEG negotiation once here.
ALONE=" test_camera_uvc.sh test_camera_vivid.sh "
# Then the long tests, so that the slots finish together rather than one of them running
# test_train_smoke.sh alone at the end (seconds measured on this project's 2-core CI machine).
SLOW_FIRST="test_camera_uvc.sh test_camera_vivid.sh test_train_smoke.sh test_golden.sh
test_distill.sh test_training_path.sh test_isa_exact.sh test_export.sh test_sink_ws.sh
test_kernels_simd_f32 test_extract_real test_anchor_cli.sh test_quantize.sh"
ordered=()
for s in $SLOW_FIRST; do
    for t in "${tests[@]}"; do [ "$(basename "$t")" = "$s" ] && ordered+=("$t"); done
done
for t in "${tests[@]}"; do
    [[ " $(echo $SLOW_FIRST) " == *" $(basename "$t") "* ]] || ordered+=("$t")
done
tests=("${ordered[@]}")

# Runs one test; leaves its output in $PL_TEST_TMP/NAME.log and "RC MS" in NAME.done (last, so
# that the file's presence means the test has ended).
run_one() {
    local t=$1 name src lacks start rc ms
    name=$(basename "$t")
    local log="$PL_TEST_TMP/$name.log"
    src=$t
    case "$t" in *.sh) ;; *) src="tests/$name.c" ;; esac
    lacks=$(missing_needs "$src")
    start=$(date +%s%N)
    if [ -n "$lacks" ]; then
        echo "skip: this build has no ${lacks% } (see docs/PORTING.md)" >"$log"
        rc=77
    elif [ -n "$RUNNER" ] && grep -qE "$RUNNER_SKIP" <<<"$name"; then
        echo "skip: not run under $RUNNER (PL_RUNNER_SKIP)" >"$log"
        rc=77
    elif [ "${PL_SAN:-0}" = 1 ] && [ -n "$(san_skip "$name")" ]; then
        echo "skip under SAN=1: $(san_skip "$name")" >"$log"
        rc=77
    else
        case "$t" in
            *.sh) BUILD=$SH_BUILD timeout 900 bash "$t" >"$log" 2>&1 </dev/null ;;
            *) timeout 900 $RUNNER "$t" >"$log" 2>&1 </dev/null ;;
        esac
        rc=$?
    fi
    ms=$(( ($(date +%s%N) - start) / 1000000 ))
    echo "$rc $ms" >"$PL_TEST_TMP/$name.done.tmp"
    mv "$PL_TEST_TMP/$name.done.tmp" "$PL_TEST_TMP/$name.done"
}

pass=0 fail=0 skip=0 failed=()
# Prints the result of a test that has ended.
report() {
    local name=$1 rc ms secs log="$PL_TEST_TMP/$1.log"
    read -r rc ms <"$PL_TEST_TMP/$name.done"
    secs="$((ms / 1000)).$(( (ms % 1000) / 100 ))"
    case $rc in
        0) pass=$((pass + 1)); echo "PASS  $name (${secs}s)" ;;
        77) skip=$((skip + 1)); echo "SKIP  $name: $(tail -n 1 "$log")" ;;
        *) fail=$((fail + 1)); failed+=("$name"); echo "FAIL  $name (exit $rc, ${secs}s)"
           sed 's/^/      /' "$log" | tail -n 40 ;;
    esac
}

JOBS=${PL_TEST_JOBS:-$(nproc 2>/dev/null || echo 1)}
[ "${PL_TEST_JOBS:-}" ] || [ "$JOBS" -le 4 ] || JOBS=4
[[ $JOBS =~ ^[1-9][0-9]*$ ]] ||
    { echo "tests/run.sh: PL_TEST_JOBS $JOBS: expected a count >= 1" >&2; exit 2; }
[ "$JOBS" -eq 1 ] || echo "running $JOBS tests at once (PL_TEST_JOBS)"
running=()
# Reports the tests of `running` that have ended and keeps the others.
reap() {
    local still=() name
    for name in "${running[@]}"; do
        if [ -f "$PL_TEST_TMP/$name.done" ]; then report "$name"; else still+=("$name"); fi
    done
    running=("${still[@]}")
}
for t in "${tests[@]}"; do
    name=$(basename "$t")
    if [ -n "${TEST_FILTER:-}" ] && ! grep -qE "$TEST_FILTER" <<<"$name"; then continue; fi
    limit=$JOBS
    [[ $ALONE == *" $name "* ]] && limit=1
    while [ "${#running[@]}" -ge "$limit" ]; do
        wait -n 2>/dev/null || true
        reap
    done
    run_one "$t" &
    running+=("$name")
    if [[ $ALONE == *" $name "* ]]; then wait; reap; fi
done
wait
reap
echo
[ $fail -eq 0 ] || echo "failed: ${failed[*]}"
echo "$pass passed, $fail failed, $skip skipped"
[ $((pass + fail + skip)) -gt 0 ] || echo "tests/run.sh: no test name matches TEST_FILTER '${TEST_FILTER:-}'" >&2
[ $fail -eq 0 ] && [ $pass -gt 0 ]
