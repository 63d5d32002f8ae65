#!/usr/bin/env bash
# The intensity anchor end to end (docs/LIGHTING.md, "Intensity anchor"):
# - `estimate --anchor 1,0` gives lightings whose mean luminance over the sphere is the frame's
#   mean linear luminance (computed here in Python from the PNG), for the float and the int8
#   model; `--anchor off` and no flag agree on a model without the metadata;
# - a model whose metadata says intensity_anchor=w,b,gamma: `info` shows it, `estimate` applies it
#   (same output as the flag on the plain model), `--anchor off` undoes it; bad metadata and bad
#   flags are refused with messages naming them;
# - tools/train/fit_anchor.py on `eval --anchor off --json`: the median RMSE it predicts for its
#   choice is what `eval` then measures with the model it wrote; it refuses to replace a file
#   without --force and refuses a JSON made with an anchor.
# Model: build/models/seeded-n3-96x128.plm (seeded weights: the plumbing and the maths are tested,
# not the network). Env: BUILD, PL_TEST_TMP (tests/run.sh). Exit 0 pass, 1 fail, 77 skip.
set -u
cd "$(dirname "$0")/.."
BUILD=${BUILD:-build}
P="$BUILD/parlight"
M=build/models/seeded-n3-96x128.plm
PY=/usr/bin/python3
T=${PL_TEST_TMP:-$(mktemp -d)}/anchor_cli
[ -x "$P" ] || { echo "skip: $P not built"; exit 77; }
[ -f "$M" ] || { echo "skip: no $M (make build/models/seeded-n3-96x128.plm)"; exit 77; }
"$PY" -c 'import numpy, PIL' 2>/dev/null || { echo "skip: $PY lacks numpy/PIL"; exit 77; }
rm -rf "$T"
mkdir -p "$T/frames" "$T/panos"
. "$(dirname "$0")/cli_helpers.sh"

# --- frames: 4:3 PNGs (what the network sees is the whole frame), dark, mid and bright ---
"$PY" - "$T/frames" <<'PY' || { echo "FAIL: cannot write the test frames"; exit 1; }
import sys
import numpy as np
from PIL import Image
rng = np.random.default_rng(7)
for i, (lo, hi) in enumerate([(0, 60), (20, 200), (120, 255)]):
    a = rng.integers(lo, hi + 1, size=(96, 128, 3), dtype=np.uint8)
    Image.fromarray(a).save(f"{sys.argv[1]}/f{i}.png")
PY

# mean_check JSONL FRAMES_DIR W B: every lighting's mean luminance = 2^b Y^(1-w) F^w for the
# unanchored Y given in $T/raw.jsonl (the same frames, --anchor off)
mean_check() {
    "$PY" - "$@" <<'PY'
import json, math, sys
import numpy as np
from PIL import Image
path, raw_path, frames = sys.argv[1:4]
w, b = float(sys.argv[4]), float(sys.argv[5])
def mean_lum(d):
    Y = lambda c: 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]
    y = Y(d["ambient"])
    for l in d["lights"]:
        sig = l["solid_angle_sr"] / (4 * math.pi)
        y += Y(l["rgb"]) * 2 * math.pi * sig * -math.expm1(-2 / sig) / (4 * math.pi)
    return y
rows = [json.loads(x) for x in open(path)]
raw = [json.loads(x) for x in open(raw_path)]
assert len(rows) == len(raw) == 3, (len(rows), len(raw))
bad = 0
for r, r0 in zip(rows, raw):
    name = r["source"].split("/")[-1]
    a = np.asarray(Image.open(f"{frames}/{name}").convert("RGB"), np.float64) / 255.0
    lin = a ** 2.2
    F = float((0.2126 * lin[..., 0] + 0.7152 * lin[..., 1] + 0.0722 * lin[..., 2]).mean())
    want = 2 ** b * mean_lum(r0) ** (1 - w) * F ** w
    got = mean_lum(r)
    if abs(got - want) > 1e-4 * want:
        print(f"{name}: mean luminance {got:.7g}, expected {want:.7g} (frame {F:.7g})")
        bad += 1
    for l, l0 in zip(r["lights"], r0["lights"]):
        if l["dir"] != l0["dir"] or l["solid_angle_sr"] != l0["solid_angle_sr"]:
            print(f"{name}: the anchor moved a light or changed its size"); bad += 1
sys.exit(1 if bad else 0)
PY
}

est() { "$P" estimate --model "$1" --input "$T/frames" "${@:2}" 2>"$T/est.err"; }

est "$M" --anchor off >"$T/raw.jsonl" || fail "estimate --anchor off: $(cat "$T/est.err")"
est "$M" >"$T/plain.jsonl" || fail "estimate: $(cat "$T/est.err")"
strip() { sed 's/"t_ns":[0-9]*,//; s/"timing_ms":{[^}]*}//' "$1"; }
[ "$(strip "$T/raw.jsonl")" = "$(strip "$T/plain.jsonl")" ] &&
    ok "no metadata: --anchor off = no flag" || fail "--anchor off differs from no flag"
