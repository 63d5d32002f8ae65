#!/usr/bin/env bash
# parlight crop --gt-map W: the crop's panorama in its camera frame, in the ground truth JSON
# (the dense target of train.py --w-map / --sphere-truth map). On a panorama rendered from one
# known light + ambient: the map's brightest pixel lies toward the ground truth's light (both
# rotated into the crop's frame by the C code, so a wrong rotation or flip shows), its
# solid-angle-weighted mean is the panorama's mean times the exposure scale k (area averaging
# keeps energy), no map is written without the flag, and bad widths are refused. --list makes the
# same bytes as one process per crop and refuses a malformed line or an existing output.
# Env: BUILD, PL_TEST_TMP (tests/run.sh). Exit 0 pass, 1 fail, 77 skip.
set -u
cd "$(dirname "$0")/.."
PY=/usr/bin/python3
BUILD=${BUILD:-build}
TMP=${PL_TEST_TMP:-$(mktemp -d)}/crop_gt_map
rm -rf "$TMP"
mkdir -p "$TMP"
"$PY" -c 'import numpy' 2>/dev/null || { echo "skip: $PY lacks numpy"; exit 77; }
[ -x "$BUILD/parlight" ] || { echo "FAIL: no $BUILD/parlight (build first)"; exit 1; }
fail() { echo "FAIL: $*"; exit 1; }

cat >"$TMP/l.json" <<'EOF'
{"lights":[{"dir":[0.5,0.45,-0.74],"distance_m":2,"solid_angle_sr":0.05,"rgb":[400,300,200]}],
 "ambient":[0.4,0.5,0.6]}
EOF
"$BUILD/parlight" render --lights "$TMP/l.json" --out "$TMP/p.hdr" --width 512 >/dev/null ||
    fail "render the panorama"
C=("$BUILD/parlight" crop --hdr "$TMP/p.hdr" --yaw 40 --pitch 10 --fov 60 --size 128x96
   --out "$TMP/c.png" --gt "$TMP/c.json")
"${C[@]}" --gt-map 32 || fail "crop --gt-map 32"
"$PY" - "$TMP/c.json" <<'EOF' || fail "map check"
import json, math, sys
import numpy as np
g = json.load(open(sys.argv[1]))
m = g["radiance_map"]
w, h = m["width"], m["height"]
assert (w, h) == (32, 16), (w, h)
a = np.array(m["rgb"], np.float64).reshape(h, w, 3)
# light/equirect.c's mapping
y, x = np.unravel_index(np.argmax(a.sum(-1)), (h, w))
phi, th = ((x + 0.5) / w - 0.5) * 2 * math.pi, (0.5 - (y + 0.5) / h) * math.pi
d = np.array([math.sin(phi) * math.cos(th), math.sin(th), -math.cos(phi) * math.cos(th)])
l = np.array(g["lights"][0]["dir"])
ang = math.degrees(math.acos(min(1, float(d @ l) / np.linalg.norm(l))))
assert ang < 12, f"brightest map pixel {ang:.1f} deg from the ground-truth light"
# solid-angle-weighted mean against the lights' own (SG integral 2 pi s/4pi (1 - e^(-8pi/s)))
rows = np.cos((0.5 - (np.arange(h) + 0.5) / h) * math.pi)
mean = (a * rows[:, None, None]).sum((0, 1)) / (rows.sum() * w)
s = 0.05 / (4 * math.pi)
lobe = 2 * math.pi * s * (1 - math.exp(-2 / s)) / (4 * math.pi)
want = g["exposure_scale"] * (np.array([0.4, 0.5, 0.6]) + lobe * np.array([400, 300, 200]))
assert np.all(np.abs(mean / want - 1) < 0.03), (mean, want)
print(f"map 32x16: brightest pixel {ang:.1f} deg from the light, mean/expected "
      f"{np.round(mean / want, 4).tolist()}")
EOF
"${C[@]}" --force || fail "crop without --gt-map"
grep -q radiance_map "$TMP/c.json" && fail "a radiance_map without --gt-map"
for bad in 3 2 300 x; do
    "${C[@]}" --force --gt-map "$bad" 2>"$TMP/err" && fail "--gt-map $bad accepted"
    grep -q -- "--gt-map" "$TMP/err" || fail "--gt-map $bad: no message naming it"
done
# --list: the same bytes as one process per crop; a malformed line is refused naming its line
printf '%s\t%s\t40\t10\t60\t0\t2.2\n# a comment\n\n%s\t%s\t-100\t-5\t75\t0.5\t1.9\n' \
    "$TMP/l1.png" "$TMP/l1.json" "$TMP/l2.png" "$TMP/l2.json" >"$TMP/list.txt"
"$BUILD/parlight" crop --hdr "$TMP/p.hdr" --size 128x96 --gt-map 32 --list "$TMP/list.txt" ||
    fail "crop --list"
"${C[@]}" --force --gt-map 32 || fail "crop again"
cmp -s "$TMP/l1.png" "$TMP/c.png" || fail "--list crop differs from a single crop"
[ "$(sed 's/"image":"[^"]*"//' "$TMP/l1.json")" = "$(sed 's/"image":"[^"]*"//' "$TMP/c.json")" ] ||
    fail "--list ground truth differs from a single crop's"
[ -s "$TMP/l2.json" ] || fail "--list: the second crop is missing"
printf '%s\t%s\t40\t10\n' "$TMP/l3.png" "$TMP/l3.json" >"$TMP/bad.txt"
"$BUILD/parlight" crop --hdr "$TMP/p.hdr" --list "$TMP/bad.txt" 2>"$TMP/err" && fail "a 4-field line accepted"
grep -q "bad.txt:1: expected 7 tab-separated fields" "$TMP/err" || fail "no line named: $(cat "$TMP/err")"
"$BUILD/parlight" crop --hdr "$TMP/p.hdr" --list "$TMP/list.txt" 2>"$TMP/err" && fail "--list overwrote"
grep -q "already exists" "$TMP/err" || fail "no reason: $(cat "$TMP/err")"
echo "crop --gt-map: map in the crop's frame, energy kept, bad widths refused; --list: same bytes"
