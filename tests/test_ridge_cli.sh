#!/usr/bin/env bash
# Baseline (d) end to end (docs/EVAL.md, "(d) ridge"): tools/train/make_dataset.py makes 6 crops
# of each of the first 2 train/ panoramas of $PL_SHARED/data/hdri with `parlight crop`;
# tools/train/fit_ridge.py fits on them (cross-validation over the 2 panoramas), twice, to the
# same bytes; it refuses a dataset row outside train/ and too few panoramas; `parlight eval
# --ridge` then reports (d) in the JSON (methods, per-crop scores, its estimate) and the text
# table, its estimates equal fit_ridge.py --predict's on the same crops (`parlight crop --batch`),
# the file beside --model is found by default, --ridge none and a broken file are handled; the
# shipped models/parlight-ridge.json was fit on train/ panoramas only and loads.
# Skipped (77) without $PL_SHARED's train panoramas. Model: build/models/seeded-n3.plm.
set -u
cd "$(dirname "$0")/.."
BUILD=${BUILD:-build}
P="$BUILD/parlight"
M=build/models/seeded-n3.plm
PY=/usr/bin/python3
HDRI=${PL_SHARED:-../shared}/data/hdri
T=${PL_TEST_TMP:-$(mktemp -d)}/ridge_cli
[ -x "$P" ] || { echo "skip: $P not built"; exit 77; }
[ -f "$M" ] || { echo "skip: no $M (make build/models/seeded-n3.plm)"; exit 77; }
[ -f "$HDRI/MANIFEST.tsv" ] && [ -d "$HDRI/train" ] ||
    { echo "skip: no train panoramas in $HDRI (set PL_SHARED)"; exit 77; }
rm -rf "$T"
mkdir -p "$T/pano" "$T/m"
EXPECT_TIMEOUT=300
. "$(dirname "$0")/cli_helpers.sh"

expect 0 "" -- "$PY" tools/train/make_dataset.py --out "$T/data" --hdri "$HDRI" --limit 2 \
    --crops-per-pano 6 --gt-map 0 --jobs 2 --parlight "$P" --quiet
[ -f "$T/data/index.tsv" ] || { echo "FAIL: make_dataset.py made no dataset"; exit 1; }

expect 0 "" -- "$PY" tools/train/fit_ridge.py --data "$T/data" --out "$T/r.json" --folds 3
grep -q "2-fold cross-validation" "$T/out" || fail "fit_ridge.py: not 2 folds over 2 panoramas: $(head -1 "$T/out")"
grep -q "chosen lambda" "$T/out" || fail "fit_ridge.py prints no chosen lambda"
cat "$T/out"
expect 0 "" -- "$PY" tools/train/fit_ridge.py --data "$T/data" --out "$T/r2.json"
cmp -s "$T/r.json" "$T/r2.json" || fail "two fits of the same data differ"
expect 1 "exists" -- "$PY" tools/train/fit_ridge.py --data "$T/data" --out "$T/r.json"
"$PY" - "$T/r.json" <<'PY' || fail "the model file lacks a documented field"
import json, sys
d = json.load(open(sys.argv[1]))
f = d["fit"]
assert d["format"] == "parlight-ridge" and d["version"] == 1, d["format"]
assert d["features"]["grid"] == [16, 12] and d["features"]["n"] == 576
assert len(d["weights"]) == 10 and all(len(w) == 576 for w in d["weights"])
assert set(d["lambda"]) == {"dir", "light", "ambient"}
assert d["cv"]["folds"] == 2 and len(f["panoramas"]) == 2 and f["n_crops"] == 12, f
assert all(p.startswith("train/") for p in f["panoramas"]) and f["held_out"] == []
print("ok   model file: lambda", d["lambda"], "CV median angle", d["cv"]["median_angle_deg"])
PY
# refusals: a row outside train/, and nothing left to cross-validate
mkdir -p "$T/evil" && cp -r "$T/data/crops" "$T/evil/" &&
    sed '2s#\ttrain/\([^\t]*\)\t#\teval/\1\t#' "$T/data/index.tsv" >"$T/evil/index.tsv"
expect 1 "not under train/" -- "$PY" tools/train/fit_ridge.py --data "$T/evil" --out "$T/e.json"
expect 1 "needs 2" -- "$PY" tools/train/fit_ridge.py --data "$T/data" --out "$T/v.json" --val-panos 1

# --- parlight eval with (d) ---
pano=$(sed -n 2p "$T/data/index.tsv" | cut -f3)
ln -s "$(cd "$HDRI" && pwd)/$pano" "$T/pano/"
name=$(basename "$pano")
expect 0 "" -- "$P" eval --model "$M" --hdr "$T/pano" --crops 2 --size 16 --ridge "$T/r.json" --json
cp "$T/out" "$T/eval.json"
if "$P" crop --hdr "$T/pano/$name" --batch 2 --out-dir "$T/batch" >/dev/null 2>&1; then
    stem=${name%.*}
    for yaw in 000 180; do
        "$PY" tools/train/fit_ridge.py --predict "$T/r.json" "$T/batch/${stem}_yaw$yaw.png" \
            --gamma 2.2 >"$T/py$yaw.json" || fail "fit_ridge.py --predict failed"
    done
    "$PY" - "$T" "$T/r.json" <<'PY' || fail "eval's (d) JSON is wrong"
