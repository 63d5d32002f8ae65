"""Checks the live viewer's screenshots for tests/test_viewer.sh (not a test by itself).

    python3 tests/viewer_check.py DIR PARLIGHT

DIR holds what tests/viewer_browser.mjs wrote (state.json, viewer.png, noshadow.png, direct.png,
direct-noshadow.png). Checks, each printed as "ok ..." or "FAIL ...":

1. frames: the page received frames (its counter went on past the frozen one) and the line on
   screen is a parlight frame; its camera frame ("thumb", a JPEG) is shown at its size.
2. sphere: the reference sphere of the screenshot (orthographic, white Lambertian, lit by the
   line's engine form) against `parlight render --sphere diffuse` of the same line's lights, in
   linear RGB: the screenshot's sRGB bytes decoded and divided by the page's exposure. Over the
   pixels whose centres are within 0.95 of the radius (the silhouette is tessellated and
   antialiased), relative to the render's largest value: RMS error <= SPHERE_RMS (1%) and
   largest error <= SPHERE_MAX (3%). docs/LIGHTING.md bounds the engine form at 2.1% of the
   largest irradiance; 8-bit sRGB adds up to about 0.4% near white. The same view mirrored
   left-right is printed beside it: the RMS tolerance must tell the two apart.
3. shadow: the primary light's shadow on the ground plane, from the pair with the directional
   light alone (shadows on and off; the difference is exactly the shadow): it exists, its
   centroid lies on the side away from the light (against the light's direction on screen) and
   where the casters' shadows should fall (along -dir onto the ground, projected by the page's
   camera), within SHADOW_COS; and the screenshot with the full lighting is darker there too.
"""
import base64
import io
import json
import math
import os
import subprocess
import sys

import numpy as np
from PIL import Image

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tools"))
from rgbe import read_rgbe  # noqa: E402

SPHERE_RMS = 0.01
SPHERE_MAX = 0.03
SHADOW_COS = 0.9
SHADOW_MIN_PIXELS = 200

fails = 0


def ok(msg):
    print(f"ok   {msg}")


def fail(msg):
    global fails
    fails += 1
    print(f"FAIL {msg}")


def srgb_to_linear(u8):
    v = u8.astype(np.float64) / 255.0
    return np.where(v <= 0.04045, v / 12.92, ((v + 0.055) / 1.055) ** 2.4)


