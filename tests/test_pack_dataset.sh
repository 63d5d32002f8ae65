#!/usr/bin/env bash
# tools/train/pack_dataset.py (docs/TRAINING.md, "Training on a remote GPU"): a small dataset
# made here (4 crops with lights, ambient and 32x16 radiance maps up to 2e4) packs into crops.zip,
# gt.json.xz, maps.npy.xz, index.tsv and encoder.pt.xz; unpacked, every ground truth is the
# original but for the maps (log1p within float16's rounding), every crop within WebP's loss of
# its PNG, the encoder its float16 rounding; train.py loads the unpacked folder and runs a step;
# a non-empty --out, a pack with a crop missing from its zip, a corrupt zip and --init-out
# without an encoder are refused by name. pack-net / unpack-net bring the run's network back as
# float16 parts (the map head left out) that export; a missing part and an existing output are
# refused. tools/train/remote_run.sh runs the recipe from a pack (on the CPU here: two seeds, one
# epoch each) into parts that export, and stops at its budget. Needs no ../shared.
set -u
cd "$(dirname "$0")/.."
PY=/usr/bin/python3
T=${PL_TEST_TMP:-$(mktemp -d)}/pack_dataset
"$PY" -c 'import torch, numpy, PIL' 2>/dev/null || { echo "skip: $PY lacks torch/numpy/PIL"; exit 77; }
rm -rf "$T"
mkdir -p "$T"
EXPECT_TIMEOUT=300
. "$(dirname "$0")/cli_helpers.sh"

"$PY" tests/tiny_dataset.py "$T/data" "$T/enc.pt" || { echo "FAIL: could not make the test dataset"; exit 1; }

PACK=("$PY" tools/train/pack_dataset.py)
expect 0 "packed 4 crops" -- "${PACK[@]}" pack --data "$T/data" --out "$T/pack" --init "$T/enc.pt"
for f in crops.zip gt.json.xz maps.npy.xz index.tsv encoder.pt.xz; do
    [ -f "$T/pack/$f" ] || fail "pack: no $f"
done
[ "$(ls "$T/pack" | wc -l)" -eq 5 ] || fail "pack: expected 5 files, got $(ls "$T/pack" | tr '\n' ' ')"
expect 1 "exists and is not empty" -- "${PACK[@]}" pack --data "$T/data" --out "$T/pack"
expect 1 "quality 0" -- "${PACK[@]}" pack --data "$T/data" --out "$T/p0" --quality 0
expect 0 "unpacked 4 crops" -- "${PACK[@]}" unpack "$T/pack" --out "$T/un" --init-out "$T/enc2.pt"
expect 1 "exists and is not empty" -- "${PACK[@]}" unpack "$T/pack" --out "$T/un"

"$PY" - "$T/data" "$T/un" "$T/enc.pt" "$T/enc2.pt" <<'PY' && ok "unpacked = original within WebP, float16" || fail "unpacked dataset differs"
import json, sys
import numpy as np, torch
from PIL import Image
src, dst, e1, e2 = sys.argv[1:]
rows = [l.rstrip("\n").split("\t") for l in open(dst + "/index.tsv")][1:]
orig = [l.rstrip("\n").split("\t") for l in open(src + "/index.tsv")][1:]
assert [r[2:] for r in rows] == [r[2:] for r in orig] and len(rows) == 4
for (img, js, _, _), (png, ojs, _, _) in zip(rows, orig):
    assert img.endswith(".webp"), img
    a = np.asarray(Image.open(f"{dst}/{img}").convert("RGB"), np.float64)
    b = np.asarray(Image.open(f"{src}/{png}").convert("RGB"), np.float64)
    assert a.shape == b.shape and np.abs(a - b).mean() < 4, (img, np.abs(a - b).mean())
    u, o = json.load(open(f"{dst}/{js}")), json.load(open(f"{src}/{ojs}"))
    mu, mo = (np.array(x["radiance_map"].pop("rgb")) for x in (u, o))
    assert u == o, js
    lu, lo = np.log1p(mu), np.log1p(mo)
    assert np.all(np.abs(lu - lo) <= np.abs(lo) * 2.0 ** -11 + 1e-7), np.abs(lu - lo).max()
    assert mo.max() > 1e3
a, b = torch.load(e1)["model"], torch.load(e2)["model"]
assert set(b) == {"features.conv0.weight", "features.norm0.num_batches_tracked"}, set(b)
w = b["features.conv0.weight"]
assert w.dtype == torch.float32 and torch.equal(w, a["features.conv0.weight"].half().float())
assert torch.equal(b["features.norm0.num_batches_tracked"], torch.tensor(5))
PY

