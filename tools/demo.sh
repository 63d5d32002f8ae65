#!/usr/bin/env bash
# make demo: runs the shipped model (models/parlight-n3.plm and its int8 twin; without them, one
# exported from seeded weights, with a warning) on the shipped sample frames and prints the light
# parameters.
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD=${BUILD:-build}
frames=tests/data/frames
model=models/parlight-n3.plm
if [ ! -f "$model" ]; then
    model=build/models/seeded-n3.plm
    cat >&2 <<MSG

  NOTE: no trained model is shipped yet (models/parlight-n3.plm). This demo runs a model exported
  from SEEDED RANDOM WEIGHTS (tools/export.py --seed 1): the pipeline is real, the network runs
  exactly as it will with trained weights, but the lights it prints are NOT meaningful.

MSG
fi
"$BUILD"/parlight info --model "$model"
echo
echo "== parlight estimate --model $model --input $frames"
"$BUILD"/parlight estimate --model "$model" --input "$frames" | tee "$BUILD/demo.jsonl"
echo
echo "== the same, summarised (frame: primary light direction and colour, ambient)"
/usr/bin/python3 - "$BUILD/demo.jsonl" <<'PY'
import json, sys
for line in open(sys.argv[1]):
    f = json.loads(line)
    p = f["primary"]
    fmt = lambda v: "(" + ", ".join(f"{x:7.3f}" for x in v) + ")"
    print(f'{f["source"]:<48} primary dir {fmt(p["dir"])} rgb {fmt(p["rgb"])} '
          f'ambient {fmt(f["ambient"])}  {f["timing_ms"]["infer"]:.0f} ms')
PY

# the int8 path (docs/QUANT.md): the shipped int8 model beside the shipped float one, else the
# float model quantised here on the sample frames
q=models/parlight-n3-int8.plm
if [ "$model" != models/parlight-n3.plm ] || [ ! -f "$q" ]; then
    q="$BUILD/demo-int8.plm"
    echo
    echo "== parlight quantize --model $model --calib $frames --method percentile --out $q"
    "$BUILD"/parlight quantize --model "$model" --calib "$frames" --method percentile --out "$q" --force
fi
echo
"$BUILD"/parlight info --model "$q"
echo
echo "== parlight estimate --model $q --input $frames (int8)"
"$BUILD"/parlight estimate --model "$q" --input "$frames" | tee "$BUILD/demo-int8.jsonl" | cut -c1-160
echo
echo "== parlight qcheck --float $model --int8 $q --input tests/data/golden-frames"
echo "   (checked on other images than the calibration frames)"
"$BUILD"/parlight qcheck --float "$model" --int8 "$q" --input tests/data/golden-frames --layers 5
