#!/usr/bin/env bash
# tools/train/compare_evals.py, the paired comparison of two `parlight eval --json` files:
# its counts, median effects and pooled medians on a hand-made pair whose answers are worked out
# below (also with a null angle, split by eval's primary_in_view flags, and the key light over
# each room's views); a model against
# itself (every effect 0, interval [0, 0]) and two models on real
# `parlight eval --json` output of rendered panoramas (so a change of eval's JSON breaks this
# test); files of different crops, non-eval JSON and a missing file refused with a message.
# Models: build/models/seeded-n3*.plm (seeded: the numbers mean nothing, the pairing is tested).
# Env: BUILD, PL_TEST_TMP (tests/run.sh). Exit 0 pass, 1 fail, 77 skip.
set -u
cd "$(dirname "$0")/.."
BUILD=${BUILD:-build}
P="$BUILD/parlight"
PY=/usr/bin/python3
C=tools/train/compare_evals.py
T=${PL_TEST_TMP:-$(mktemp -d)}/compare_evals
rm -rf "$T"
mkdir -p "$T/panos"
fail() { echo "FAIL: $*"; exit 1; }

# --- hand-made: 2 panoramas x 2 crops -------------------------------------------------------
# A: rmse 1 1 1 1, si 0.1 0.2 0.3 0.4, angle 10 20 30 40
# B: rmse 0.5 2 1 1 -> lower 1, higher 1, log ratios -ln2 ln2 0 0: median 0
#    si 0.05 0.2 0.6 0.2 -> lower 2, higher 1, log ratios -ln2 0 ln2 -ln2: median -ln2/2
#    angle 0 20 50 40 -> lower 1, higher 1, differences -10 0 20 0: median 0
#    pooled si medians: A 0.25, B 0.2
"$PY" - "$T" <<'PY' || fail "could not write the hand-made files"
import json, sys
def f(rmse, si, ang, yaws=(0, 45), view=None):
    pan = []
    for i, name in enumerate(("p1.hdr", "p2.hdr")):
        crops = [{"yaw_deg": yaws[j], "exposure_scale": 1.0,
                  "model": {"rmse": rmse[2 * i + j], "si_rmse": si[2 * i + j], "angle_deg": ang[2 * i + j]}}
                 for j in range(2)]
        for j, c in enumerate(crops):
            if view:
                c["primary_in_view"] = view[2 * i + j]
        pan.append({"file": name, "crops": crops})
    return {"panoramas": pan}
t = sys.argv[1]
json.dump(f([1, 1, 1, 1], [0.1, 0.2, 0.3, 0.4], [10, 20, 30, 40]), open(f"{t}/a.json", "w"))
json.dump(f([0.5, 2, 1, 1], [0.05, 0.2, 0.6, 0.2], [0, 20, 50, 40]), open(f"{t}/b.json", "w"))
json.dump(f([1, 1, 1, 1], [0.1, 0.2, 0.3, 0.4], [10, 20, 30, 40], yaws=(0, 90)), open(f"{t}/c.json", "w"))
# B with its third angle null (eval writes null for a crop whose panorama has no light)
json.dump(f([0.5, 2, 1, 1], [0.05, 0.2, 0.6, 0.2], [0, 20, None, 40]), open(f"{t}/n.json", "w"))
# B with two answers past 90 deg and one at exactly 45: tail over 90 A 0 -> B 2, within 45 4 -> 1
json.dump(f([1, 1, 1, 1], [0.1, 0.2, 0.3, 0.4], [100, 45, 95, 60]), open(f"{t}/t.json", "w"))
# the same pair with eval's primary_in_view flags: crops 1 and 4 in view (angle differences -10
# and 0: median -5), 2 and 3 out of view (0 and +20: median +10); and B with other flags
V = [True, False, False, True]
json.dump(f([1, 1, 1, 1], [0.1, 0.2, 0.3, 0.4], [10, 20, 30, 40], view=V), open(f"{t}/av.json", "w"))
json.dump(f([0.5, 2, 1, 1], [0.05, 0.2, 0.6, 0.2], [0, 20, 50, 40], view=V), open(f"{t}/bv.json", "w"))
json.dump(f([0.5, 2, 1, 1], [0.05, 0.2, 0.6, 0.2], [0, 20, 50, 40], view=[not v for v in V]), open(f"{t}/bw.json", "w"))
PY
"$PY" "$C" "$T/a.json" "$T/b.json" --json >"$T/ab.json" 2>"$T/err" || fail "compare: $(cat "$T/err")"
"$PY" - "$T/ab.json" <<'PY' || fail "hand-made pair: wrong figures ($(cat "$T/ab.json"))"
import json, math, sys
r = json.load(open(sys.argv[1]))["scores"]
want = {"rmse": (1, 1, 0.0, 1.0, 1.0), "si_rmse": (2, 1, -math.log(2) / 2, 0.25, 0.2),
        "angle_deg": (1, 1, 0.0, 25.0, 30.0)}