import json, math, sys
t, model = sys.argv[1], sys.argv[2]
d = json.load(open(t + "/eval.json"))
err = []
if d.get("ridge", {}).get("file") != model:
    err.append(f"top-level ridge {d.get('ridge')}")
r = d["methods"].get("ridge")
if not r or r["rmse"]["n"] != 2 or r["angle_deg"]["n"] != 2:
    err.append(f"methods.ridge {r}")
p = d["panoramas"][0]
if "ridge" not in p["methods"]:
    err.append("panoramas[0].methods lacks ridge")
for i, yaw in enumerate(("000", "180")):
    c = p["crops"][i]
    if not all(c["ridge"][k] is not None and c["ridge"][k] >= 0 for k in ("rmse", "si_rmse")):
        err.append(f"crop {i}: ridge scores {c['ridge']}")
    want = json.load(open(f"{t}/py{yaw}.json"))
    got = c.get("ridge_estimate")
    def close(a, b):
        return abs(a - b) <= 2e-6 * max(1.0, abs(b))
    ok = got is not None and len(got["lights"]) == 1 and all(
        close(a, b) for key in ("dir", "rgb") for a, b in zip(got["lights"][0][key], want["lights"][0][key])) \
        and close(got["lights"][0]["solid_angle_sr"], want["lights"][0]["solid_angle_sr"]) \
        and all(close(a, b) for a, b in zip(got["ambient"], want["ambient"]))
    if not ok:
        err.append(f"yaw {yaw}: C {got} vs fit_ridge.py {want}")
print("\n".join("FAIL: " + e for e in err) or "ok   eval JSON: (d) scored, its estimates = fit_ridge.py --predict on crop --batch")
sys.exit(1 if err else 0)
PY
else
    fail "parlight crop --batch failed"
fi
expect 0 "" -- "$P" eval --model "$M" --hdr "$T/pano" --crops 1 --size 16 --ridge "$T/r.json"
grep -qE "^  \(d\) ridge +[0-9]" "$T/out" || fail "the text table has no (d) row: $(cat "$T/out")"
# the file beside the model is found without --ridge; --ridge none and no file: not scored
cp "$M" "$T/m/" && cp "$T/r.json" "$T/m/parlight-ridge.json"
expect 0 "" -- "$P" eval --model "$T/m/$(basename "$M")" --hdr "$T/pano" --crops 1 --size 16
grep -qE "^  \(d\) ridge +[0-9]" "$T/out" || fail "parlight-ridge.json beside the model not used"
expect 0 "not scored: --ridge none" -- "$P" eval --model "$T/m/$(basename "$M")" --hdr "$T/pano" --crops 1 --size 16 --ridge none
grep -q "(d) ridge" "$T/out" && fail "--ridge none still prints (d)"
expect 0 "not scored: no parlight-ridge.json" -- "$P" eval --model "$M" --hdr "$T/pano" --crops 1 --size 16 --json
"$PY" -c 'import json,sys; d=json.load(open(sys.argv[1])); sys.exit(0 if d["ridge"] is None and "ridge" not in d["methods"] else 1)' "$T/out" ||
    fail "unscored (d) in the JSON"
# the shipped file: fit on train/ panoramas only, none held out, and the C loader takes it
R=models/parlight-ridge.json
if [ -f "$R" ]; then
    "$PY" - "$R" <<'PY' || fail "$R: not a train/-only fit"
import json, sys
d = json.load(open(sys.argv[1]))
f = d["fit"]
assert f["tool"] == "tools/train/fit_ridge.py" and f["val_panos"] == 0 and f["held_out"] == [], f["tool"]
assert f["panoramas"] and all(p.startswith("train/") for p in f["panoramas"]), "panoramas"
assert f["n_crops"] >= len(f["panoramas"]), "n_crops"
print(f"ok   {sys.argv[1]}: {f['n_crops']} crops of {len(f['panoramas'])} train/ panoramas, "
      f"lambda {d['lambda']}, CV median angle {d['cv']['median_angle_deg']:.1f}")
PY
    expect 0 "" -- "$P" eval --model "$M" --hdr "$T/pano" --crops 1 --size 16 --ridge "$R"
    grep -qE "^  \(d\) ridge +[0-9]" "$T/out" || fail "$R: no (d) row"
else
    fail "$R is not in the repository"
fi
# broken files: exit 1 naming the file and the problem
echo '{"format":"parlight-ridge","version":1}' >"$T/broken.json"
expect 1 "broken.json: missing field features" -- "$P" eval --model "$M" --hdr "$T/pano" --crops 1 --ridge "$T/broken.json"
expect 1 "nofile.json" -- "$P" eval --model "$M" --hdr "$T/pano" --crops 1 --ridge "$T/nofile.json"
echo "not json" >"$T/m/parlight-ridge.json"
expect 1 "parlight-ridge.json" -- "$P" eval --model "$T/m/$(basename "$M")" --hdr "$T/pano" --crops 1

finish
