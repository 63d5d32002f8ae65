#!/usr/bin/env bash
# A USB webcam made of files, read through the real uvcvideo driver: boots the camera rig's UVC
# guest once (tools/camrig/run.sh --frames DIR --backend both: dummy_hcd + gadgetfs +
# tools/camrig/uvc-gadget streaming two of tests/data/frames as YUYV over a bulk endpoint) and
# checks, from the guest's results,
#  - `parlight cameras` lists uvcvideo's /dev/video0 (UVC Camera 1d6b:0102) with YUYV usable,
#    and libcamera's camera [0];
#  - `parlight estimate --camera v4l2:/dev/video0 --n-frames 2` (YUYV), the same with
#    `:640x480:mjpeg`, and `parlight estimate --camera libcamera --n-frames 2` (libcamera's UVC
#    pipeline, YUYV, with the udev-less workarounds of init-uvc.sh): two JSON lines each, driver
#    CLOCK_MONOTONIC t_ns and frame indices increasing, and every frame's lights, ambient and sh9
#    IDENTICAL (bit for bit as printed) to those of `parlight estimate --input` on one of the
#    frames read as files: after the same RGB -> YUYV -> RGB round trip (uvc-gadget --expected)
#    for YUYV, the JPEG files themselves for MJPEG (the device sends their bytes), and the frame-index distance
#    of the two camera frames agrees with the distance of the files they matched (the device
#    sends the files in order, one per sequence number);
#  - the libcamera camera ID is built from the controller's firmware node and the USB IDs;
#    an unknown ID and an index out of range are refused with clear messages (and, on the host,
#    an empty ID and a spec that is not libcamera's).
# A small seeded model (96x128 input, tools/export.py) keeps the TCG guest's estimates short.
# A boot that the test device broke (its control-request race in its log, or no /dev/video0 at
# all) is booted again, at most twice (docs/CAMERAS.md, "Known limits of the UVC rig"); the last
# boot decides.
# Skips (77) when the VM cannot start (no qemu, kernel not downloadable). About 50-70 s here on an
# idle machine (240-260 s on a 2-core AMD EPYC, 2026-12-07); the limits (820 s for the VM boots
# together, 400 s for each step in the guest) are hang guards
# sized for a loaded one: beside two training jobs and the rest of the suite the guest's steps
# took 5x as long (v4l2 done at 208 s, libcamera at 300 s, 2026-12-06), past the old 340 s.
set -u
cd "$(dirname "$0")/.."
BUILD=${BUILD:-build}
T="${PL_TEST_TMP:-$(mktemp -d)}/camera_uvc"
rm -rf "$T"
mkdir -p "$T/frames"
fail() { echo "FAIL: $*"; exit 1; }
skip() { echo "SKIP: $*"; exit 77; }
[ -x "$BUILD/parlight" ] || fail "no $BUILD/parlight (make all)"
command -v qemu-system-x86_64 >/dev/null 2>&1 ||
    skip "qemu-system-x86_64 not installed: the camera VM cannot start (tools/install-deps.sh installs qemu-system-x86)"
M=build/models/seeded-n3-96x128.plm
[ -f "$M" ] || fail "no $M (make test exports it)"
cp tests/data/frames/lab-lamps.jpg tests/data/frames/warehouse-tubes.jpg "$T/frames/"

# the spec checks that need no camera, on the host
out=$("$BUILD/parlight" estimate --model "$M" --camera libcamera: 2>&1)
[ $? -eq 1 ] && grep -q "empty camera ID after ':' (expected libcamera\[:ID|N\])" <<<"$out" ||
    fail "--camera libcamera: gave: $out"
out=$("$BUILD/parlight" estimate --model "$M" --camera libcamerax 2>&1)
[ $? -eq 1 ] || fail "--camera libcamerax was accepted: $out"

