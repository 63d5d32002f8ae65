#!/usr/bin/env bash
# tools/train/synth_rooms.py, the procedurally lit rooms (synthetic indoor training data):
# - radiometry: a point lit by one bulb, and one far below a ceiling panel, against the inverse
#   square law (the renderer's shading, no indirect term), and a shadow cast by furniture;
# - the slab test (ray_boxes, occluded): entry distance and face of rays into a box, misses
#   from inside it and away from it;
# - geometry: each room's brightest extracted light (parlight extract, the C maths) lies in the
#   direction the room's JSON records for one of its lights, so the panorama mapping is
#   light/equirect.c's;
# - files: deterministic (same seed: same bytes), resumable (more --rooms adds, keeps the old),
#   another seed in the same folder refused, a folder holding another MANIFEST.tsv left as it
#   was, bad flags refused with the flag named.
# Needs python3 with numpy and $BUILD/parlight; not ../shared. Exit 0 pass, 1 fail, 77 skip.
set -u
cd "$(dirname "$0")/.."
PY=/usr/bin/python3
BUILD=${BUILD:-build}
TMP=${PL_TEST_TMP:-$(mktemp -d)}/synth_rooms
rm -rf "$TMP"
mkdir -p "$TMP"
if ! "$PY" -c 'import numpy' 2>/dev/null; then
    echo "skip: $PY lacks numpy (tools/install-deps.sh installs it)"
    exit 77
fi
[ -x "$BUILD/parlight" ] || { echo "FAIL: no $BUILD/parlight (build first)"; exit 1; }
fail() { echo "FAIL: $*"; exit 1; }

"$PY" - <<'EOF' || fail "radiometry"
import math, sys
import numpy as np
sys.path.insert(0, "tools/train")
import synth_rooms as sr

def room(lights, furniture=()):
    return {"size": [6.0, 3.0, 6.0], "camera": [3.0, 1.5, 3.0], "doors": [], "pictures": [],
            "furniture": list(furniture), "lights": lights,
            "materials": {"walls": [[0.5] * 3] * 4, "floor": [0.5] * 3, "floor_kind": "carpet",
                          "plank_or_tile_m": 0.3, "plank_axis": 0, "ceiling": [0.5] * 3,
                          "skirting": [0.0, 0.5, 0.5, 0.5], "noise_seed": 1},
            "_indirect": np.zeros(3)}

def radiance(r, p, n, surf):
    samples = [sr.light_samples(r, l) for l in r["lights"]]
    return sr.shade(r, np.array([p], float), np.array([n], float), np.array([surf]), samples,
                    sr.boxes(r))[0]

white = [1.0, 1.0, 1.0]
# a bulb of flux 4 pi (intensity 1) 2 m from a floor point, 60 degrees off its normal:
# L = rho / pi * I cos / d^2 (the carpet's noise is within 20% of rho: compare to its albedo)
bulb = room([{"type": "bulb", "centre": [3.0, 1.0, 3.0], "radius": 0.05, "flux": 4 * math.pi,
              "color": white}])
p = [3.0 + 2 * math.sin(math.radians(60)), 0.0, 3.0]
p[1] = 1.0 - 2 * math.cos(math.radians(60))
rho = sr.albedo(bulb, np.array([sr.FLOOR]), np.array([p]))[0]
got = radiance(bulb, p, [0, 1, 0], sr.FLOOR)
want = rho / math.pi * 1.0 * 0.5 / 4.0
assert np.allclose(got, want, rtol=1e-6), (got, want)
# a 0.2 x 0.2 m panel of flux F: far below it E = F / (pi d^2) (Lambertian emitter on axis)
panel = room([{"type": "panel", "centre": [3.0, 3.0, 3.0], "half": [0.1, 0.1], "flux": 2.0,
               "color": white}])
q = [3.0, 0.0, 3.0]
rho = sr.albedo(panel, np.array([sr.FLOOR]), np.array([q]))[0]
got = radiance(panel, q, [0, 1, 0], sr.FLOOR)
want = rho / math.pi * 2.0 / (math.pi * 9.0)
assert np.allclose(got, want, rtol=2e-3), (got, want)
# a table between the bulb and the floor point shadows it
table = {"lo": [3.5, 0.0, 2.5], "hi": [4.0, 0.7, 3.5], "color": [0.5] * 3}
shadowed = room(bulb["lights"], [table])
p2 = [4.5, 0.0, 3.0]
assert radiance(bulb, p2, [0, 1, 0], sr.FLOOR).max() > 0
assert radiance(shadowed, p2, [0, 1, 0], sr.FLOOR).max() == 0
# the slab test: rays toward the table enter it at its faces (distance and face axis); a ray
# that starts inside it or points away misses it
o = np.array([[3.0, 0.35, 3.0], [3.75, 0.2, 3.0], [3.75, 0.35, 2.0], [3.0, 0.35, 3.0],
              [3.75, 1.5, 3.0]])
