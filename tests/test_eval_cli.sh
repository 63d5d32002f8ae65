#!/usr/bin/env bash
# `parlight eval` end to end (docs/EVAL.md): on a panorama made here with `parlight render` from one
# strong light (its extracted lights, baseline (c), must beat the mean-ambient baseline (a) by far),
# with a file that is not a panorama beside it (reported, counted, skipped); the JSON's shape; the
# same numbers with 1 and 2 threads; the key light and the model aimed at it (estimate --aim) per
# room, brought to the room's level (estimate --level: its RMSE the exact one at the level's
# factor) and both; the text table and --per-pano; bad inputs (exit 1 or 2 with
# a message naming the problem). Then 2 crops of 2 panoramas of ../shared/data/hdri/eval when it
# is there (that part is skipped without it). Model: build/models/seeded-n3.plm (seeded weights:
# the model's numbers mean nothing, the plumbing is what is tested).
set -u
cd "$(dirname "$0")/.."
BUILD=${BUILD:-build}
P="$BUILD/parlight"
M=build/models/seeded-n3.plm
PY=/usr/bin/python3
T=${PL_TEST_TMP:-$(mktemp -d)}/eval_cli
[ -x "$P" ] || { echo "skip: $P not built"; exit 77; }
[ -f "$M" ] || { echo "skip: no $M (make build/models/seeded-n3.plm)"; exit 77; }
rm -rf "$T"
mkdir -p "$T/synth" "$T/empty" "$T/junk"
. "$(dirname "$0")/cli_helpers.sh"

# --- a panorama with one strong light above and to the right, and a dim ambient ---
cat >"$T/one.json" <<'J'
{"lights":[{"dir":[0.4,0.6,-0.7],"distance_m":2,"solid_angle_sr":0.08,"rgb":[300,280,240]}],
 "ambient":[0.25,0.25,0.3]}
J
"$P" render --lights "$T/one.json" --out "$T/synth/one.exr" --width 512 >/dev/null 2>&1 ||
    { echo "FAIL: parlight render could not make the test panorama"; exit 1; }
echo "not a panorama" >"$T/synth/notes.txt"