ok = True
for s, (lo, hi, eff, ma, mb) in want.items():
    v = r[s]
    got = (v["b_lower"], v["b_higher"], v["median_effect"], v["median_a"], v["median_b"])
    if got[:2] != (lo, hi) or any(abs(g - w) > 1e-9 for g, w in zip(got[2:], (eff, ma, mb))):
        print(f"{s}: got {got}, want {(lo, hi, eff, ma, mb)}")
        ok = False
    if not (v["ci95"][0] <= v["median_effect"] <= v["ci95"][1]):
        print(f"{s}: the median effect {v['median_effect']} is outside its interval {v['ci95']}")
        ok = False
sys.exit(0 if ok else 1)
PY
# null left out: differences -10 0 (none) 0 -> lower 1, higher 0, median 0; B's pooled angle
# median of 0 20 40 is 20
"$PY" "$C" "$T/a.json" "$T/n.json" --json >"$T/an.json" 2>"$T/err" ||
    fail "a null angle was refused: $(cat "$T/err")"
"$PY" - "$T/an.json" <<'PY' || fail "null angle: wrong figures ($(cat "$T/an.json"))"
import json, sys
v = json.load(open(sys.argv[1]))["scores"]["angle_deg"]
got = (v["b_lower"], v["b_higher"], v["median_effect"], v["median_a"], v["median_b"])
print(got)
sys.exit(0 if got == (1, 0, 0.0, 25.0, 20.0) else 1)
PY
"$PY" "$C" "$T/av.json" "$T/bv.json" --json >"$T/abv.json" 2>"$T/err" || fail "compare with flags: $(cat "$T/err")"
"$PY" - "$T/abv.json" <<'PY' || fail "angle by view: wrong figures ($(cat "$T/abv.json"))"
import json, sys
r = json.load(open(sys.argv[1]))["scores"]
got = {k: (r[k]["crops"], r[k]["panoramas"], r[k]["median_effect"], r[k]["median_a"], r[k]["median_b"])
       for k in ("angle_deg in view", "angle_deg out of view")}