d = np.array([[1.0, 0, 0], [0, 1.0, 0], [0, 0, 1.0], [-1.0, 0, 0], [0, -1.0, 0]])
t, which, axis = sr.ray_boxes(o, d, sr.boxes(shadowed))
assert list(which) == [0, -1, 0, -1, 0], which
assert np.allclose(t[[0, 2, 4]], [0.5, 0.5, 0.8]) and list(axis[[0, 2, 4]]) == [0, 2, 1], (t, axis)
assert sr.occluded(o[:1], np.array([4.5, 0.35, 3.0]), sr.boxes(shadowed))[0]
assert not sr.occluded(o[:1], np.array([3.4, 0.35, 3.0]), sr.boxes(shadowed))[0]
assert sr.boxes(bulb)[0].shape == (0, 3)
# the emitter's radiance: a bulb seen directly is flux / (4 pi) / (pi r^2)
assert np.allclose(sr.emitter_radiance(bulb, bulb["lights"][0]), 1 / (math.pi * 0.05 ** 2))
print("radiometry: bulb and panel irradiance as the inverse square law, shadows cast")
EOF

SR=("$PY" tools/train/synth_rooms.py --width 256 --seed 3 --quiet)
"${SR[@]}" --rooms 3 --out "$TMP/a" || fail "synth_rooms.py"
[ "$(ls "$TMP"/a/synth/*.hdr | wc -l)" -eq 3 ] || fail "expected 3 panoramas"
[ "$(wc -l <"$TMP/a/MANIFEST.tsv")" -eq 4 ] || fail "MANIFEST.tsv: expected a header and 3 rows"
"${SR[@]}" --rooms 3 --out "$TMP/b" || fail "synth_rooms.py, second folder"
for f in "$TMP"/a/synth/*; do
    cmp -s "$f" "$TMP/b/synth/$(basename "$f")" || fail "same seed, different bytes: $f"
done
sum1=$(cat "$TMP"/a/synth/room_000[0-2].* | sha256sum)
"${SR[@]}" --rooms 4 --out "$TMP/a" || fail "synth_rooms.py, one more room"
[ "$(cat "$TMP"/a/synth/room_000[0-2].* | sha256sum)" = "$sum1" ] || fail "adding a room changed others"
[ "$(wc -l <"$TMP/a/MANIFEST.tsv")" -eq 5 ] || fail "MANIFEST.tsv: expected 4 rows after adding one"
"$PY" tools/train/synth_rooms.py --width 256 --seed 4 --rooms 1 --out "$TMP/a" >"$TMP/e.log" 2>&1 &&
    fail "another seed was accepted in the same folder"
grep -q "another seed, width or version" "$TMP/e.log" || fail "no reason: $(cat "$TMP/e.log")"
mkdir -p "$TMP/d" && printf 'file\tscene\n' >"$TMP/d/MANIFEST.tsv"
"$PY" tools/train/synth_rooms.py --rooms 1 --out "$TMP/d" >"$TMP/e.log" 2>&1 &&
    fail "wrote into a folder with another MANIFEST.tsv"
grep -q "no readable synth.json" "$TMP/e.log" || fail "no reason: $(cat "$TMP/e.log")"
[ "$(ls "$TMP/d")" = MANIFEST.tsv ] || fail "a refused run left files: $(ls "$TMP/d")"
for bad in "--width 63" "--width 100000" "--rooms 0" "--first -1"; do
    # shellcheck disable=SC2086
    "$PY" tools/train/synth_rooms.py $bad --out "$TMP/c" >"$TMP/e.log" 2>&1 && fail "$bad accepted"
    grep -q -- "${bad% *}" "$TMP/e.log" || fail "$bad: no reason naming it: $(cat "$TMP/e.log")"
done
echo "files: deterministic, resumable, another seed and bad flags refused"

for i in 0 1 2 3; do
    "$BUILD/parlight" extract --hdr "$TMP/a/synth/room_000$i.hdr" --json >"$TMP/x$i.json" ||
        fail "parlight extract room $i"
done
"$PY" - "$TMP" <<'EOF' || fail "extracted lights are not where the rooms put them"
import json, math, sys
tmp = sys.argv[1]
for i in range(4):
    ext = json.load(open(f"{tmp}/x{i}.json"))["lights"]
    room = json.load(open(f"{tmp}/a/synth/room_{i:04d}.json"))
    first = ext[0]["dir"]
    near = min(math.degrees(math.acos(max(-1, min(1, sum(a * b for a, b in zip(first, l["direction_from_camera"]))))))
               for l in room["lights"])
    kinds = [l["type"] for l in room["lights"]]
    print(f"room {i} ({', '.join(kinds)}): brightest extracted light {near:.1f} deg from a drawn one")
    assert near < 12, near
EOF
echo "ok"
