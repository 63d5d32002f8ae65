#!/bin/sh
# /init of the camera rig's guest (tools/camrig/build.sh copies it into the initramfs).
# Loads vivid, runs parlight against it and reports on the second serial port (/dev/ttyS1), which
# the host reads (tools/camrig/run.sh). Protocol, one item per line:
#   @@UPTIME <what> <seconds since boot>
#   @@BEGIN <step>          then the step's output: "O <stdout line>" / "E <stderr line>"
#   @@END <step> <exit status>
#   @@EXIT <status>         last line: the status of the main `estimate` step (the host's test
#                           judges the other steps from their output)
# Kernel command line: camrig.frames=N (default 3), camrig.suite=basic|full (default basic),
# camrig.threads=N (parlight estimate --threads, default 1).
export PATH=/bin:/sbin
mount -t proc proc /proc
mount -t sysfs sysfs /sys
mount -t devtmpfs devtmpfs /dev
mount -t tmpfs tmpfs /tmp
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

frames=3
threads=1
suite=basic
for a in $(cat /proc/cmdline); do
    case "$a" in
        camrig.frames=*) frames=${a#*=} ;;
        camrig.suite=*) suite=${a#*=} ;;
        camrig.threads=*) threads=${a#*=} ;;
    esac
done

while read -r m; do
    insmod "$m" || { emit "@@ERROR insmod $m failed"; finish 1; }
done </modules.list
for i in 1 2 3 4 5 6 7 8 9 10 11 12 13 14 15 16 17 18 19 20; do
    [ -e /dev/video0 ] && break
    usleep 100000
done
[ -e /dev/video0 ] || { emit "@@ERROR vivid made no /dev/video0"; finish 1; }
up vivid

# parlight and its libraries: in the initramfs, or on the host's read-only 9p share (run through
# the share's dynamic loader, since the libraries are not at their usual paths).
P=/opt/parlight/parlight
CTL=/opt/parlight/vivid_ctl
M=/opt/parlight/model.plm
if [ -f /share.mode ]; then
    mkdir -p /share
    mount -t 9p -o trans=virtio,version=9p2000.L,ro,cache=loose plshare /share ||
        { emit "@@ERROR cannot mount the 9p share"; finish 1; }
    LD="/share/lib64/ld-linux-x86-64.so.2 --library-path $(sed 's|^|/share|' /share/ldpath | tr '\n' ':')"
    P="$LD /share/opt/parlight/parlight"
    CTL="$LD /share/opt/parlight/vivid_ctl"
    M=/share/opt/parlight/model.plm
    up share
fi
# step NAME CMD...: runs CMD under a timeout, relays its output and status once it is done.
step() {
    name=$1
    shift
    emit "@@BEGIN $name"
    timeout 120 "$@" >/tmp/out 2>/tmp/err
    rc=$?
    sed 's/^/O /' /tmp/out >$OUT
    sed 's/^/E /' /tmp/err >$OUT
    emit "@@END $name $rc"
}
# estimate [--unplug]: parlight estimate on vivid, its JSON lines relayed as they come (the host
# times the first one). --unplug presses vivid's "Disconnect" button (a USB unplug until every
# handle is closed) while the first frame is being estimated: parlight must say so, reopen and
# go on.
estimate() {
    emit "@@BEGIN estimate"
    rm -f /tmp/est /tmp/rc
    (
        timeout 170 $P estimate --model $M --camera v4l2:/dev/video0:640x480 --n-frames "$frames" \
            --threads "$threads" 2>/tmp/err
        echo $? >/tmp/rc
    ) | while IFS= read -r l; do
        echo "O $l" >$OUT
        echo "$l" >>/tmp/est
    done &
    pid=$!
    if [ "$1" = --unplug ]; then
        # Once parlight streams (it holds /dev/video0 open and its first frame is being
        # estimated), unplug: its next read must find the device gone.
        n=0
        while [ $n -lt 1200 ]; do
            ls -l /proc/[0-9]*/fd 2>/dev/null | grep -q /dev/video0 && break
            usleep 100000
            n=$((n + 1))
        done
        usleep 1500000
        if $CTL /dev/video0 Disconnect 2>>/tmp/err; then
            emit "@@UNPLUGGED $(cut -d' ' -f1 /proc/uptime)"
        fi
    fi
    wait $pid
    rc=$(cat /tmp/rc 2>/dev/null || echo 255)
    sed 's/^/E /' /tmp/err >$OUT
    emit "@@END estimate $rc"
}

step cameras $P cameras
if [ "$suite" = full ]; then
    # The conversions through the real driver, without the model: vivid draws the same test
    # pattern in every format, so the mean colours must agree.
    step grab-yuyv $P cameras --grab v4l2:/dev/video0:640x480:yuyv --frames 4
    step grab-nv12 $P cameras --grab v4l2:/dev/video0:640x480:nv12 --frames 4
    step grab-rgb24 $P cameras --grab v4l2:/dev/video0:640x480@25:rgb24 --frames 4
    step missing $P estimate --model $M --camera v4l2:/dev/video9 --n-frames 1
    step not-capture $P estimate --model $M --camera v4l2:/dev/video1 --n-frames 1
    step no-format $P estimate --model $M --camera v4l2:/dev/video0:640x480:mjpeg --n-frames 1
    step bad-size $P estimate --model $M --camera v4l2:/dev/video0:641x479 --n-frames 1
    step bad-spec-1 $P estimate --model $M --camera v4l2:/dev/video0:640x --n-frames 1
    step bad-spec-2 $P estimate --model $M --camera v4l2:video0 --n-frames 1
    step bad-spec-3 $P estimate --model $M --camera v4l2:/dev/video0:640x480:bgr24 --n-frames 1
    # A camera that stays unplugged: vivid_ctl keeps the disconnected device open for 13 s, so
    # it cannot come back; the reopen attempts must fail and give up after 10 s, exit 1.
    emit "@@BEGIN gone"
    # Unplug only once the grab streams (two frames printed): on a loaded host the guest may
    # take longer than any fixed wait to start it, and an unplug before the open is another test.
    # The output file exists before the grab starts: the loop below must read "0 frames", not
    # find no file (grep then prints nothing, the test fails, and the unplug came before the
    # open: what a loaded host showed, 2026-12-06).
    : >/tmp/gout
    timeout 120 $P cameras --grab v4l2:/dev/video0:640x480 --frames 100000 >/tmp/gout 2>/tmp/gerr &
    gpid=$!
    while [ "$(grep -c '^frame ' /tmp/gout)" -lt 2 ] && kill -0 $gpid 2>/dev/null; do
        usleep 100000
    done
    $CTL /dev/video0 Disconnect 13 2>>/tmp/gerr
    wait $gpid
    rc=$?
    tail -n 3 /tmp/gout | sed 's/^/O /' >$OUT
    sed 's/^/E /' /tmp/gerr >$OUT
    emit "@@END gone $rc"
    up checks
    estimate --unplug
else
    estimate
fi
status=$rc
up done
finish $status
