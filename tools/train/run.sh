#!/usr/bin/env bash
# The real training run (models/MODEL_CARD.md): train.py in the background under nohup and
# nice -n 10, checkpointing to $CACHE/train-ckpt, one line per epoch in $CACHE/train-log.txt,
# stdout/stderr in $CACHE/train-nohup.txt, exporting $CACHE/parlight-n3-96x128.plm at the end.
# One torch thread: on the shared 2-core machine two threads cost 10x the CPU time per step
# (measured: 0.54 CPU-s/step with 1 thread, 2.6-7.2 with 2, load average 11).
# Rerun this script to resume after a stop (it refuses while the run is alive: $CACHE/train.pid).
# The dataset must exist: tools/train/make_dataset.py --out $CACHE/train-data --crops-per-pano 48.
# Env: CACHE (default /work/cache); extra arguments go to train.py.
set -eu
cd "$(dirname "$0")/../.."
CACHE=${CACHE:-/work/cache}
PID=$CACHE/train.pid
if [ -f "$PID" ] && kill -0 "$(cat "$PID")" 2>/dev/null &&
    grep -q "train.py" "/proc/$(cat "$PID")/cmdline" 2>/dev/null; then
    echo "run.sh: training is running already (pid $(cat "$PID"))" >&2
    exit 1
fi
[ -f "$CACHE/train-data/index.tsv" ] || {
    echo "run.sh: no $CACHE/train-data/index.tsv (make the dataset first)" >&2; exit 1; }
nohup nice -n 10 /usr/bin/python3 tools/train/train.py --data "$CACHE/train-data" \
    --ckpt-dir "$CACHE/train-ckpt" --log "$CACHE/train-log.txt" --input 96x128 --batch 16 \
    --step1-epochs 40 --step2-epochs 20 --halve-every 10 --bf16 --threads 1 \
    --export "$CACHE/parlight-n3-96x128.plm" "$@" >>"$CACHE/train-nohup.txt" 2>&1 &
echo $! >"$PID"
echo "run.sh: training started (pid $!), log $CACHE/train-log.txt"
