#!/usr/bin/env bash
# tools/make-calib-frames.sh keeps every panorama's frames: two panoramas whose crops would take
# the same file names must not silently replace each other. The pmndrs panoramas (when the npm
# package is installed) are written with a "pmndrs-" prefix, so pmndrs "workshop" and a train/
# workshop.hdr both keep their 4 frames; two train/ files with one stem (a.hdr, a.exr) are an
# error naming both. Uses small panoramas rendered by parlight into a stand-in PL_SHARED, never
# ../shared. Env: BUILD, PL_TEST_TMP (tests/run.sh). Exit 0 pass, 1 fail.
set -u
T="$PL_TEST_TMP/calib-frames"
S="$T/shared"
mkdir -p "$S/data/hdri/train" "$S/data/hdri/eval"
fail() { echo "FAIL: $*"; exit 1; }
P="$BUILD/parlight"
echo '{"lights":[{"dir":[1,0,0],"distance_m":2,"solid_angle_sr":0.05,"rgb":[10,10,10]}],"ambient":[0.2,0.2,0.2]}' >"$T/L.json"
render() { "$P" render --lights "$T/L.json" --out "$1" --width 128 >/dev/null 2>"$T/err" ||
    fail "render $1: $(cat "$T/err")"; }
render "$S/data/hdri/train/workshop.hdr"
render "$S/data/hdri/train/room.hdr"
render "$S/data/hdri/eval/test_room.hdr"
manifest() { # manifest FILE...: MANIFEST.tsv with these rows, all indoor
    printf 'file\tscene\twidth\n' >"$S/data/hdri/MANIFEST.tsv"
    for f in "$@"; do printf '%s\tindoor\t128\n' "$f" >>"$S/data/hdri/MANIFEST.tsv"; done
}
manifest train/workshop.hdr train/room.hdr eval/test_room.hdr
BUILD=$BUILD PL_SHARED=$S tools/make-calib-frames.sh "$T/out" 4 >"$T/log" 2>&1 ||
    fail "make-calib-frames: $(cat "$T/log")"
for n in workshop room; do
    [ "$(ls "$T/out/calib/${n}"_yaw*.jpg 2>/dev/null | wc -l)" -eq 4 ] ||
        fail "calib/: not 4 frames of train/$n.hdr: $(ls "$T/out/calib")"
done
[ "$(ls "$T/out/check/" | wc -l)" -eq 4 ] || fail "check/: not the 4 frames of eval/: $(ls "$T/out/check")"
if tools/pmndrs-hdri.sh --indoor >/dev/null 2>&1 && [ -d .deps/npm/node_modules/@pmndrs/assets ]; then
    [ "$(ls "$T/out/calib/pmndrs-workshop"_yaw*.jpg | wc -l)" -eq 4 ] ||
        fail "pmndrs workshop's frames were not kept beside train/workshop.hdr's: $(ls "$T/out/calib")"
    echo "ok  pmndrs-workshop_* and workshop_* both kept ($(ls "$T/out/calib" | wc -l) calibration frames)"
else
    echo "ok  train/ frames kept (the pmndrs npm package is not installed: its half not checked)"
fi
# Two train/ panoramas with one stem: an error naming both, never one replacing the other.
"$P" render --lights "$T/L.json" --out "$S/data/hdri/train/room.exr" --width 128 >/dev/null 2>&1 ||
    fail "render room.exr"
manifest train/room.hdr train/room.exr
rm -rf "$T/out2"
if BUILD=$BUILD PL_SHARED=$S tools/make-calib-frames.sh "$T/out2" 4 >"$T/log2" 2>&1; then
    fail "room.hdr and room.exr crops took the same names without an error: $(cat "$T/log2")"
fi
grep -q "room.exr and .*room.hdr both make .*room_yaw" "$T/log2" ||
    fail "the clash message does not name both panoramas: $(cat "$T/log2")"
echo "ok  a name clash between two panoramas is an error naming both"