for wb in "1 0" "0.5 1" "0 -2" "0.25 0.75"; do
    set -- $wb
    est "$M" --anchor "$1,$2" >"$T/a.jsonl" || fail "estimate --anchor $1,$2: $(cat "$T/est.err")"
    mean_check "$T/a.jsonl" "$T/raw.jsonl" "$T/frames" "$1" "$2" &&
        ok "float, --anchor $1,$2: mean luminance 2^b Y^(1-w) F^w" || fail "float --anchor $1,$2"
done
# negative control: a wrong w must not pass the check
est "$M" --anchor 0.5,0 >"$T/a.jsonl"
mean_check "$T/a.jsonl" "$T/raw.jsonl" "$T/frames" 1 0 >/dev/null &&
    fail "the check passed --anchor 0.5,0 as w = 1" || ok "the check tells w 0.5 from w 1"

# --- int8: the anchor runs after either executor ---
Q="$T/q.plm"
if "$P" quantize --model "$M" --calib tests/data/frames --out "$Q" >/dev/null 2>"$T/q.err"; then
    est "$Q" --anchor off >"$T/qraw.jsonl" && est "$Q" --anchor 1,0 >"$T/q1.jsonl" &&
        mean_check "$T/q1.jsonl" "$T/qraw.jsonl" "$T/frames" 1 0 &&
        ok "int8, --anchor 1,0: the frame's mean luminance" || fail "int8 --anchor 1,0"
else
    fail "quantize: $(tail -n 2 "$T/q.err")"
fi

# --- the anchor in the model's metadata ---
with_meta() { # SRC DST VALUE
    "$PY" - "$@" <<'PY'
import sys
sys.path.insert(0, "tools")
import plm
meta, tensors, info = plm.read_plm(sys.argv[1])
meta = dict(meta)
meta["intensity_anchor"] = sys.argv[3]
quant = {n: (e["scale"], e["zero_point"]) for n, e in info["entries"].items()}
plm.write_plm(sys.argv[2], meta, list(tensors.items()), quant)
PY
}
with_meta "$M" "$T/anch.plm" "0.5,1,2.2" || fail "cannot write the anchored model"
"$P" info --model "$T/anch.plm" >"$T/info" 2>&1
grep -q "anchor *w 0.5, b 1 stops, gamma 2.2" "$T/info" && ok "info shows the file's anchor" ||
    fail "info: $(grep anchor "$T/info")"
est "$T/anch.plm" >"$T/m.jsonl" && est "$M" --anchor 0.5,1,2.2 >"$T/f.jsonl"
[ "$(strip "$T/m.jsonl")" = "$(strip "$T/f.jsonl")" ] &&
    ok "metadata 0.5,1,2.2 = --anchor 0.5,1,2.2" || fail "the file's anchor differs from the flag's"
est "$T/anch.plm" --anchor off >"$T/o.jsonl"
[ "$(strip "$T/o.jsonl")" = "$(strip "$T/raw.jsonl")" ] &&
    ok "--anchor off undoes the file's anchor" || fail "--anchor off on the anchored model"
for bad in "2,0,2.2" "0.5,9,2.2" "0.5,0,0.5" "abc" "0.5,0"; do
    with_meta "$M" "$T/bad.plm" "$bad" &&
        expect 1 "intensity_anchor" -- "$P" info --model "$T/bad.plm"
    rm -f "$T/bad.plm"
done
for bad in 1 0.5,9 x 0.5,0,2.2,1 1.5,0 ""; do
    expect 2 "--anchor '$bad'" -- "$P" estimate --model "$M" --input "$T/frames" --anchor "$bad"
done
expect 2 "--anchor" -- "$P" eval --model "$M" --hdr "$T/panos" --anchor 2,0

# --- fit_anchor.py: its prediction is what eval measures ---
for L in '[0.4,0.6,-0.7],"distance_m":2,"solid_angle_sr":0.08,"rgb":[300,280,240]' \
         '[-0.7,0.2,0.5],"distance_m":3,"solid_angle_sr":0.4,"rgb":[20,30,40]'; do
    n=$(ls "$T/panos" | wc -l)
    echo "{\"lights\":[{\"dir\":$L}],\"ambient\":[0.2,0.25,0.3]}" >"$T/l$n.json"
    "$P" render --lights "$T/l$n.json" --out "$T/panos/p$n.exr" --width 256 >/dev/null 2>&1 ||
        { fail "parlight render could not make a test panorama"; }
done
"$P" eval --model "$M" --hdr "$T/panos" --crops 6 --anchor off --json >"$T/raw.json" 2>"$T/e.err" ||
    fail "eval --anchor off: $(cat "$T/e.err")"
if "$PY" - "$T/raw.json" <<'PY'; then
import json, sys
d = json.load(open(sys.argv[1]))
assert d["intensity_anchor"] == {"w": 0, "b": 0, "gamma": 2.2}, d["intensity_anchor"]
for p in d["panoramas"]:
    for c in p["crops"]:
        assert isinstance(c["frame_ev"], float), c["frame_ev"]
        for m in ("model", "ambient", "brightest", "gt_lights"):
            assert c[m]["render_rms"] > 0, (m, c[m])
