#!/usr/bin/env bash
# The V4L2 source through a real driver: boots the camera rig (tools/camrig: QEMU with Debian's
# kernel and vivid, software emulation) once and checks, inside the guest,
#  - `parlight cameras` lists vivid's /dev/video0 with YUYV (usable) and skips the other nodes;
#  - `parlight cameras --grab` in YUYV, NV12 and RGB24: vivid draws the same test pattern in every
#    format, so the mean colours after conversion agree (a wrong range or matrix would not);
#  - `parlight estimate --camera v4l2:/dev/video0:640x480 --n-frames 2`: two JSON lines with the
#    schema (source v4l2:/dev/video0, finite lights, sh9), increasing frame indices and t_ns that
#    are the driver's CLOCK_MONOTONIC timestamps (seconds since the guest booted), while vivid's
#    "Disconnect" button unplugs the camera during the first frame's estimate: one "device lost"
#    warning, the camera reopened, the second frame captured after the unplug;
#  - a camera unplugged for good (vivid_ctl holds the disconnected device): failed reopen
#    attempts with backoff, then `parlight cameras --grab` gives up after 10 s, exit 1;
#  - a missing device, a non-capture node, a format and a size the device lacks, and malformed
#    specs: one clear error line each, exit 1.
# Skips (77) only when the VM cannot start at all (no qemu, kernel not downloadable). Takes about
# 1.5 minutes here (TCG); prints boot-to-first-JSON and frames/s.
set -u
cd "$(dirname "$0")/.."
BUILD=${BUILD:-build}
T="${PL_TEST_TMP:-$(mktemp -d)}/camera_vivid"
mkdir -p "$T"
# the small seeded model (96x128 input; Makefile) keeps the TCG guest's estimates short
M=build/models/seeded-n3-96x128.plm
fail() { echo "FAIL: $*"; exit 1; }
skip() { echo "SKIP: $*"; exit 77; }
[ -x "$BUILD/parlight" ] || fail "no $BUILD/parlight (make all)"
[ -x "$BUILD/tests/vivid_ctl" ] || fail "no $BUILD/tests/vivid_ctl (make all)"
[ -f "$M" ] || fail "no $M (make test exports it)"
command -v qemu-system-x86_64 >/dev/null 2>&1 ||
    skip "qemu-system-x86_64 not installed: the camera VM cannot start (tools/install-deps.sh installs qemu-system-x86)"

start=$(date +%s%N)
if ! tools/camrig/build.sh --build "$BUILD" --model "$M" >"$T/build.log" 2>&1; then
    if grep -q "apt-get download\|cannot resolve" "$T/build.log"; then
        skip "the camera VM cannot start: Debian's kernel could not be downloaded ($(tail -n 1 "$T/build.log"))"
    fi
    cat "$T/build.log"
    fail "tools/camrig/build.sh failed"
fi
tools/camrig/run.sh --backend v4l2 --suite full --frames 2 --build "$BUILD" --no-build \
    --timeout 480 --results "$T/results.txt" >"$T/json.txt" 2>"$T/log.txt"
rc=$?
cat "$T/log.txt"
[ $rc -eq 3 ] && skip "the camera VM did not start: $(grep -m1 'did not start' "$T/log.txt")"
[ $rc -eq 0 ] || fail "the rig's estimate step exited $rc (console: $BUILD/camrig/console.log)"
secs=$(( ($(date +%s%N) - start) / 1000000000 ))

/usr/bin/python3 - "$T/results.txt" <<'EOF' || fail "checks on the guest's results failed (above)"
import json, math, re, sys

steps, cur, rcs, unplugged = {}, None, {}, False
for line in open(sys.argv[1], encoding="utf-8", errors="replace"):
    line = line.rstrip("\n")
    if line.startswith("@@BEGIN "):
        cur = line.split()[1]
        steps[cur] = {"O": [], "E": []}
    elif line.startswith("@@END "):
        _, name, rc = line.split()
        rcs[name] = int(rc)
        cur = None
    elif line.startswith("@@UNPLUGGED"):
        unplugged = float(line.split()[1])
    elif cur and line[:2] in ("O ", "E "):
        steps[cur][line[0]].append(line[2:])

