#!/usr/bin/env bash
# The Python binding (python/parlight, ctypes over libparlight.so) against the CLI:
#  - every sample frame, with the float and the int8 model, without and with a pose
#    (--orientation), and with the int8 one also a pose and --at, gives the same JSON object as
#    `parlight estimate`, field for field and number for number (tolerance 0; "frame", "t_ns",
#    "source" and "timing_ms" aside). The JPEGs
#    are first converted to PNG (lossless) and both sides read the PNGs, so both see the same
#    pixels: PIL's JPEG decoder may round differently from the CLI's libjpeg;
#  - Model.from_bytes, threads=2 and a non-contiguous array give the same lights;
#  - bad inputs (a float or a wrong-shaped array, a tiny frame, a non-unit or non-finite
#    quaternion, a missing model, a truncated model file or buffer, an empty buffer, a closed
#    model, an unloadable library) raise a clear ValueError, TypeError, ParlightError or OSError
#    naming the problem, and the interpreter never crashes (the script runs in one process and
#    must exit 0, not by a signal).
# Skips (77) without /usr/bin/python3 + numpy + PIL (tools/install-deps.sh installs python3-numpy and
# python3-pil) or without $BUILD/libparlight.so (SHARED=0, or build-san/, which has none by
# default: an ASan library only loads into an ASan-linked process).
set -u
cd "$(dirname "$0")/.."
BUILD=${BUILD:-build}
T="${PL_TEST_TMP:-/tmp}/python_binding"
mkdir -p "$T"
. tests/cli_helpers.sh

PY=/usr/bin/python3 # Debian's, with python3-numpy and python3-pil (a pyenv python3 may lack them)
[ -x "$PY" ] || { echo "skip: no $PY"; exit 77; }
"$PY" -c 'import numpy, PIL' 2>/dev/null || { echo "skip: python3 lacks numpy or PIL (python3-numpy, python3-pil)"; exit 77; }
[ -f "$BUILD/libparlight.so" ] || { echo "skip: no $BUILD/libparlight.so (SHARED=0 or a sanitizer build)"; exit 77; }
for m in models/parlight-n3.plm models/parlight-n3-int8.plm; do
    [ -f "$m" ] || { echo "skip: no $m"; exit 77; }
done
LIB=$(cd "$BUILD" && pwd)/libparlight.so