want = {"angle_deg in view": (2, 2, -5.0, 25.0, 20.0), "angle_deg out of view": (2, 2, 10.0, 25.0, 35.0)}
print(got)
sys.exit(0 if got == want and r["angle_deg"]["median_effect"] == 0.0 else 1)
PY
"$PY" "$C" "$T/av.json" "$T/bv.json" >"$T/out" 2>"$T/err" || fail "table with flags: $(cat "$T/err")"
grep -q "angle_deg out of view (2 crops of 2 panoramas)" "$T/out" || fail "table lacks the out-of-view row: $(cat "$T/out")"
"$PY" "$C" "$T/a.json" "$T/b.json" >"$T/out" 2>"$T/err" || fail "table: $(cat "$T/err")"
grep -q "in view" "$T/out" && fail "files without flags got an in-view row"
"$PY" "$C" "$T/a.json" "$T/bv.json" >"$T/out" 2>"$T/err" || fail "one file with flags: $(cat "$T/err")"
grep -q "in view" "$T/out" && fail "a file without flags got an in-view row"
"$PY" "$C" "$T/av.json" "$T/bw.json" >"$T/out" 2>"$T/err" && fail "files whose flags disagree were compared"
grep -q "disagree on which crops have the primary light in view" "$T/err" || fail "disagreeing flags: $(cat "$T/err")"
"$PY" "$C" "$T/a.json" "$T/t.json" --json >"$T/at.json" 2>"$T/err" || fail "tail pair: $(cat "$T/err")"
"$PY" - "$T/at.json" "$T/an.json" <<'PY' || fail "angle tail: wrong counts ($(cat "$T/at.json"))"
import json, sys
t = json.load(open(sys.argv[1]))["angle_tail"]
n = json.load(open(sys.argv[2]))["angle_tail"]   # B's null angle counts in neither
print(t, n)
sys.exit(0 if t == {"over_90": [0, 2], "within_45": [4, 1]} and n == {"over_90": [0, 0], "within_45": [4, 3]} else 1)
PY
"$PY" "$C" "$T/a.json" "$T/t.json" >"$T/out" 2>"$T/err" || fail "tail table: $(cat "$T/err")"
grep -q "angle tail: crops over 90 deg 0 -> 2, within 45 deg 4 -> 1" "$T/out" ||
    fail "table lacks the tail line: $(cat "$T/out")"
# the key light over each room's views: A 40 and 70, B 30 and 80 -> B closer in 1, farther in 1,
# medians over rooms 55 -> 55; one file without the member: no key-light figures; a B null: 1 room
"$PY" - "$T" <<'PY' || fail "could not write the key-light files"
import json, sys
t = sys.argv[1]
for src, dst, keys in (("a", "ka", (40, 70)), ("b", "kb", (30, 80)), ("b", "kn", (None, 80)),
                       ("b", "kx", ("far", 80))):
    d = json.load(open(f"{t}/{src}.json"))
    for p, k in zip(d["panoramas"], keys):
        p["key_light_angle_deg"] = {"model": k}
    json.dump(d, open(f"{t}/{dst}.json", "w"))
PY
"$PY" "$C" "$T/ka.json" "$T/kb.json" --json >"$T/kab.json" 2>"$T/err" || fail "key-light pair: $(cat "$T/err")"
"$PY" "$C" "$T/ka.json" "$T/kn.json" --json >"$T/kan.json" 2>"$T/err" || fail "key-light null: $(cat "$T/err")"
"$PY" "$C" "$T/ka.json" "$T/b.json" --json >"$T/kaa.json" 2>"$T/err" || fail "one without: $(cat "$T/err")"
"$PY" - "$T/kab.json" "$T/kan.json" "$T/kaa.json" <<'PY' || fail "key light: wrong figures ($(cat "$T/kab.json" "$T/kan.json"))"
import json, sys
k, n, none = (json.load(open(p)) for p in sys.argv[1:4])
want = {"rooms": 2, "b_closer": 1, "b_farther": 1, "median_a": 55.0, "median_b": 55.0}
wantn = {"rooms": 1, "b_closer": 0, "b_farther": 1, "median_a": 70.0, "median_b": 80.0}
print(k.get("key_light"), n.get("key_light"))
sys.exit(0 if k.get("key_light") == want and n.get("key_light") == wantn and "key_light" not in none
         and k["per_panorama"][0]["key_light_angle_deg"] == [40, 30] else 1)
PY
"$PY" "$C" "$T/ka.json" "$T/kb.json" >"$T/out" 2>"$T/err" || fail "key-light table: $(cat "$T/err")"
grep -q "key light over each room's views (deg): B closer in 1, farther in 1 of 2 rooms; median over rooms 55 -> 55" "$T/out" ||
    fail "table lacks the key-light line: $(cat "$T/out")"
