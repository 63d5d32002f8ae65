#!/usr/bin/python3
"""Writes our own int8 golden-vector cases into tests/data/nn-vectors/, in exactly the JSON schema
of the CMSIS-NN vectors (../shared/data/cmsis-nn-vectors/README.md), for what those do not cover:
positive (left) requantisation shifts up to 30, dilation combined with stride and padding, odd
channel counts, batches, extreme values (-128/127 inputs and weights, input_offset -127 and 128,
int32 biases near +-2^30, multipliers 2^30 and 2^31-1, shifts -31 and 30), partial activation
ranges, FC with a weights offset and per-channel quantisation, average-pooling rounding ties.

    tools/make_nn_vectors.py [--out tests/data/nn-vectors]

Expected outputs come from an independent numpy / Python-integer implementation of the TFLite
int8 reference semantics written from their definition (explicitly padded input, exact integer
rounding), not from the C kernels. Seeded: the files are identical on every run. Each file says
how it was made in its `provenance` object. Never edit the files by hand; change this script and
rerun it. Checked by `build/tests/nn_vectors tests/data/nn-vectors` (tests/test_nn_vectors.sh).
Needs only Debian's python3 and numpy.
"""

import argparse
import json
import os
import sys

import numpy as np

TOOL = "tools/make_nn_vectors.py"
SEED = 20261122
INT32_MIN, INT32_MAX = -(2 ** 31), 2 ** 31 - 1

LAYOUTS = {
    "conv2d": "NHWC input, OHWI weights (conv) [output_c][kernel_h][kernel_w][input_c], NHWC output",
    "depthwise_conv2d": "NHWC input, 1HWC weights (depthwise) [1][kernel_h][kernel_w][output_c] "
                        "with output_c = input_c*depth_multiplier and oc = ic*depth_multiplier + m, "
                        "NHWC output",
    "fully_connected": "input [batches][accum_depth] (row-major; NHWC-flattened per batch), "
                       "weights [out][in] (FC) i.e. [output_c][accum_depth], output [batches][output_c]",
    "avgpool": "NHWC input, NHWC output",
    "maxpool": "NHWC input, NHWC output",
}


# --- requantisation, from the definition (Python integers are exact) -------------------------

def high_mul(a, b):
    """2*a*b / 2^32 rounded to nearest with ties toward +infinity; INT32_MIN^2 saturates."""
    if a == INT32_MIN and b == INT32_MIN:
        return INT32_MAX
    return (a * b + (1 << 30)) >> 31  # Python >> floors


def divide_pot(x, e):
    """x / 2^e rounded to nearest, ties away from zero."""
    mag = abs(x)
    q, r = mag >> e, mag & ((1 << e) - 1)
    if e > 0 and 2 * r >= (1 << e):
        q += 1
    return q if x >= 0 else -q


def requantize(acc, mult, shift):
    """TFLite MultiplyByQuantizedMultiplier. Only defined (in TFLite) while acc << shift fits."""
    assert INT32_MIN <= acc <= INT32_MAX, acc
    x = acc << max(shift, 0)
    assert INT32_MIN <= x <= INT32_MAX, ("left shift overflows int32", acc, shift)
    return divide_pot(high_mul(x, mult), max(-shift, 0))


def output_stage(acc, mult, shift, output_offset, act_min, act_max):
    """acc: int64 array [..., C]; mult/shift: per channel lists (or length 1)."""
    out = np.empty(acc.shape, dtype=np.int64)
    c = acc.shape[-1]
    flat, oflat = acc.reshape(-1, c), out.reshape(-1, c)
    for i in range(flat.shape[0]):
        for oc in range(c):
            q = oc if len(mult) > 1 else 0
            v = requantize(int(flat[i, oc]), mult[q], shift[q]) + output_offset
            oflat[i, oc] = min(max(v, act_min), act_max)
    return out


def check_acc(acc):
    assert acc.min() >= INT32_MIN and acc.max() <= INT32_MAX, "accumulator leaves int32"


# --- kernels, from the definition -------------------------------------------------------------

def padded(x, input_offset, pad_h, pad_w, need_h, need_w):
    """(x + input_offset) as int64, padded with 0 (the input zero point) to need_h x need_w:
    pad_h/pad_w rows/columns on top/left, the rest on the bottom/right."""
    n, h, w, c = x.shape
    out = np.zeros((n, max(need_h, pad_h + h), max(need_w, pad_w + w), c), dtype=np.int64)
    out[:, pad_h:pad_h + h, pad_w:pad_w + w, :] = x.astype(np.int64) + input_offset
    return out