start=$(date +%s%N)
# Each boot's VM limit is what is left of TOTAL seconds since here, so that on a machine too busy
# for the rig this test says so itself, before tests/run.sh's 900 s limit kills it silently.
TOTAL=820
boot() {
    local left=$((TOTAL - ($(date +%s%N) - start) / 1000000000)) b0
    [ $left -ge 60 ] || fail "no time left for another boot (${left} s of ${TOTAL} s)"
    rm -f "$T/results.txt"
    b0=$(date +%s)
    tools/camrig/run.sh --frames "$T/frames" --backend both --n-frames 2 --build "$BUILD" \
        --model "$M" --timeout $left --results "$T/results.txt" >"$T/json.txt" 2>"$T/log.txt"
    rc=$?
    cat "$T/log.txt"
    [ $rc -eq 0 ] || [ $(($(date +%s) - b0)) -lt $left ] ||
        fail "the VM ran into its ${left} s limit (the machine is too busy for the rig's" \
            "guest; alone it takes 1-5 min)"
}
# device_broke: the failed boot is the emulated webcam's, not parlight's: the device's log shows
# its control-request race (gadgetfs on dummy_hcd has no delayed status stage: docs/CAMERAS.md,
# "Known limits of the UVC rig": a SET_CUR overtaken, an ep0 request left pending, EIDRM or
# EL2HLT, or a GET's reply refused because its request was gone), or uvcvideo never made
# /dev/video0, so parlight never ran.
RACE='uvc-gadget: \(SET_CUR overtaken\|ep0: Identifier removed\|ep0: Level 2 halted'
RACE+='\|GET reply: Identifier removed\)'
device_broke() {
    [ $rc -ne 0 ] && [ $rc -ne 3 ] &&
        { grep -q "$RACE" "$T/log.txt" ||
            grep -q "^@@ERROR uvcvideo made no /dev/video0" "$T/results.txt" 2>/dev/null; }
}
boot
# Up to two more boots when the device broke; the last one decides.
for again in 1 2; do
    device_broke || break
    echo "the test device broke this boot before parlight could decide (rig exit $rc): booting again ($again of 2)"
    boot
done
if [ $rc -ne 0 ] && grep -q "apt-get download\|cannot resolve" "$T/log.txt"; then
    skip "the camera VM cannot start: Debian's kernel could not be downloaded"
fi
[ $rc -eq 3 ] && skip "the camera VM did not start: $(grep -m1 'did not start' "$T/log.txt")"
[ $rc -eq 0 ] || fail "the rig exited $rc (console: $BUILD/camrig-uvc/console.log)"
secs=$(( ($(date +%s%N) - start) / 1000000000 ))

/usr/bin/python3 - "$T/results.txt" <<'PYEOF' || fail "checks on the guest's results failed (above)"
import json, math, re, sys

steps, cur, rcs = {}, None, {}
for line in open(sys.argv[1], encoding="utf-8", errors="replace"):
    line = line.rstrip("\n")
    if line.startswith("@@BEGIN "):
        cur = line.split()[1]
        steps[cur] = {"O": [], "E": []}
    elif line.startswith("@@END "):
        _, name, rc = line.split()
        rcs[name] = int(rc)
        cur = None
    elif cur and line[:2] in ("O ", "E "):
        steps[cur][line[0]].append(line[2:])
bad = []
def check(cond, msg):
    if not cond:
        bad.append(msg)

cams = steps.get("cameras", {"O": [], "E": []})
check(rcs.get("cameras") == 0, f"cameras exited {rcs.get('cameras')}: {cams['E']}")
check(any(l.startswith("/dev/video0: UVC Camera (1d6b:0102) (driver uvcvideo") for l in cams["O"]),
      f"cameras: no uvcvideo /dev/video0: {cams['O'][:3]}")
check(any("YUYV" in l and "usable" in l for l in cams["O"]), "cameras: YUYV not usable")
check(any(l.startswith("libcamera: 1 camera") for l in cams["O"]) and
      any(re.match(r"\s+\[0\] \S+", l) for l in cams["O"]),
      f"cameras: libcamera does not list the webcam: {[l for l in cams['O'] if 'libcamera' in l]}")