"$PY" "$C" "$T/ka.json" "$T/kx.json" >"$T/out" 2>"$T/err" && fail "a key light that is not a number was compared"
grep -q "key_light_angle_deg 'far' is not a number" "$T/err" || fail "bad key light: $(cat "$T/err")"
echo "ok  hand-made pair: counts, median effects and pooled medians as worked out, nulls left out, angle split by view, tail counts, key light over views"
"$PY" "$C" "$T/a.json" "$T/c.json" >"$T/out" 2>"$T/err" && fail "different yaws were compared"
grep -q "p1.hdr: .*score different crops" "$T/err" || fail "different crops: $(cat "$T/err")"
echo '{"lights": []}' >"$T/lights.json"
"$PY" "$C" "$T/a.json" "$T/lights.json" >"$T/out" 2>"$T/err" && fail "a lights file was compared"
grep -q "lights.json: not .parlight eval --json. output" "$T/err" || fail "non-eval JSON: $(cat "$T/err")"
"$PY" "$C" "$T/a.json" "$T/missing.json" >"$T/out" 2>"$T/err" && fail "a missing file was compared"
grep -q "missing.json" "$T/err" || fail "missing file: $(cat "$T/err")"
echo "ok  different crops, non-eval JSON and a missing file refused, naming the problem"

# --- real parlight eval output ---------------------------------------------------------------
M1=build/models/seeded-n3.plm
M2=build/models/seeded-n3-96x128.plm
{ [ -x "$P" ] && [ -f "$M1" ] && [ -f "$M2" ]; } ||
    { echo "skip: $P or the seeded models are not built (make test builds them)"; exit 77; }
echo '{"lights":[{"dir":[0.4,0.6,-0.7],"distance_m":2,"solid_angle_sr":0.08,"rgb":[300,280,240]}],"ambient":[0.25,0.25,0.3]}' >"$T/L1.json"
echo '{"lights":[{"dir":[-0.8,0.2,0.5],"distance_m":3,"solid_angle_sr":0.2,"rgb":[50,60,80]}],"ambient":[0.1,0.1,0.1]}' >"$T/L2.json"
for i in 1 2; do
    "$P" render --lights "$T/L$i.json" --out "$T/panos/room$i.exr" --width 256 >/dev/null 2>&1 ||
        fail "render room$i"
done
for m in 1 2; do
    M=$M1; [ $m -eq 2 ] && M=$M2
    "$P" eval --model "$M" --hdr "$T/panos" --crops 3 --json --ridge none >"$T/e$m.json" 2>"$T/err" ||
        fail "eval $M: $(cat "$T/err")"
done
"$P" eval --model "$M1" --hdr "$T/panos" --crops 2 --json --ridge none >"$T/e3.json" 2>"$T/err" ||
    fail "eval --crops 2: $(cat "$T/err")"
"$PY" "$C" "$T/e1.json" "$T/e1.json" --json >"$T/self.json" 2>"$T/err" || fail "self: $(cat "$T/err")"
"$PY" - "$T/self.json" <<'PY' || fail "a model against itself: not all zero ($(cat "$T/self.json"))"
import json, sys
r = json.load(open(sys.argv[1]))
assert r["crops"] == 6 and r["panoramas"] == 2, r
for s, v in r["scores"].items():
    assert v["b_lower"] == 0 and v["b_higher"] == 0, (s, v)
    assert v["median_effect"] == 0 and v["ci95"] == [0, 0], (s, v)
    assert v["median_a"] == v["median_b"], (s, v)
PY
"$PY" "$C" "$T/e1.json" "$T/e2.json" >"$T/table" 2>"$T/err" || fail "two models: $(cat "$T/err")"
grep -q "^6 crops of 2 panoramas" "$T/table" || fail "two models: $(cat "$T/table")"
grep -q "room2.exr" "$T/table" || fail "two models: no per-panorama rows: $(cat "$T/table")"
"$PY" "$C" "$T/e1.json" "$T/e3.json" >"$T/out" 2>"$T/err" && fail "--crops 3 and --crops 2 were compared"
grep -q "score different crops" "$T/err" || fail "--crops 3 against 2: $(cat "$T/err")"
echo "ok  real eval output: a model against itself is all zero, two models pair crop for crop," \
    "--crops 3 against --crops 2 refused"