bad = []
def check(cond, msg):
    if not cond:
        bad.append(msg)

# parlight cameras
cams = steps.get("cameras", {"O": [], "E": []})
out = "\n".join(cams["O"])
check(rcs.get("cameras") == 0, f"cameras exited {rcs.get('cameras')}")
check(re.search(r"^/dev/video0: vivid \(driver vivid", out, re.M), "cameras: no '/dev/video0: vivid' line")
check(re.search(r"^  YUYV .*usable$", out, re.M), "cameras: YUYV not listed as usable")
check(re.search(r"^        640x480 @ .*25", out, re.M), "cameras: 640x480 with its rates not listed")
check(re.search(r"^/dev/video1: .*not a video capture device, skipped", out, re.M),
      "cameras: the output node video1 not named as skipped")

# grabs: same pattern, same mean colour in every format
means = {}
for fmt in ("yuyv", "nv12", "rgb24"):
    s = steps.get("grab-" + fmt, {"O": [], "E": []})
    check(rcs.get("grab-" + fmt) == 0, f"grab {fmt} exited {rcs.get('grab-' + fmt)}: {s['E']}")
    rows = [l for l in s["O"] if l.startswith("frame ")]
    check(len(rows) == 4, f"grab {fmt}: {len(rows)} frames, expected 4")
    if rows:
        m = re.search(r"640x480 mean_rgb ([\d.]+) ([\d.]+) ([\d.]+)", rows[-1])
        check(m, f"grab {fmt}: no 640x480 mean in '{rows[-1]}'")
        if m:
            means[fmt] = [float(x) for x in m.groups()]
    check(any(("BT.601 limited" if fmt != "rgb24" else ", RGB,") in l for l in s["O"]),
          f"grab {fmt}: coding not reported as expected: {s['O'][:1]}")
if len(means) == 3:
    for fmt, tol in (("nv12", 1.0), ("rgb24", 2.5)):
        d = max(abs(a - b) for a, b in zip(means[fmt], means["yuyv"]))
        check(d <= tol, f"mean RGB {fmt} {means[fmt]} vs yuyv {means['yuyv']}: differ by {d:.2f} > {tol}")
    print(f"mean RGB of vivid's pattern: yuyv {means['yuyv']}, nv12 {means['nv12']}, rgb24 {means['rgb24']}")

# errors: one clear line each, exit 1, nothing on stdout
errors = {
    "missing": r"v4l2:/dev/video9: cannot open camera: No such file or directory",
    "not-capture": r"v4l2:/dev/video1: .*not a single-planar video capture device",
    "no-format": r"does not offer MJPG \(it offers: YUYV ",
    "bad-size": r"asked for 641x479 YUYV, the device gives 640x480",
    "bad-spec-1": r"camera spec 'v4l2:/dev/video0:640x': size '640x' is not WxH",
    "bad-spec-2": r"camera spec 'v4l2:video0': device path must be absolute",
    "bad-spec-3": r"format 'bgr24' is not one of yuyv, nv12, rgb24, mjpeg",
}
for name, pat in errors.items():
    s = steps.get(name, {"O": [], "E": []})
    check(rcs.get(name) == 1, f"{name}: exit {rcs.get(name)}, expected 1")
    check(len(s["E"]) == 1, f"{name}: {len(s['E'])} stderr lines, expected 1: {s['E']}")
    check(not s["O"], f"{name}: printed on stdout: {s['O']}")
    check(s["E"] and re.search(pat, s["E"][0]), f"{name}: '{s['E'][:1]}' does not match '{pat}'")

# a camera that never comes back: one "device lost", failed reopen attempts, then giving up
g = steps.get("gone", {"O": [], "E": []})
check(rcs.get("gone") == 1, f"gone: exit {rcs.get('gone')}, expected 1: {g['E'][-2:]}")
lost = [l for l in g["E"] if "device lost" in l and "reopening" in l]
tries = [l for l in g["E"] if re.search(r"reopen attempt \d+ failed .*No such device", l)]
check(len(lost) == 1, f"gone: expected one 'device lost ... reopening' warning: {g['E'][:2]}")
check(len(tries) >= 4, f"gone: {len(tries)} failed reopen attempts, expected >= 4 in 10 s")
check(g["E"] and re.search(r"not back after 10 s \(\d+ reopen attempts\): giving up", g["E"][-1]),
      f"gone: last line does not say it gave up: {g['E'][-1:]}")