# The sample frames as PNGs, in name order like the JPEGs.
mkdir -p "$T/png"
"$PY" - "$T/png" tests/data/frames/*.jpg <<'PY' || fail "converting the sample frames to PNG"
import os, sys
from PIL import Image, ImageOps
for f in sys.argv[2:]:
    im = ImageOps.exif_transpose(Image.open(f)).convert("RGB")
    im.save(os.path.join(sys.argv[1], os.path.basename(f)[:-4] + ".png"))
PY
n=$(ls "$T"/png/*.png | wc -l)
[ "$n" -ge 1 ] || fail "no sample frames converted"

# A pose written with 17 digits, so that the CLI's strtod and Python's float agree exactly.
POSE=$("$PY" -c 'import math; q=[0.9, 0.1, 0.3, -0.2]; s=math.sqrt(sum(v*v for v in q)); print(",".join(repr(v/s) for v in q))')
for model in parlight-n3 parlight-n3-int8; do
    expect 0 "" -- "$BUILD/parlight" estimate --model "models/$model.plm" --input "$T/png"
    cp "$T/out" "$T/cli-$model.jsonl"
    expect 0 "" -- "$BUILD/parlight" estimate --model "models/$model.plm" --input "$T/png" --orientation "$POSE"
    cp "$T/out" "$T/cli-$model-pose.jsonl"
done
expect 0 "" -- "$BUILD/parlight" estimate --model models/parlight-n3-int8.plm --input "$T/png" --orientation "$POSE" --at 0.5,0.25,-1
cp "$T/out" "$T/cli-parlight-n3-int8-pose-at.jsonl"
# The key light over views: frame i turned by 90 i degrees about y (json.dumps writes each
# float's shortest exact form, so the CLI and Python read the same doubles).
"$PY" -c 'import json, math
for i in range(32):
    a = math.radians(90 * i)
    print(json.dumps({"frame": i, "q": [math.cos(a / 2), 0, -math.sin(a / 2), 0]}))' >"$T/poses.jsonl"
expect 0 "" -- "$BUILD/parlight" estimate --model models/parlight-n3-int8.plm --input "$T/png" --poses "$T/poses.jsonl" --fuse 0
cp "$T/out" "$T/cli-fuse.jsonl"
expect 0 "" -- "$BUILD/parlight" estimate --model models/parlight-n3-int8.plm --input "$T/png" --poses "$T/poses.jsonl" --fuse 0 --aim 3
cp "$T/out" "$T/cli-aim.jsonl"
# and the room's level: each line with an exposure (0.01 x 1.5^i: any unit the file keeps)
"$PY" -c 'import json, math
for i in range(32):
    a = math.radians(90 * i)
    print(json.dumps({"frame": i, "q": [math.cos(a / 2), 0, -math.sin(a / 2), 0],
                      "exposure": 0.01 * 1.5 ** i}))' >"$T/poses-x.jsonl"
expect 0 "" -- "$BUILD/parlight" estimate --model models/parlight-n3-int8.plm --input "$T/png" --poses "$T/poses-x.jsonl" --fuse 0 --aim 3 --level 3
cp "$T/out" "$T/cli-level.jsonl"

timeout 600 env PYTHONPATH=python PARLIGHT_LIB="$LIB" "$PY" - "$T" "$POSE" "$LIB" <<'PY' >"$T/py.log" 2>&1
import glob, json, math, os, sys
import numpy as np
from PIL import Image
import parlight
from parlight import Model, ParlightError

T, POSE, LIB = sys.argv[1], [float(v) for v in sys.argv[2].split(",")], sys.argv[3]
fails = 0

def ok(msg): print("ok   " + msg)
def fail(msg):
    global fails
    fails += 1
    print("FAIL: " + msg)

IGNORED = ("frame", "t_ns", "source", "timing_ms")
def same(a, b):
    return {k: v for k, v in a.items() if k not in IGNORED} == \
           {k: v for k, v in b.items() if k not in IGNORED}

def raises(what, exc, pattern, fn):
    """fn() must raise exc whose message contains pattern (case-insensitive)."""
    try:
        fn()
    except exc as e:
        if pattern.lower() in str(e).lower():
            ok(f"{what}: {type(e).__name__}: {e}")
        else:
            fail(f"{what}: {type(e).__name__} '{e}' lacks '{pattern}'")
        return
    except Exception as e:
        fail(f"{what}: raised {type(e).__name__} ({e}), expected {exc.__name__}")
        return
    fail(f"{what}: no exception, expected {exc.__name__}")

pngs = sorted(glob.glob(os.path.join(T, "png", "*.png")))
frames = [np.asarray(Image.open(p).convert("RGB")) for p in pngs]

v = parlight.version()
with open("include/parlight.h") as h:
    want = [l.split('"')[1] for l in h if l.startswith("#define PARLIGHT_VERSION ")][0]
(ok if v == want else fail)(f"version() {v}, header {want}")

for model in ("parlight-n3", "parlight-n3-int8"):
    with Model(f"models/{model}.plm") as m:
        prec = m.info["precision"]
        variants = [("", None, None), ("-pose", POSE, None)]
        if model.endswith("int8"):
            variants.append(("-pose-at", POSE, (0.5, 0.25, -1)))
        for suffix, pose, at in variants:
            with open(os.path.join(T, f"cli-{model}{suffix}.jsonl")) as f:
                cli = [json.loads(l) for l in f]
            if len(cli) != len(frames):
                fail(f"{model}{suffix}: CLI gave {len(cli)} lines for {len(frames)} frames")
                continue
            for i, (rgb, c) in enumerate(zip(frames, cli)):
                name = os.path.basename(pngs[i])
                if not c["source"].endswith("/" + name):
                    fail(f"CLI line {i} is {c['source']}, expected {name}")
                py = m.estimate(rgb, pose=pose, at=at, frame=i)
                if same(py, c) and py["frame"] == c["frame"] and set(py) == set(c):
                    ok(f"{model} ({prec}){suffix} {name}: same JSON as the CLI "
                       f"(space {py['space']}, {len(py['lights'])} lights)")
                else:
                    fail(f"{model}{suffix} {name}: Python {json.dumps(py)}\n   CLI {json.dumps(c)}")

int8 = "models/parlight-n3-int8.plm"
rgb = frames[0]
with Model(int8) as m:
    ref = m.estimate(rgb)
    (ok if ref["space"] == "camera" else fail)(f"no pose: space {ref['space']}")
    posed = m.estimate(rgb, pose=POSE)
    (ok if posed["space"] == "world" else fail)(f"a pose: space {posed['space']}")
    nc = np.repeat(rgb, 2, axis=1)[:, ::2]  # rgb again, as a strided view
    assert not nc.flags["C_CONTIGUOUS"]
    (ok if same(m.estimate(nc), ref) else fail)("a non-contiguous view (every other column of a column-doubled frame)")
    raises("float32 frame", ValueError, "uint8", lambda: m.estimate(rgb.astype(np.float32)))
    raises("int16 frame", ValueError, "uint8", lambda: m.estimate(rgb.astype(np.int16)))
    raises("H x W frame", ValueError, "H x W x 3", lambda: m.estimate(rgb[:, :, 0]))
    raises("RGBA frame", ValueError, "H x W x 3", lambda: m.estimate(np.zeros((64, 64, 4), np.uint8)))
    raises("4 x 4 frame", ValueError, "8 x 8", lambda: m.estimate(np.zeros((4, 4, 3), np.uint8)))
    raises("a list", TypeError, "numpy array", lambda: m.estimate(rgb.tolist()))
    raises("non-unit quaternion", ValueError, "pose", lambda: m.estimate(rgb, pose=(1, 1, 0, 0)))
    raises("NaN quaternion", ValueError, "pose", lambda: m.estimate(rgb, pose=(math.nan, 0, 0, 1)))
    raises("3-number pose", ValueError, "4 numbers", lambda: m.estimate(rgb, pose=(1, 0, 0)))
    raises("pose not numbers", ValueError, "4 numbers", lambda: m.estimate(rgb, pose="abcd"))
    raises("at of 2 numbers", ValueError, "3 finite numbers", lambda: m.estimate(rgb, at=(0, 1)))
    (ok if same(m.estimate(rgb), ref) else fail)("the model still estimates after the refused calls")
    raises("threads=0", ParlightError, "thread", lambda: Model(int8, threads=0))
raises("estimate on a closed model", ValueError, "closed", lambda: m.estimate(rgb))

# KeyFuser: estimate(..., fuse=k) gives the CLI's --poses --fuse lines (key_light included), and
# the CLI's own camera-space lines replayed through KeyFuser.add give the same key light.
with open(os.path.join(T, "poses.jsonl")) as f:
    poses = [json.loads(l)["q"] for l in f]
with open(os.path.join(T, "cli-fuse.jsonl")) as f:
    cli = [json.loads(l) for l in f]
with open(os.path.join(T, "cli-parlight-n3-int8.jsonl")) as f:
    cam = [json.loads(l) for l in f]
with Model(int8) as m, parlight.KeyFuser(0) as k, parlight.KeyFuser(0) as k2:
    (ok if k.key(0) is None else fail)("an empty KeyFuser has no key light (None)")
    for i, (rgb_i, c) in enumerate(zip(frames, cli)):
        py = m.estimate(rgb_i, pose=poses[i], fuse=k, frame=i)
        kl = k2.add(cam[i], poses[i], i)
        views = min(i + 1, 4)  # four headings, 90 degrees apart
        if same(py, c) and py["key_light"]["views"] == views:
            ok(f"fuse: frame {i}: the CLI's line, key_light {py['key_light']}")
        else:
            fail(f"fuse: frame {i}: Python {json.dumps(py)}\n   CLI {json.dumps(c)}")
        if kl and [float("%.6g" % v) for v in kl["dir"]] == c["key_light"]["dir"] and \
                kl["views"] == views:
            ok(f"fuse: frame {i}: KeyFuser.add of the CLI's camera line gives its key light")
        else:
            fail(f"fuse: frame {i}: KeyFuser.add gave {kl}, the CLI {c['key_light']}")
    with open(os.path.join(T, "cli-aim.jsonl")) as f:
        cli_aim = [json.loads(l) for l in f]
    with parlight.KeyFuser(0) as k3:
        for i, (rgb_i, c) in enumerate(zip(frames, cli_aim)):
            py = m.estimate(rgb_i, pose=poses[i], fuse=k3, frame=i, aim=3)
            moved = py["primary"]["dir"] == py["key_light"]["dir"] != cli[i]["primary"]["dir"]
            (ok if same(py, c) and (i < 2 or moved) else fail)(
                f"aim=3: frame {i}: the CLI's --aim 3 line (primary {'turned' if moved else 'as it was'})")
    with open(os.path.join(T, "cli-level.jsonl")) as f:
        cli_level = [json.loads(l) for l in f]
    with open(os.path.join(T, "poses-x.jsonl")) as f:
        expo = [json.loads(l)["exposure"] for l in f]
    with parlight.KeyFuser(0) as k4:
        for i, (rgb_i, c) in enumerate(zip(frames, cli_level)):
            py = m.estimate(rgb_i, pose=poses[i], fuse=k4, frame=i, aim=3, level=3,
                            exposure=expo[i])
            scaled = py["ambient"] != cli_aim[i]["ambient"]
            (ok if same(py, c) and (i < 2 or scaled) else fail)(
                f"level=3: frame {i}: the CLI's --level 3 line ({'brought to the level' if scaled else 'as it was'})")
    raises("level without exposure", ValueError, "exposure=",
           lambda: m.estimate(rgb, pose=POSE, fuse=k, level=3))
    raises("exposure without fuse", ValueError, "needs fuse",
           lambda: m.estimate(rgb, pose=POSE, exposure=1))
    for bad in (0, -1, math.nan, math.inf, True, "bright"):
        raises(f"exposure {bad!r}", ValueError, "exposure must be",
               lambda: m.estimate(rgb, pose=POSE, fuse=k, exposure=bad))
    raises("level 25", ValueError, "1..24",
           lambda: m.estimate(rgb, pose=POSE, fuse=k, exposure=1, level=25))
    raises("level True", ValueError, "1..24",
           lambda: m.estimate(rgb, pose=POSE, fuse=k, exposure=1, level=True))
    raises("add with exposure 0", ValueError, "exposure must be",
           lambda: k2.add(cam[0], POSE, 0, exposure=0))
    raises("aim without fuse", ValueError, "needs fuse", lambda: m.estimate(rgb, pose=POSE, aim=3))
    raises("aim 0", ValueError, "1..24", lambda: m.estimate(rgb, pose=POSE, fuse=k, aim=0))
    raises("aim True", ValueError, "1..24", lambda: m.estimate(rgb, pose=POSE, fuse=k, aim=True))
    raises("fuse without a pose", ValueError, "pose", lambda: m.estimate(rgb, fuse=k))
    raises("fuse not a KeyFuser", TypeError, "KeyFuser", lambda: m.estimate(rgb, pose=POSE, fuse=3))
    raises("a NaN fuse_t", ValueError, "finite", lambda: m.estimate(rgb, pose=POSE, fuse=k,
                                                                     fuse_t=math.nan))
    raises("add a world-space line", ValueError, "camera space", lambda: k2.add(cli[0], POSE, 0))
    raises("add a line without lights", ValueError, "lights", lambda: k2.add({"ambient": [0, 0, 0]}, POSE, 0))
    raises("add a light without rgb", ValueError, "rgb[3]", lambda: k2.add(
        {"lights": [{"dir": [0, 1, 0], "distance_m": 1, "solid_angle_sr": 1}]}, POSE, 0))
    bad = json.loads(json.dumps(cam[0]))
    bad["lights"][0]["solid_angle_sr"] = -1
    raises("add a negative solid angle", ParlightError, "solid", lambda: k2.add(bad, POSE, 0))
    raises("add a non-unit pose", ValueError, "pose", lambda: k2.add(cam[0], (2, 0, 0, 0), 0))
    raises("key at NaN", ValueError, "finite", lambda: k2.key(math.nan))
    before = k2.key(99)
    (ok if before and before["views"] == 4 else fail)(f"refused adds left the fuser as it was: {before}")
    k2.reset()
    (ok if k2.key(99) is None else fail)("reset forgets every frame")
raises("a negative max_age", ValueError, "max age", lambda: parlight.KeyFuser(-1))
raises("max_age not a number", ValueError, "seconds", lambda: parlight.KeyFuser("soon"))
raises("a closed KeyFuser", ValueError, "closed", lambda: k.key(0))
k.close()  # twice is fine
with parlight.KeyFuser(10) as ka:
    ka.add(cam[0], (1, 0, 0, 0), 0)
    (ok if ka.key(5) and ka.key(11) is None else fail)("max_age 10: a view at t 0 counts at 5, not at 11")
m.close()  # twice is fine

with Model(int8, threads=2) as m2:
    (ok if same(m2.estimate(rgb), ref) else fail)("threads=2 gives the same lights")

data = open(int8, "rb").read()
with Model.from_bytes(data) as mb:
    (ok if same(mb.estimate(rgb), ref) else fail)("Model.from_bytes gives the same lights as Model(path)")
    (ok if mb.info["file_size"] == len(data) else fail)(f"from_bytes info: {mb.info['file_size']} bytes")

def status_is(what, name, fn):
    try:
        fn()
    except ParlightError as e:
        (ok if e.status_name == name and str(e) else fail)(f"{what}: {e.status_name} ({e.status}): {e}")
        return
    except Exception as e:
        fail(f"{what}: raised {type(e).__name__} ({e}), expected ParlightError {name}")
        return
    fail(f"{what}: no exception, expected ParlightError {name}")

missing = os.path.join(T, "no-such-model.plm")
status_is("missing model file", "PL_E_IO", lambda: Model(missing))
raises("missing model names the path", ParlightError, "no-such-model.plm", lambda: Model(missing))
trunc = os.path.join(T, "truncated.plm")
with open(trunc, "wb") as f:
    f.write(data[: len(data) // 2])
status_is("truncated model file", "PL_E_FORMAT", lambda: Model(trunc))
status_is("truncated model bytes", "PL_E_FORMAT", lambda: Model.from_bytes(data[:100]))
status_is("empty model bytes", "PL_E_ARG", lambda: Model.from_bytes(b""))
status_is("a JPEG as a model", "PL_E_FORMAT", lambda: Model("tests/data/frames/lab-lamps.jpg"))
status_is("a directory as a model", "PL_E_IO", lambda: Model("tests"))
raises("an unloadable library", OSError, "nope.so", lambda: Model(int8, lib=os.path.join(T, "nope.so")))

print("all passed" if fails == 0 else f"{fails} failure(s)")
sys.exit(1 if fails else 0)
PY
rc=$?
cat "$T/py.log"
if [ $rc -gt 128 ]; then
    fail "the Python interpreter died by signal $((rc - 128))"
elif [ $rc -ne 0 ]; then
    fail "python checks (exit $rc)"
fi
finish