def parse(step):
    objs = []
    for l in steps.get(step, {"O": []})["O"]:
        try:
            objs.append(json.loads(l))
        except ValueError as e:
            bad.append(f"{step}: not JSON ({e}): {l[:80]}")
    return objs

def key(o):
    return json.dumps([o.get("lights"), o.get("ambient"), o.get("sh9")])

refs = {}
for fstep in ("estimate-files", "estimate-files-jpeg"):
    files = parse(fstep)
    check(rcs.get(fstep) == 0, f"{fstep} exited {rcs.get(fstep)}")
    check(len(files) == 2, f"{fstep}: {len(files)} JSON lines, expected 2")
    ref = {key(o): i for i, o in enumerate(files)}
    check(len(ref) == len(files), f"{fstep}: the two files gave the same lights (must differ)")
    refs[fstep] = (files, ref)

for step, prefix, fstep in (("estimate-v4l2", "v4l2:/dev/video0", "estimate-files"),
                            ("estimate-v4l2-mjpeg", "v4l2:/dev/video0", "estimate-files-jpeg"),
                            ("estimate-libcamera", "libcamera:", "estimate-files")):
    files, ref = refs[fstep]
    objs = parse(step)
    check(rcs.get(step) == 0, f"{step} exited {rcs.get(step)}: {steps.get(step, {}).get('E')}")
    check(len(objs) == 2, f"{step}: {len(objs)} JSON lines, expected 2")
    matched = []
    for o in objs:
        check(o.get("source", "").startswith(prefix), f"{step}: source {o.get('source')!r}")
        check(isinstance(o.get("t_ns"), int) and 1e9 < o["t_ns"] < 900e9,
              f"{step}: t_ns {o.get('t_ns')!r} is not a CLOCK_MONOTONIC time of the guest")
        L = o.get("lights", [])
        check(len(L) == 3 and all(math.isfinite(v) for l in L for v in l["dir"] + l["rgb"]),
              f"{step}: lights {L}")
        i = ref.get(key(o))
        check(i is not None, f"{step}: frame {o.get('frame')}: lights differ from every file's "
              f"(camera {o.get('lights')} vs files {[f.get('lights') for f in files]})")
        matched.append(i)
    if len(objs) == 2 and None not in matched:
        a, b = objs
        check(b["frame"] > a["frame"] and b["t_ns"] > a["t_ns"],
              f"{step}: frame/t_ns not increasing: {a['frame']},{a['t_ns']} {b['frame']},{b['t_ns']}")
        n = len(files)
        check((b["frame"] - a["frame"]) % n == (matched[1] - matched[0]) % n,
              f"{step}: frames {a['frame']}, {b['frame']} matched files {matched}: "
              "the sequence numbers do not follow the files")
        print(f"{step}: frames {a['frame']}, {b['frame']} identical to files "
              f"{[files[m]['source'].split('/')[-1] for m in matched]}; capture-to-JSON latency "
              f"{', '.join(str(round(o['timing_ms'].get('latency', -1))) for o in objs)} ms, "
              f"infer {', '.join(str(round(o['timing_ms']['infer'])) for o in objs)} ms, "
              f"dropped {', '.join(str(o.get('dropped')) for o in objs)}")
    if step == "estimate-libcamera" and objs:
        sid = objs[0].get("source", "")
        check("-1:1.0-1d6b:0102" in sid and "DUMMY" in sid, f"libcamera camera ID {sid!r}")

# libcamera's errors with a real camera present
for step, want in (("libcamera-bad-id", "no libcamera camera with ID 'nope' (have: "),
                   ("libcamera-bad-index", "camera index 3 out of range (libcamera has 1)")):
    e = steps.get(step, {"E": []})["E"]
    check(rcs.get(step) == 1, f"{step} exited {rcs.get(step)}, expected 1")
    check(any(want in l for l in e), f"{step}: expected '{want}' in {e}")

for b in bad:
    print("FAIL:", b)
sys.exit(1 if bad else 0)
PYEOF
echo "UVC camera rig checks passed in ${secs} s"
