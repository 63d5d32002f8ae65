#!/usr/bin/env bash
# The Python side of the model file: tools/plm.py (writer/reader self-test, corruption detection),
# tools/export.py (fold check, byte-identical seeded exports, read-back with every tensor of
# docs/FORMAT.md in shape, refusal to overwrite, --force, checkpoint export = seeded export,
# clear failures on bad arguments). Uses a small 64x96 input to stay fast.
# Env: PL_TEST_TMP (set by tests/run.sh). Exit 0 pass, 1 fail, 77 skip.
set -u
cd "$(dirname "$0")/.."
PY=/usr/bin/python3
TMP=${PL_TEST_TMP:-$(mktemp -d)}/export
mkdir -p "$TMP"

if ! "$PY" -c 'import torch, torchvision, numpy' 2>/dev/null; then
    echo "skip: $PY lacks torch/torchvision/numpy (tools/install-deps.sh installs them)"
    exit 77
fi
fail() { echo "FAIL: $*"; exit 1; }
EXPORT=("$PY" tools/export.py --input 64x96)

"$PY" tools/plm.py || fail "tools/plm.py self-test"

"${EXPORT[@]}" --n-lights 2 --seed 7 --out "$TMP/a.plm" --check || fail "export --check"
"${EXPORT[@]}" --n-lights 2 --seed 7 --out "$TMP/b.plm" >/dev/null || fail "second export"
cmp -s "$TMP/a.plm" "$TMP/b.plm" || fail "two exports with seed 7 differ"
echo "seeded export is byte-identical across runs"

# Refuses to overwrite (exit 1, file untouched); --force replaces.
"${EXPORT[@]}" --n-lights 2 --seed 8 --out "$TMP/a.plm" >"$TMP/refuse.log" 2>&1
[ $? -eq 1 ] || fail "export over an existing file did not exit 1"
grep -q "exists" "$TMP/refuse.log" || fail "no 'exists' in: $(cat "$TMP/refuse.log")"
cmp -s "$TMP/a.plm" "$TMP/b.plm" || fail "refused export still changed the file"
"${EXPORT[@]}" --n-lights 2 --seed 8 --out "$TMP/b.plm" --force >/dev/null || fail "--force"
cmp -s "$TMP/a.plm" "$TMP/b.plm" && fail "seed 8 wrote the same file as seed 7"
echo "overwrite refused without --force, done with it"

# Bad arguments fail with a message, before any work.
"${EXPORT[@]}" --n-lights 4 --seed 1 --out "$TMP/x.plm" 2>/dev/null && fail "accepted N=4"
"$PY" tools/export.py --input 100x96 --n-lights 3 --seed 1 --out "$TMP/x.plm" 2>/dev/null &&
    fail "accepted input 100x96"
"${EXPORT[@]}" --n-lights 3 --seed 1 --out "$TMP/no/such/dir/x.plm" 2>/dev/null &&
    fail "wrote into a missing folder"
[ -e "$TMP/x.plm" ] && fail "a failed export left $TMP/x.plm"

# Read back with the validating reader; every tensor of docs/FORMAT.md present, in shape and
# order; metadata as documented; a checkpoint of the same seeded model exports the same tensors.
"$PY" - "$TMP" <<'EOF' || fail "read-back / checkpoint checks"
import os, subprocess, sys
sys.path.insert(0, "tools")
import numpy as np, torch
import export, plm
tmp = sys.argv[1]
meta, tensors, info = plm.read_plm(f"{tmp}/a.plm")
want = export.expected_shapes(2, 64)
assert list(tensors) == list(want), "tensor names or order differ from expected_shapes"
for k, shape in want.items():
    assert tensors[k].shape == shape and tensors[k].dtype == np.float32, (k, tensors[k].shape)
for k, v in {"arch": "densenet121-parametric", "precision": "fp32", "n_lights": "2",
             "input_h": "64", "input_w": "96", "mean": "0.485,0.456,0.406",
             "std": "0.229,0.224,0.225", "bands": "3", "fc": "512", "dist_hidden": "64",
             "created_by": "tools/export.py"}.items():
    assert meta.get(k) == v, (k, meta.get(k), v)
assert "seed 7" in meta["provenance"], meta["provenance"]
assert all(e["offset"] % 64 == 0 for e in info["entries"].values())
print(f"read back {len(tensors)} tensors, {info['file_size']} bytes, crc {info['crc32']:08x}")

# A BN really got folded: conv1.bias exists and differs from zero.
assert np.abs(tensors["denseblock1.denselayer1.conv1.bias"]).max() > 1e-3

model = export.build_seeded(2, 7, (64, 96))
torch.save({"state_dict": model.state_dict()}, f"{tmp}/ck.pt")
subprocess.run([sys.executable, "tools/export.py", "--input", "64x96", "--n-lights", "2",
                "--state-dict", f"{tmp}/ck.pt", "--out", f"{tmp}/ck.plm"], check=True,
               stdout=subprocess.DEVNULL)
meta2, t2, _ = plm.read_plm(f"{tmp}/ck.plm")
assert all(np.array_equal(tensors[k], t2[k]) for k in want), "checkpoint export differs"
assert "checkpoint ck.pt sha256" in meta2["provenance"], meta2["provenance"]
r = subprocess.run([sys.executable, "tools/export.py", "--input", "64x96", "--n-lights", "3",
                    "--state-dict", f"{tmp}/ck.pt", "--out", f"{tmp}/ck3.plm"],
                   capture_output=True, text=True)
assert r.returncode == 1 and "2 lights" in r.stderr, (r.returncode, r.stderr)
print("checkpoint export matches the seeded export; wrong N rejected")

# Corruptions the C loader must also reject are rejected by the reader.
data = open(f"{tmp}/a.plm", "rb").read()
for pos in (0, 8, 16, 56, 64, info["table_offset"] + 70, info["data_offset"] + 5, len(data) - 1):
    bad = bytearray(data); bad[pos] ^= 0x10
    try:
        plm.decode_plm(bytes(bad)); raise AssertionError(f"corruption at {pos} accepted")
    except plm.PlmError:
        pass
print("corruptions rejected")

# golden.py refuses frames that are not exactly the model input (no resize may differ).
import golden
from PIL import Image
Image.new("RGB", (255, 192)).save(f"{tmp}/small.png")
try:
    golden.read_frame(f"{tmp}/small.png", 192, 256); raise AssertionError("255x192 frame accepted")
except ValueError as e:
    assert "255x192" in str(e), e
print("golden.py refuses a frame of the wrong size")
EOF
echo "export: ok"
