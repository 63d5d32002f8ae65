#!/usr/bin/env bash
# The live viewer in a real browser (docs/VIEWER.md): `parlight view` replays sample frames
# (four of tests/data/frames, shipped model, --realtime --frame-interval 300, --wait-clients 1) on
# loopback; its ws:// server also serves the page; Debian's headless Chromium (driven by
# playwright-core from app/viewer/node_modules, tests/viewer_browser.mjs) opens it, keeps the 2nd
# frame on screen and takes screenshots; tests/viewer_check.py checks them: frames received, the
# page's diffuse sphere against `parlight render --sphere diffuse` of the same line (linear RGB,
# RMS <= 1% and largest error <= 3% of the peak), the primary light's shadow on the side away
# from the light, the key light's arrow (--poses with identity poses, --fuse 0). Also: the
# static files (MIME types, 404, no way out of the folder by ".." or %2e%2e), --thumb (a JPEG per line, shown by the page) and the flags' errors (--frame-interval,
# --thumb, view without node_modules).
# The screenshots are kept in $PL_VIEWER_SHOTS when set (tools/viewer-shots.sh -> docs/).
# Bounded: every step has a timeout; the whole test takes about 30 s here.
# needs: ws libjpeg
set -u
cd "$(dirname "$0")/.."
BUILD=${BUILD:-build}
P="$BUILD/parlight"
M=models/parlight-n3.plm
PY=/usr/bin/python3
CHROMIUM=${CHROMIUM:-/usr/bin/chromium}
T=${PL_TEST_TMP:-$(mktemp -d)}/viewer
[ -x "$P" ] || { echo "skip: $P not built"; exit 77; }
[ -f "$M" ] || { echo "skip: no $M"; exit 77; }
[ -x "$CHROMIUM" ] || { echo "skip: no $CHROMIUM (tools/install-deps.sh installs chromium)"; exit 77; }
command -v node >/dev/null || { echo "skip: no node (tools/install-deps.sh installs nodejs)"; exit 77; }
[ -f app/viewer/node_modules/three/build/three.module.min.js ] &&
    [ -f app/viewer/node_modules/playwright-core/package.json ] ||
    { echo "skip: no app/viewer/node_modules (make deps runs npm ci there)"; exit 77; }
$PY -c 'import numpy, PIL' 2>/dev/null || { echo "skip: no numpy/PIL for $PY"; exit 77; }
command -v curl >/dev/null || { echo "skip: no curl"; exit 77; }
rm -rf "$T"
mkdir -p "$T/shots"
. "$(dirname "$0")/cli_helpers.sh"
pids=()
cleanup() { for p in "${pids[@]}"; do kill "$p" 2>/dev/null; done; }
trap cleanup EXIT
start=$(date +%s.%N)

# port_of ERRFILE: the port from estimate's "listening on 127.0.0.1:PORT" (waits up to 10 s)
port_of() {
    local i
    for i in $(seq 100); do
        sed -n 's/.*listening on 127\.0\.0\.1:\([0-9]*\).*/\1/p' "$1" | head -n 1 | grep . && return 0
        sleep 0.1
    done
    return 1
}

# ---- flags -------------------------------------------------------------------------------------
expect 2 "frame-interval.*--realtime" -- "$P" estimate --model "$M" --input tests/data/frames \
    --frame-interval 100
expect 2 "frame-interval '0'" -- "$P" estimate --model "$M" --input tests/data/frames --realtime \
    --frame-interval 0
expect 2 "frame-interval 'x'" -- "$P" estimate --model "$M" --input tests/data/frames --realtime \
    --frame-interval x
expect 2 "web directory $T/none" -- "$P" estimate --model "$M" --input tests/data/frames \
    --out ws://127.0.0.1:0/stream --www "$T/none"
expect 2 "--www needs a ws:// server" -- "$P" estimate --model "$M" --input tests/data/frames \
    --www app/viewer --out tcp://127.0.0.1:0
mkdir -p "$T/bare"
expect 1 "node_modules/three.*missing.*npm ci" -- "$P" view --model "$M" --input tests/data/frames \
    --port 0 --www "$T/bare"
expect 2 "--port" -- "$P" view --model "$M" --input tests/data/frames --port 70000
expect 2 "--thumb '8'" -- "$P" estimate --model "$M" --input tests/data/frames --thumb 8
expect 0 "" -- "$P" estimate --model "$M" --input tests/data/frames --thumb 64
$PY - "$T/out" <<'PYEOF' && ok "--thumb 64: every line has a 64-pixel-wide JPEG as a data: URL" ||
import base64, io, json, sys
from PIL import Image
lines = open(sys.argv[1]).read().splitlines()
assert len(lines) == 5, len(lines)
for l in lines:
    t = json.loads(l)["thumb"]
    assert t.startswith("data:image/jpeg;base64,"), t[:40]
    im = Image.open(io.BytesIO(base64.b64decode(t.split(",", 1)[1])))
    assert im.format == "JPEG" and im.size[0] == 64, (im.format, im.size)
PYEOF
    fail "--thumb 64: lines without a proper thumb field"