PY
    ok "eval JSON: intensity_anchor, frame_ev, render_rms"
else
    fail "eval JSON fields"
fi
FIT=tools/train/fit_anchor.py
if "$PY" "$FIT" "$T/raw.json" --w 0,0.5,1 --b=-1:1:0.5 --write "$M" "$T/fit.plm" \
    >"$T/fit.out" 2>&1; then
    pred=$(sed -n 's/^best: .*median RMSE \([0-9.]*\).*/\1/p' "$T/fit.out")
    "$P" eval --model "$T/fit.plm" --hdr "$T/panos" --crops 6 --json >"$T/fit.json" 2>/dev/null
    got=$("$PY" -c 'import json, sys
print(json.load(open(sys.argv[1]))["methods"]["model"]["rmse"]["median"])' "$T/fit.json")
    "$PY" -c 'import sys
p, g = map(float, sys.argv[1:])
sys.exit(abs(p - g) > 1e-4 + 1e-4 * g)' "$pred" "$got" &&
        ok "fit_anchor predicted median RMSE $pred, eval measures $got" ||
        fail "fit_anchor predicted $pred, eval measures $got ($(cat "$T/fit.out" | tail -n 2))"
    base=$(sed -n 's/.*without the anchor \([0-9.]*\).*/\1/p' "$T/fit.out")
    "$PY" -c 'import sys; p, b = map(float, sys.argv[1:]); sys.exit(p > b)' "$pred" "$base" &&
        ok "the fit is no worse than no anchor ($pred <= $base)" ||
        fail "fit $pred > no anchor $base"
else
    fail "fit_anchor.py: $(tail -n 3 "$T/fit.out")"
fi
# --lopo: each fold's (w, b) is the plain fit on the crops of the other panoramas
if "$PY" "$FIT" "$T/raw.json" --w 0,0.5,1 --b=-1:1:0.5 --lopo >"$T/lopo.out" 2>&1 &&
    "$PY" - "$T/raw.json" "$T/lopo.out" "$FIT" <<'PY'; then
import json, re, subprocess, sys
d = json.load(open(sys.argv[1]))
out = open(sys.argv[2]).read()
assert re.search(r"^leave one panorama out \(%d panoramas\): median RMSE [0-9.]+" % len(d["panoramas"]),
                 out, re.M), out
for p in d["panoramas"]:
    rest = dict(d, panoramas=[q for q in d["panoramas"] if q is not p])
    path = sys.argv[1] + ".rest"
    json.dump(rest, open(path, "w"))
    r = subprocess.run([sys.executable, sys.argv[3], path, "--w", "0,0.5,1", "--b=-1:1:0.5"],
                       capture_output=True, text=True, check=True).stdout
    w, b = re.search(r"^best: w (\S+), b (\S+):", r, re.M).groups()
    assert f"  without {p['file']}: w {w}, b {b}\n" in out, (p["file"], w, b, out)
PY
    ok "fit_anchor --lopo: each fold is the fit without its panorama"
else
    fail "fit_anchor --lopo: $(tail -n 3 "$T/lopo.out")"
fi
# the int8 file of the same network takes the same anchor (its f32 activation entries keep their
# zero points through tools/plm.py), and runs it as the flag would
if [ -f "$Q" ] && "$PY" "$FIT" "$T/raw.json" --w 0,0.5,1 --b=-1:1:0.5 --write "$Q" "$T/fitq.plm" \
    >"$T/fitq.out" 2>&1; then
    an=$(sed -n 's/^wrote .*intensity_anchor=//p' "$T/fitq.out")
    est "$T/fitq.plm" >"$T/fq.jsonl" && est "$Q" --anchor "$an" >"$T/fq2.jsonl"
    [ -n "$an" ] && [ "$(strip "$T/fq.jsonl")" = "$(strip "$T/fq2.jsonl")" ] &&
        ok "int8 file written with the anchor $an = --anchor $an" ||
        fail "int8 file with the anchor '$an' differs from the flag"
else
    fail "fit_anchor.py --write on the int8 model: $(tail -n 2 "$T/fitq.out" 2>/dev/null)"
fi
cp "$T/fit.plm" "$T/fit.keep"
expect 1 "exists" -- "$PY" "$FIT" "$T/raw.json" --write "$M" "$T/fit.plm"
cmp -s "$T/fit.plm" "$T/fit.keep" && ok "an existing OUT is kept without --force" ||
    fail "fit_anchor replaced an existing file without --force"
"$P" eval --model "$T/fit.plm" --hdr "$T/panos" --crops 2 --json >"$T/anch.json" 2>/dev/null
expect 1 "anchor off" -- "$PY" "$FIT" "$T/anch.json"
echo '{"not": "an eval"}' >"$T/junk.json"
expect 1 "not the --json output" -- "$PY" "$FIT" "$T/junk.json"

finish
exit 1
