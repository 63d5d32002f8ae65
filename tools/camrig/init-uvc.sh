#!/bin/sh
# /init of the camera rig's UVC guest (tools/camrig/build.sh --frames DIR copies it into the
# initramfs). Makes a USB webcam out of files: dummy_hcd (a virtual USB controller and its host
# side in one), gadgetfs and tools/camrig/uvc-gadget streaming /opt/parlight/frames; the real
# uvcvideo driver binds it as /dev/video0. Then parlight reads it through V4L2 (YUYV and MJPEG)
# and/or libcamera, and estimates from the same frames read as files (/opt/parlight/expected: what
# a YUYV reader sees; /opt/parlight/frames: the JPEGs the MJPEG stream carries). Same result protocol on /dev/ttyS1 as tools/camrig/init.sh (@@UPTIME, @@BEGIN/@@END with
# O/E lines, @@EXIT). Kernel command line: camrig.frames=N (frames per camera estimate, default 2),
# camrig.backend=v4l2|libcamera|both (default both), camrig.threads=N.
export PATH=/bin:/sbin
mount -t proc proc /proc
mount -t sysfs sysfs /sys
mount -t devtmpfs devtmpfs /dev
mount -t tmpfs tmpfs /tmp
mount -t tmpfs tmpfs /run
echo 1 >/proc/sys/kernel/printk
OUT=/dev/ttyS1
stty -F $OUT raw -echo 2>/dev/null
emit() { echo "$*" >$OUT; }
up() { emit "@@UPTIME $1 $(cut -d' ' -f1 /proc/uptime)"; }
finish() {
    emit "@@EXIT $1"
    sync
    poweroff -f
    sleep 5
}
up init

frames=2
threads=1
backend=both
for a in $(cat /proc/cmdline); do
    case "$a" in
        camrig.frames=*) frames=${a#*=} ;;
        camrig.backend=*) backend=${a#*=} ;;
        camrig.threads=*) threads=${a#*=} ;;
        camrig.libcamera_log=*) LIBCAMERA_LOG_LEVELS=${a#*=} ;;
        camrig.race_delay_us=*) race="--race-delay-us ${a#*=}" ;;
    esac
done

# usbcore autosuspend=-1: no runtime suspend of the idle webcam between parlight's runs (a
# control request right after the resume fails through dummy_hcd + gadgetfs)
while read -r m; do
    arg=
    case "$m" in */usbcore.ko*) arg=autosuspend=-1 ;; esac
    insmod "$m" $arg || { emit "@@ERROR insmod $m failed"; finish 1; }
done </modules.list

