#!/usr/bin/env bash
# Trains the shipped recipe on a remote GPU from a pack_dataset.py pack, inside one job of bounded
# time, and leaves each finished network in OUT as pack_dataset.py pack-net parts, with one log
# (docs/TRAINING.md, "Training on a remote GPU"). Seeds run side by side.
#
#   tools/train/remote_run.sh PACK OUT SEED [SEED...]
#
# Env: INPUT (default 192x256), BUDGET (seconds for the whole job, default 555: what is still
# training then is stopped, and the log says how far it got), DEVICE (cuda), EXTRA (more
# train.py flags for both steps; later flags win, e.g. "--step1-epochs 20"), P (python3),
# WORK (scratch, default a new folder under /tmp). The recipe: step 1 30 epochs with the map
# head from the pack's encoder (from scratch when the pack has none), step 2 on the indoor
# crops 20 epochs (MODEL_CARD.md, "The map head, a second pair").
set -u
[ $# -ge 3 ] || { echo "usage: $0 PACK OUT SEED [SEED...]" >&2; exit 2; }
PACK=$1 OUT=$2
shift 2
cd "$(dirname "$0")/../.."
T0=$(date +%s)
el() { echo $(($(date +%s) - T0)); }
P=${P:-python3}
W=${WORK:-$(mktemp -d /tmp/pl-remote.XXXXXX)}
L=$OUT/logs.txt
export PYTHONUNBUFFERED=1
mkdir -p "$OUT" "$W" || exit 1
{
    nvidia-smi -L 2>/dev/null
    "$P" -c 'import torch; print("torch", torch.__version__, "cuda", torch.cuda.is_available())'
    echo "cpus $(nproc)"
} >>"$L" 2>&1
init=()
if [ -f "$PACK/encoder.pt.xz" ]; then
    init=(--init "$W/encoder.pt")
    "$P" tools/train/pack_dataset.py unpack "$PACK" --out "$W/data" --init-out "$W/encoder.pt"
else
    "$P" tools/train/pack_dataset.py unpack "$PACK" --out "$W/data"
fi >>"$L" 2>&1 || { cat "$L"; exit 1; }
echo "unpacked at $(el) s" >>"$L"
C=(--data "$W/data" --input "${INPUT:-192x256}" --batch 16 --step1-epochs 30 --halve-every 10
   --bf16 --threads 3 --val-panos 0 --w-d1 20 --step2-loss render --device "${DEVICE:-cuda}")
# shellcheck disable=SC2206  # EXTRA is a list of flags
X=(${EXTRA:-})
arm() {
    local s=$1 g=$W/g$1
    "$P" tools/train/train.py "${C[@]}" --seed "$s" --ckpt-dir "$g/s1" --log "$g.log" \
        --step2-epochs 0 --w-map 1 "${init[@]}" "${X[@]}" >"$g.out" 2>&1 &&
    "$P" tools/train/train.py "${C[@]}" --seed "$s" --ckpt-dir "$g/s2" --log "$g.log" \
        --step2-epochs 20 --step2-from "$g/s1/step1.pt" --train-scenes indoor "${X[@]}" \
        >>"$g.out" 2>&1 &&
    "$P" tools/train/pack_dataset.py pack-net "$g/s2/final.pt" "$OUT/g$s" >>"$g.out" 2>&1
    echo "seed $s ended with status $? at $(el) s" >>"$g.out"
}
pids=()
for s in "$@"; do
    arm "$s" &
    pids+=($!)
done
# the deadline and a line a minute (GPU use, each run's last log line); each kills its own sleep
# when killed, so nothing outlives the job
(
    trap 'kill $sp 2>/dev/null; exit 0' TERM
    sleep $((${BUDGET:-555} - $(el))) & sp=$!
    wait $sp
    echo "budget reached at $(el) s: stopping what still trains"
    pkill -f "train.py .*--ckpt-dir $W/"
) >>"$L" 2>&1 &
dl=$!
(
    trap 'kill $sp 2>/dev/null; exit 0' TERM
    while :; do
        sleep 60 & sp=$!
        wait $sp
        echo "t=$(el) s $(nvidia-smi --query-gpu=utilization.gpu,memory.used \
            --format=csv,noheader 2>/dev/null) $(for s in "$@"; do tail -n 1 "$W/g$s.log" \
            2>/dev/null | cut -c 1-150; done | tr '\n' '|')"
    done
) >>"$L" 2>&1 &
mon=$!
wait "${pids[@]}"
kill "$dl" "$mon" 2>/dev/null
for s in "$@"; do
    echo "== seed $s"
    cat "$W/g$s.log"
    tail -n 5 "$W/g$s.out"
done >>"$L" 2>&1
echo "total $(el) s" >>"$L"
ls -l "$OUT" >>"$L"
tail -c 11000 "$L"
