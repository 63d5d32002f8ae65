#!/usr/bin/env bash
# `parlight estimate --fuse` (docs/OUTPUT.md, "Key light over views"): eight crops of one
# panorama made here (`parlight render` of one light, `parlight crop --batch 8`), read as files
# with a --poses file that turns each by its yaw. Every line gets "key_light", resting on one more
# heading each frame; the last one is the key light recomputed by tests/fuse_ref.py from the
# lines' own world-space lights, and its angle to the panorama's light is the one `parlight eval`
# reports for the same room (eval's crops are crop --batch's: test_eval_cli.sh). --aim 3 turns the
# primary light of the lines with 3 headings or more to the key light and leaves the rest. --level 8
# with each crop's exposure on its poses line brings the line with 8 headings to the room's level
# (the rule fuse_sweeps.py scores) and leaves the rest. With --fuse 1.5
# (frames 1 s apart by their files' times) at most two views count. Bad input: --fuse without --poses, with
# --orientation, a negative or non-numeric age; --aim without --fuse, out of 1..24; --level likewise, and without an exposure for a frame, or a bad
# one. Also tools/train/fuse_sweeps.py on eval's file.
# Model: build/models/seeded-n3.plm (seeded weights: the plumbing is what is tested).
set -u
cd "$(dirname "$0")/.."
BUILD=${BUILD:-build}
P="$BUILD/parlight"
M=build/models/seeded-n3.plm
PY=/usr/bin/python3
T=${PL_TEST_TMP:-$(mktemp -d)}/fuse_cli
[ -x "$P" ] || { echo "skip: $P not built"; exit 77; }
[ -f "$M" ] || { echo "skip: no $M (make build/models/seeded-n3.plm)"; exit 77; }
rm -rf "$T"
mkdir -p "$T/pano" "$T/crops"
. "$(dirname "$0")/cli_helpers.sh"

cat >"$T/one.json" <<'J'
{"lights":[{"dir":[0.5,0.3,-0.6],"distance_m":2,"solid_angle_sr":0.08,"rgb":[300,280,240]}],
 "ambient":[0.25,0.25,0.3]}
J
"$P" render --lights "$T/one.json" --out "$T/pano/one.exr" --width 512 >/dev/null 2>&1 &&
    "$P" crop --hdr "$T/pano/one.exr" --batch 8 --out-dir "$T/crops" >/dev/null 2>&1 ||
    { echo "FAIL: could not make the test panorama and its crops"; exit 1; }
