#!/usr/bin/env bash
# Every instruction-set path this CPU runs, at the shipped 96x128 and at 192x256, fp32 and int8,
# then the end-to-end frame rate on the sample frames (docs/PERFORMANCE.md, "Every path at both
# input sizes"). Figures, not a test: it prints a Markdown table headed by this machine's CPU,
# load average and git revision.
#
#   tools/bench/paths.sh        (after make and make build/models/seeded-n3.plm)
#
# bench rows: `parlight bench` per path (PARLIGHT_ISA), median wall ms and median CPU ms per frame
# (all threads' CPU time: on a shared machine the steadier figure), PATHS_RUNS runs (default 20;
# the ref path PATHS_REF_RUNS, default 3) after 2 warm-up, at PATHS_THREADS (default "1 2").
# end-to-end rows: `parlight estimate --input tests/data/frames --loop` on the default path,
# from JPEG file to JSON line (decode, crop, resize, network, heads, lights, JSON to /dev/null),
# 20 and 20 + PATHS_E2E_FRAMES (default 200) frames: frames / (difference of the wall times, and
# of the CPU times), so model loading cancels out.
# Models: models/parlight-n3{,-int8}.plm (96x128) and build/models/seeded-n3.plm with its int8
# twin build/bench/seeded-n3-int8.plm (192x256; made as make bench makes it when missing).
set -euo pipefail
cd "$(dirname "$0")/../.."
BUILD=${BUILD:-build}
P=$BUILD/parlight
RUNS=${PATHS_RUNS:-20}
REF_RUNS=${PATHS_REF_RUNS:-3}
THREADS=${PATHS_THREADS:-1 2}
E2E=${PATHS_E2E_FRAMES:-200}
FRAMES=tests/data/frames
Q256=build/bench/seeded-n3-int8.plm
[ -x "$P" ] || { echo "paths: no $P (make)" >&2; exit 1; }
[ -f build/models/seeded-n3.plm ] || { echo "paths: make build/models/seeded-n3.plm" >&2; exit 1; }
if [ ! -f "$Q256" ]; then
    mkdir -p build/bench
    "$P" quantize --model build/models/seeded-n3.plm --calib "$FRAMES" --method minmax \
        --out "$Q256.tmp" >&2 && mv "$Q256.tmp" "$Q256"
fi
paths=$("$P" info --model models/parlight-n3-int8.plm | sed -n 's/.*this CPU runs: \(.*\))$/\1/p')
echo "machine: $(sed -n 's/^model name\s*: //p' /proc/cpuinfo | head -1), $(nproc) CPUs;" \
    "paths: $paths; git $(git rev-parse --short HEAD)$(git diff --quiet HEAD || echo +changes);" \
    "$(date -u '+%Y-%m-%d %H:%M UTC'); load $(cut -d' ' -f1-3 /proc/loadavg)"
echo
# one table row from parlight bench --json
ROW_PY=$(
    cat <<'PY'
import json, sys
j = json.load(sys.stdin)
print(f"| {j['isa']} | {j['precision']} | {j['input_h']}x{j['input_w']} | {j['threads']} | "
      f"{j['median_ms']:.2f} | {j['median_cpu_ms']:.2f} | "
      f"{j['gmac_per_frame'] / j['median_cpu_ms'] * 1e3:.1f} |")
PY
)
echo "| path | prec | input | threads | median ms | CPU ms | GMAC/s (CPU) |"
echo "|---|---|---|---|---|---|---|"
for isa in $paths; do
    r=$RUNS
    [ "$isa" = ref ] && r=$REF_RUNS
    for pair in "models/parlight-n3.plm models/parlight-n3-int8.plm" \
        "build/models/seeded-n3.plm $Q256"; do
        for m in $pair; do
            for t in $THREADS; do
                [ "$isa" = ref ] && [ "$t" != 1 ] && continue
                PARLIGHT_ISA=$isa "$P" bench --model "$m" --threads "$t" --runs "$r" --warmup 2 \
                    --json | /usr/bin/python3 -c "$ROW_PY"
            done
        done
    done
done
echo "(load $(cut -d' ' -f1-3 /proc/loadavg))"
echo
echo "| end to end (JPEG to JSON) | prec | threads | frames/s (wall) | ms/frame (wall) | CPU ms/frame |"
echo "|---|---|---|---|---|---|"
# run_e2e MODEL THREADS N: "wall_s cpu_s" of estimate over N frames
run_e2e() {
    local t0 t1 c
    t0=$(date +%s.%N)
    c=$( { /usr/bin/time -f '%U %S' "$P" estimate --model "$1" --input "$FRAMES" --loop \
        --n-frames "$3" --threads "$2" >/dev/null; } 2>&1 | tail -n 1)
    t1=$(date +%s.%N)
    echo "$t0 $t1 $c" | awk '{print $2 - $1, $3 + $4}'
}
for m in models/parlight-n3-int8.plm models/parlight-n3.plm; do
    for t in $THREADS; do
        read -r w0 c0 <<<"$(run_e2e "$m" "$t" 20)"
        read -r w1 c1 <<<"$(run_e2e "$m" "$t" $((20 + E2E)))"
        prec=int8
        [ "$m" = models/parlight-n3.plm ] && prec=fp32
        awk -v n="$E2E" -v w0="$w0" -v w1="$w1" -v c0="$c0" -v c1="$c1" -v p="$prec" -v t="$t" \
            'BEGIN { printf "| 96x128 model, %d sample frames | %s | %d | %.1f | %.2f | %.2f |\n",
                     n, p, t, n / (w1 - w0), 1e3 * (w1 - w0) / n, 1e3 * (c1 - c0) / n }'
    done
done
echo "(load $(cut -d' ' -f1-3 /proc/loadavg))"
