#!/usr/bin/env bash
# parlight estimate in world space (docs/OUTPUT.md, "World space"): --orientation, --gravity and
# --poses (by frame and by timestamp, with slerp between poses) turn lights, primary, sh9 and
# engine by the camera's pose and say "space":"world"; --at is then in world axes; smoothing
# commutes with a fixed pose. Bad quaternions, poses files and missing poses are refused with a
# message naming the problem, never a silently wrong frame.
# needs: opencv (tests/run.sh skips this test in a build without it)
set -u
cd "$(dirname "$0")/.."
BUILD=${BUILD:-build}
P="$BUILD/parlight"
M=build/models/seeded-n3.plm
PY=/usr/bin/python3
T=${PL_TEST_TMP:-$(mktemp -d)}/world_space
[ -x "$P" ] || { echo "skip: $P not built"; exit 77; }
[ -f "$M" ] || { echo "skip: no $M (make build/models/seeded-n3.plm)"; exit 77; }
rm -rf "$T"
mkdir -p "$T/five"
. "$(dirname "$0")/cli_helpers.sh"
# five frames with distinct, increasing modification times (their t_ns)
i=0
for f in $(ls tests/data/frames/*.jpg | head -n 5); do
    cp "$f" "$T/five/"
    touch -d "@$((1700000000 + 10 * i))" "$T/five/$(basename "$f")"
    i=$((i + 1))
done
est=("$P" estimate --model "$M" --input "$T/five")
expect 0 "" -- "${est[@]}"
cp "$T/out" "$T/cam.jsonl"

# compare A B ROT: every frame of B is frame of A turned by the rotation given per frame
check() {
    $PY - "$@" <<'PYEOF'
import json, math, sys
a = [json.loads(l) for l in open(sys.argv[1])]
b = [json.loads(l) for l in open(sys.argv[2])]
quats = json.loads(sys.argv[3])
assert len(a) == len(b) == len(quats), (len(a), len(b), len(quats))
def rot(q, v):
    w, x, y, z = q
    R = [[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
         [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
         [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]]
    return [sum(R[i][k] * v[k] for k in range(3)) for i in range(3)]
def close(u, v, tol=2e-5):
    return all(abs(p - q) <= tol * max(1.0, abs(q)) for p, q in zip(u, v))
for fa, fb, q in zip(a, b, quats):
    assert fa["space"] == "camera" and fb["space"] == "world", (fa["space"], fb["space"])
    assert close(fb["orientation"], q, 1e-5), (fb["orientation"], q)
    for la, lb in zip(fa["lights"], fb["lights"]):
        assert close(rot(q, la["dir"]), lb["dir"]), (la["dir"], lb["dir"])
        assert la["rgb"] == lb["rgb"] and la["solid_angle_sr"] == lb["solid_angle_sr"]
    assert close(rot(q, fa["primary"]["dir"]), fb["primary"]["dir"])
    assert close(rot(q, fa["engine"]["dir"]), fb["engine"]["dir"])
    # SH band 1 (coefficients 1..3 = y, z, x components) turns like a vector; band 0 stays
    for c in range(3):
        v = [fa["sh9"][3 * 3 + c], fa["sh9"][1 * 3 + c], fa["sh9"][2 * 3 + c]]
        w = [fb["sh9"][3 * 3 + c], fb["sh9"][1 * 3 + c], fb["sh9"][2 * 3 + c]]
        assert close(rot(q, v), w, 1e-4), (rot(q, v), w)
        assert abs(fa["sh9"][c] - fb["sh9"][c]) <= 1e-5 * abs(fa["sh9"][c])
PYEOF
}

# --- a fixed orientation ---
s=$($PY -c 'import math; print(math.sqrt(0.5))')
expect 0 "" -- "${est[@]}" --orientation "$s,0,$s,0"
check "$T/cam.jsonl" "$T/out" "[$(printf "[$s,0,$s,0],%.0s" 1 2 3 4)[$s,0,$s,0]]" &&
    ok "--orientation: 90 deg about y turns lights, primary, engine and sh9" || fail "--orientation"
expect 0 "" -- "${est[@]}" --orientation 1,0,0,0
check "$T/cam.jsonl" "$T/out" "[[1,0,0,0],[1,0,0,0],[1,0,0,0],[1,0,0,0],[1,0,0,0]]" &&
    ok "--orientation 1,0,0,0: world = camera" || fail "identity orientation"

# --- gravity: a camera rolled 90 deg to the left sees gravity along its +x ---
expect 0 "" -- "${est[@]}" --gravity 9.81,0,0
check "$T/cam.jsonl" "$T/out" "[$(printf "[$s,0,0,-$s],%.0s" 1 2 3 4)[$s,0,0,-$s]]" &&
    ok "--gravity 9.81,0,0: camera +x becomes world down" || fail "--gravity"

# --- poses by frame: a different orientation for each frame ---
$PY - "$T/poses.jsonl" <<'PYEOF'
import json, math, sys
with open(sys.argv[1], "w") as f:
    for k in range(5):
        a = k * 0.3
        f.write(json.dumps({"frame": k, "q": [math.cos(a / 2), 0, math.sin(a / 2), 0], "x": 1}) + "\n")
PYEOF
expect 0 "" -- "${est[@]}" --poses "$T/poses.jsonl"
qs=$($PY -c 'import json,sys; print(json.dumps([json.loads(l)["q"] for l in open(sys.argv[1])]))' "$T/poses.jsonl")
check "$T/cam.jsonl" "$T/out" "$qs" && ok "--poses by frame" || fail "--poses by frame"

# --- poses by time: two poses around the frames, slerp between ---
$PY - "$T/cam.jsonl" "$T/tposes.jsonl" "$T/tq.json" <<'PYEOF'
import json, math, sys
t = [json.loads(l)["t_ns"] for l in open(sys.argv[1])]
t0, t1 = t[0] - 10**9, t[-1] + 10**9
with open(sys.argv[2], "w") as f:
    f.write(json.dumps({"t_ns": t0, "q": [1, 0, 0, 0]}) + "\n")
    f.write(json.dumps({"t_ns": t1, "q": [0, 1, 0, 0]}) + "\n")   # half turn about x
qs = []
for ti in t:
    a = math.pi * (ti - t0) / (t1 - t0)
    qs.append([math.cos(a / 2), math.sin(a / 2), 0, 0])
json.dump(qs, open(sys.argv[3], "w"))
PYEOF
expect 0 "" -- "${est[@]}" --poses "$T/tposes.jsonl"
check "$T/cam.jsonl" "$T/out" "$(cat "$T/tq.json")" && ok "--poses by t_ns: slerp between poses" ||
    fail "--poses by t_ns"

# --- smoothing commutes with a fixed pose; --at is in world axes ---
expect 0 "" -- "${est[@]}" --smooth 0.5
cp "$T/out" "$T/cam_smooth.jsonl"
expect 0 "" -- "${est[@]}" --smooth 0.5 --orientation "$s,0,$s,0"
check "$T/cam_smooth.jsonl" "$T/out" "[$(printf "[$s,0,$s,0],%.0s" 1 2 3 4)[$s,0,$s,0]]" &&
    ok "--smooth in world space = the camera's smoothed lights turned" || fail "--smooth world"
# R = 90 deg about y maps camera (x, y, z) to world (z, y, -x): world point (1, 0, -0.5) is
# camera point (0.5, 0, 1)
expect 0 "" -- "${est[@]}" --at 0.5,0,1
cp "$T/out" "$T/cam_at.jsonl"
expect 0 "" -- "${est[@]}" --at 1,0,-0.5 --orientation "$s,0,$s,0"
check "$T/cam_at.jsonl" "$T/out" "[$(printf "[$s,0,$s,0],%.0s" 1 2 3 4)[$s,0,$s,0]]" &&
    ok "--at in world axes" || fail "--at with a pose"

# --- bad input ---
expect 2 "unit quaternion W,X,Y,Z" -- "${est[@]}" --orientation 1,0,0
expect 2 "length 2, expected 1" -- "${est[@]}" --orientation 2,0,0,0
expect 2 "unit quaternion" -- "${est[@]}" --orientation nan,0,0,0
expect 2 "gravity" -- "${est[@]}" --gravity 0,0,0
expect 2 "exclude each other" -- "${est[@]}" --orientation 1,0,0,0 --poses "$T/poses.jsonl"
head -n 3 "$T/poses.jsonl" >"$T/short.jsonl"
expect 1 "short.jsonl: no pose for frame 3" -- "${est[@]}" --poses "$T/short.jsonl"
(sed -n 2p "$T/poses.jsonl"; sed -n 1p "$T/poses.jsonl") >"$T/order.jsonl"
expect 2 "order.jsonl:2: frame 0 comes after 1: keys must increase" -- "${est[@]}" --poses "$T/order.jsonl"
(sed -n 1p "$T/poses.jsonl"; sed -n 2p "$T/tposes.jsonl") >"$T/mixed.jsonl"
expect 2 "mixed.jsonl:2: keyed by t_ns, the lines before by frame" -- "${est[@]}" --poses "$T/mixed.jsonl"
echo '{"frame": 0, "q": [1, 0, 0, 0.5]}' >"$T/nonunit.jsonl"
expect 2 "nonunit.jsonl:1: quaternion .* length 1.118" -- "${est[@]}" --poses "$T/nonunit.jsonl"
echo '{"frame": 0, "q": [1, 0, 0]}' >"$T/three.jsonl"
expect 2 "three.jsonl:1: \"q\" must be an array of 4 numbers" -- "${est[@]}" --poses "$T/three.jsonl"
echo '{"frame": -1, "q": [1, 0, 0, 0]}' >"$T/neg.jsonl"
expect 2 "neg.jsonl:1: \"frame\" must be a non-negative integer" -- "${est[@]}" --poses "$T/neg.jsonl"
echo 'not json' >"$T/junk.jsonl"
expect 2 "junk.jsonl:1" -- "${est[@]}" --poses "$T/junk.jsonl"
: >"$T/empty.jsonl"
expect 2 "empty.jsonl: no poses" -- "${est[@]}" --poses "$T/empty.jsonl"
expect 2 "cannot open poses file" -- "${est[@]}" --poses "$T/missing.jsonl"
$PY -c 'import json,sys; t=[json.loads(l)["t_ns"] for l in open(sys.argv[1])]
print(json.dumps({"t_ns": t[1], "q": [1,0,0,0]})); print(json.dumps({"t_ns": t[1] + 1, "q": [1,0,0,0]}))' \
    "$T/cam.jsonl" >"$T/span.jsonl"
expect 1 "outside the poses' span" -- "${est[@]}" --poses "$T/span.jsonl"
finish