def taps(xp, ky, kx, p, oh, ow):
    """The input values tap (ky, kx) reads for every output pixel: [n, oh, ow, c]."""
    y0, x0 = ky * p["dilation_h"], kx * p["dilation_w"]
    return xp[:, y0:y0 + (oh - 1) * p["stride_h"] + 1:p["stride_h"],
              x0:x0 + (ow - 1) * p["stride_w"] + 1:p["stride_w"], :]


def conv_acc(case, x, w, bias, depthwise):
    p = case
    kh, kw, oh, ow = p["kernel_h"], p["kernel_w"], p["output_h"], p["output_w"]
    need_h = (oh - 1) * p["stride_h"] + (kh - 1) * p["dilation_h"] + 1
    need_w = (ow - 1) * p["stride_w"] + (kw - 1) * p["dilation_w"] + 1
    xp = padded(x, p["input_offset"], p["pad_h"], p["pad_w"], need_h, need_w)
    oc = p["output_c"]
    acc = np.zeros((x.shape[0], oh, ow, oc), dtype=np.int64)
    for ky in range(kh):
        for kx in range(kw):
            t = taps(xp, ky, kx, p, oh, ow)
            if depthwise:
                acc += np.repeat(t, p["depth_multiplier"], axis=3) * w[0, ky, kx, :].astype(np.int64)
            else:
                acc += np.tensordot(t, w[:, ky, kx, :].astype(np.int64), axes=([3], [1]))
    if bias is not None:
        acc += np.asarray(bias, dtype=np.int64)
    check_acc(acc)
    return acc


