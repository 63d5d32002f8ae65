#!/usr/bin/env bash
# parlight estimate end to end on the sample frames, and on every kind of bad input: each bad case
# must give one clear line on stderr and a non-zero exit, never a crash or a hang.
# needs: opencv (tests/run.sh skips this test in a build without it)
set -u
P="$BUILD/parlight"
M=build/models/seeded-n3.plm
T="$PL_TEST_TMP/cli_estimate"
mkdir -p "$T"
fail() { echo "FAIL: $*"; exit 1; }
[ -f "$M" ] || fail "no $M (make test exports it)"
frame=$(ls tests/data/frames/*.jpg | head -n 1)
[ -n "$frame" ] || fail "no sample frames in tests/data/frames"

# expect_error RC PATTERN CMD...: exit status RC, exactly one stderr line matching PATTERN
expect_error() {
    local want=$1 pat=$2
    shift 2
    timeout 60 "$@" >"$T/out" 2>"$T/err"
    local rc=$?
    [ "$rc" -eq "$want" ] || fail "'$*' exited $rc, expected $want; stderr: $(cat "$T/err")"
    [ "$(wc -l <"$T/err")" -eq 1 ] || fail "'$*' printed $(wc -l <"$T/err") lines on stderr: $(cat "$T/err")"
    grep -qiE -e "$pat" "$T/err" || fail "'$*': stderr '$(cat "$T/err")' does not match '$pat'"
    [ ! -s "$T/out" ] || fail "'$*' printed on stdout"
    echo "ok  rc=$rc  $(cat "$T/err")"
}

# --- good input: one JSON line per frame, every field of docs/OUTPUT.md present and sane ---
"$P" estimate --model "$M" --input tests/data/frames >"$T/all.jsonl" || fail "estimate on the sample frames failed"
n=$(ls tests/data/frames/*.jpg | wc -l)
[ "$(wc -l <"$T/all.jsonl")" -eq "$n" ] || fail "expected $n lines"
/usr/bin/python3 - "$T/all.jsonl" <<'PY' || fail "schema check"
import json, math, sys
for line in open(sys.argv[1]):
    f = json.loads(line)
    for k in ("frame", "t_ns", "source", "lights", "ambient", "primary", "sh9", "engine", "timing_ms",
              "dropped"):
        assert k in f, k
    assert len(f["lights"]) == 3 and len(f["sh9"]) == 27 and len(f["ambient"]) == 3
    for L in f["lights"]:
        assert abs(math.sqrt(sum(x * x for x in L["dir"])) - 1) < 1e-5, L
        assert L["distance_m"] > 0 and L["solid_angle_sr"] > 0 and min(L["rgb"]) >= 0, L
    assert f["source"].startswith("dir:tests/data/frames/"), f["source"]
    e = f["engine"]
    assert e["dir"] == f["primary"]["dir"] and len(e["sh9"]) == 27 and min(e["intensity"]) >= 0, e
    # the probe lost exactly a delta light of that intensity: its L00 drops by I * Y00
    for c in range(3):
        d = f["sh9"][c] - e["sh9"][c] - e["intensity"][c] * 0.28209479
        assert abs(d) <= 1e-4 * max(1.0, abs(f["sh9"][c])), (c, d)
print("schema ok")
PY

# --- results do not depend on the thread count (timing aside) ---
"$P" estimate --model "$M" --input "$frame" --threads 2 >"$T/t2.jsonl" || fail "--threads 2"
"$P" estimate --model "$M" --input "$frame" --threads 1 >"$T/t1.jsonl" || fail "--threads 1"
lights() { sed 's/.*\("lights"\)/\1/; s/"timing_ms".*//' "$1"; }
lights "$T/t1.jsonl" >"$T/a"
lights "$T/t2.jsonl" >"$T/b"
cmp -s "$T/a" <(head -n 1 "$T/all.jsonl" | lights /dev/stdin) || fail "the first frame differs read alone and from its directory"
cmp -s "$T/a" "$T/b" || fail "--threads 2 changes the result"
echo "ok  1 and 2 threads give identical lights"

# --- --n-frames, --at ---
[ "$("$P" estimate --model "$M" --input tests/data/frames --n-frames 1 | wc -l)" -eq 1 ] || fail "--n-frames 1"
"$P" estimate --model "$M" --input "$frame" --at 0.5,0,-1 >"$T/at.jsonl" || fail "--at"
cmp -s <(lights "$T/at.jsonl") "$T/b" && fail "--at changed nothing"
echo "ok  --n-frames and --at"

# --- sinks: the same lines on stdout and over UDP; the temporal filter ---
port_file="$T/udp.port"
/usr/bin/python3 - "$port_file" "$T/udp.jsonl" <<'PY' &
import socket, sys
s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
s.bind(("127.0.0.1", 0)); s.settimeout(20)
open(sys.argv[1] + ".tmp", "w").write(str(s.getsockname()[1]))
import os; os.rename(sys.argv[1] + ".tmp", sys.argv[1])
with open(sys.argv[2], "w") as out:
    for _ in range(5):
        out.write(s.recv(65536).decode())
PY
rx=$!
for _ in $(seq 100); do [ -f "$port_file" ] && break; sleep 0.1; done
"$P" estimate --model "$M" --input tests/data/frames --out stdout --out "udp://127.0.0.1:$(cat "$port_file")" >"$T/both.jsonl" || fail "--out stdout --out udp"
wait $rx || fail "UDP receiver got fewer than 5 datagrams"
cmp -s "$T/both.jsonl" "$T/udp.jsonl" || fail "UDP datagrams differ from the stdout lines"
echo "ok  --out stdout + udp: identical lines"
"$P" estimate --model "$M" --input tests/data/frames --smooth 0.3 >"$T/smooth.jsonl" || fail "--smooth"
/usr/bin/python3 - "$T/all.jsonl" "$T/smooth.jsonl" <<'PY' || fail "--smooth"
import json, sys
raw = [json.loads(l) for l in open(sys.argv[1])]
sm = [json.loads(l) for l in open(sys.argv[2])]
assert len(raw) == len(sm) == 5
assert sm[0]["ambient"] == raw[0]["ambient"], "the first frame's ambient must pass through"
# ambient is an exponential moving average with weight 0.3 on the newest frame
for k in range(3):
    a = raw[0]["ambient"][k]
    for f in raw[1:]:
        a = 0.7 * a + 0.3 * f["ambient"][k]
    assert abs(sm[-1]["ambient"][k] - a) <= 1e-5 * max(1.0, abs(a)), (sm[-1]["ambient"], a)
assert sm[-1]["lights"] != raw[-1]["lights"]
print("smoothed ambient follows the EMA")
PY
echo "ok  --smooth filters"

# --- image variants that must work: grayscale, 16-bit, alpha, PNG, BMP, TIFF, odd sizes ---
/usr/bin/python3 - "$frame" "$T" <<'PY' || fail "making image variants"
import sys
from PIL import Image
import numpy as np
src, out = sys.argv[1], sys.argv[2]
im = Image.open(src).convert("RGB")
im.convert("L").save(f"{out}/gray.png")
im.convert("RGBA").save(f"{out}/alpha.png")
a = np.asarray(im.convert("L"), dtype=np.uint16) * 257
Image.fromarray(a).save(f"{out}/gray16.png")
im.save(f"{out}/frame.bmp"); im.save(f"{out}/frame.tiff")
im.resize((333, 101)).save(f"{out}/wide.png"); im.resize((9, 50)).save(f"{out}/tall.png")
PY
for f in gray.png alpha.png gray16.png frame.bmp frame.tiff wide.png tall.png; do
    "$P" estimate --model "$M" --input "$T/$f" >"$T/v.jsonl" 2>"$T/err" || fail "$f: $(cat "$T/err")"
    [ "$(wc -l <"$T/v.jsonl")" -eq 1 ] || fail "$f: no output"
done
echo "ok  grayscale, 16-bit, alpha, BMP, TIFF and odd-sized images"

# --- bad inputs ---
: >"$T/empty.jpg"
head -c 2000 "$frame" >"$T/truncated.jpg"
head -c 5000 /dev/urandom >"$T/noise.png"
echo "not an image" >"$T/text.jpg"
head -c 1000000 "$M" >"$T/truncated.plm"
mkdir -p "$T/emptydir" "$T/junkdir"
cp "$T/text.jpg" "$T/noise.png" "$T/junkdir/"
expect_error 2 "--input.*required" "$P" estimate --model "$M"
expect_error 2 "--model is required" "$P" estimate --input "$frame"
expect_error 2 "threads.*1\.\.64" "$P" estimate --model "$M" --input "$frame" --threads 0
expect_error 2 "n-frames" "$P" estimate --model "$M" --input "$frame" --n-frames abc
expect_error 2 "--at" "$P" estimate --model "$M" --input "$frame" --at 1,2
expect_error 2 "unknown option" "$P" estimate --model "$M" --input "$frame" --bogus
expect_error 2 "smooth" "$P" estimate --model "$M" --input "$frame" --smooth 0
expect_error 2 "smooth" "$P" estimate --model "$M" --input "$frame" --smooth 1.5
expect_error 2 "unknown kind" "$P" estimate --model "$M" --input "$frame" --out ftp://x
expect_error 2 "port" "$P" estimate --model "$M" --input "$frame" --out udp://127.0.0.1:99999
expect_error 2 "exclude" "$P" estimate --model "$M" --input "$frame" --camera v4l2:/dev/video0
expect_error 1 "no such file|cannot open|not found|does not exist" "$P" estimate --model "$M" --input "$T/missing.jpg"
expect_error 1 "truncated|bytes" "$P" estimate --model "$T/truncated.plm" --input "$frame"
expect_error 1 "empty|0 bytes|zero" "$P" estimate --model "$M" --input "$T/empty.jpg"
expect_error 1 "truncat|corrupt|decode|not an image|premature" "$P" estimate --model "$M" --input "$T/truncated.jpg"
expect_error 1 "not an image|decode|format" "$P" estimate --model "$M" --input "$T/noise.png"
expect_error 1 "not an image|decode|format" "$P" estimate --model "$M" --input "$T/text.jpg"
expect_error 1 "no .*(file|frame)|empty" "$P" estimate --model "$M" --input "$T/emptydir"
# a directory of junk: a warning per bad file, a summary, then failure
timeout 60 "$P" estimate --model "$M" --input "$T/junkdir" >"$T/out" 2>"$T/err"
[ $? -eq 1 ] || fail "junk directory did not fail"
grep -q "0 frames estimated, 2 skipped" "$T/err" || fail "junk directory summary: $(cat "$T/err")"
# a directory with one bad file among good ones: skipped, counted, exit 0
mkdir -p "$T/mixed"
cp "$frame" "$T/mixed/a.jpg"; cp "$T/text.jpg" "$T/mixed/b.jpg"; cp "$frame" "$T/mixed/c.jpg"
timeout 60 "$P" estimate --model "$M" --input "$T/mixed" >"$T/out" 2>"$T/err" || fail "mixed directory failed"
[ "$(wc -l <"$T/out")" -eq 2 ] || fail "mixed directory: expected 2 lines"
grep -q "2 frames estimated, 1 skipped" "$T/err" || fail "mixed summary: $(cat "$T/err")"
echo "ok  bad inputs"
