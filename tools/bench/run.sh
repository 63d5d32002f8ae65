#!/usr/bin/env bash
# `make bench`: parlight against its peers on the same weights and input size, in one run.
#
#   tools/bench/run.sh            (BUILD=build by default; run by `make bench` after the build)
#
# Model: models/parlight-n3.plm when a trained one ships, else build/models/seeded-n3.plm. Its
# int8 twin: the shipped models/parlight-n3-int8.plm with the shipped model (what users run: its
# quantiser options are in its provenance), else made here with `parlight quantize` (minmax,
# calibrated on tests/data/frames).
# Rows, each a median over BENCH_RUNS (default 30) runs after BENCH_WARMUP (default 5) warm-up:
#   parlight  fp32 and int8, 1 and 2 threads    (parlight bench, a fixed synthetic frame)
#   PyTorch   fp32 and int8, 1 and 2 threads    (Debian's python3-torch; tools/bench/peers.py)
#   ONNX Runtime fp32 and int8 QDQ, 1 and 2     (npm onnxruntime-node; tools/bench/ort_bench.js)
# then the peak RSS of `parlight estimate` on the int8 model over tests/data/frames
# (/usr/bin/time -v), and one core's measured VNNI and FMA peak (tools/bench/peak.c) for the
# "here" floor column. tools/bench/report.py prints the table and writes it as JSON into
# build/bench/. A peer that cannot be installed or run gets a row saying why; the rest still runs.
# Environment: BUILD, BENCH_RUNS, BENCH_WARMUP, BENCH_THREADS (default "1,2"), BENCH_MODEL (a
# float .plm instead of the default above; the targets of docs/PERFORMANCE.md are at 192x256).
set -u
cd "$(dirname "$0")/../.."
BUILD=${BUILD:-build}
RUNS=${BENCH_RUNS:-30}
WARMUP=${BENCH_WARMUP:-5}
THREADS=${BENCH_THREADS:-1,2}
OUT=build/bench
P="$BUILD/parlight"
FRAMES=tests/data/frames
ORT_VERSION=1.30.0
PY=/usr/bin/python3
mkdir -p "$OUT"
ROWS="$OUT/rows.jsonl"
: >"$ROWS"
LOG="$OUT/run.log"
: >"$LOG"
say() { echo "bench: $*" >&2; }

# error_rows ENGINE PRECISIONS MESSAGE: one row per precision and thread count saying why
error_rows() {
    local engine=$1 precs=$2 msg=$3 prec n
    for prec in ${precs//,/ }; do
        for n in ${THREADS//,/ }; do
            "$PY" -c 'import json,sys; print(json.dumps({"engine": sys.argv[1], "precision": sys.argv[2],
                "threads": int(sys.argv[3]), "status": sys.argv[4]}))' "$engine" "$prec" "$n" "$msg" >>"$ROWS"
        done
    done
}
# last line of a log, for a row's status
why() { tail -n 1 "$1" 2>/dev/null | cut -c1-200; }

[ -x "$P" ] || { say "no $P: run make first"; exit 1; }
MODEL=${BENCH_MODEL:-models/parlight-n3.plm}
[ -n "${BENCH_MODEL:-}" ] || [ -f "$MODEL" ] || MODEL=build/models/seeded-n3.plm
[ -f "$MODEL" ] || { say "no $MODEL (make build/models/seeded-n3.plm)"; exit 1; }
INT8="$OUT/$(basename "$MODEL" .plm)-int8.plm"
LOAD_START=$(cut -d' ' -f1-3 /proc/loadavg)
T0=$(date +%s)

if [ "$MODEL" = models/parlight-n3.plm ] && [ -f models/parlight-n3-int8.plm ]; then
    INT8=models/parlight-n3-int8.plm
    say "model $MODEL; int8 twin $INT8 (shipped)"
else
    say "model $MODEL; int8 twin $INT8 (parlight quantize, minmax on $FRAMES)"
    if [ ! -f "$INT8" ] || [ "$INT8" -ot "$MODEL" ] || [ "$INT8" -ot "$P" ]; then
        "$P" quantize --model "$MODEL" --calib "$FRAMES" --method minmax --out "$INT8.tmp" \
            >>"$LOG" 2>&1 && mv "$INT8.tmp" "$INT8" ||
            { say "quantize failed: $(why "$LOG")"; rm -f "$INT8.tmp" "$INT8"; }
    fi
fi