expect 0 "" -- "$PY" tools/train/train.py --data "$T/un" --input 96x128 \
    --batch 2 --step1-epochs 1 --step2-epochs 0 --w-map 1 --threads 1 --max-steps 1 --val-panos 0 \
    --ckpt-dir "$T/run" --log "$T/run.log"
grep -q "stopped at --max-steps 1" "$T/run.log" || fail "train.py on the unpacked set: $(tail -n 2 "$T/run.log")"

# a crop missing from the zip, a corrupt zip, --init-out without an encoder
cp -r "$T/pack" "$T/bad1"
"$PY" - "$T/bad1/crops.zip" <<'PY'
import sys, zipfile
with zipfile.ZipFile(sys.argv[1]) as z:
    keep = [(n, z.read(n)) for n in z.namelist()[1:]]
with zipfile.ZipFile(sys.argv[1], "w") as w:
    for n, d in keep:
        w.writestr(n, d)
PY
expect 1 "crops.zip: no crops/c0.webp" -- "${PACK[@]}" unpack "$T/bad1" --out "$T/u1"
cp -r "$T/pack" "$T/bad2"
head -c 1000 "$T/pack/crops.zip" >"$T/bad2/crops.zip"
expect 1 "bad2/crops.zip: " -- "${PACK[@]}" unpack "$T/bad2" --out "$T/u2"
cp -r "$T/pack" "$T/bad3"
rm "$T/bad3/encoder.pt.xz"
expect 1 "holds no encoder.pt.xz" -- "${PACK[@]}" unpack "$T/bad3" --out "$T/u3" --init-out "$T/e3.pt"
expect 1 "not a make_dataset.py folder" -- "${PACK[@]}" pack --data "$T/pack/crops.zip" --out "$T/p4"
# a network there and back: pack-net / unpack-net of the run's checkpoint, then export
expect 0 "2 parts" -- "${PACK[@]}" pack-net "$T/run/last.pt" "$T/net"
expect 0 "joined 2 parts" -- "${PACK[@]}" unpack-net "$T/net" "$T/net.pt"
"$PY" - "$T/run/last.pt" "$T/net.pt" <<'PY' && ok "unpack-net = the network in float16" || fail "unpack-net differs"
import sys
import torch
a, b = (torch.load(p, weights_only=False) for p in sys.argv[1:])
assert any(k.startswith("aux_map.") for k in a["model"]), "the run had no map head"
want = {k: v for k, v in a["model"].items() if not k.startswith("aux_map.")}
assert set(b["model"]) == set(want) and b["config"] == a["config"]
for k, v in want.items():
    w = v.half().float() if v.is_floating_point() and v.numel() >= 4096 else v
    assert b["model"][k].dtype == v.dtype and torch.equal(b["model"][k], w), k
PY
expect 0 "" -- "$PY" tools/train/train.py --export-only "$T/net.pt" "$T/net.plm"
expect 1 "exists; not replacing it" -- "${PACK[@]}" unpack-net "$T/net" "$T/net.pt"
mv "$T/net.part1" "$T/net1.bak"
expect 1 "not a pack-net network" -- "${PACK[@]}" unpack-net "$T/net" "$T/net2.pt"
expect 1 "nope.part0: no such file" -- "${PACK[@]}" unpack-net "$T/nope" "$T/net3.pt"
# tools/train/remote_run.sh on the CPU: a pack without an encoder (from scratch), two seeds side
# by side, one epoch of each step; the networks come back as parts that unpack and export. Then
# a budget too short: the runs are stopped, the log says so, no parts.
expect 0 "packed 4 crops" -- "${PACK[@]}" pack --data "$T/data" --out "$T/pack2"
R=(env DEVICE=cpu INPUT=96x128 P="$PY" WORK="$T/rw"
   EXTRA="--step1-epochs 1 --step2-epochs 1 --batch 2 --threads 1" tools/train/remote_run.sh "$T/pack2")
expect 0 "" -- "${R[@]}" "$T/rout" 1 2
for s in 1 2; do
    grep -q "seed $s ended with status 0" "$T/rout/logs.txt" || fail "remote_run: seed $s did not finish"
done
expect 0 "joined 2 parts" -- "${PACK[@]}" unpack-net "$T/rout/g2" "$T/r2.pt"
expect 0 "" -- "$PY" tools/train/train.py --export-only "$T/r2.pt" "$T/r2.plm"
rm -rf "$T/rw"
expect 0 "" -- env BUDGET=3 "${R[@]}" "$T/rout3" 1
grep -q "budget reached" "$T/rout3/logs.txt" || fail "remote_run: no budget line"
ls "$T/rout3"/g1.part* >/dev/null 2>&1 && fail "remote_run: parts of a stopped run"
finish