rm -f "$T"/crops/*.json # the crops' ground truth: not frames
[ "$(ls "$T"/crops | wc -l)" -eq 8 ] || { echo "FAIL: expected 8 crops: $(ls "$T/crops")"; exit 1; }
i=0 # modification times 1 s apart: the frames' t_ns, hence the clock --fuse's ages are read on
for f in "$T"/crops/*; do touch -d "@$((1700000000 + i))" "$f"; i=$((i + 1)); done
# frame i is the crop at yaw 45 i (files in name order); its camera-to-world turn is about y by
# -yaw: q = (cos(yaw/2), 0, -sin(yaw/2), 0)
$PY -c 'import json, math
for i in range(8):
    a = math.radians(45 * i)
    print(json.dumps({"frame": i, "q": [math.cos(a / 2), 0, -math.sin(a / 2), 0]}))' >"$T/poses.jsonl"

est=("$P" estimate --model "$M" --input "$T/crops" --poses "$T/poses.jsonl")
expect 0 "" -- "${est[@]}" --fuse 0
cp "$T/out" "$T/fused.jsonl"
expect 0 "" -- "$P" eval --model "$M" --hdr "$T/pano" --crops 8 --size 32 --json --ridge none
cp "$T/out" "$T/eval.json"
$PY - "$T/fused.jsonl" "$T/eval.json" <<'PY' && ok "key_light: 1..8 views, the reference's direction, eval's angle" || fail "key_light"
import json, sys
sys.path.insert(0, "tests")
from fuse_ref import key_light, angle_deg
lines = [json.loads(l) for l in open(sys.argv[1])]
ev = json.load(open(sys.argv[2]))
assert len(lines) == 8, len(lines)
views = {}
for i, d in enumerate(lines):
    assert d["space"] == "world", d["space"]
    k = d["key_light"]
    views[i] = d["lights"]  # one heading each (45 degrees apart)
    want = key_light(views)
    assert k["views"] == len([v for v in views.values() if v]), (i, k)
    a = angle_deg(k["dir"], want)
    assert a < 0.01, f"frame {i}: key light {k['dir']} is {a:.4f} deg from the reference {want}"
truth = [0.5, 0.3, -0.6]
got = angle_deg(lines[-1]["key_light"]["dir"], truth)
want = ev["panoramas"][0]["key_light_angle_deg"]["model"]
assert abs(got - want) < 0.5, f"estimate's key light is {got:.3f} deg from the light, eval says {want}"
print(f"last key light {got:.2f} deg from the panorama's light (eval: {want:.2f})")
PY
# tools/train/fuse_sweeps.py (the model card's sweep table) on the same eval file: its one sweep
# of all 8 views is eval's key light angle, its single-frame figure the crops' median angle
expect 0 "" -- $PY tools/train/fuse_sweeps.py "$T/eval.json" --views 8,3 --json
$PY - "$T/out" "$T/eval.json" <<'PY' && ok "fuse_sweeps.py: 8 views = eval's key light, 3 views = 8 sweeps" ||
import json, statistics, sys
r = {row["views"]: row for row in json.load(open(sys.argv[1]))["rows"]}
p = json.load(open(sys.argv[2]))["panoramas"][0]
assert abs(r[8]["fused_median_deg"] - p["key_light_angle_deg"]["model"]) < 1e-3, (r[8], p["key_light_angle_deg"])
single = statistics.median(c["model"]["angle_deg"] for c in p["crops"])
assert r[8]["sweeps"] == 1 and abs(r[8]["single_median_deg"] - single) < 1e-9, r[8]
assert r[3]["sweeps"] == 8 and 0 <= r[3]["fused_closer"] <= 8, r[3]
PY
    fail "fuse_sweeps.py: $(head -c 300 "$T/out")"
# its intensity over views, by hand: two crops, total energies 2 and 1 at the same exposure, so
# the room's intensity is 2^0.5 and the crops take factors 2^-0.5 and 2^0.5; with si 0, render
# RMS 1 and alpha = those factors, their RMSE falls from |1 - alpha| to 0
$PY - "$T/hand.json" <<'PY'
import json, math, sys
sys.path.insert(0, "tests")
from fuse_ref import sg_integral
def crop(yaw, e, ev):  # total energy e: one light of 1 sr, no ambient
    return {"yaw_deg": yaw, "exposure_scale": 0.5,
            "model": {"rmse": abs(1 - 2 ** ev), "si_rmse": 0, "scale_ev": ev, "render_rms": 1, "angle_deg": 90},
            "estimate": {"lights": [{"dir": [0, 1, 0], "distance_m": 2, "solid_angle_sr": 1,
                                     "rgb": [e / sg_integral(1)] * 3}], "ambient": [0, 0, 0]},
            "ground_truth": {"lights": [{"dir": [0, 1, 0], "distance_m": 2, "solid_angle_sr": 1, "rgb": [1, 1, 1]}],
                             "ambient": [0, 0, 0]}}
json.dump({"panoramas": [{"file": "hand", "crops": [crop(0, 2, -0.5), crop(180, 1, 0.5)]}]},
          open(sys.argv[1], "w"))
PY
expect 0 "" -- $PY tools/train/fuse_sweeps.py "$T/hand.json" --views 2,1 --json
$PY - "$T/out" <<'PY' && ok "fuse_sweeps.py: intensity over views, by hand (0.293 -> 0; one view: unchanged)" ||
import json, sys
r = {row["views"]: row for row in json.load(open(sys.argv[1]))["rows"]}
assert abs(r[2]["rmse_own_median"] - (1 - 2 ** -0.5 + 2 ** 0.5 - 1) / 2) < 1e-12, r[2]
assert abs(r[2]["rmse_views_median"]) < 1e-12 and r[2]["rooms_rmse_lower"] == 1, r[2]
assert r[1]["rmse_views_median"] == r[1]["rmse_own_median"] and r[1]["rooms_rmse_lower"] == 0, r[1]
PY
    fail "fuse_sweeps.py intensity: $(head -c 400 "$T/out")"
expect 1 "fewer than 9 views" -- $PY tools/train/fuse_sweeps.py "$T/eval.json" --views 9
expect 1 "No such file" -- $PY tools/train/fuse_sweeps.py "$T/none.json"

# a short memory: frames 1 s apart, so 1.5 s keeps the newest two views
expect 0 "" -- "${est[@]}" --fuse 1.5
$PY -c 'import json, sys
v = [json.loads(l)["key_light"]["views"] for l in open(sys.argv[1])]
sys.exit(0 if v == [1, 2, 2, 2, 2, 2, 2, 2] else (print(v) or 1))' "$T/out" &&
    ok "--fuse 1.5: views 1, then 2" || fail "--fuse 1.5 views: $(head -c 300 "$T/out")"
# --aim 3: from the third heading on, each line's primary light points along its key light and
# nothing else of the lighting moves; before it the lines are --fuse's own
expect 0 "" -- "${est[@]}" --fuse 0 --aim 3
$PY - "$T/out" "$T/fused.jsonl" <<'PY' && ok "--aim 3: primary along key_light from 3 views, the rest as --fuse" ||
import json, sys
aimed = [json.loads(l) for l in open(sys.argv[1])]
plain = [json.loads(l) for l in open(sys.argv[2])]
assert len(aimed) == len(plain) == 8
n_moved = 0
def close(a, b, tol=1e-6):
    return all(abs(x - y) <= tol * max(1, abs(y)) for x, y in zip(a, b))
for i, (a, p) in enumerate(zip(aimed, plain)):
    assert a["key_light"] == p["key_light"], (i, a["key_light"], p["key_light"])
    if a["key_light"]["views"] < 3:
        for f in ("lights", "ambient", "primary", "sh9", "engine"):
            assert a[f] == p[f], (i, f)
        continue
    k = a["key_light"]["dir"]
    assert close(a["primary"]["dir"], k), (i, a["primary"]["dir"], k)
    assert close(a["engine"]["dir"], k), (i, a["engine"]["dir"], k)
    moved = [j for j, (la, lp) in enumerate(zip(a["lights"], p["lights"])) if la != lp]
    assert len(moved) <= 1, (i, moved)
    n_moved += len(moved)
    for j in moved:
        la, lp = a["lights"][j], p["lights"][j]
        assert close(la["dir"], k) and la["rgb"] == lp["rgb"] and la["solid_angle_sr"] == lp["solid_angle_sr"], (i, la, lp)
        assert a["sh9"] != p["sh9"], f"frame {i}: the light moved, its sh9 did not"
    assert a["ambient"] == p["ambient"] and a["primary"]["rgb"] == p["primary"]["rgb"], i
assert n_moved >= 3, f"the primary light moved in only {n_moved} of the aimed frames"
print("aimed from frame", next(i for i, a in enumerate(aimed) if a["key_light"]["views"] >= 3), "moved in", n_moved)
PY
    fail "--aim 3: $(head -c 300 "$T/out")"
# --level 8: the poses lines carry each crop's exposure (eval's exposure_scale of the same crop:
# what crop multiplied the panorama by; the first four said to be 4x brighter, as if the camera
# had exposed them longer). The line with 8 headings is brought to the room's level, 2^(mean over
# the views of log2(energy / exposure)) x its own exposure, by one factor (the intensity over
# views that tools/train/fuse_sweeps.py scores); the lines before it are --fuse's own.
$PY - "$T/eval.json" >"$T/poses-x.jsonl" <<'PY'
import json, math, sys
cs = sorted(json.load(open(sys.argv[1]))["panoramas"][0]["crops"], key=lambda c: c["yaw_deg"])
for i, c in enumerate(cs):
    a = math.radians(45 * i)
    print(json.dumps({"frame": i, "q": [math.cos(a / 2), 0, -math.sin(a / 2), 0],
                      "exposure": c["exposure_scale"] * (4 if i < 4 else 1)}))
PY
lvl=("$P" estimate --model "$M" --input "$T/crops" --poses "$T/poses-x.jsonl")
expect 0 "" -- "${lvl[@]}" --fuse 0 --level 8
$PY - "$T/out" "$T/fused.jsonl" "$T/eval.json" "$T/poses-x.jsonl" <<'PY' && ok "--level 8: the 8th line at the room's level, one factor, the rest as --fuse" ||
import json, math, sys
sys.path.insert(0, "tests")
from fuse_ref import lum, sg_integral
lev = [json.loads(l) for l in open(sys.argv[1])]
plain = [json.loads(l) for l in open(sys.argv[2])]
cs = sorted(json.load(open(sys.argv[3]))["panoramas"][0]["crops"], key=lambda c: c["yaw_deg"])
assert len(lev) == len(plain) == len(cs) == 8
def energy(L):
    return (sum(lum(l["rgb"]) * sg_integral(l["solid_angle_sr"]) for l in L["lights"]) +
            4 * math.pi * lum(L["ambient"]))
for i in range(7):
    for f in ("lights", "ambient", "primary", "sh9", "engine", "key_light"):
        assert lev[i][f] == plain[i][f], (i, f)
k = [json.loads(l)["exposure"] for l in open(sys.argv[4])]
# the eval file's estimates are the same crops' (its crops are crop --batch's)
r = [math.log2(energy(c["estimate"]) / k[i]) for i, c in enumerate(cs)]
assert all(abs(energy(p) / energy(c["estimate"]) - 1) < 1e-5 for p, c in zip(plain, cs))
mean = sum(r) / 8
c = 2 ** (mean - r[7])  # fuse_sweeps.py's factor for frame 7 over the full turn
a, p = lev[7], plain[7]
assert abs(energy(a) / (2 ** mean * k[7]) - 1) < 1e-4, (energy(a), 2 ** mean * k[7])
for la, lp in zip(a["lights"], p["lights"]):
    assert la["dir"] == lp["dir"] and la["solid_angle_sr"] == lp["solid_angle_sr"], (la, lp)
    assert all(abs(x - c * y) <= 1e-5 * c * y + 1e-30 for x, y in zip(la["rgb"], lp["rgb"])), (la, lp, c)
assert all(abs(x - c * y) <= 1e-5 * c * y + 1e-30 for x, y in zip(a["ambient"], p["ambient"]))
assert abs(c - 1) > 0.01, f"factor {c}: the test says nothing"
print(f"factor {c:.4f} on frame 7")
PY
    fail "--level 8: $(head -c 300 "$T/out")"
# poses keyed by time: frame 1 (t 1 s) lies between lines at 0 s (exposure 1) and 2 s (exposure
# 4), so it gets the slerp's heading (45 degrees) and the exposure's log midpoint, 2; with
# --level 1 its energy is then 2^(mean of log2(E0 / 1), log2(E1 / 2)) x 2
$PY -c 'import json, math
for i, x in ((0, 1), (2, 4)):
    a = math.radians(45 * i)
    print(json.dumps({"t_ns": (1700000000 + i) * 10**9, "q": [math.cos(a / 2), 0, -math.sin(a / 2), 0],
                      "exposure": x}))' >"$T/poses-t.jsonl"
expect 0 "" -- "$P" estimate --model "$M" --input "$T/crops" --poses "$T/poses-t.jsonl" --fuse 0 \
    --level 1 --n-frames 3
$PY - "$T/out" "$T/fused.jsonl" <<'PY' && ok "--level by time: the exposure interpolated in log (2 between 1 and 4)" ||
import json, math, sys
sys.path.insert(0, "tests")
from fuse_ref import lum, sg_integral
lev = [json.loads(l) for l in open(sys.argv[1])]
plain = [json.loads(l) for l in open(sys.argv[2])]
def energy(L):
    return (sum(lum(l["rgb"]) * sg_integral(l["solid_angle_sr"]) for l in L["lights"]) +
            4 * math.pi * lum(L["ambient"]))
e = [energy(p) for p in plain[:2]]
want = 2 ** ((math.log2(e[0] / 1) + math.log2(e[1] / 2)) / 2) * 2
assert len(lev) == 3 and lev[1]["key_light"]["views"] == 2, lev
assert abs(energy(lev[1]) / want - 1) < 1e-4, (energy(lev[1]), want)
PY
    fail "--level by time: $(head -c 300 "$T/out")"
# without --fuse, no key_light
expect 0 "" -- "${est[@]}"
grep -q key_light "$T/out" && fail "key_light without --fuse"

# --- bad input ---
expect 2 "--fuse needs the camera's heading in every frame: --poses FILE" -- \
    "$P" estimate --model "$M" --input "$T/crops" --fuse 0
expect 2 "--fuse needs" -- "$P" estimate --model "$M" --input "$T/crops" --orientation 1,0,0,0 --fuse 0
expect 2 "--fuse" -- "${est[@]}" --fuse -1
expect 2 "--fuse" -- "${est[@]}" --fuse soon
expect 2 "--fuse" -- "${est[@]}" --fuse nan
expect 2 "--aim turns the lights to the fused key light: it needs --fuse MAX_AGE" -- \
    "${est[@]}" --aim 3
expect 2 "--aim" -- "${est[@]}" --fuse 0 --aim 0
expect 2 "--aim" -- "${est[@]}" --fuse 0 --aim 25
expect 2 "--aim" -- "${est[@]}" --fuse 0 --aim three
expect 2 "--level brings the lights to the room's level over views: it needs --fuse" -- \
    "${lvl[@]}" --level 8
expect 2 "--level" -- "${lvl[@]}" --fuse 0 --level 0
expect 2 "--level" -- "${lvl[@]}" --fuse 0 --level 25
expect 2 "--level" -- "${lvl[@]}" --fuse 0 --level all
expect 1 "--level needs the frame's \"exposure\": .*poses.jsonl has none for frame 0" -- \
    "${est[@]}" --fuse 0 --level 3
head -n 3 "$T/poses-x.jsonl" >"$T/poses-x3.jsonl"
sed -n 4p "$T/poses.jsonl" >>"$T/poses-x3.jsonl"
expect 1 "has none for frame 3" -- "${lvl[@]/poses-x.jsonl/poses-x3.jsonl}" --fuse 0 --level 2
for bad in -1 0 '"bright"' null 1e999; do
    sed "2s/\"exposure\": [^}]*/\"exposure\": $bad/" "$T/poses-x.jsonl" >"$T/poses-bad.jsonl"
    want='poses-bad.jsonl:2: "exposure" must be a number > 0'
    [ "$bad" = 1e999 ] && want='poses-bad.jsonl:2: .*within double range'
    expect 2 "$want" -- "${lvl[@]/poses-x.jsonl/poses-bad.jsonl}" --fuse 0 --level 8
done
finish