# --- parlight ---
for prec in fp32 int8; do
    m=$MODEL
    [ $prec = int8 ] && m=$INT8
    for n in ${THREADS//,/ }; do
        say "parlight $prec, $n thread(s), $RUNS runs"
        if [ -f "$m" ] && timeout 600 "$P" bench --model "$m" --threads "$n" --runs "$RUNS" \
            --warmup "$WARMUP" --json >"$OUT/parlight.json" 2>>"$LOG"; then
            "$PY" -c 'import json,sys; r=json.load(open(sys.argv[1])); r.update(engine="parlight", status="ok"); print(json.dumps(r))' \
                "$OUT/parlight.json" >>"$ROWS"
        else
            error_rows parlight $prec "failed: $(why "$LOG")"
        fi
    done
done

# --- PyTorch (oneDNN's AMX int8 path crashes: keep it on AVX512_CORE_VNNI) ---
say "PyTorch fp32 and int8 (tools/bench/peers.py torch)"
before=$(wc -l <"$ROWS")
ONEDNN_MAX_CPU_ISA=AVX512_CORE_VNNI timeout 900 "$PY" tools/bench/peers.py torch --model "$MODEL" \
    --frames "$FRAMES" --runs "$RUNS" --warmup "$WARMUP" --threads "$THREADS" --out "$ROWS" \
    >/dev/null 2>"$OUT/torch.log"
rc=$?
[ $rc -eq 0 ] || cat "$OUT/torch.log" >>"$LOG"
[ "$(wc -l <"$ROWS")" -gt "$before" ] || error_rows pytorch fp32,int8 "failed (exit $rc): $(why "$OUT/torch.log")"

# --- ONNX Runtime from npm, into a cache under build/ ---
say "ONNX Runtime fp32 and int8 QDQ (onnxruntime-node $ORT_VERSION)"
ORT_DIR="$OUT/npm/node_modules/onnxruntime-node"
ort_ok=1
if ! command -v node >/dev/null 2>&1 || ! command -v npm >/dev/null 2>&1; then
    error_rows onnxruntime fp32,int8 "not run: node/npm missing (tools/install-deps.sh installs them)"
    ort_ok=0
elif [ ! -f "$ORT_DIR/package.json" ] || ! grep -q "\"version\": \"$ORT_VERSION\"" "$ORT_DIR/package.json"; then
    mkdir -p "$OUT/npm"
    if ! ONNXRUNTIME_NODE_INSTALL=skip timeout 300 npm install --prefix "$OUT/npm" --no-audit \
        --no-fund --loglevel=error "onnxruntime-node@$ORT_VERSION" >"$OUT/npm.log" 2>&1; then
        error_rows onnxruntime fp32,int8 "not installed: npm install onnxruntime-node@$ORT_VERSION failed: $(why "$OUT/npm.log")"
        ort_ok=0
    fi
fi
if [ $ort_ok = 1 ]; then
    if ! timeout 300 "$PY" tools/bench/peers.py onnx --model "$MODEL" --frames "$FRAMES" \
        --outdir "$OUT/onnx" >>"$LOG" 2>"$OUT/onnx.log"; then
        error_rows onnxruntime fp32,int8 "ONNX export failed: $(why "$OUT/onnx.log")"
    else
        before=$(wc -l <"$ROWS")
        timeout 900 node tools/bench/ort_bench.js --ort "$ORT_DIR" --onnx "$OUT/onnx" \
            --runs "$RUNS" --warmup "$WARMUP" --threads "$THREADS" >>"$ROWS" 2>"$OUT/ort.log"
        rc=$?
        [ "$(wc -l <"$ROWS")" -gt "$before" ] ||
            error_rows onnxruntime fp32,int8 "failed (exit $rc): $(why "$OUT/ort.log")"
    fi
fi

# --- peak RSS of parlight estimate on the int8 model over the sample frames ---
say "peak RSS: parlight estimate --model $INT8 --input $FRAMES"
RSS_KIB="" BASE_KIB=""
max_rss() { sed -n 's/^[[:space:]]*Maximum resident set size (kbytes): //p' "$1"; }
if [ -f "$INT8" ] && [ -x /usr/bin/time ]; then
    /usr/bin/time -v "$P" estimate --model "$INT8" --input "$FRAMES" >/dev/null 2>"$OUT/time.log" &&
        RSS_KIB=$(max_rss "$OUT/time.log")
    # the process before any model: the executable and its shared libraries (OpenCV's tree)
    /usr/bin/time -v "$P" --help >/dev/null 2>"$OUT/time-base.log" && BASE_KIB=$(max_rss "$OUT/time-base.log")
fi

# --- one core's arithmetic peak (x86-64 with AVX-512 VNNI; elsewhere the column stays empty) ---
PEAK_JSON=""
if ${CC:-cc} -O2 -o "$OUT/peak" tools/bench/peak.c >>"$LOG" 2>&1 && "$OUT/peak" >"$OUT/peak.json" 2>>"$LOG"; then
    PEAK_JSON="$OUT/peak.json"
    say "one core's peak: $(cat "$PEAK_JSON")"
fi

LOAD_END=$(cut -d' ' -f1-3 /proc/loadavg)
"$PY" tools/bench/report.py --rows "$ROWS" --model "$MODEL" --int8 "$INT8" --rss-kib "${RSS_KIB:-}" --base-rss-kib "${BASE_KIB:-}" \
    --load-start "$LOAD_START" --load-end "$LOAD_END" --seconds $(( $(date +%s) - T0 )) \
    --out-dir "$OUT" --peak-json "$PEAK_JSON"