# --realtime paces a directory: 5 frames at 200 ms take about 0.8 s (4 intervals), not 0.2
t0=$(date +%s%N)
expect 0 "" -- "$P" estimate --model "$M" --input tests/data/frames --realtime --frame-interval 200
t1=$(date +%s%N)
ms=$(((t1 - t0) / 1000000))
n=$(wc -l <"$T/out")
if [ "$n" -eq 5 ] && [ "$ms" -ge 780 ] && [ "$ms" -lt 3000 ]; then
    ok "--realtime --frame-interval 200: $n frames in $ms ms"
else
    fail "--realtime --frame-interval 200: $n frames in $ms ms (expected 5 in 0.8..3 s)"
fi

# ---- the stream and the page -------------------------------------------------------------------
# the sample frames whose primary light is high enough to cast its shadow on the ground in
# view (workshop-skylights.jpg's is 9 degrees above the horizon): whichever frame the page
# keeps, should a slow (sanitized) build drop one, the shadow check applies
mkdir -p "$T/frames"
for f in apartment-window lab-lamps lobby-ceiling-lights warehouse-tubes; do
    ln -s "$PWD/tests/data/frames/$f.jpg" "$T/frames/$f.jpg"
done
# with the key light over views (--poses --fuse): the camera turned by nothing (identity
# poses), so that the scene's lights, the sphere and the shadow are the camera's as above
$PY -c 'import json
for i in range(256):
    print(json.dumps({"frame": i, "q": [1, 0, 0, 0]}))' >"$T/poses.jsonl"
"$P" view --model "$M" --input "$T/frames" --port 0 --wait-clients 1 \
    --frame-interval 300 --n-frames 200 --poses "$T/poses.jsonl" --fuse 0 \
    >"$T/view.out" 2>"$T/view.err" &
pids+=($!)
PORT=$(port_of "$T/view.err") || { fail "view: no port ($(head -c 400 "$T/view.err"))"; finish; }
grep -q "viewer: open http://127.0.0.1:$PORT/ in a browser" "$T/view.err" &&
    ok "view prints the URL: $(grep -o 'http://[^ ]*' "$T/view.err")" ||
    fail "view: no URL line ($(head -c 400 "$T/view.err"))"

# static files: types, 404, nothing outside the folder (before the browser: the sink serves
# them while it waits for its reader)
http() { curl -s --path-as-is --max-time 5 -o "$T/body" -w '%{http_code} %{content_type}' \
    "http://127.0.0.1:$PORT$1"; }
for c in "/ 200 text/html" "/viewer.js 200 text/javascript" "/viewer.css 200 text/css" \
    "/node_modules/three/build/three.module.min.js 200 text/javascript" \
    "/missing.html 404" "/../cmd_view.c 404" "/%2e%2e/cmd_view.c 404" \
    "/node_modules/../../cmd_view.c 404" "/..%2fcmd_view.c 404" "/%2e%2e%2f%2e%2e%2fMakefile 404" \
    "/stream 404"; do
    set -- $c
    got=$(http "$1")
    if [ "${got%% *}" = "$2" ] && { [ -z "${3:-}" ] || [ "${got#* }" = "$3" ]; } &&
        ! grep -q "cmd_view\|^# parlight" "$T/body"; then
        ok "GET $1 -> $got"
    else
        fail "GET $1 -> $got, expected $2 ${3:-}"
    fi
done
http / >/dev/null && cmp -s "$T/body" app/viewer/index.html && ok "GET / is index.html" ||
    fail "GET / is not app/viewer/index.html"

timeout 120 node tests/viewer_browser.mjs "http://127.0.0.1:$PORT/" "$T/shots" "$CHROMIUM" \
    >"$T/browser.log" 2>&1
rc=$?
sed 's/^/     browser: /' "$T/browser.log"
if [ $rc -eq 3 ]; then
    echo "skip: headless chromium has no WebGL here ($(tail -n 1 "$T/browser.log"))"
    exit 77
fi
[ $rc -eq 0 ] && ok "browser: page loaded, frames shown, screenshots taken" ||
    fail "browser: exit $rc"
kill "${pids[0]}" 2>/dev/null
wait "${pids[0]}" 2>/dev/null
grep -q "client .* connected" "$T/view.err" && ok "view: the page connected to the stream" ||
    fail "view: no client connected ($(head -c 400 "$T/view.err"))"
if [ $rc -eq 0 ]; then
    timeout 60 $PY tests/viewer_check.py "$T/shots" "$P" >"$T/check.log" 2>&1
    crc=$?
    cat "$T/check.log"
    fails=$((fails + $(grep -c '^FAIL' "$T/check.log")))
    [ $crc -eq 0 ] || [ "$(grep -c '^FAIL' "$T/check.log")" -gt 0 ] || fail "viewer_check.py: exit $crc"
    if [ -n "${PL_VIEWER_SHOTS:-}" ]; then
        mkdir -p "$PL_VIEWER_SHOTS"
        cp "$T"/shots/*.png "$T/shots/state.json" "$T/shots/figures.txt" "$PL_VIEWER_SHOTS"/
    fi
fi
echo "     test time $(awk -v a="$start" -v b="$(date +%s.%N)" 'BEGIN { printf "%.1f", b - a }') s"
finish
