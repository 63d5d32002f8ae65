#!/usr/bin/env bash
# Runs the whole suite: every compiled tests/test_*.c program and every tests/test_*.sh script.
# Exit status 0 = pass, 77 = skip (with a reason on its output), anything else = fail.
# Prints one line per test and closes with "N passed, M failed, K skipped"; exits 1 on any failure.
# Environment: BUILD (default build), PL_SHARED (default ../shared, beside the repo),
# TEST_FILTER (a grep pattern on test names),
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
trap 'rm -rf "$PL_TEST_TMP"' EXIT

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
        test_export.sh | test_synth_rooms.sh)
            echo "Python only (tools/export.py, tools/train/synth_rooms.py): nothing sanitized to run" ;;
        test_bench_cli.sh)
            echo "times parlight against PyTorch and ONNX Runtime: sanitized timings mean nothing" ;;
    esac
}

tests=()
for t in "$BUILD"/tests/test_*; do [ -x "$t" ] && tests+=("$t"); done
for t in tests/test_*.sh; do [ -f "$t" ] && tests+=("$t"); done

pass=0 fail=0 skip=0 failed=()
for t in "${tests[@]}"; do
    name=$(basename "$t")
    if [ -n "${TEST_FILTER:-}" ] && ! grep -qE "$TEST_FILTER" <<<"$name"; then continue; fi
    log="$PL_TEST_TMP/$name.log"
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
            *.sh) BUILD=$SH_BUILD timeout 900 bash "$t" >"$log" 2>&1 ;;
            *) timeout 900 $RUNNER "$t" >"$log" 2>&1 ;;
        esac
        rc=$?
    fi
    ms=$(( ($(date +%s%N) - start) / 1000000 ))
    secs="$((ms / 1000)).$(( (ms % 1000) / 100 ))"
    case $rc in
        0) pass=$((pass + 1)); echo "PASS  $name (${secs}s)" ;;
        77) skip=$((skip + 1)); echo "SKIP  $name: $(tail -n 1 "$log")" ;;
        *) fail=$((fail + 1)); failed+=("$name"); echo "FAIL  $name (exit $rc, ${secs}s)"
           sed 's/^/      /' "$log" | tail -n 40 ;;
    esac
done
echo
[ $fail -eq 0 ] || echo "failed: ${failed[*]}"
echo "$pass passed, $fail failed, $skip skipped"
[ $fail -eq 0 ] && [ $pass -gt 0 ]
