#!/usr/bin/env bash
# Boots the camera rig (a QEMU guest with Debian's kernel and the vivid V4L2 driver), runs
# `parlight cameras` and `parlight estimate --camera v4l2:/dev/video0:640x480` inside it, and
# prints parlight's JSON lines on stdout. Timings and the guest's other output go to stderr.
#
#   tools/camrig/run.sh --backend v4l2 [--frames N] [--precision fp32|int8] [--model FILE]
#                       [--suite basic|full] [--build DIR] [--results FILE] [--timeout S]
#                       [--accel tcg|kvm] [--smp N] [--compress none|gzip] [--share none|9p]
#                       [--no-build]
#   tools/camrig/run.sh --frames DIR --backend v4l2|libcamera|both [--n-frames N] [...]
#
#   --frames N     frames to estimate (default 3)
#   --frames DIR   the UVC webcam instead of vivid: tools/camrig/uvc-gadget streams DIR's images
#                  (one size, even width) as YUYV (and MJPEG when they are JPEGs) over USB
#                  (dummy_hcd + gadgetfs), uvcvideo binds it, parlight estimates N frames
#                  (--n-frames, default 2) through the backend(s) (v4l2: YUYV, then MJPEG if
#                  offered), then the same frames read as files ("source" "dir:..."): the YUYV
#                  round trip of DIR and (v4l2) DIR's JPEGs. Build outputs in BUILD/camrig-uvc;
#                  env CAMRIG_LIBCAMERA_LOG=LEVELS sets LIBCAMERA_LOG_LEVELS in the guest,
#                  CAMRIG_RACE_DELAY_US=N uvc-gadget's --race-delay-us (a test aid)
#   --suite full   also the error cases and an unplug mid-stream (tests/test_camera_vivid.sh)
#   --results FILE keep the guest's result stream there (protocol: tools/camrig/init.sh)
#   --timeout S    wall-clock limit for the whole VM run (default 200)
#   --smp N        guest CPUs, also parlight's --threads (default 2: TCG runs one host thread
#                  per CPU; 2 cut inference from ~27 s to ~17 s a frame here)
#   --share 9p     parlight, its libraries and the model on a read-only virtio-9p share instead
#                  of the initramfs (docs/CAMERAS.md compares the two)
#   --accel        tcg (default: software emulation; /dev/kvm on these machines is PVM and
#                  cannot boot the guest) or kvm
#
# Exit status: the guest's (that of the estimate step); 1 when the guest did not finish;
# 3 when the VM could not start at all (no qemu, or qemu refused to run).
set -euo pipefail
cd "$(dirname "$0")/../.."

BACKEND="" FRAMES=3 PRECISION=fp32 MODEL="" SUITE=basic BUILD_DIR=${BUILD:-build}
RESULTS="" TIMEOUT=200 ACCEL=tcg COMPRESS=none DO_BUILD=1 SMP=2 SHARE=none N_FRAMES=2 UVC_DIR=""
while [ $# -gt 0 ]; do
    case "$1" in
        --backend) BACKEND=$2; shift 2 ;;
        --frames) FRAMES=$2; shift 2 ;;
        --n-frames) N_FRAMES=$2; shift 2 ;;
        --precision) PRECISION=$2; shift 2 ;;
        --model) MODEL=$2; shift 2 ;;
        --suite) SUITE=$2; shift 2 ;;
        --build) BUILD_DIR=$2; shift 2 ;;
        --results) RESULTS=$2; shift 2 ;;
        --timeout) TIMEOUT=$2; shift 2 ;;
        --accel) ACCEL=$2; shift 2 ;;
        --smp) SMP=$2; shift 2 ;;
        --compress) COMPRESS=$2; shift 2 ;;
        --share) SHARE=$2; shift 2 ;;
        --no-build) DO_BUILD=0; shift ;;
        -h|--help) sed -n '2,29p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
        *) echo "camrig: unknown argument '$1' (see --help)" >&2; exit 2 ;;
    esac
done
usage() { echo "camrig: $*" >&2; exit 2; }
if [ -d "$FRAMES" ]; then
    UVC_DIR=$FRAMES
    FRAMES=$N_FRAMES
    case "$BACKEND" in v4l2|libcamera|both) ;; *) usage "--backend v4l2|libcamera|both is required" ;; esac
    [ "$SHARE" = none ] || usage "--frames DIR works with --share none only"
else
    [ "$BACKEND" = v4l2 ] || usage "--backend v4l2 is required for vivid (libcamera: with --frames DIR)"