# check_json FILE N_PANOS N_CROPS N_SKIPPED: the documented shape (docs/EVAL.md)
check_json() {
    "$PY" - "$@" <<'PY'
import json, math, sys
path, n_pano, n_crops, n_skip = sys.argv[1], *map(int, sys.argv[2:5])
d = json.load(open(path))
err = []
def need(c, msg):
    if not c: err.append(msg)
methods = ["model", "ambient", "brightest", "gt_lights"]
need(d.get("n_panoramas") == n_pano, f"n_panoramas {d.get('n_panoramas')}, want {n_pano}")
need(d.get("n_crops") == n_pano * n_crops, f"n_crops {d.get('n_crops')}")
need(d.get("n_skipped") == n_skip and len(d.get("skipped", [])) == n_skip, f"skipped {d.get('skipped')}")
need(d.get("crops_per_panorama") == n_crops, "crops_per_panorama")
need(d.get("precision") in ("fp32", "int8"), "precision")
def stats_ok(m, where):
    for k in ("rmse", "si_rmse"):
        s = m.get(k, {})
        ok = all(isinstance(s.get(q), (int, float)) for q in ("median", "q1", "q3"))
        need(ok and s["q1"] <= s["median"] <= s["q3"] and s["q1"] >= 0, f"{where}.{k} = {s}")
    need("median" in m.get("angle_deg", {}), f"{where}.angle_deg")
    need("median" in m.get("scale_ev", {}), f"{where}.scale_ev")
for m in methods:
    stats_ok(d["methods"].get(m, {}), "methods." + m)
need(len(d.get("panoramas", [])) == n_pano, "panoramas rows")
for p in d.get("panoramas", []):
    for m in methods:
        stats_ok(p["methods"].get(m, {}), p["file"] + "." + m)
    need(len(p.get("crops", [])) == n_crops, p["file"] + " crops")
    for c in p.get("crops", []):
        need(c["exposure_scale"] > 0 and all(c[m]["rmse"] >= 0 for m in methods), f"crop {c}")
# (c), the extracted lights, is the representation's ceiling: far better than a flat ambient
a, c = d["methods"]["ambient"], d["methods"]["gt_lights"]
need(c["rmse"]["median"] < 0.5 * a["rmse"]["median"],
     f"(c) rmse {c['rmse']['median']} does not beat (a) {a['rmse']['median']}")
need(c["angle_deg"]["median"] < 1e-3, "(c) angle")
need(abs(c["scale_ev"]["median"]) < 0.25, f"(c) scale EV {c['scale_ev']['median']}: not near 0")
# primary_in_view per crop, and angle_by_view: the angle medians of the crops of each kind
flags = [c.get("primary_in_view", "absent") for p in d["panoramas"] for c in p["crops"]]
need(all(f in (True, False, None) for f in flags), f"primary_in_view flags {flags}")
abv = d.get("angle_by_view", {})
for key, want in (("in_view", True), ("out_of_view", False)):
    sel = [c for p in d["panoramas"] for c in p["crops"] if c.get("primary_in_view") is want]
    need(abv.get(key, {}).get("crops") == len(sel), f"angle_by_view.{key}.crops {abv.get(key)}")
    for m in methods:
        v = sorted(c[m]["angle_deg"] for c in sel if c[m]["angle_deg"] is not None)
        med = (v[len(v) // 2] if len(v) % 2 else 0.5 * (v[len(v) // 2 - 1] + v[len(v) // 2])) if v else None
        got = abv.get(key, {}).get(m, {}).get("median")
        need((med is None and got is None) or (med is not None and got is not None and abs(got - med) < 1e-3),
             f"angle_by_view.{key}.{m} median {got}, the crops say {med}")
# the key light over each room's views (light/fuse.h), recomputed from the crops' estimates
# and yaws by tests/fuse_ref.py (the same rule written again in Python)
sys.path.insert(0, "tests")
from fuse_ref import key_light as fused, angle_deg, yaw_to_world, energy
def key_light(crops):
    k = fused({round(c["yaw_deg"] / 45) % 8: [dict(l, dir=yaw_to_world(c["yaw_deg"], l["dir"]))
                                           for l in c["estimate"]["lights"]] for c in crops})
    gt = crops[0]["ground_truth"]["lights"]
    if k is None or not gt: return None
    return angle_deg(k, yaw_to_world(crops[0]["yaw_deg"], max(gt, key=energy)["dir"]))
kl = d.get("key_light_over_views", {})
need(kl.get("rooms") == n_pano and kl.get("views") == n_crops, f"key_light_over_views {kl}")
mine = []
for p in d.get("panoramas", []):
    got = p.get("key_light_angle_deg", {}).get("model", "absent")
    want = key_light(p["crops"])
    mine.append(want)
    need((got is None and want is None) or (isinstance(got, (int, float)) and want is not None and abs(got - want) < 0.05),
         f"{p['file']}: key light angle {got}, recomputed {want}")
v = sorted(x for x in mine if x is not None)
med = (v[len(v) // 2] if len(v) % 2 else 0.5 * (v[len(v) // 2 - 1] + v[len(v) // 2])) if v else None
got = kl.get("model", {}).get("fused_angle_deg", {}).get("median")
need((med is None and got is None) or (got is not None and abs(got - med) < 0.05), f"fused median {got}, recomputed {med}")
# the model aimed at each room's key light (estimate --aim): its primary IS the key light, so
# every crop's aimed angle is the room's key-light angle; the statistics are its crops'
def median(v):
    v = sorted(x for x in v if x is not None)
    return (v[len(v) // 2] if len(v) % 2 else 0.5 * (v[len(v) // 2 - 1] + v[len(v) // 2])) if v else None
# brought to the room's level (estimate --level, each crop's exposure scale as its exposure): one
# factor c = 2^(mean_i log2(E_i / k_i) - log2(E / k)) per crop, so its rendered RMSE is the one
# docs/EVAL.md's identity gives at c from the crop's own scores, and its si-RMSE is unchanged
import math
def lum(c):
    return 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]
def energy(L):
    def sg(sr):
        s = sr / (4 * math.pi)
        return 2 * math.pi * s * -math.expm1(-2 / s)
    return sum(lum(l["rgb"]) * sg(l["solid_angle_sr"]) for l in L["lights"]) + 4 * math.pi * lum(L["ambient"])
def close(x, y, tol=2e-4):
    return x is not None and y is not None and abs(x - y) <= tol * max(1e-3, abs(y))
lower = {v: [0, 0] for v in ("aimed", "leveled", "aimed_leveled")}
for p in d.get("panoramas", []):
    ka = p.get("key_light_angle_deg", {}).get("model")
    r = [math.log2(energy(cr["estimate"]) / cr["exposure_scale"]) for cr in p["crops"]]
    mean = sum(r) / len(r)
    for cr, ri in zip(p["crops"], r):
        a_ = cr.get("key_aimed", {})
        need(all(k in a_ for k in ("rmse", "si_rmse", "angle_deg", "scale_ev", "render_rms")), f"crop key_aimed {a_}")
        need(ka is None or (a_.get("angle_deg") is not None and abs(a_["angle_deg"] - ka) < 0.05),
             f"{p['file']} yaw {cr['yaw_deg']}: aimed angle {a_.get('angle_deg')}, key light angle {ka}")
        fac = 2 ** (mean - ri)
        for own, v in ((cr["model"], "key_leveled"), (a_, "key_aimed_leveled")):
            lv = cr.get(v, {})
            want = math.sqrt(own["si_rmse"] ** 2 + (fac - 2 ** own["scale_ev"]) ** 2 * own["render_rms"] ** 2)
            need(close(lv.get("rmse"), want) and close(lv.get("si_rmse"), own["si_rmse"]) and
                 close(lv.get("angle_deg"), own["angle_deg"]),
                 f"{p['file']} yaw {cr['yaw_deg']}: {v} {lv}, want rmse {want} (factor {fac})")
    for v in lower:
        key = "key_" + v
        for q, k in enumerate(("rmse", "si_rmse")):
            got, want = p.get(key, {}).get(k, {}).get("median"), median(cr[key][k] for cr in p["crops"])
            need(got is not None and abs(got - want) <= 1e-5 * max(1, want), f"{p['file']} {key}.{k} {got}, crops say {want}")
            lower[v][q] += want < median(cr["model"][k] for cr in p["crops"]) * (1 - 1e-6)
m = kl.get("model", {})
for v in lower:
    for q, k in enumerate(("rmse", "si_rmse")):
        got, want = m.get(f"{v}_{k}", {}).get("median"), median(cr["key_" + v][k] for p in d["panoramas"] for cr in p["crops"])
        need(got is not None and abs(got - want) <= 1e-5 * max(1, want), f"{v}_{k} {got}, crops say {want}")
        need(m.get(f"rooms_{v}_{k}_lower") == lower[v][q], f"rooms_{v}_{k}_lower {m.get(f'rooms_{v}_{k}_lower')}, crops say {lower[v][q]}")
print("\n".join("FAIL: " + e for e in err) or f"ok   JSON shape of {path}: (a) rmse {a['rmse']['median']:.4g}, (c) rmse {c['rmse']['median']:.4g}")
sys.exit(1 if err else 0)
PY
}

expect 0 "1 file skipped" -- "$P" eval --model "$M" --hdr "$T/synth" --crops 2 --size 32 --json --threads 2
cp "$T/out" "$T/synth2.json"
grep -q "skipping notes.txt" "$T/err" || fail "notes.txt was not reported as skipped"
check_json "$T/synth2.json" 1 2 1 || fails=$((fails + 1))
"$PY" -c 'import json,sys; d=json.load(open(sys.argv[1])); c=d["panoramas"][0]["crops"][0]["gt_lights"]; a=d["panoramas"][0]["crops"][0]["ambient"]; sys.exit(0 if c["si_rmse"] < 0.2*a["si_rmse"] else 1)' "$T/synth2.json" ||
    fail "(c) si-rmse is not far below (a) on the one-light panorama"
expect 0 "" -- "$P" eval --model "$M" --hdr "$T/synth" --crops 2 --size 32 --json --threads 1
cmp -s "$T/out" "$T/synth2.json" || fail "--threads 1 and --threads 2 give different JSON"
# the crops, estimates and ground truth are those of `crop --batch` + `estimate`, to the last digit
if "$P" crop --hdr "$T/synth/one.exr" --batch 2 --out-dir "$T/batch" >/dev/null 2>&1 &&
    "$P" estimate --model "$M" --input "$T/batch/one_yaw000.png" >"$T/est0.json" 2>/dev/null &&
    "$P" estimate --model "$M" --input "$T/batch/one_yaw180.png" >"$T/est1.json" 2>/dev/null; then
    "$PY" - "$T" <<'PY' || fail "eval's crops differ from crop --batch + estimate"
import json, sys
t = sys.argv[1]
crops = json.load(open(t + "/synth2.json"))["panoramas"][0]["crops"]
bad = 0
for i, yaw in enumerate(("000", "180")):
    est = json.load(open(f"{t}/est{i}.json"))
    gt = json.load(open(f"{t}/batch/one_yaw{yaw}.json"))
    c = crops[i]
    if c["estimate"] != {"lights": est["lights"], "ambient": est["ambient"]}:
        print(f"yaw {yaw}: estimate {c['estimate']} vs parlight estimate {est['lights']}"); bad = 1
    if c["ground_truth"] != {"lights": gt["lights"], "ambient": gt["ambient"]} or \
            c["exposure_scale"] != gt["exposure_scale"]:
        print(f"yaw {yaw}: ground truth {c['ground_truth']} vs crop --gt {gt['lights']}"); bad = 1
    # brightest_estimate is the lighting (b) was scored with: its light's angle to the truth's
    # primary (most energy) is (b)'s angle_deg
    sys.path.insert(0, "tests")
    from fuse_ref import angle_deg, energy
    b = c["brightest_estimate"]["lights"]
    a = angle_deg(b[0]["dir"], max(gt["lights"], key=energy)["dir"]) if len(b) == 1 else None
    if a is None or abs(a - c["brightest"]["angle_deg"]) > 1e-3:
        print(f"yaw {yaw}: brightest_estimate {b}: angle {a} vs (b)'s {c['brightest']['angle_deg']}"); bad = 1
print("ok   estimates, (b)'s lights and ground truth = crop --batch + estimate" if not bad else "")
sys.exit(bad)
PY
else
    fail "parlight crop --batch / estimate failed on the test panorama"
fi

# --- where the primary light is: a light just right of straight ahead is in view of the yaw-0
# crop (x/-z 0.1 against tan 30 = 0.58) and behind the yaw-180 one ---
mkdir -p "$T/front"
cat >"$T/front.json" <<'J'
{"lights":[{"dir":[0.1,0.05,-1],"distance_m":2,"solid_angle_sr":0.05,"rgb":[400,380,350]}],
 "ambient":[0.2,0.2,0.2]}
J
"$P" render --lights "$T/front.json" --out "$T/front/front.exr" --width 256 >/dev/null 2>&1 ||
    fail "parlight render could not make the light-ahead panorama"
expect 0 "" -- "$P" eval --model "$M" --hdr "$T/front" --crops 2 --size 16 --json
check_json "$T/out" 1 2 0 || fails=$((fails + 1))
"$PY" -c 'import json,sys; d=json.load(open(sys.argv[1])); f=[c["primary_in_view"] for c in d["panoramas"][0]["crops"]]; a=d["angle_by_view"]; sys.exit(0 if f == [True, False] and a["in_view"]["crops"] == 1 and a["out_of_view"]["crops"] == 1 and a["in_view"]["brightest"]["median"] < 5 else 1)' "$T/out" ||
    fail "light ahead: primary_in_view is not [true, false], or (b) does not find the light in view"
expect 0 "" -- "$P" eval --model "$M" --hdr "$T/front" --crops 2 --size 16
grep -qE "angle deg, primary light +in view \(1 crop\) +out of view \(1 crop\)" "$T/out" ||
    fail "text output lacks the angle-by-view table"

expect 0 "" -- "$P" eval --model "$M" --hdr "$T/synth" --crops 1 --size 16 --per-pano
for w in "rmse median" "^  model " "\(a\) mean ambient" "\(b\) brightest" "\(c\) gt lights" "^one.exr" \
    "^  key light, 1 room " "^  own  " "^  aimed at the key light .*[0-9], [0-9] of 1\$" \
    "^  at the room's level .* of 1\$" "^  aimed \+ the room's level .* of 1\$"; do
    grep -qE -- "$w" "$T/out" || fail "text output lacks /$w/"
done

# --- bad inputs ---
echo "not a model" >"$T/bad.plm"
echo "x" >"$T/junk/a.txt"
expect 1 "cannot open" -- "$P" eval --model "$M" --hdr "$T/missing"
expect 1 "no files" -- "$P" eval --model "$M" --hdr "$T/empty"
expect 1 "no usable panorama.*1 file skipped" -- "$P" eval --model "$M" --hdr "$T/junk"
expect 1 "bad.plm" -- "$P" eval --model "$T/bad.plm" --hdr "$T/synth"
expect 1 "missing.plm" -- "$P" eval --model "$T/missing.plm" --hdr "$T/synth"
expect 2 "--model" -- "$P" eval --hdr "$T/synth"
expect 2 "--hdr" -- "$P" eval --model "$M"
expect 2 "--crops" -- "$P" eval --model "$M" --hdr "$T/synth" --crops 0
expect 2 "--size" -- "$P" eval --model "$M" --hdr "$T/synth" --size 4
expect 2 "--threads" -- "$P" eval --model "$M" --hdr "$T/synth" --threads x
expect 2 "unknown option" -- "$P" eval --model "$M" --hdr "$T/synth" --frobnicate
expect 2 "needs a value" -- "$P" eval --model "$M" --hdr
expect 2 "unexpected argument" -- "$P" eval --model "$M" --hdr "$T/synth" extra
expect 0 "" -- "$P" eval --help
grep -q -- "--per-pano" "$T/out" || fail "eval --help lacks --per-pano"

# --- 2 crops of 2 real panoramas, when ../shared is there ---
E=${PL_SHARED:-../shared}/data/hdri/eval
if [ -d "$E" ]; then
    mkdir -p "$T/real"
    for f in lebombo.hdr st_fagans_interior.hdr; do
        [ -f "$E/$f" ] && ln -sf "$(cd "$E" && pwd)/$f" "$T/real/$f"
    done
    if [ "$(ls "$T/real" | wc -l)" -eq 2 ]; then
        expect 0 "2 panoramas, 4 crops" -- "$P" eval --model "$M" --hdr "$T/real" --crops 2 --size 32 --json --threads 2
        cp "$T/out" "$T/real.json"
        check_json "$T/real.json" 2 2 0 || fails=$((fails + 1))
    else
        echo "skip (part): lebombo.hdr / st_fagans_interior.hdr missing from $E"
    fi
else
    echo "skip (part): no $E"
fi

finish
echo "all eval CLI checks passed"
