#!/usr/bin/env bash
# tools/train/probe_z.py end to end (MODEL_CARD.md, "What the encoder knows"): make_dataset.py
# makes 4 crops of each of 3 train/ panoramas; the probe reads their z through build/tools/zdump
# (the seeded 96x128 model), cross-validates over the 3 panoramas, scores the batch crops of a
# fourth folder's panorama, and with `parlight eval --json` of the same model reports the
# network's own median angle exactly as eval's table does; a rerun reuses the cached z and writes
# the same JSON; bad flags, a missing model and an empty panorama folder are refused by name.
# Skipped (77) without $PL_SHARED's train panoramas.
set -u
cd "$(dirname "$0")/.."
BUILD=${BUILD:-build}
P="$BUILD/parlight"
Z="$BUILD/tools/zdump"
M=build/models/seeded-n3-96x128.plm
PY=/usr/bin/python3
HDRI=${PL_SHARED:-../shared}/data/hdri
T=${PL_TEST_TMP:-$(mktemp -d)}/probe_z
[ -x "$P" ] && [ -x "$Z" ] || { echo "skip: $P or $Z not built"; exit 77; }
[ -f "$M" ] || { echo "skip: no $M (make build/models/seeded-n3-96x128.plm)"; exit 77; }
"$PY" -c 'import numpy, PIL' 2>/dev/null || { echo "skip: $PY lacks numpy/PIL"; exit 77; }
[ -f "$HDRI/MANIFEST.tsv" ] && [ -d "$HDRI/train" ] ||
    { echo "skip: no train panoramas in $HDRI (set PL_SHARED)"; exit 77; }
rm -rf "$T"
mkdir -p "$T/score" "$T/empty"
EXPECT_TIMEOUT=300
. "$(dirname "$0")/cli_helpers.sh"

expect 0 "" -- "$PY" tools/train/make_dataset.py --out "$T/data" --hdri "$HDRI" --limit 3 \
    --crops-per-pano 4 --gt-map 0 --jobs 2 --parlight "$P" --quiet
[ -f "$T/data/index.tsv" ] || { echo "FAIL: make_dataset.py made no dataset"; exit 1; }
# the scoring panorama: the last train/ one by name (the test checks the mechanics, not a score)
pano=$(ls "$HDRI/train" | grep -iE '\.(exr|hdr)$' | tail -n 1)
ln -s "$(cd "$HDRI/train" && pwd)/$pano" "$T/score/"

expect 0 "" -- "$P" eval --model "$M" --hdr "$T/score" --crops 2 --size 16 --json --ridge none
cp "$T/out" "$T/eval.json"
PROBE=("$PY" tools/train/probe_z.py --model "$M" --data "$T/data" --score-hdr "$T/score"
       --crops 2 --folds 3 --work "$T/work" --eval-json "$T/eval.json")
expect 0 "" -- "${PROBE[@]}" --json "$T/p1.json"
cat "$T/out"
grep -q "3-fold cross-validation" "$T/out" || fail "not 3 folds over 3 panoramas"
ls "$T/work"/z-train-*.f32 "$T/work"/z-score-*.f32 >/dev/null 2>&1 || fail "no cached z in $T/work"
"$PY" - "$T/p1.json" "$T/eval.json" <<'PY' || fail "the probe's JSON is wrong"
import json, math, sys
p = json.load(open(sys.argv[1]))
e = json.load(open(sys.argv[2]))
assert p["folds"] == 3 and p["panoramas"] == 3 and p["features"] == 3072, p
assert 0 < p["train_crops"] <= 12 and 0 < p["score_crops"] <= 2, p
for k in ("probe_median_angle_deg", "mean_direction_median_angle_deg",
          "straight_up_median_angle_deg", "cv_constant_median_angle_deg",
          "network_median_angle_deg"):
    assert 0 <= p[k] <= 180, (k, p[k])
assert p["lambda"] in (0.01, 0.1, 1.0, 10.0) and len(p["cv_median_angle_deg"]) == 4, p
want = e["methods"]["model"]["angle_deg"]["median"]
assert abs(p["network_median_angle_deg"] - want) < 1e-3, (p["network_median_angle_deg"], want)
# eval's "ambient" baseline answers straight up: the probe's truth is eval's truth
up = e["methods"]["ambient"]["angle_deg"]["median"]
assert abs(p["straight_up_median_angle_deg"] - up) < 0.01, (p["straight_up_median_angle_deg"], up)
print(f"ok   probe JSON: CV {p['cv_median_angle_deg']}, score {p['probe_median_angle_deg']:.1f}, "
      f"network {p['network_median_angle_deg']:.1f} = eval's")
PY
expect 0 "" -- "${PROBE[@]}" --json "$T/p2.json"
cmp -s "$T/p1.json" "$T/p2.json" || fail "a rerun on the cached z gives other figures"

expect 1 "--crops 0" -- "$PY" tools/train/probe_z.py --model "$M" --data "$T/data" \
    --score-hdr "$T/score" --crops 0 --work "$T/work"
expect 1 "no .exr or .hdr panoramas" -- "$PY" tools/train/probe_z.py --model "$M" \
    --data "$T/data" --score-hdr "$T/empty" --crops 2 --folds 3 --work "$T/work"
expect 1 "nomodel.plm" -- "$PY" tools/train/probe_z.py --model "$T/nomodel.plm" \
    --data "$T/data" --score-hdr "$T/score" --crops 2 --work "$T/work2"
finish