fi
[[ "$FRAMES" =~ ^[1-9][0-9]{0,3}$ ]] || usage "--frames: expected 1..9999, got '$FRAMES'"
[[ "$TIMEOUT" =~ ^[1-9][0-9]{0,3}$ ]] || usage "--timeout: expected seconds, got '$TIMEOUT'"
[[ "$SMP" =~ ^[1-8]$ ]] || usage "--smp: expected 1..8, got '$SMP'"
case "$SUITE" in basic|full) ;; *) usage "--suite basic|full" ;; esac
case "$ACCEL" in tcg|kvm) ;; *) usage "--accel tcg|kvm" ;; esac
case "$SHARE" in none|9p) ;; *) usage "--share none|9p" ;; esac
if [ -z "$MODEL" ]; then
    case "$PRECISION" in
        fp32) MODEL=build/models/seeded-n3.plm ;;
        int8) MODEL=build/models/seeded-n3-int8.plm ;;
        *) usage "--precision fp32|int8" ;;
    esac
    # the int8 model: the seeded float model quantised on the sample frames, made when missing
    if [ "$PRECISION" = int8 ] && [ ! -f "$MODEL" ]; then
        [ -f build/models/seeded-n3.plm ] || make --no-print-directory build/models/seeded-n3.plm >&2
        "$BUILD_DIR/parlight" quantize --model build/models/seeded-n3.plm --calib tests/data/frames \
            --method percentile --out "$MODEL" >&2 || { echo "camrig: cannot make $MODEL" >&2; exit 1; }
    fi
fi

command -v qemu-system-x86_64 >/dev/null 2>&1 || {
    echo "camrig: qemu-system-x86_64 not found (tools/install-deps.sh installs qemu-system-x86)" >&2
    exit 3
}
OUT=$BUILD_DIR/camrig
UVC_ARGS=()
if [ -n "$UVC_DIR" ]; then
    OUT=$BUILD_DIR/camrig-uvc
    UVC_ARGS=(--frames "$UVC_DIR")
fi
if [ $DO_BUILD = 1 ]; then
    tools/camrig/build.sh --build "$BUILD_DIR" --model "$MODEL" --compress "$COMPRESS" \
        --share "$SHARE" "${UVC_ARGS[@]}" >/dev/null
fi
VMLINUX=$OUT/vmlinux
INITRD=$OUT/initramfs.cpio
[ "$COMPRESS" = gzip ] && INITRD=$OUT/initramfs.cpio.gz
[ -f "$VMLINUX" ] && [ -f "$INITRD" ] || { echo "camrig: $VMLINUX or $INITRD missing (build.sh)" >&2; exit 1; }

CPU=max # TCG: every feature it emulates (AVX2 included); KVM: the host's
[ "$ACCEL" = kvm ] && CPU=host
SHARE_ARGS=()
if [ "$SHARE" = 9p ]; then
    [ -d "$OUT/share" ] || { echo "camrig: $OUT/share missing (build.sh --share 9p)" >&2; exit 1; }
    SHARE_ARGS=(-virtfs "local,path=$OUT/share,mount_tag=plshare,security_model=none,readonly=on")
fi
RES=$OUT/results.txt
CONSOLE=$OUT/console.log
QERR=$OUT/qemu.err
: >"$RES"
: >"$CONSOLE"
start=$(date +%s%N)
first_json_ms=""
# Console (ttyS0) to a file; the result stream (ttyS1) to our stdout, read line by line so that
# the host can time the first JSON line.
while IFS= read -r line; do
    line=${line%$'\r'}
    printf '%s\n' "$line" >>"$RES"
    case "$line" in
        "@@BEGIN estimate"*) in_est=1 ;;
        "@@END "*) in_est=0 ;;
        "O {"*) if [ "${in_est:-0}" = 1 ]; then
                    last_json_ms=$((($(date +%s%N) - start) / 1000000))
                    [ -n "$first_json_ms" ] || first_json_ms=$last_json_ms
                    n_json=$((${n_json:-0} + 1))
                fi ;;
    esac
done < <(set +e; timeout -k 5 "$TIMEOUT" qemu-system-x86_64 -accel "$ACCEL" -cpu "$CPU" -smp "$SMP" -m 1536 \
    -nodefaults -no-user-config -display none -no-reboot \
    -kernel "$VMLINUX" -initrd "$INITRD" "${SHARE_ARGS[@]}" \
    -append "console=ttyS0 quiet loglevel=3 panic=-1 camrig.frames=$FRAMES camrig.suite=$SUITE camrig.threads=$SMP camrig.backend=$BACKEND${CAMRIG_LIBCAMERA_LOG:+ camrig.libcamera_log=$CAMRIG_LIBCAMERA_LOG}${CAMRIG_RACE_DELAY_US:+ camrig.race_delay_us=$CAMRIG_RACE_DELAY_US}" \
    -serial "file:$CONSOLE" -serial stdio </dev/null 2>"$QERR"; echo "@@QEMU $?")
