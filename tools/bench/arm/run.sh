#!/usr/bin/env bash
# `make bench-arm`: the Raspberry Pi 4, Pi 5 and Jetson Orin frame times predicted on this machine
# (no board needed): tools/bench/arm/predict.py for each board and model, then one table.
# docs/PERFORMANCE.md, "Arm predicted by simulation", has the method and its uncertainty.
#
# Environment: BENCH_ARM_BOARDS (default "rpi4 rpi5 jetson-orin"), BENCH_ARM_MODELS (default: the
# shipped 96x128 int8 model and the seeded 192x256 model's int8 twin, made as `make bench` makes
# it), BENCH_ARM_ISAS (default: each board's BOARD_PREDICT_ISA; e.g. "neon dotprod" predicts
# both paths on each board). Needs qemu-user, gcc-aarch64-linux-gnu and llvm-19
# (tools/install-deps.sh rpi5). Takes ~10 minutes on a 2-core machine (qemu runs each model twice
# per board and path).
set -euo pipefail
cd "$(dirname "$0")/../../.."
BOARDS=${BENCH_ARM_BOARDS:-rpi4 rpi5 jetson-orin}
OUT=build/bench/arm
mkdir -p "$OUT" build/tools
say() { echo "bench-arm: $*" >&2; }

command -v llvm-mca-19 >/dev/null || { say "no llvm-mca-19: tools/install-deps.sh rpi5"; exit 1; }
cc -std=c11 -O2 -Wall -Wextra -shared -fPIC -o build/tools/tbcount.so tools/bench/arm/tbcount.c

if [ -z "${BENCH_ARM_MODELS:-}" ]; then
    make --no-print-directory build/parlight build/models/seeded-n3.plm >&2
    Q=build/bench/seeded-n3-int8.plm
    if [ ! -f "$Q" ]; then
        say "making $Q (parlight quantize, minmax on tests/data/frames, as make bench does)"
        build/parlight quantize --model build/models/seeded-n3.plm --calib tests/data/frames \
            --method minmax --out "$Q.tmp" >&2 && mv "$Q.tmp" "$Q"
    fi
    BENCH_ARM_MODELS="models/parlight-n3-int8.plm $Q"
fi

JSONS=()
for b in $BOARDS; do
    make --no-print-directory BOARD="$b" "build/$b/parlight" >&2
    isas=${BENCH_ARM_ISAS:-$(sed -n 's/^BOARD_PREDICT_ISA *:\?= *\([a-z0-9]*\).*/\1/p' "boards/$b.mk")}
    for isa in $isas; do
        for m in $BENCH_ARM_MODELS; do
            j="$OUT/$b-$isa-$(basename "$m" .plm).json"
            say "$b $isa $m"
            /usr/bin/python3 tools/bench/arm/predict.py --board "$b" --isa "$isa" --model "$m" --json "$j"
            JSONS+=("$j")
        done
    done
done
/usr/bin/python3 tools/bench/arm/predict.py --summary "${JSONS[@]}"
