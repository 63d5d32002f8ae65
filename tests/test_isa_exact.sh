#!/usr/bin/env bash
# The int8 network gives byte-identical JSON (timing and timestamp fields removed) on every
# instruction-set path this CPU runs — PARLIGHT_ISA=ref (the reference kernels), avx2, avxvnni,
# avx512f (AVX-512 without VNNI: the AVX2 int8 kernels), avx512vnni, amx (where the CPU has it) on x86, neon, dotprod, i8mm on Arm (under qemu: the -cpu model decides) — and with 1
# or 2 threads: the SIMD kernels are bit-exact and the work split does
# not change a bit. (The reference path runs once, with 2 threads, as the baseline: it is 60-100x
# slower, and its independence of the thread count is tests/test_quantize.sh's.) Models: int8 quantisations of build/models/seeded-n3.plm (192x256) and, when
# it exists, build/models/seeded-n3-96x128.plm (other block sizes, so other tile remainders),
# calibrated on tests/data/frames, and the 96x128 one again with --keep-float transition3,fc (the
# float transition and fc with int8-stored weights: not ISA-dispatched, but split over threads);
# the frames of tests/data/frames as input (under an emulator, PL_RUNNER set: the plain 96x128
# model and one frame, see below). A path the CPU
# lacks is skipped with a message (parlight estimate says why); at least ref and one SIMD path
# must run. Also `parlight info` names the path and the implementation of every slot, and
# the executor's per-layer observer sees the same activations on every path.
set -u
P="$BUILD/parlight"
T="$PL_TEST_TMP/isa_exact"
mkdir -p "$T"
fail() { echo "FAIL: $*"; exit 1; }
[ -f build/models/seeded-n3.plm ] || fail "no build/models/seeded-n3.plm (make test exports it)"

strip() { sed -E 's/"timing_ms":\{[^}]*\},?//; s/"t_ns":[0-9]+,?//' "$1"; }

MODELS="build/models/seeded-n3.plm build/models/seeded-n3-96x128.plm
        build/models/seeded-n3-96x128.plm:transition3,fc"
FRAMES=tests/data/frames
NFRAMES=5
OBS_MODEL=seeded-n3
THREADS="1 2" # SIMD paths
REF_TH=2
if [ -n "${PL_RUNNER:-}" ]; then
    # Under an emulator (make test BOARD=rpi5: qemu-aarch64) the reference path takes minutes per
    # 192x256 frame: the 96x128 model only (the same layers and tile remainders of other sizes),
    # one frame to estimate and to calibrate on. One thread: qemu-aarch64 7.2 hangs in
    # pthread_create on this machine's kernel (docs/PORTING.md).
    MODELS=build/models/seeded-n3-96x128.plm
    FRAMES=tests/data/frames/lab-lamps.jpg
    NFRAMES=1
    OBS_MODEL=seeded-n3-96x128
    THREADS=1
    REF_TH=1
    [ -f "$MODELS" ] || fail "no $MODELS (make test exports it)"
    echo "under $PL_RUNNER: $MODELS, $FRAMES, one thread"
fi

