#!/usr/bin/env bash
# parlight render / compare end to end: maps (PNG, EXR, HDR), cube maps (cross, strip), spheres,
# --at, --force, round trips through the files (a map of the lights compared with the lights
# gives ~0), and bad inputs (missing/malformed JSON, bad flags, existing outputs) -> exit 1/2
# with a message naming the problem.
# needs: openexr (tests/run.sh skips this test in a build without it)
set -u
BUILD=${BUILD:-build}
P="$BUILD/parlight"
T=${PL_TEST_TMP:-$(mktemp -d)}/render_cli
if [ ! -x "$P" ]; then echo "skip: $P not built"; exit 77; fi
rm -rf "$T"; mkdir -p "$T"
. "$(dirname "$0")/cli_helpers.sh"

cat >"$T/L.json" <<'J'
{"frame": 1, "lights":[{"dir":[0.3,0.8,-0.5],"distance_m":2.5,"solid_angle_sr":0.15,"rgb":[40,36,30]},
{"dir":[-0.8,0.3,-0.5],"distance_m":3,"solid_angle_sr":0.6,"rgb":[3,4,6]}],"ambient":[0.3,0.28,0.25]}
J
cat >"$T/px.json" <<'J'
{"lights":[{"dir":[1,0,0],"distance_m":2,"solid_angle_sr":0.05,"rgb":[10,10,10]}],"ambient":[0,0,0]}
J

expect 0 "" -- "$P" render --help
grep -q -- "--cubemap" "$T/out" || fail "render --help lacks --cubemap"
expect 0 "" -- "$P" render --lights "$T/L.json" --out "$T/map.png" --width 256
expect 0 "" -- "$P" render --lights "$T/L.json" --out "$T/map.exr" --width 256
expect 0 "" -- "$P" render --lights "$T/L.json" --out "$T/map.hdr" --width 128
expect 0 "" -- "$P" render --lights "$T/L.json" --out "$T/cube.png" --cubemap 16
expect 0 "" -- "$P" render --lights "$T/L.json" --out "$T/strip.exr" --cubemap 8 --layout strip
expect 0 "" -- "$P" render --lights "$T/L.json" --out "$T/sphere.png" --sphere glossy --size 48
expect 0 "" -- "$P" render --lights "$T/L.json" --out "$T/at.exr" --width 64 --at 0.5,1,-0.5
expect 0 "" -- "$P" render --env "$T/map.exr" --out "$T/envsphere.exr" --sphere diffuse --size 16
for f in map.png map.exr map.hdr cube.png strip.exr sphere.png at.exr envsphere.exr; do
    [ -s "$T/$f" ] || fail "$f not written"
done
if command -v file >/dev/null; then
    file "$T/map.png" | grep -q "256 x 128" || fail "map.png is not 256x128: $(file "$T/map.png")"
    file "$T/cube.png" | grep -q "64 x 48" || fail "cube.png is not a 64x48 cross: $(file "$T/cube.png")"
fi
# never overwrite without --force
cp "$T/map.png" "$T/keep.png"
expect 1 "already exists.*--force" -- "$P" render --lights "$T/L.json" --out "$T/map.png" --width 64
cmp -s "$T/map.png" "$T/keep.png" || fail "existing output was changed without --force"
expect 0 "" -- "$P" render --lights "$T/L.json" --out "$T/map.png" --width 64 --force
cmp -s "$T/map.png" "$T/keep.png" && fail "--force did not overwrite"

# compare: lights vs their own map ~ 0, vs a different lighting > 0
expect 0 "" -- "$P" compare "$T/L.json" "$T/map.exr"
awk '/^rmse/ {r=$2} /^si_rmse/ {s=$2} END {exit !(r < 0.01 && s < 0.01)}' "$T/out" ||
    fail "compare lights vs own map: $(cat "$T/out")"
expect 0 "" -- "$P" compare "$T/L.json" "$T/px.json" --sphere glossy --size 32 --json
grep -qE '^\{"a":.*"sphere":"glossy","size":32,"rmse":[0-9.e+-]+,"si_rmse":[0-9.e+-]+\}$' "$T/out" ||
    fail "compare --json output: $(cat "$T/out")"