print(f"unplugged for good: {len(tries)} reopen attempts, then: {g['E'][-1] if g['E'] else ''}")

# estimate with an unplug during the first frame
est = steps.get("estimate", {"O": [], "E": []})
check(rcs.get("estimate") == 0, f"estimate exited {rcs.get('estimate')}: {est['E']}")
check(unplugged, "vivid's Disconnect control was not pressed")
objs = []
for l in est["O"]:
    try:
        objs.append(json.loads(l))
    except ValueError as e:
        bad.append(f"estimate: not JSON ({e}): {l[:80]}")
check(len(objs) == 2, f"estimate: {len(objs)} JSON lines, expected 2")
def finite(v):
    return isinstance(v, (int, float)) and math.isfinite(v)
for o in objs:
    check(o.get("source") == "v4l2:/dev/video0", f"source {o.get('source')!r}")
    check(isinstance(o.get("frame"), int) and o["frame"] >= 0, f"frame {o.get('frame')!r}")
    # the driver's CLOCK_MONOTONIC stamp: seconds since the guest booted, not the epoch
    check(isinstance(o.get("t_ns"), int) and 1e9 < o["t_ns"] < 900e9, f"t_ns {o.get('t_ns')!r}")
    L = o.get("lights", [])
    check(len(L) == 3, f"{len(L)} lights")
    for l in L:
        vals = l.get("dir", []) + [l.get("distance_m"), l.get("solid_angle_sr")] + l.get("rgb", [])
        check(len(vals) == 8 and all(finite(v) for v in vals), f"light not finite: {l}")
        check(abs(math.sqrt(sum(v * v for v in l.get("dir", [0]))) - 1) < 1e-3, f"dir not unit: {l}")
    check(len(o.get("ambient", [])) == 3 and all(finite(v) for v in o["ambient"]), "ambient")
    check(len(o.get("sh9", [])) == 27 and all(finite(v) for v in o["sh9"]), "sh9")
    check("primary" in o and "timing_ms" in o, "primary/timing_ms missing")
    lat = o.get("timing_ms", {}).get("latency")
    # capture to JSON: about the network's time or more (vivid stamps a frame with its nominal
    # time, up to one frame period off), and not beyond the run
    check(finite(lat) and o["timing_ms"]["infer"] - 100 <= lat < 300e3, f"latency {lat!r}")
if objs:
    print("capture-to-JSON latency (ms): " + ", ".join(f"{o['timing_ms'].get('latency', 0):.0f}" for o in objs)
          + "; infer (ms): " + ", ".join(f"{o['timing_ms']['infer']:.0f}" for o in objs)
          + "; dropped: " + ", ".join(str(o.get("dropped")) for o in objs))
if len(objs) == 2:
    check(objs[1]["frame"] > objs[0]["frame"], f"frame indices {objs[0]['frame']}, {objs[1]['frame']} not increasing")
    check(objs[1]["t_ns"] > objs[0]["t_ns"], f"t_ns {objs[0]['t_ns']}, {objs[1]['t_ns']} not increasing")
if len(objs) == 2 and unplugged:
    check(objs[0]["t_ns"] < unplugged * 1e9 < objs[1]["t_ns"],
          f"unplug at {unplugged} s is not between the frames' times {objs[0]['t_ns']}, {objs[1]['t_ns']}")
lost = [l for l in est["E"] if "device lost" in l]
check(len(lost) == 1, f"expected one 'device lost' warning, got {len(lost)}: {est['E']}")
check(lost and re.search(r"device lost \((VIDIOC_DQBUF|VIDIOC_QBUF|poll): No such device\); reopening",
                         lost[0]), f"lost message: {lost[:1]}")

for b in bad:
    print("FAIL:", b)
sys.exit(1 if bad else 0)
EOF
echo "camera rig checks passed in ${secs} s"