def pool(case, x, op):
    p = case
    n, h, w, c = x.shape
    out = np.empty((n, p["output_h"], p["output_w"], c), dtype=np.int64)
    for oy in range(p["output_h"]):
        for ox in range(p["output_w"]):
            y0, x0 = oy * p["stride_h"] - p["pad_h"], ox * p["stride_w"] - p["pad_w"]
            win = x[:, max(y0, 0):min(y0 + p["kernel_h"], h), max(x0, 0):min(x0 + p["kernel_w"], w), :]
            win = win.astype(np.int64).reshape(n, -1, c)
            assert win.shape[1] > 0, "empty pooling window"
            if op == "maxpool":
                v = win.max(axis=1)
            else:
                s, cnt = win.sum(axis=1), win.shape[1]
                v = np.sign(s) * ((2 * np.abs(s) + cnt) // (2 * cnt))  # half away from zero
            out[:, oy, ox, :] = np.clip(v, p["act_min"], p["act_max"])
    return out


# --- cases ------------------------------------------------------------------------------------

def s8(rng, shape, extreme=0.0):
    """Uniform int8 with a fraction `extreme` of the values at -128 or 127."""
    v = rng.integers(-128, 128, size=shape)
    m = rng.random(size=shape) < extreme
    v[m] = rng.choice([-128, 127], size=int(m.sum()))
    return v.astype(np.int64)


def mults(rng, n):
    return [int(v) for v in rng.integers(1 << 30, 1 << 31, size=n)]


def finish(case, x, w, bias, mult, shift, expected):
    case["input"] = [int(v) for v in x.reshape(-1)]
    if w is not None:
        case["weights"] = [int(v) for v in w.reshape(-1)]
    if case["op"] not in ("avgpool", "maxpool"):
        case["bias"] = None if bias is None else [int(v) for v in bias]
        case["multiplier"] = mult
        case["shift"] = shift
    case["expected_output"] = [int(v) for v in expected.reshape(-1)]
    case["provenance"] = case.pop("provenance")  # last, as in the CMSIS-NN files
    assert all(-128 <= v <= 127 for v in case["expected_output"])
    return case


def header(op, name, what, **dims):
    case = {"op": op, "source_case": name, "layout": LAYOUTS[op]}
    case.update(dims)
    case["provenance"] = {
        "tool": TOOL, "seed": SEED, "numpy": np.__version__,
        "method": "independent numpy / Python-integer implementation of the TFLite int8 reference "
                  "semantics (docs/QUANT.md, ../shared/data/cmsis-nn-vectors/README.md); not "
                  "computed by the C kernels",
        "covers": what,
    }
    return case


def conv_case(rng, name, what, *, batches, ih, iw, ic, oc, kh, kw, sh, sw, ph, pw, dh, dw, oh, ow,
              in_off, out_off, act, x, w, bias, mult, shift, depthwise=False, fit=False):
    """fit: choose bias and shifts from the data so that acc + bias <= 0 and its range maps onto
    about 200 output steps (so output_offset 127 leaves most outputs unclamped)."""
    op = "depthwise_conv2d" if depthwise else "conv2d"
    dims = dict(batches=batches, input_h=ih, input_w=iw, input_c=ic, output_h=oh, output_w=ow,
                output_c=oc, kernel_h=kh, kernel_w=kw, stride_h=sh, stride_w=sw, pad_h=ph, pad_w=pw,
                dilation_h=dh, dilation_w=dw)
    if depthwise:
        dims["depth_multiplier"] = oc // ic
    dims.update(input_offset=in_off, output_offset=out_off, act_min=act[0], act_max=act[1],
                quant_granularity="per_channel")
    case = header(op, name, what, **dims)
    if fit:
        acc0 = conv_acc(case, x, w, None, depthwise)
        hi, lo = acc0.reshape(-1, oc).max(axis=0), acc0.reshape(-1, oc).min(axis=0)
        bias = [-int(v) for v in hi]
        shift = [-int(np.ceil(np.log2(max(int(h - l), 200) / 200.0))) for h, l in zip(hi, lo)]
    acc = conv_acc(case, x, w, bias, depthwise)
    out = output_stage(acc, mult, shift, out_off, act[0], act[1])
    return finish(case, x, w, bias, mult, shift, out)


def make_cases():
    rng = np.random.default_rng(SEED)
    cases = []

    # 1. Left shifts 1..30: tiny accumulators so that acc << shift stays in int32 (TFLite's
    #    behaviour is undefined beyond); a channel with zero weights and bias +-1 at shift 30.
    ic, oc = 3, 9
    x = rng.integers(-6, 7, size=(2, 4, 5, ic)) - 3  # input_offset 3: x + 3 in [-6, 6]
    w = rng.integers(-1, 2, size=(oc, 1, 1, ic))
    w[8] = 0
    bias = [int(v) for v in rng.integers(-4, 5, size=oc)]
    bias[8] = -1
    shift = [1, 2, 3, 4, 5, 8, 12, 20, 30]
    mult = [1 << 30, (1 << 31) - 1] + mults(rng, 6) + [(1 << 31) - 1]
    # keep |acc| << shift inside int32 for the larger shifts
    for c in range(oc):
        if shift[c] > 8:
            w[c] = 0
            bias[c] = int(rng.integers(-1, 2)) if shift[c] == 30 else int(rng.integers(-40, 41))
    cases.append(conv_case(
        rng, "left_shift", "positive (left) requantisation shifts 1..30, multipliers 2^30 and 2^31-1, "
        "1x1 conv with stride, batches 2",
        batches=2, ih=4, iw=5, ic=ic, oc=oc, kh=1, kw=1, sh=2, sw=1, ph=0, pw=0, dh=1, dw=1, oh=2,
        ow=5, in_off=3, out_off=-7, act=(-128, 127), x=x, w=w, bias=bias, mult=mult, shift=shift))

    # 2. Dilation with stride and padding, odd channel counts, asymmetric everything.
    ic, oc = 5, 7
    x = s8(rng, (2, 9, 8, ic))
    w = s8(rng, (oc, 3, 2, ic))
    bias = [int(v) for v in rng.integers(-30000, 30001, size=oc)]
    cases.append(conv_case(
        rng, "dilation_stride_pad", "3x2 kernel, dilation 2x3 with stride 2x1 and padding 2x1, "
        "input_c 5, output_c 7, batches 2, partial activation range",
        batches=2, ih=9, iw=8, ic=ic, oc=oc, kh=3, kw=2, sh=2, sw=1, ph=2, pw=1, dh=2, dw=3, oh=5,
        ow=6, in_off=17, out_off=5, act=(-100, 90), x=x, w=w, bias=bias, mult=mults(rng, oc),
        shift=[int(v) for v in rng.integers(-12, -6, size=oc)]))

    # 3. Extremes: -128/127 inputs and weights, input_offset 128 (x + 128 in [0, 255]), biases
    #    near +-2^30, multipliers 2^30 / 2^31-1, shifts -31 and -1.
    ic, oc = 13, 6
    x = s8(rng, (1, 5, 4, ic), extreme=0.8)
    w = s8(rng, (oc, 3, 3, ic), extreme=0.8)
    # |sum of products| <= 3*3*13 * 255*128 = 3818880, so these biases keep acc inside int32
    bias = [1 << 30, -(1 << 30), INT32_MAX - 4000000, INT32_MIN + 4000000, 0, 1 << 29]
    cases.append(conv_case(
        rng, "extremes_offset_128", "-128/127 inputs and weights, input_offset 128, int32 biases "
        "near +-2^30 and INT32_MAX/MIN -+ 4e6, multipliers 2^30 and 2^31-1, shifts -31..-11, "
        "output_offset -128",
        batches=1, ih=5, iw=4, ic=ic, oc=oc, kh=3, kw=3, sh=1, sw=1, ph=1, pw=1, dh=1, dw=1, oh=5,
        ow=4, in_off=128, out_off=-128, act=(-128, 127), x=x, w=w, bias=bias,
        mult=[1 << 30, (1 << 31) - 1, (1 << 31) - 1, (1 << 31) - 1, 1 << 30, (1 << 31) - 1],
        shift=[-23, -23, -31, -24, -11, -22]))

    # 4. The other extreme offset: input_offset -127 (input zero point 127).
    ic, oc = 3, 5
    x = s8(rng, (1, 6, 6, ic), extreme=0.5)
    w = s8(rng, (oc, 2, 2, ic), extreme=0.5)
    cases.append(conv_case(
        rng, "extremes_offset_minus127", "input_offset -127, output_offset 127, 2x2 kernel with "
        "stride 2, bias and shifts fitted to the data so outputs span about 200 steps below 127",
        batches=1, ih=6, iw=6, ic=ic, oc=oc, kh=2, kw=2, sh=2, sw=2, ph=0, pw=0, dh=1, dw=1, oh=3,
        ow=3, in_off=-127, out_off=127, act=(-128, 127), x=x, w=w, bias=None, mult=mults(rng, oc),
        shift=None, fit=True))

    # 5. Depthwise: odd input channels, depth multiplier 2, dilation + stride + padding, left shifts.
    ic, dm = 3, 2
    oc = ic * dm
    x = s8(rng, (2, 7, 6, ic), extreme=0.2)
    w = s8(rng, (1, 3, 2, oc), extreme=0.2)
    bias = [int(v) for v in rng.integers(-2000, 2001, size=oc)]
    cases.append(conv_case(
        rng, "depthwise_dilation_stride", "depthwise 3x2, depth_multiplier 2, dilation 2x2, stride "
        "2x1, padding 2x1, input_c 3, batches 2, shifts -8..-5",
        batches=2, ih=7, iw=6, ic=ic, oc=oc, kh=3, kw=2, sh=2, sw=1, ph=2, pw=1, dh=2, dw=2, oh=4,
        ow=6, in_off=-5, out_off=9, act=(-128, 127), x=x, w=w, bias=bias, mult=mults(rng, oc),
        shift=[-8, -7, -6, -5, -8, -7], depthwise=True))

    # 6. Depthwise with left shifts: accumulators kept tiny.
    ic, dm = 5, 1
    x = rng.integers(-3, 4, size=(1, 4, 4, ic))
    w = rng.integers(-1, 2, size=(1, 2, 2, ic))
    cases.append(conv_case(
        rng, "depthwise_left_shift", "depthwise 2x2 with positive shifts 1..4 and 0",
        batches=1, ih=4, iw=4, ic=ic, oc=ic, kh=2, kw=2, sh=1, sw=1, ph=1, pw=0, dh=1, dw=1, oh=4,
        ow=3, in_off=0, out_off=-3, act=(-128, 127), x=x, w=w,
        bias=[int(v) for v in rng.integers(-3, 4, size=ic)], mult=mults(rng, ic),
        shift=[1, 2, 3, 4, 0], depthwise=True))

    # 7. Fully connected: per channel, weights_offset, odd sizes, extremes, a left shift.
    batches, depth, oc = 2, 33, 7
    x = s8(rng, (batches, 1, 3, 11), extreme=0.3)
    w = s8(rng, (oc, depth), extreme=0.3)
    w_off, in_off, out_off = 13, -127, 3
    bias = np.array([int(v) for v in rng.integers(-300000, 300001, size=oc)], dtype=np.int64)
    mult, shift = mults(rng, oc), [-14, -13, -12, -15, -16, -31, 1]
    # the left-shifted channel: tiny weights so acc << 1 fits and some outputs are not clamped
    w[6] = -w_off
    w[6, :3] += np.array([1, -1, 1])
    bias[6] = 40
    acc = (x.reshape(batches, depth) + in_off) @ (w + w_off).T + bias
    check_acc(acc)
    case = header("fully_connected", "fc_per_channel_w_offset", "fully connected per channel, "
                  "weights_offset 13, input_offset -127, depth 33, output_c 7, batches 2, shifts "
                  "-31 and +1", batches=batches, input_h=1, input_w=3, input_c=11,
                  accum_depth=depth, output_c=oc, input_offset=in_off, weights_offset=w_off,
                  output_offset=out_off, act_min=-128, act_max=127,
                  quant_granularity="per_channel")
    out = output_stage(acc, mult, shift, out_off, -128, 127)
    cases.append(finish(case, x, w, [int(v) for v in bias], mult, shift, out))

    # 8. Fully connected per tensor with a partial activation range and no bias.
    batches, depth, oc = 3, 17, 5
    x = s8(rng, (batches, 1, 1, depth), extreme=0.3)
    w = s8(rng, (oc, depth), extreme=0.3)
    acc = (x.reshape(batches, depth) + 9) @ w.T
    check_acc(acc)
    mult, shift = mults(rng, 1), [-10]
    case = header("fully_connected", "fc_per_tensor_act", "fully connected per tensor, no bias, "
                  "activation range [-20, 60]", batches=batches, input_h=1, input_w=1,
                  input_c=depth, accum_depth=depth, output_c=oc, input_offset=9, weights_offset=0,
                  output_offset=-1, act_min=-20, act_max=60, quant_granularity="per_tensor")
    out = output_stage(acc, mult, shift, -1, -20, 60)
    cases.append(finish(case, x, w, None, mult, shift, out))

    # 9./10. Pooling with TFLite SAME padding, odd channels, rounding ties, extremes.
    for op in ("avgpool", "maxpool"):
        n, h, w_, c, kh, kw, sh, sw = 2, 7, 8, 5, 3, 2, 2, 3
        oh, ow = -(-h // sh), -(-w_ // sw)  # SAME: ceil(in / stride)
        ph = max((oh - 1) * sh + kh - h, 0) // 2
        pw = max((ow - 1) * sw + kw - w_, 0) // 2
        x = s8(rng, (n, h, w_, c), extreme=0.3)
        if op == "avgpool":  # make ties: a channel of +-1 steps where window sums hit x.5
            x[..., 0] = rng.choice([-1, 0, 1, 2], size=(n, h, w_))
        act = (-128, 127) if op == "avgpool" else (-90, 100)
        case = header(op, op + "_same_odd", op + " 3x2 stride 2x3, TFLite SAME padding, input_c 5, "
                      "batches 2, extremes" + (", rounding ties" if op == "avgpool" else
                                               ", activation range [-90, 100]"),
                      batches=n, input_h=h, input_w=w_, input_c=c, output_h=oh, output_w=ow,
                      output_c=c, kernel_h=kh, kernel_w=kw, stride_h=sh, stride_w=sw, pad_h=ph,
                      pad_w=pw, act_min=act[0], act_max=act[1], tflite_padding="SAME")
        out = pool(case, x, op)
        cases.append(finish(case, x, None, None, None, None, out))
    return cases


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    here = os.path.dirname(os.path.abspath(__file__))
    ap.add_argument("--out", default=os.path.join(here, "..", "tests", "data", "nn-vectors"))
    args = ap.parse_args()
    os.makedirs(args.out, exist_ok=True)
    # remove what an earlier run of this tool wrote, so renamed cases do not linger
    for root, _, files in os.walk(args.out):
        for name in files:
            path = os.path.join(root, name)
            if name.endswith(".json"):
                try:
                    with open(path) as f:
                        made_here = json.load(f).get("provenance", {}).get("tool") == TOOL
                except (OSError, ValueError, AttributeError):
                    made_here = False
                if made_here:
                    os.remove(path)
    total = 0
    for case in make_cases():
        op_dir = os.path.join(args.out, case["op"])
        os.makedirs(op_dir, exist_ok=True)
        path = os.path.join(op_dir, case["source_case"] + ".json")
        # one field per line, arrays on one line (like the CMSIS-NN files)
        text = "{\n" + ",\n".join("  %s: %s" % (json.dumps(k), json.dumps(v, separators=(",", ":"))
                                                if isinstance(v, list) else json.dumps(v))
                                  for k, v in case.items()) + "\n}\n"
        with open(path, "w") as f:
            f.write(text)
        total += len(text)
        out = case["expected_output"]
        print("wrote %s (%d bytes; %d outputs, %d distinct, %d clamped)" % (
            os.path.relpath(path), len(text), len(out), len(set(out)),
            sum(v in (case["act_min"], case["act_max"]) for v in out)))
    print("%d bytes in all" % total)
    if total > 100_000:
        sys.exit("too large: keep tests/data/nn-vectors under 100 KB")


if __name__ == "__main__":
    main()