awk -F'"rmse":' '{split($2, a, ","); exit !(a[1] > 0.1)}' "$T/out" || fail "different lightings compare ~0: $(cat "$T/out")"
# moving toward a light makes it brighter on the sphere: the render at p differs from the camera's
expect 0 "" -- "$P" compare "$T/at.exr" "$T/map.exr"

# bad inputs
printf '{"lights": [{"dir": [0,1,0]' >"$T/trunc.json"
printf '{"lights": [], "ambient": [0, NaN, 0]}' >"$T/nan.json"
printf '{"lights": [{"dir": [0,1,0], "distance_m": 1, "solid_angle_sr": 0.1}], "ambient": [0,0,0]}' >"$T/norgb.json"
printf '#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 4 +X 4\n' >"$T/bad.hdr"
expect 1 "trunc.json: byte 27.*end of input" -- "$P" render --lights "$T/trunc.json" --out "$T/x.png"
expect 1 "nan.json: byte 30" -- "$P" render --lights "$T/nan.json" --out "$T/x.png"
expect 1 "missing field lights\[0\]\.rgb" -- "$P" render --lights "$T/norgb.json" --out "$T/x.png"
expect 1 "nope.json: cannot open" -- "$P" render --lights "$T/nope.json" --out "$T/x.png"
expect 1 "bad.hdr" -- "$P" render --env "$T/bad.hdr" --out "$T/x.png" --sphere diffuse
expect 1 "bad.hdr" -- "$P" compare "$T/L.json" "$T/bad.hdr"
expect 1 "trunc.json" -- "$P" compare "$T/trunc.json" "$T/L.json"
expect 1 "relighting point.*light 0" -- "$P" render --lights "$T/px.json" --out "$T/x.png" --at 2,0,0.0002
[ -e "$T/x.png" ] && fail "an output was written on failure"
expect 2 "--out is required" -- "$P" render --lights "$T/L.json"
expect 2 "exactly one of --lights or --env" -- "$P" render --out "$T/x.png"
expect 2 "expected a .exr, .hdr or .png" -- "$P" render --lights "$T/L.json" --out "$T/x.jpg"
expect 2 "--width 7: expected an even" -- "$P" render --lights "$T/L.json" --out "$T/x.png" --width 7
expect 2 "--width 'abc'" -- "$P" render --lights "$T/L.json" --out "$T/x.png" --width abc
expect 2 "--at '1,2': expected" -- "$P" render --lights "$T/L.json" --out "$T/x.png" --at 1,2
expect 2 "--at 'nan,0,0'" -- "$P" render --lights "$T/L.json" --out "$T/x.png" --at nan,0,0
expect 2 "--sphere 'shiny'" -- "$P" render --lights "$T/L.json" --out "$T/x.png" --sphere shiny
expect 2 "exclusive" -- "$P" render --lights "$T/L.json" --out "$T/x.png" --sphere diffuse --cubemap 8
expect 2 "panorama has no depth" -- "$P" render --env "$T/map.exr" --out "$T/x.png" --sphere diffuse --at 0,0,1
expect 2 "--cubemap '0'" -- "$P" render --lights "$T/L.json" --out "$T/x.png" --cubemap 0
expect 2 "unknown option '--bogus'" -- "$P" render --bogus
expect 2 "expected two inputs" -- "$P" compare "$T/L.json"
expect 1 "unknown input type" -- "$P" compare "$T/L.json" "$T/map.png"
expect 2 "--size '0'" -- "$P" compare "$T/L.json" "$T/L.json" --size 0

# a real panorama, when the shared data is there: cube map and spheres from the map, and a
# panorama compared with itself is exactly 0
PANO="${PL_SHARED:-/nonexistent}/data/hdri/eval/lebombo.hdr"
if [ -f "$PANO" ]; then
    expect 0 "" -- "$P" render --env "$PANO" --out "$T/pano_cube.exr" --cubemap 32
    expect 0 "" -- "$P" render --env "$PANO" --out "$T/pano_sphere.png" --sphere glossy --size 32
    expect 0 "" -- "$P" compare "$PANO" "$PANO" --size 32
    grep -qx "rmse 0" "$T/out" || fail "panorama vs itself: $(cat "$T/out")"
else
    echo "note: $PANO absent, panorama part not run"
fi

finish
echo ok