wall_ms=$((($(date +%s%N) - start) / 1000000))
[ -n "$RESULTS" ] && cp "$RES" "$RESULTS"

qemu_rc=$(sed -n 's/^@@QEMU //p' "$RES" | tail -n 1)
if ! grep -q '^@@UPTIME init' "$RES"; then
    # qemu itself refusing to run (status != 0 and a complaint, no timeout) is "cannot start";
    # a guest that boots but never reaches /init (panic, hang) is a failure of the rig.
    if [ "${qemu_rc:-1}" != 0 ] && [ "${qemu_rc:-1}" != 124 ] && [ -s "$QERR" ]; then
        echo "camrig: the VM did not start (qemu status ${qemu_rc:-?}): $(head -n 3 "$QERR")" >&2
        exit 3
    fi
    echo "camrig: the guest never reached /init (qemu status ${qemu_rc:-?}, ${wall_ms} ms); console $CONSOLE:" >&2
    tail -n 20 "$CONSOLE" >&2 || true
    exit 1
fi

# JSON lines of the estimate step on stdout; everything else on stderr.
awk '/^@@BEGIN estimate/ {on=1; next} /^@@END / {on=0} on && /^O / {print substr($0, 3)}' "$RES"
# (the cameras listing shortened to its device lines and usable formats: vivid offers 83 formats)
awk '/^@@BEGIN / {name=$2} /^@@END / {name=""}
    name == "cameras" && /^O / && !/^O (\/dev|libcamera|V4L2|  *\[)|usable/ {next}
    name !~ /^estimate/ && /^[OE] / || name ~ /^estimate/ && /^E / {print "  [" name "] " substr($0, 3)}' "$RES" >&2
guest_rc=$(sed -n 's/^@@EXIT //p' "$RES" | tail -n 1)
up() { sed -n "s/^@@UPTIME $1 //p" "$RES" | tail -n 1; }
host_fps=n/a
if [ "${n_json:-0}" -gt 1 ] && [ "$last_json_ms" -gt "$first_json_ms" ]; then
    host_fps=$(awk -v n="$n_json" -v a="$first_json_ms" -v b="$last_json_ms" 'BEGIN {printf "%.3f", (n - 1) / ((b - a) / 1000)}')
fi
fps=$(awk '/^@@BEGIN estimate$/ {on=1; next} /^@@END / {on=0}
    on && /^O \{/ {match($0, /"t_ns":[0-9]+/); t = substr($0, RSTART + 7, RLENGTH - 7) + 0;
        if (n == 0) t0 = t; t1 = t; n++}
    END {if (n > 1 && t1 > t0) printf "%.2f", (n - 1) / ((t1 - t0) / 1e9); else print "n/a"}' "$RES")
{
    echo "camrig: accel $ACCEL, initramfs $(stat -c %s "$INITRD") bytes ($COMPRESS), share $SHARE, wall ${wall_ms} ms"
    line="camrig: guest uptime: /init at $(up init) s"
    [ "$SHARE" = 9p ] && line+=", 9p share mounted at $(up share) s"
    if [ -n "$UVC_DIR" ]; then
        line+=", gadgetfs at $(up gadgetfs) s, uvcvideo's /dev/video0 at $(up uvc) s"
        [ "$BACKEND" = libcamera ] || line+=", v4l2 estimate done at $(up v4l2) s"
        [ "$BACKEND" = v4l2 ] || line+=", libcamera estimate done at $(up libcamera) s"
    else
        line+=", vivid loaded at $(up vivid) s"
    fi
    [ "$SUITE" = full ] && line+=", full checks done at $(up checks) s"
    echo "$line, all done at $(up done) s"
    echo "camrig: boot to first JSON line ${first_json_ms:-n/a} ms (host wall); ${n_json:-0} JSON lines, ${host_fps} frames/s through the rig (host arrival times), ${fps} frames/s by the frames' driver timestamps"
} >&2
if [ -z "$guest_rc" ]; then
    echo "camrig: the guest did not finish (qemu status ${qemu_rc:-?}); console: $CONSOLE" >&2
    tail -n 20 "$CONSOLE" >&2 || true
    exit 1
fi
exit "$guest_rc"
