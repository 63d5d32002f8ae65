#!/usr/bin/env bash
# `parlight extract` end to end: its --json is a lights JSON that `parlight render --lights` and
# `parlight compare` accept; --out refuses to overwrite without --force; bad inputs give exit 1
# (or 2 for usage) with one line naming the problem, never a crash. Needs $BUILD/parlight and the
# @pmndrs/assets panoramas (skips with 77 otherwise).
# needs: openexr (tests/run.sh skips this test in a build without it)
set -u
cd "$(dirname "$0")/.."
BUILD=${BUILD:-build}
P=$BUILD/parlight
T=${PL_TEST_TMP:-/tmp}/extract_cli
[ -x "$P" ] || { echo "skip: $P not built"; exit 77; }
mkdir -p "$T"
tools/pmndrs-hdri.sh --indoor "$T/hdri" >/dev/null 2>&1 || { echo "skip: @pmndrs/assets not installed"; exit 77; }
fail=0
check() { # expected-exit description command...
    local want=$1 what=$2; shift 2
    "$@" >"$T/out" 2>"$T/err"; local rc=$?
    if [ $rc -ne "$want" ]; then echo "FAIL $what: exit $rc, expected $want"; cat "$T/err"; fail=1;
    else echo "ok   $what (exit $rc) $(head -c 200 "$T/err")"; fi
}
check 0 "extract --json" "$P" extract --hdr "$T/hdri/lobby.exr" --json
cp "$T/out" "$T/lobby.json"
grep -q '"distance_assumed":true' "$T/lobby.json" || { echo "FAIL distance_assumed missing"; fail=1; }
check 0 "render --lights accepts it" "$P" render --lights "$T/lobby.json" --out "$T/env.exr" --width 64 --force
check 0 "compare accepts it" "$P" compare "$T/lobby.json" "$T/hdri/lobby.exr"
grep -q "si_rmse" "$T/out" || { echo "FAIL compare printed no si_rmse"; fail=1; }
check 0 "extract table" "$P" extract --hdr "$T/hdri/studio.exr" --max-lights 2 --room-height 3 --room-width 5
rm -f "$T/x.json"
check 0 "--out" "$P" extract --hdr "$T/hdri/studio.exr" --out "$T/x.json"
check 1 "--out exists" "$P" extract --hdr "$T/hdri/studio.exr" --out "$T/x.json"
check 0 "--out --force" "$P" extract --hdr "$T/hdri/studio.exr" --out "$T/x.json" --force
check 1 "missing file" "$P" extract --hdr "$T/missing.exr"
head -c 5000 "$T/hdri/studio.exr" >"$T/trunc.exr"
check 1 "truncated EXR" "$P" extract --hdr "$T/trunc.exr"
printf '#?RADIANCE\n\n-Y 100000 +X 200000\n' >"$T/huge.hdr"
check 1 "huge declared size" "$P" extract --hdr "$T/huge.hdr"
"$P" render --lights "$T/lobby.json" --cubemap 8 --layout strip --out "$T/strip.exr" --force >/dev/null 2>&1
check 1 "not 2:1 (a 48x8 cube-map strip)" "$P" extract --hdr "$T/strip.exr"
check 2 "no --hdr" "$P" extract --json
check 2 "bad --max-lights" "$P" extract --hdr "$T/hdri/studio.exr" --max-lights 0
check 2 "camera above the ceiling" "$P" extract --hdr "$T/hdri/studio.exr" --camera-height 3
exit $fail