for MK in $MODELS; do
    M=${MK%%:*}
    [ -f "$M" ] || { echo "no $M, skipped"; continue; }
    Q="$T/$(basename "$M" .plm)-int8.plm"
    kf=()
    if [ "$MK" != "$M" ]; then
        kf=(--keep-float "${MK#*:}")
        Q="$T/$(basename "$M" .plm)-kf-int8.plm"
    fi
    "$P" quantize --model "$M" --calib "$FRAMES" --method minmax "${kf[@]}" --out "$Q" \
        2>"$T/qerr" || fail "quantize $MK: $(cat "$T/qerr")"
    ref=""
    simd=0
    for isa in ref avx2 avxvnni avx512f avx512vnni amx neon dotprod i8mm; do
        ths=$THREADS
        [ "$isa" = ref ] && ths=$REF_TH
        for th in $ths; do
            out="$T/$(basename "$Q" .plm)-$isa-$th.jsonl"
            if ! PARLIGHT_ISA=$isa "$P" estimate --model "$Q" --input "$FRAMES" \
                --threads "$th" >"$out" 2>"$T/err"; then
                grep -q "cannot run it" "$T/err" && [ "$isa" != ref ] ||
                    fail "PARLIGHT_ISA=$isa --threads $th: $(cat "$T/err")"
                echo "skip $isa: $(cat "$T/err")"
                continue 2
            fi
            [ "$(wc -l <"$out")" -eq "$NFRAMES" ] ||
                fail "$isa: $(wc -l <"$out") lines, expected $NFRAMES"
            if [ -z "$ref" ]; then
                ref="$out"
            else
                cmp -s <(strip "$ref") <(strip "$out") ||
                    fail "$(basename "$Q"): PARLIGHT_ISA=$isa --threads $th differs from ref"
            fi
        done
        [ "$isa" = ref ] || simd=$((simd + 1))
        echo "$(basename "$Q") $isa: identical to ref (threads: $ths)"
        # info names the path and the kernel of every slot
        PARLIGHT_ISA=$isa "$P" info --model "$Q" >"$T/info" || fail "info under $isa"
        grep -q "^isa path     $isa" "$T/info" || fail "info under $isa: $(cat "$T/info")"
    done
    [ "$simd" -ge 1 ] || echo "no SIMD path on this CPU: only ref ran"
done
PARLIGHT_ISA=ref "$P" info --model "$Q" | grep -q "nn_conv1x1_clamp_s8__ref" ||
    fail "info on ref does not list nn_conv1x1_clamp_s8__ref"

# the per-layer observer (calibration, qcheck's SQNR per layer) sees the same int8 activations on
# every path and thread count (tests/observe_dump.c hashes each observed layer)
Q="$T/$OBS_MODEL-int8.plm"
PARLIGHT_ISA=ref "$BUILD/tests/observe_dump" "$Q" $REF_TH >"$T/obs-ref" 2>"$T/err" ||
    fail "observe_dump under ref: $(cat "$T/err")"
[ "$(wc -l <"$T/obs-ref")" -eq 122 ] || fail "observe_dump: $(wc -l <"$T/obs-ref") layers, expected 122"
for isa in avx2 avxvnni avx512f avx512vnni amx neon dotprod i8mm; do
    for th in $THREADS; do
        PARLIGHT_ISA=$isa "$BUILD/tests/observe_dump" "$Q" $th >"$T/obs" 2>"$T/err" ||
            { echo "observer: skip $isa: $(cat "$T/err")"; continue 2; }
        cmp -s "$T/obs-ref" "$T/obs" || fail "observed layers under $isa ($th threads) differ from ref"
    done
    echo "observer $isa: identical to ref"
done

# AVX-512 without VNNI (a Skylake-SP; forced here with PARLIGHT_ISA=avx512f) runs the AVX-512 fp32
# kernels, which need only AVX-512F: the float model's output equals avx512vnni's, and info names
# them (tests/test_isa.c checks the selection for CPUs this machine is not)
F=build/models/seeded-n3.plm
[ -n "${PL_RUNNER:-}" ] && F=build/models/seeded-n3-96x128.plm
if PARLIGHT_ISA=avx512f "$P" info --model "$F" >"$T/info-f" 2>"$T/err"; then
    grep -q "nn_conv_gemm_f32_8x48__avx512f" "$T/info-f" ||
        fail "avx512f does not run the AVX-512 fp32 GEMM: $(cat "$T/info-f")"
    for isa in avx512f avx512vnni; do
        PARLIGHT_ISA=$isa "$P" estimate --model "$F" --input "$FRAMES" >"$T/f32-$isa.jsonl" ||
            fail "float estimate under $isa"
    done
    cmp -s <(strip "$T/f32-avx512f.jsonl") <(strip "$T/f32-avx512vnni.jsonl") ||
        fail "float model: avx512f differs from avx512vnni (the same fp32 kernels)"
    echo "avx512f: the AVX-512F fp32 kernels, float output identical to avx512vnni's"
else
    echo "skip avx512f fp32: $(cat "$T/err")"
fi
