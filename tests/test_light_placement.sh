#!/usr/bin/env bash
# tools/train/light_placement.py, where a model's lights point against the true primary light, on
# hand-made `parlight eval --json` rows whose answers are worked out below: an estimate equal to
# the ground truth (every angle 0, the closest light always ranked first, the other-room control
# not 0), the same lights with the energies turned round (the closest light always last, the
# primary 90 deg off, best of N still 0), one answer for every crop (fixed slots; the control
# equals the answer), and refusals of a non-eval JSON, of rows without lights and of a light
# without its solid angle, naming the problem. No build needed.
# Env: PL_TEST_TMP (tests/run.sh). Exit 0 pass, 1 fail.
set -u
cd "$(dirname "$0")/.."
PY=/usr/bin/python3
L=tools/train/light_placement.py
T=${PL_TEST_TMP:-$(mktemp -d)}/light_placement
rm -rf "$T"
mkdir -p "$T"
fail() { echo "FAIL: $*"; exit 1; }

# 3 panoramas x 4 crops; panorama k's lights along +-x, +-y, +-z (sign (-1)^k), the first the
# brightest (rgb 3 against 2 and 1, the same solid angle)
"$PY" - "$T" <<'PY' || fail "could not write the hand-made files"
import json, sys
t = sys.argv[1]
def lights(k, rgbs):
    s = -1.0 if k % 2 else 1.0
    dirs = ([s, 0, 0], [0, s, 0], [0, 0, s])
    return [{"dir": d, "solid_angle_sr": 0.5, "rgb": [v, v, v], "distance_m": 1.0}
            for d, v in zip(dirs, rgbs)]
def f(rgbs_est, row="estimate"):
    pans = []
    for k in range(3):
        crops = [{"yaw_deg": 90 * j, "ground_truth": {"lights": lights(k, (3, 2, 1)), "ambient": [0, 0, 0]},
                  row: {"lights": lights(k, rgbs_est), "ambient": [0, 0, 0]}} for j in range(4)]
        pans.append({"file": f"p{k}.hdr", "crops": crops})
    return {"panoramas": pans}
json.dump(f((3, 2, 1)), open(f"{t}/same.json", "w"))
json.dump(f((1, 2, 3)), open(f"{t}/turned.json", "w"))
json.dump(f((3, 2, 1), row="other"), open(f"{t}/norow.json", "w"))
# every crop answers panorama 0's lights: fixed slots, and the other-room control is the answer
fixed = f((3, 2, 1))
for p in fixed["panoramas"]:
    for c in p["crops"]:
        c["estimate"] = {"lights": lights(0, (3, 2, 1)), "ambient": [0, 0, 0]}
json.dump(fixed, open(f"{t}/fixed.json", "w"))
json.dump({"lights": []}, open(f"{t}/lights.json", "w"))
bad = f((3, 2, 1))
del bad["panoramas"][1]["crops"][2]["estimate"]["lights"][0]["solid_angle_sr"]
json.dump(bad, open(f"{t}/bad.json", "w"))
PY

"$PY" "$L" "$T/same.json" "$T/turned.json" "$T/fixed.json" --json --draws 50 >"$T/out.json" 2>"$T/err" ||
    fail "light_placement: $(cat "$T/err")"
"$PY" - "$T/out.json" <<'PY' || fail "wrong figures: $(cat "$T/out.json")"
import json, sys
same, turned, fixed = [json.loads(l) for l in open(sys.argv[1])]
assert same["crops"] == 12 and turned["crops"] == 12, "crops"
assert same["primary_deg"] == 0 and same["best_of_n_deg"] == 0, "same: angles"
assert same["best_within_45"] == 12 and same["closest_rank"] == [12, 0, 0], "same: rank"
# another panorama's lights point the other way along the same axes: best of N 90 (k and k+1)
# or 0 (k and k+2), primary 180 or 0; never all 0
o = same["other_room"]
assert o["best_of_n_deg"] > 0 and o["draws"] == 50, "same: other room"
assert abs(turned["primary_deg"] - 90) < 1e-9, "turned: primary 90"
assert turned["best_of_n_deg"] == 0 and turned["closest_rank"] == [0, 0, 12], "turned: rank"
# same: light 1 alternates +x / -x over the panoramas (8 crops +x, 4 -x): mean (1/3, 0, 0), so
# the median angle to it is 0; fixed: every slot exactly in place, and another room's answer is
# this crop's answer
sl = same["slots"][0]
assert abs(sl["resultant"] - 1 / 3) < 1e-9 and sl["mean_dir"] == [1.0, 0.0, 0.0], "same: slot 1"
assert all(d["median_angle_deg"] == 0 and abs(d["resultant"] - 1) < 1e-9 for d in fixed["slots"]), "fixed: slots"
fo = fixed["other_room"]
assert fo["best_of_n_deg"] == fixed["best_of_n_deg"] and fo["primary_deg"] == fixed["primary_deg"], "fixed: control"
# panorama 1's primary is -x: 4 crops at 180 deg (best of N 90, its closest light the 2nd)
assert fixed["primary_deg"] == 0 and fixed["best_of_n_deg"] == 0, "fixed: angles"
assert fixed["closest_rank"] == [8, 4, 0] and fixed["best_within_45"] == 8, "fixed: rank"
PY
"$PY" "$L" "$T/same.json" --draws 20 >"$T/txt" 2>"$T/err" || fail "text output: $(cat "$T/err")"
grep -q "the closest light is the estimate's #1 in 12, #2 in 0, #3 in 0 crops" "$T/txt" ||
    fail "text output: $(cat "$T/txt")"
echo "ok  an exact estimate, the same lights ranked the wrong way round, and the other-room control"

"$PY" "$L" "$T/lights.json" >/dev/null 2>"$T/err" && fail "a non-eval JSON was accepted"
grep -q "lights.json: not .parlight eval --json. output" "$T/err" || fail "non-eval JSON: $(cat "$T/err")"
"$PY" "$L" "$T/norow.json" >/dev/null 2>"$T/err" && fail "rows without estimate lights were accepted"
grep -q "has no 'estimate' or 'ground_truth' lights" "$T/err" || fail "no estimate: $(cat "$T/err")"
"$PY" "$L" "$T/bad.json" >/dev/null 2>"$T/err" && fail "a light without a solid angle was accepted"
grep -q "bad.json: a crop of p1.hdr: malformed lights (KeyError: 'solid_angle_sr')" "$T/err" ||
    fail "malformed light: $(cat "$T/err")"
"$PY" "$L" "$T/missing.json" >/dev/null 2>"$T/err" && fail "a missing file was accepted"
grep -q "missing.json: No such file" "$T/err" || fail "missing file: $(cat "$T/err")"
echo "ok  a non-eval JSON, rows without lights, a malformed light and a missing file refused, naming the problem"