def main():
    d, parlight = sys.argv[1], sys.argv[2]
    st = json.load(open(f"{d}/state.json"))
    frame = json.loads(st["line"])
    print(f"     page: {st['frames']} frames received, frame {frame['frame']} on screen "
          f"({frame['source']}), exposure {st['exposure']:.4g}, browser part {st['seconds']:.1f} s")

    # 1. frames
    if st["shown"] >= 2 and st["frames"] > st["shown"] and st["dom_frames"] == str(st["frames"]):
        ok(f"frames: the page received {st['frames']} frames (title '{st['title']}')")
    else:
        fail(f"frames: shown {st['shown']}, received {st['frames']}, DOM {st['dom_frames']}")
    if not all(k in frame for k in ("engine", "lights", "ambient", "primary")):
        fail("frames: the line on screen lacks engine/lights/ambient/primary")
        return
    # the camera frame: the line's thumbnail, decoded and shown by the page at its own size
    th = st["thumb"]
    if "thumb" in frame:
        size = Image.open(io.BytesIO(base64.b64decode(frame["thumb"].split(",", 1)[1]))).size
        if th["shown"] and (th["width"], th["height"]) == size:
            ok(f"camera frame: the line's {size[0]}x{size[1]} JPEG is shown at "
               f"({th['rect']['x']:.0f}, {th['rect']['y']:.0f})")
        else:
            fail(f"camera frame: the line has a {size} JPEG, the page shows {th}")
    else:
        fail("camera frame: the line has no thumb field (parlight view adds --thumb 160)")
    # the key light over views (the test runs view with --poses ... --fuse 0): an arrow along the
    # line's key_light and its direction and view count in the panel
    kl = frame.get("key_light")
    if not kl:
        fail(f"key light: the line on screen has key_light {kl!r} (view runs with --fuse 0)")
    else:
        n = math.sqrt(sum(v * v for v in kl["dir"]))
        want = [v / n for v in kl["dir"]]
        got, text = st.get("key"), st.get("key_text", "")
        views = f"({kl['views']} view"
        if got and max(abs(a - b) for a, b in zip(got, want)) < 1e-5 and views in text:
            ok(f"key light: an arrow along the line's key_light {kl['dir']}, panel '{text}'")
        else:
            fail(f"key light: the line's {kl}, the page's arrow {got}, panel '{text}'")

    # 2. sphere
    with open(f"{d}/lights.json", "w") as f:
        f.write(st["line"])
    size = st["ref"]["size"]
    subprocess.run([parlight, "render", "--lights", f"{d}/lights.json", "--sphere", "diffuse",
                    "--size", str(size), "--out", f"{d}/sphere.hdr", "--force"], check=True)
    subprocess.run([parlight, "render", "--lights", f"{d}/lights.json", "--sphere", "diffuse",
                    "--size", str(size), "--out", f"{d}/sphere.png", "--force"], check=True)
    ref = read_rgbe(f"{d}/sphere.hdr")
    shot = np.asarray(Image.open(f"{d}/viewer.png").convert("RGB"))
    W, H = st["width"], st["height"]
    x0 = W - st["ref"]["right"] - size
    y0 = H - st["ref"]["bottom"] - size
    crop = shot[y0:y0 + size, x0:x0 + size]
    Image.fromarray(crop).save(f"{d}/viewer-sphere.png")
    view = srgb_to_linear(crop) / st["exposure"]
    c = (np.arange(size) + 0.5) / size * 2 - 1
    r = np.hypot(c[None, :], c[:, None])
    inner = r <= 0.95
    peak = ref[inner].max()
    err = np.abs(view - ref)[inner]
    rms, mx = math.sqrt((err ** 2).mean()) / peak, err.max() / peak
    mean_ratio = view[inner].mean() / ref[inner].mean()
    # what a mirror image would score: the check must be able to tell
    mirror = np.abs(view[:, ::-1] - ref)[inner]
    msg = (f"sphere: {inner.sum()} pixels, RMS error {100 * rms:.2f}%, largest {100 * mx:.2f}% of "
           f"the largest value (tolerances {100 * SPHERE_RMS:.0f}%, {100 * SPHERE_MAX:.0f}%); "
           f"mean ratio {mean_ratio:.4f}; mirrored left-right it would be "
           f"{100 * math.sqrt((mirror ** 2).mean()) / peak:.2f}% RMS")
    (ok if rms <= SPHERE_RMS and mx <= SPHERE_MAX else fail)(msg)
    with open(f"{d}/figures.txt", "w") as f:
        f.write(f"sphere_rms {rms:.5f}\nsphere_max {mx:.5f}\nmean_ratio {mean_ratio:.5f}\n")

    # 3. shadow
    dirv = np.array(frame["engine"]["dir"], float)
    dirv /= np.linalg.norm(dirv)
    if dirv[1] < 0.2:
        fail(f"shadow: the primary light of frame {frame['frame']} is {dirv} (y < 0.2): too low "
             "to cast a shadow on the ground in view; the test needs another frame")
        return
    lum = lambda p: (srgb_to_linear(np.asarray(Image.open(f"{d}/{p}").convert("RGB")))
                     @ [0.2126, 0.7152, 0.0722])
    lit, dark = lum("direct-noshadow.png"), lum("direct.png")
    mask = (dark < 0.5 * lit) & (lit > 1e-3)
    mask[:, :282] = False  # under the HTML panel on the left (dimmed by it): not counted
    n = int(mask.sum())
    if n < SHADOW_MIN_PIXELS:
        fail(f"shadow: {n} shadowed pixels with the directional light alone (need "
             f"{SHADOW_MIN_PIXELS})")
        return
    ys, xs = np.nonzero(mask)
    centroid = np.array([xs.mean(), ys.mean()])
    pts = st["points"]
    k = len(st["casters"])
    base = np.mean([pts[f"base{i}"] for i in range(k)], axis=0)
    expect = np.mean([pts[f"shadow{i}"] for i in range(k)], axis=0)
    toward = np.mean([np.subtract(pts[f"light{i}"], pts[f"base{i}"]) for i in range(k)], axis=0)
    m, v = centroid - base, expect - base
    cos_expect = float(m @ v / (np.linalg.norm(m) * np.linalg.norm(v) + 1e-9))
    cos_light = float(m @ toward / (np.linalg.norm(m) * np.linalg.norm(toward) + 1e-9))
    Image.fromarray((mask * 255).astype(np.uint8)).save(f"{d}/shadow-mask.png")
    msg = (f"shadow: {n} pixels, centroid ({centroid[0]:.0f}, {centroid[1]:.0f}) px, "
           f"{np.linalg.norm(m):.0f} px from the casters' bases toward ({m[0]:.0f}, {m[1]:.0f}); "
           f"cos with the expected shadow side {cos_expect:.3f} (need >= {SHADOW_COS}), with the "
           f"light's side {cos_light:.3f} (need < 0)")
    (ok if cos_expect >= SHADOW_COS and cos_light < 0 else fail)(msg)
    full_on, full_off = lum("viewer.png"), lum("noshadow.png")
    drop = 1 - full_on[mask].mean() / full_off[mask].mean()
    rest = np.abs(full_on[~mask] - full_off[~mask]).mean()
    msg = (f"shadow in the full lighting: {100 * drop:.1f}% darker inside the mask, "
           f"mean change elsewhere {rest:.2e} (linear)")
    (ok if drop > 0.005 and drop > 20 * rest else fail)(msg)
    with open(f"{d}/figures.txt", "a") as f:
        f.write(f"shadow_pixels {n}\nshadow_cos {cos_expect:.4f}\nshadow_drop {drop:.4f}\n")


main()
print("all passed" if fails == 0 else f"{fails} failure(s)")
sys.exit(1 if fails else 0)
