#!/usr/bin/env bash
# parlight bench: the text and --json output shapes (fp32 and int8, 1 and 2 threads, a given
# image), the MAC count against the documented 2.775 GMAC of the features at 192x256 (and its
# scaling with the input size), and bad flags, models and images: one clear stderr line each and
# exit 2 (usage) or 1 (failure), never a crash.
set -u
P="$BUILD/parlight"
M=build/models/seeded-n3.plm
M96=build/models/seeded-n3-96x128.plm
T="$PL_TEST_TMP/bench_cli"
mkdir -p "$T"
fail() { echo "FAIL: $*"; exit 1; }
[ -f "$M" ] || fail "no $M (make test exports it)"
frame=$(ls tests/data/frames/*.jpg | head -n 1)
[ -n "$frame" ] || fail "no sample frames in tests/data/frames"

expect_error() {
    local want=$1 pat=$2
    shift 2
    timeout 120 "$@" >"$T/out" 2>"$T/err"
    local rc=$?
    [ "$rc" -eq "$want" ] || fail "'$*' exited $rc, expected $want; stderr: $(cat "$T/err")"
    [ "$(wc -l <"$T/err")" -eq 1 ] || fail "'$*' printed $(wc -l <"$T/err") lines on stderr: $(cat "$T/err")"
    grep -qiE -e "$pat" "$T/err" || fail "'$*': stderr '$(cat "$T/err")' does not match '$pat'"
    [ ! -s "$T/out" ] || fail "'$*' printed on stdout"
    echo "ok  rc=$rc  $(cat "$T/err")"
}

# --- --help ---
"$P" bench --help >"$T/help" || fail "--help exited non-zero"
grep -q -- "--runs" "$T/help" && grep -q -- "--json" "$T/help" || fail "--help lacks --runs/--json"
echo "ok  --help"

# --- an int8 model made from the float one (small calibration: this is about shapes) ---
Q="$T/q.plm"
"$P" quantize --model "$M" --calib tests/data/frames --max-frames 2 --out "$Q" 2>"$T/qerr" ||
    fail "quantize: $(cat "$T/qerr")"

# --- text output: every line present ---
"$P" bench --model "$M" --runs 2 --warmup 0 >"$T/text" 2>"$T/err" || fail "bench fp32: $(cat "$T/err")"
for k in model frame isa threads runs median min max CPU GMAC/s "peak RSS" "key fuser"; do
    grep -q "^$k " "$T/text" || fail "text output lacks '$k': $(cat "$T/text")"
done
grep -q "^runs       2 after 0 warm-up" "$T/text" || fail "runs line: $(cat "$T/text")"
[ ! -s "$T/err" ] || fail "bench printed on stderr: $(cat "$T/err")"
echo "ok  text output"

# --- --json: one object with the documented fields, consistent values ---
"$P" bench --model "$M" --runs 3 --warmup 1 --json >"$T/f32.json" || fail "bench --json fp32"
"$P" bench --model "$Q" --runs 4 --warmup 1 --threads 2 --json >"$T/s8.json" || fail "bench --json int8"
"$P" bench --model "$Q" --runs 2 --warmup 0 --input "$frame" --json >"$T/img.json" || fail "bench --input"
[ -f "$M96" ] && "$P" bench --model "$M96" --runs 1 --warmup 0 --json >"$T/m96.json"
/usr/bin/python3 - "$T" "$frame" <<'PY' || fail "json check"
import json, os, sys
t, frame = sys.argv[1], sys.argv[2]
isas = {"ref", "avx2", "avxvnni", "avx512f", "avx512vnni", "amx", "neon", "dotprod", "i8mm"}
def load(name):
    lines = open(os.path.join(t, name)).read().splitlines()
    assert len(lines) == 1, f"{name}: {len(lines)} lines, expected one JSON object"
    return json.loads(lines[0])
f32, s8, img = load("f32.json"), load("s8.json"), load("img.json")
for o, prec, thr, runs in ((f32, "fp32", 1, 3), (s8, "int8", 2, 4), (img, "int8", 1, 2)):
    for k in ("median_ms", "min_ms", "max_ms", "isa", "threads", "runs", "warmup", "precision",
              "gmac_per_frame", "gmac_per_s", "peak_rss_kib", "median_infer_ms", "mean_ms",
              "median_cpu_ms", "key_fuser_get_ms"):
        assert k in o, (k, o)
    assert 0 < o["key_fuser_get_ms"] < 1000, o  # estimate --fuse's worst case a frame
    assert o["precision"] == prec and o["threads"] == thr and o["runs"] == runs, o
    assert o["isa"] in isas, o["isa"]
    assert 0 < o["min_ms"] <= o["median_ms"] <= o["max_ms"], o
    assert o["min_ms"] <= o["mean_ms"] <= o["max_ms"], o
    assert 0 < o["median_infer_ms"] <= o["max_ms"], o
    assert o["median_cpu_ms"] > 0, o
    if thr == 1:   # one thread cannot spend more CPU than wall time (1 ms of clock slack)
        assert o["median_cpu_ms"] <= o["max_ms"] + 1.0, o
    assert abs(o["gmac_per_s"] - o["gmac_per_frame"] / o["median_ms"] * 1e3) < 1e-2 * o["gmac_per_s"], o
    assert o["peak_rss_kib"] > 1024, o
# DenseNet-121 features at 192x256 are 2.775 GMAC (docs/PERFORMANCE.md); FC and heads add ~1.6 M
assert 2.775 < f32["gmac_per_frame"] < 2.780, f32["gmac_per_frame"]
assert s8["gmac_per_frame"] == f32["gmac_per_frame"]
assert f32["frame"] == "synthetic" and img["frame"] == frame, (f32["frame"], img["frame"])
if os.path.exists(os.path.join(t, "m96.json")):
    m96 = load("m96.json")
    assert (m96["input_h"], m96["input_w"]) == (96, 128)
    feats = f32["gmac_per_frame"] - 0.0016
    assert abs(m96["gmac_per_frame"] - 0.0016 - feats / 4) < 0.01 * feats / 4, m96
print("json ok")
PY
echo "ok  --json"

# --- --layers / --layers-cpu: every stage of the network, in order, adding up to the frame ---
"$P" bench --model "$Q" --runs 3 --warmup 1 --layers --json >"$T/lay8.json" || fail "--layers int8"
"$P" bench --model "$M" --runs 2 --warmup 0 --threads 2 --layers --json >"$T/lay32.json" ||
    fail "--layers fp32"
"$P" bench --model "$Q" --runs 3 --warmup 0 --layers-cpu --json >"$T/laycpu.json" ||
    fail "--layers-cpu"
"$P" bench --model "$Q" --runs 2 --warmup 0 --layers >"$T/laytext" || fail "--layers text"
grep -q "^stage (wall) *median ms" "$T/laytext" && grep -q "^  dense 3x3 b1 " "$T/laytext" ||
    fail "--layers text: $(cat "$T/laytext")"
/usr/bin/python3 - "$T" <<'PY' || fail "--layers json check"
import json, os, sys
t = sys.argv[1]
names = ["preprocess", "stem 7x7", "max pool"] + [f"dense {k} b{b}" for b in range(1, 5)
         for k in ("1x1", "3x3")] + ["transition 1", "transition 2", "transition 3",
         "norm5 + bands", "fc + heads"]
for f, clock in (("lay8.json", "wall"), ("lay32.json", "wall"), ("laycpu.json", "thread_cpu")):
    o = json.load(open(os.path.join(t, f)))
    assert o["stage_clock"] == clock, (f, o.get("stage_clock"))
    st = o["stages"]
    assert [s["stage"] for s in st] == names, (f, [s["stage"] for s in st])
    for s in st:
        assert 0 <= s["min_ms"] <= s["median_ms"], (f, s)
    for s in st[1:-2]:   # every convolution stage does work
        assert s["median_ms"] > 0, (f, s)
    total = sum(s["min_ms"] for s in st)
    # the stages cover the whole frame: the sum of their minima is at most the slowest frame
    # and at least a third of the fastest (the rest is clock reads and the result copy)
    assert total <= o["max_ms"] + 0.5, (f, total, o["max_ms"])
    assert total >= o["min_ms"] / 3, (f, total, o["min_ms"])
    if clock == "wall" and o["threads"] == 1:
        # the 3x3s of block 1 and the 1x1s of blocks 1-3 are most of the work (one thread: with
        # two on a loaded machine, the pool's waits at ~130 joins can outweigh them)
        big = sum(s["median_ms"] for s in st if s["stage"] in ("dense 3x3 b1", "dense 1x1 b1", "dense 1x1 b2"))
        assert big > 0.2 * sum(s["median_ms"] for s in st), (f, big)
print("layers ok")
PY
"$P" bench --model "$Q" --runs 1 --json | grep -q '"stages"' && fail "stages without --layers"
echo "ok  --layers"

# --- PARLIGHT_ISA=ref is reported as such ---
PARLIGHT_ISA=ref "$P" bench --model "$Q" --runs 1 --warmup 0 --json | grep -q '"isa":"ref"' ||
    fail "PARLIGHT_ISA=ref not reported"
echo "ok  PARLIGHT_ISA=ref"

# --- bad flags: exit 2 ---
expect_error 2 "--model is required" "$P" bench
expect_error 2 "--runs '0'" "$P" bench --model "$M" --runs 0
expect_error 2 "--runs 'x'" "$P" bench --model "$M" --runs x
expect_error 2 "--threads '0'" "$P" bench --model "$M" --threads 0
expect_error 2 "--threads '65'" "$P" bench --model "$M" --threads 65
expect_error 2 "--warmup '-1'" "$P" bench --model "$M" --warmup -1
expect_error 2 "needs a value" "$P" bench --model "$M" --runs
expect_error 2 "unknown option '--frobnicate'" "$P" bench --model "$M" --frobnicate
expect_error 2 "unexpected argument 'extra'" "$P" bench --model "$M" extra

# --- bad models and images: exit 1, the message names the file ---
expect_error 1 "nope.plm" "$P" bench --model "$T/nope.plm"
head -c 1000 "$M" >"$T/trunc.plm"
expect_error 1 "trunc.plm" "$P" bench --model "$T/trunc.plm" --runs 1
echo "not an image" >"$T/text.jpg"
expect_error 1 "text.jpg" "$P" bench --model "$M" --runs 1 --input "$T/text.jpg"
expect_error 1 "missing.png" "$P" bench --model "$M" --runs 1 --input "$T/missing.png"
expect_error 1 "bogus" env PARLIGHT_ISA=bogus "$P" bench --model "$M" --runs 1
echo "all ok"
