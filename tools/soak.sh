#!/usr/bin/env bash
# A long replay of the sample frames with RSS and open-fd samples, for leaks and fd growth that
# the suite's short runs cannot show (docs/TESTING.md, "Soak"):
#
#   tools/soak.sh [FRAMES] [OUTDIR]      (default 50000 frames, OUTDIR a new temporary folder)
#
# Runs `parlight estimate --loop` (int8 model, stdout + a TCP sink with one reader) until FRAMES
# lines are out (kept in OUTDIR/lines.jsonl, ~1.4 KB each), samples VmRSS and /proc/PID/fd every 10 s into OUTDIR/samples.txt, then stops
# the estimate with SIGTERM and prints the first and last samples and the distinct (RSS, fds)
# pairs. Environment: BUILD (default build), MODEL (default models/parlight-n3-int8.plm).
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD=${BUILD:-build}
MODEL=${MODEL:-models/parlight-n3-int8.plm}
FRAMES=${1:-50000}
OUT=${2:-$(mktemp -d "${TMPDIR:-/tmp}/parlight-soak.XXXXXX")}
mkdir -p "$OUT"
[ -x "$BUILD/parlight" ] || { echo "soak: no $BUILD/parlight (make first)" >&2; exit 1; }
PORT=$(python3 -c 'import socket; s = socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])')
"$BUILD/parlight" estimate --model "$MODEL" --input tests/data/frames --loop --out stdout \
    --out "tcp://127.0.0.1:$PORT" 2>"$OUT/err.log" >"$OUT/lines.jsonl" &
PID=$!
trap 'kill $PID 2>/dev/null || true' EXIT
for _ in $(seq 50); do grep -q listening "$OUT/err.log" 2>/dev/null && break; sleep 0.1; done
(exec 3<>"/dev/tcp/127.0.0.1/$PORT" && cat <&3 >/dev/null) &
READER=$!
echo "t_s rss_kb fds lines" >"$OUT/samples.txt"
t0=$(date +%s)
while kill -0 $PID 2>/dev/null; do
    n=$(wc -l <"$OUT/lines.jsonl")
    echo "$(($(date +%s) - t0)) $(awk '/VmRSS/{print $2}' /proc/$PID/status) $(ls /proc/$PID/fd | wc -l) $n" \
        >>"$OUT/samples.txt"
    [ "$n" -ge "$FRAMES" ] && break
    sleep 10
done
kill $PID
wait $PID 2>/dev/null || true
kill $READER 2>/dev/null || true
echo "soak: $(tail -1 "$OUT/err.log")"
echo "soak: first and last samples (t_s rss_kb fds lines):"
sed -n 2p "$OUT/samples.txt"
tail -1 "$OUT/samples.txt"
echo "soak: distinct (rss_kb, fds): $(awk 'NR > 1 {print $2 "/" $3}' "$OUT/samples.txt" | sort -u | tr '\n' ' ')"
echo "soak: samples in $OUT/samples.txt"