# libcamera's UVC pipeline names a camera after the firmware node of its USB controller
# (<controller>/firmware_node/path, ACPI) and fails without one ("Can not find controller ID").
# dummy_hcd's platform device has none and sysfs cannot be written: overlay its directory with a
# tmpfs that holds firmware_node/path and bind mounts of every real entry.
C=/sys/devices/platform/dummy_hcd.0
if [ -d $C ]; then
    mkdir -p /tmp/real-hcd
    mount --bind $C /tmp/real-hcd
    mount -t tmpfs tmpfs $C
    for e in /tmp/real-hcd/* /tmp/real-hcd/.[!.]*; do
        [ -e "$e" ] || [ -L "$e" ] || continue
        n=${e#/tmp/real-hcd/}
        if [ -L "$e" ]; then
            ln -s "$(readlink "$e")" "$C/$n"
        elif [ -d "$e" ]; then
            mkdir "$C/$n" && mount --bind "$e" "$C/$n"
        else
            : >"$C/$n" && mount --bind "$e" "$C/$n"
        fi
    done
    mkdir -p $C/firmware_node
    echo '\_SB_.PCI0.DUMMY' >$C/firmware_node/path
fi

mkdir -p /dev/gadget
mount -t gadgetfs gadgetfs /dev/gadget || { emit "@@ERROR cannot mount gadgetfs"; finish 1; }
up gadgetfs
P=/opt/parlight/parlight
M=/opt/parlight/model.plm
/opt/parlight/uvc-gadget --verbose ${race:-} --fps 5 /opt/parlight/frames 2>/tmp/gadget.err &
for i in $(seq 1 100); do
    [ -e /dev/video0 ] && [ -e /dev/media0 ] && break
    usleep 100000
done
if [ ! -e /dev/video0 ]; then
    emit "@@BEGIN gadget"
    sed 's/^/E /' /tmp/gadget.err >$OUT
    dmesg | tail -n 20 | sed 's/^/E /' >$OUT
    emit "@@END gadget 1"
    emit "@@ERROR uvcvideo made no /dev/video0"
    finish 1
fi
up uvc
# The udev database that libcamera's device enumerator (libudev) consults: "initialized" entries
# for every video and media node (there is no udevd here).
mkdir -p /run/udev/data
for d in /sys/class/video4linux/* /sys/bus/media/devices/*; do
    [ -f "$d/dev" ] && echo I:1 >/run/udev/data/c$(cat "$d/dev")
done

# step NAME CMD...: runs CMD under STEP_TIMEOUT, relays its output and status once it is done.
# step_format_retry NAME CMD...: the same, but runs CMD once more when the first run ended with
# the driver choosing another format than the one asked for: the gadget's known race
# (uvc-gadget.c, SET_CUR overtaken: the host's PROBE data is lost and the device answers with its
# previous format). parlight's error there is right; the second run's output is the step's, with
# a note of the retry on its stderr.
STEP_TIMEOUT=400 # s; a hang guard: TCG on a loaded host is 5x slower than idle
step() { run_step 0 "$@"; }
step_format_retry() { run_step 1 "$@"; }
run_step() {
    retry=$1
    name=$2
    shift 2
    emit "@@BEGIN $name"
    timeout $STEP_TIMEOUT "$@" >/tmp/out 2>/tmp/err
    rc=$?
    if [ "$retry" = 1 ] && [ $rc != 0 ] && grep -q 'the driver set' /tmp/err; then
        first=$(cat /tmp/err)
        timeout $STEP_TIMEOUT "$@" >/tmp/out 2>/tmp/err
        rc=$?
        echo "(retried once: the first run said: $first)" >>/tmp/err
    fi
    sed 's/^/O /' /tmp/out >$OUT
    sed 's/^/E /' /tmp/err >$OUT
    emit "@@END $name $rc"
}

step cameras $P cameras
# the device's one frame size, and whether it offers MJPEG (all its files are JPEGs)
size=$(grep -o '[0-9]*x[0-9]* @' /tmp/out | head -n 1 | cut -d' ' -f1)
mjpeg=$(grep -c 'MJPG' /tmp/out)
status=0
# --smooth 1: no temporal filter, so each JSON line is that frame's own estimate
if [ "$backend" = v4l2 ] || [ "$backend" = both ]; then
    step_format_retry estimate-v4l2 $P estimate --model $M --camera v4l2:/dev/video0 --n-frames "$frames" \
        --threads "$threads" --smooth 1
    [ $rc = 0 ] || status=$rc
    # MJPEG: the device sends the JPEG files' own bytes
    if [ "$mjpeg" -gt 0 ]; then
        step_format_retry estimate-v4l2-mjpeg $P estimate --model $M --camera v4l2:/dev/video0:$size:mjpeg \
            --n-frames "$frames" --threads "$threads" --smooth 1
        [ $rc = 0 ] || status=$rc
    fi
    up v4l2
fi
if [ "$backend" = libcamera ] || [ "$backend" = both ]; then
    step libcamera-bad-id $P estimate --model $M --camera libcamera:nope --n-frames 1
    step libcamera-bad-index $P estimate --model $M --camera libcamera:3 --n-frames 1
    step estimate-libcamera env ${LIBCAMERA_LOG_LEVELS:+LIBCAMERA_LOG_LEVELS=$LIBCAMERA_LOG_LEVELS} $P estimate --model $M --camera libcamera --n-frames "$frames" \
        --threads "$threads" --smooth 1
    [ $rc = 0 ] || status=$rc
    up libcamera
fi
step estimate-files $P estimate --model $M --input /opt/parlight/expected --threads "$threads"
[ $rc = 0 ] || status=$rc
if { [ "$backend" = v4l2 ] || [ "$backend" = both ]; } && [ "$mjpeg" -gt 0 ]; then
    step estimate-files-jpeg $P estimate --model $M --input /opt/parlight/frames --threads "$threads"
    [ $rc = 0 ] || status=$rc
fi
# the device's log, without its one line per control request (counted instead)
emit "@@BEGIN gadget"
grep -v ': setup ' /tmp/gadget.err | sed 's/^/E /' >$OUT
emit "E uvc-gadget: $(grep -c ': setup ' /tmp/gadget.err) control requests"
emit "@@END gadget 0"
up done
finish $status
