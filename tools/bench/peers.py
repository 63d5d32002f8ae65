#!/usr/bin/python3
"""Peer engines for `make bench` (tools/bench/run.sh), on the SAME weights as a .plm file.

    peers.py torch --model M.plm --frames DIR --runs R --warmup W --threads 1,2 --out rows.jsonl
        PyTorch 1.13 (Debian): fp32 (jit.trace + freeze) and int8 (FX graph mode quantisation,
        onednn backend, calibrated on the frames; jit.trace + freeze). Set
        ONEDNN_MAX_CPU_ISA=AVX512_CORE_VNNI before Python starts (oneDNN's AMX int8 path crashes).
    peers.py onnx --model M.plm --frames DIR --outdir D
        Writes D/fp32.onnx and D/int8.onnx (QuantizeLinear/DequantizeLinear around each conv and
        the FC: per-output-channel symmetric int8 weights, int32 biases at s_in*s_w, uint8
        activations with scales from min/max calibration on the frames) and D/input.bin, the
        normalised input tensor (float32, 1x3xHxW) that tools/bench/ort_bench.js times.

Same weights: the .plm holds the batch-norm-folded tensors that tools/export.py writes. The
PyTorch peer is tools/model.py's ParLightNet with those tensors put back (a folded conv+BN
becomes the conv plus a BN that only adds the bias; a pre-activation BN gets scale and shift
with mean 0, var 1, eps 0); the ONNX graphs are built from the tensors directly. Both are
checked against tools/export.py:folded_forward on the .plm tensors before anything is timed,
so a weight that went astray fails the run instead of producing a figure.

Each timing row is one JSON line: engine, precision, threads, runs, warmup, median_ms, min_ms,
max_ms, status ("ok" or what went wrong).
"""

import argparse
import glob
import json
import os
import statistics
import sys
import time

import numpy as np
import torch
import torch.nn.functional as F
from PIL import Image

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, ".."))
import export  # noqa: E402
import plm  # noqa: E402
from model import ParLightNet, preprocess  # noqa: E402

OUT_KEYS = ("z", "dir", "distance", "size", "rgb", "ambient")


# ---- the model and its frames ------------------------------------------------------------------

def read_model(path):
    """(meta, {name: float32 ndarray}) of an fp32 .plm; exits with a message otherwise."""
    meta, tensors, _ = plm.read_plm(path)
    if meta.get("precision") != "fp32":
        raise ValueError(f"{path}: precision {meta.get('precision')}, the peers need the fp32 model")
    return meta, tensors


def load_frames(folder, h, w):
    """u8 RGB frames [h, w, 3] of every image in folder: centre-cropped to w:h, area-resized."""
    paths = sorted(p for p in glob.glob(os.path.join(folder, "*"))
                   if p.lower().endswith((".jpg", ".jpeg", ".png")))
    if not paths:
        raise ValueError(f"{folder}: no .jpg/.png frames")
    frames = []
    for p in paths:
        with Image.open(p) as im:
            im = im.convert("RGB")
            W, H = im.size
            if W * h > H * w:
                cw = H * w // h
                im = im.crop(((W - cw) // 2, 0, (W - cw) // 2 + cw, H))
            else:
                ch = W * h // w
                im = im.crop((0, (H - ch) // 2, W, (H - ch) // 2 + ch))
            frames.append(np.array(im.resize((w, h), Image.BOX), dtype=np.uint8))
    return frames


def reference(meta, tensors, x):
    """tools/export.py's folded forward on the .plm tensors (what the C executor computes)."""
    t = {k: torch.from_numpy(np.array(v)) for k, v in tensors.items()}
    with torch.no_grad():
        return export.folded_forward(t, x, int(meta["n_lights"]))


def rel_err(got, ref):
    return max(float((got[k].float() - ref[k]).norm() / ref[k].norm().clamp_min(1e-30))
               for k in OUT_KEYS)


# ---- PyTorch ------------------------------------------------------------------------------------

def torch_model(meta, tensors):
    """tools/model.py's ParLightNet carrying the .plm tensors (see the module docstring)."""
    n, h, w = int(meta["n_lights"]), int(meta["input_h"]), int(meta["input_w"])
    m = ParLightNet(n, (h, w), int(meta["dist_hidden"])).eval()
    t = {k: torch.from_numpy(np.array(v)) for k, v in tensors.items()}

    def bias_bn(bn, b):      # the BN of a folded conv: adds b, nothing else
        bn.weight.data.fill_(1.0)
        bn.bias.data.copy_(b)
        bn.running_mean.zero_()
        bn.running_var.fill_(1.0)
        bn.eps = 0.0

    def affine_bn(bn, prefix):   # a pre-activation BN: scale and shift as stored
        bn.weight.data.copy_(t[f"{prefix}.scale"])
        bn.bias.data.copy_(t[f"{prefix}.shift"])
        bn.running_mean.zero_()
        bn.running_var.fill_(1.0)
        bn.eps = 0.0

    f = m.features
    f.conv0.weight.data.copy_(t["conv0.weight"])
    bias_bn(f.norm0, t["conv0.bias"])
    for bi in range(1, 5):
        block = getattr(f, f"denseblock{bi}")
        for li in range(1, export.BLOCKS[bi - 1] + 1):
            layer = getattr(block, f"denselayer{li}")
            p = f"denseblock{bi}.denselayer{li}"
            affine_bn(layer.norm1, f"{p}.norm1")
            layer.conv1.weight.data.copy_(t[f"{p}.conv1.weight"])
            bias_bn(layer.norm2, t[f"{p}.conv1.bias"])
            layer.conv2.weight.data.copy_(t[f"{p}.conv2.weight"])
        if bi < 4:
            tr = getattr(f, f"transition{bi}")
            affine_bn(tr.norm, f"transition{bi}.norm")
            tr.conv.weight.data.copy_(t[f"transition{bi}.conv.weight"])
    affine_bn(f.norm5, "norm5")
    for name in ("fc", "head_dir", "head_size", "head_rgb", "head_ambient", "head_dist.fc1",
                 "head_dist.fc2"):
        lin = m.get_submodule(name)
        lin.weight.data.copy_(t[f"{name}.weight"])
        lin.bias.data.copy_(t[f"{name}.bias"])
    return m


def time_fn(fn, runs, warmup):
    for _ in range(warmup):
        fn()
    ms, cpu = [], []
    for _ in range(runs):
        c0, t0 = time.process_time(), time.perf_counter()
        fn()
        t1, c1 = time.perf_counter(), time.process_time()
        ms.append((t1 - t0) * 1e3)
        cpu.append((c1 - c0) * 1e3)
    return {"runs": runs, "warmup": warmup, "median_ms": statistics.median(ms), "min_ms": min(ms),
            "max_ms": max(ms), "median_cpu_ms": statistics.median(cpu)}


def cmd_torch(args):
    def emit(row):
        print(json.dumps(row), flush=True)
        if args.out:
            with open(args.out, "a") as f:
                f.write(json.dumps(row) + "\n")

    meta, tensors = read_model(args.model)
    h, w = int(meta["input_h"]), int(meta["input_w"])
    frames = load_frames(args.frames, h, w)
    x = preprocess(frames[0])
    ref = reference(meta, tensors, x)
    model = torch_model(meta, tensors)
    with torch.no_grad():
        err = rel_err(model(x), ref)
    if err > 1e-4:
        raise RuntimeError(f"PyTorch model differs from the .plm's folded forward: rel err {err:.2e}")
    threads = [int(v) for v in args.threads.split(",")]

    def traced(m):
        with torch.no_grad():
            tm = torch.jit.trace(m, x, strict=False)
            return torch.jit.freeze(tm.eval())

    engines = []
    try:
        # Debian's torch runs a plain frozen fp32 graph's 1x1 convolutions through its generic
        # (reference) BLAS, ~1 s a frame; optimize_for_inference (freeze + conversion to oneDNN
        # convolutions) is PyTorch's own fast CPU path, so that is the fp32 peer.
        with torch.no_grad():
            fast = torch.jit.optimize_for_inference(
                torch.jit.trace(model, x, strict=False).eval())
            err = rel_err(fast(x), ref)
        if err > 1e-4:
            raise RuntimeError(f"optimized fp32 graph differs from the .plm's: rel err {err:.2e}")
        engines.append(("fp32", "jit.trace + freeze + optimize_for_inference (oneDNN)", fast, err))
    except Exception as e:  # noqa: BLE001 - a peer that fails is reported in its row
        for n in threads:
            emit({"engine": "pytorch", "precision": "fp32", "threads": n,
                  "status": f"fp32 trace failed: {type(e).__name__}: {e}"})
    try:
        from torch.ao.quantization import get_default_qconfig_mapping
        from torch.ao.quantization.quantize_fx import convert_fx, prepare_fx
        torch.backends.quantized.engine = "onednn"
        qmap = get_default_qconfig_mapping("onednn")
        prepared = prepare_fx(torch_model(meta, tensors), qmap, (x,))
        with torch.no_grad():
            for fr in frames:
                prepared(preprocess(fr))
        q = convert_fx(prepared)
        with torch.no_grad():
            qerr = rel_err(q(x), ref)
        engines.append(("int8", "FX onednn, jit.trace + freeze", traced(q), qerr))
    except Exception as e:  # noqa: BLE001
        for n in threads:
            emit({"engine": "pytorch", "precision": "int8", "threads": n,
                  "status": f"int8 (FX, onednn) failed: {type(e).__name__}: {e}"})
    for prec, how, fn, e in engines:
        for n in threads:
            torch.set_num_threads(n)
            with torch.no_grad():
                r = time_fn(lambda: fn(x), args.runs, args.warmup)
            emit({"engine": "pytorch", "precision": prec, "threads": n, **r, "how": how,
                  "rel_err_vs_plm": e, "version": torch.__version__, "status": "ok"})
    return 0


# ---- ONNX ---------------------------------------------------------------------------------------
#
# One forward, written once over an `ops` object: TorchOps computes it (checking the graph against
# the reference and collecting calibration ranges at the quantisation points), OnnxOps writes it
# as ONNX nodes, in float or with Q/DQ pairs.

class TorchOps:
    def __init__(self, t):
        self.t = {k: torch.from_numpy(np.array(v)) for k, v in t.items()}
        self.ranges = {}

    def observe(self, key, v):
        lo, hi = float(v.min()), float(v.max())
        a, b = self.ranges.get(key, (lo, hi))
        self.ranges[key] = (min(a, lo), max(b, hi))

    def conv(self, key, x, wname, bname, stride, pad, relu):
        self.observe(key + ".in", x)
        b = self.t[bname] if bname else None
        y = F.conv2d(x, self.t[wname], b, stride=stride, padding=pad)
        y = F.relu(y) if relu else y
        self.observe(key + ".out", y)
        return y

    def linear(self, key, x, name, relu, quant):
        if quant:
            self.observe(key + ".in", x)
        y = F.linear(x, self.t[name + ".weight"], self.t[name + ".bias"])
        y = F.relu(y) if relu else y
        if quant:
            self.observe(key + ".out", y)
        return y

    def bn_relu(self, x, prefix):
        s, b = self.t[prefix + ".scale"], self.t[prefix + ".shift"]
        return F.relu(x * s.view(1, -1, 1, 1) + b.view(1, -1, 1, 1))

    def maxpool(self, x):
        return F.max_pool2d(x, 3, stride=2, padding=1)

    def avgpool(self, x):
        return F.avg_pool2d(x, 2, 2)

    def concat(self, xs, axis):
        return torch.cat(xs, axis)

    def bands(self, x, bands):
        return F.adaptive_avg_pool2d(x, (bands, 1)).flatten(1)

    def normalize_dirs(self, x, n):
        return F.normalize(x.view(-1, n, 3), dim=-1)

    def flatten(self, x):
        return x.flatten(1)

    def softplus(self, x):
        return F.softplus(x)

    def view3(self, x, n):
        return x.view(-1, n, 3)


class OnnxOps:
    def __init__(self, t, h, ranges=None):
        from onnx import helper, numpy_helper, TensorProto
        self.helper, self.nph, self.TP = helper, numpy_helper, TensorProto
        self.t, self.h = t, h
        self.ranges = ranges          # None: float graph; else {key: (min, max)} for Q/DQ
        self.nodes, self.inits, self.done, self.n = [], [], set(), 0

    def name(self, base):
        self.n += 1
        return f"{base}_{self.n}"

    def init(self, name, arr):
        if name not in self.done:
            self.done.add(name)
            self.inits.append(self.nph.from_array(np.ascontiguousarray(arr), name))
        return name

    def node(self, op, inputs, base, **attrs):
        out = self.name(base)
        self.nodes.append(self.helper.make_node(op, inputs, [out], name=out, **attrs))
        return out

    def act_qparams(self, key):
        """uint8 asymmetric scale and zero point covering [min(lo,0), max(hi,0)]."""
        lo, hi = self.ranges[key]
        lo, hi = min(lo, 0.0), max(hi, 0.0)
        scale = max(hi - lo, 1e-8) / 255.0
        zp = int(np.clip(round(-lo / scale), 0, 255))
        return np.float32(scale), np.uint8(zp)

    def qdq(self, key, x):
        s, zp = self.act_qparams(key)
        sn = self.init(key + ".s", np.array(s, np.float32))
        zn = self.init(key + ".zp", np.array(zp, np.uint8))
        q = self.node("QuantizeLinear", [x, sn, zn], key + ".q")
        return self.node("DequantizeLinear", [q, sn, zn], key + ".dq"), float(s)

    def weights(self, wname, bname, s_in, out_ch_axis_len):
        """DQ'd per-output-channel symmetric int8 weights and int32 bias at s_in * s_w."""
        w = np.asarray(self.t[wname], np.float32)
        flat = np.abs(w.reshape(w.shape[0], -1)).max(axis=1)
        sw = (np.maximum(flat, 1e-12) / 127.0).astype(np.float32)
        wq = np.clip(np.round(w / sw.reshape((-1,) + (1,) * (w.ndim - 1))), -127, 127).astype(np.int8)
        wn = self.node("DequantizeLinear", [self.init(wname + ".q", wq),
                                            self.init(wname + ".s", sw),
                                            self.init(wname + ".zp", np.zeros(len(sw), np.int8))],
                       wname + ".dq", axis=0)
        b = np.asarray(self.t[bname], np.float32) if bname else np.zeros(out_ch_axis_len, np.float32)
        sb = (np.float32(s_in) * sw).astype(np.float32)
        bq = np.clip(np.round(b / sb), -2**31, 2**31 - 1).astype(np.int32)
        bn = self.node("DequantizeLinear", [self.init((bname or wname) + ".bq", bq),
                                            self.init((bname or wname) + ".bs", sb),
                                            self.init((bname or wname) + ".bzp",
                                                      np.zeros(len(sb), np.int32))],
                       (bname or wname) + ".bdq", axis=0)
        return wn, bn

    def conv(self, key, x, wname, bname, stride, pad, relu):
        w = self.t[wname]
        k = int(w.shape[2])
        attrs = dict(kernel_shape=[k, k], strides=[stride, stride], pads=[pad] * 4)
        if self.ranges is None:
            ins = [x, self.init(wname, w)] + ([self.init(bname, self.t[bname])] if bname else [])
            y = self.node("Conv", ins, key, **attrs)
            return self.node("Relu", [y], key + ".relu") if relu else y
        xq, s_in = self.qdq(key + ".in", x)
        wn, bn = self.weights(wname, bname, s_in, int(w.shape[0]))
        y = self.node("Conv", [xq, wn, bn], key, **attrs)
        if relu:
            y = self.node("Relu", [y], key + ".relu")
        return self.qdq(key + ".out", y)[0]

    def linear(self, key, x, name, relu, quant):
        w, b = self.t[name + ".weight"], self.t[name + ".bias"]
        if self.ranges is None or not quant:
            y = self.node("Gemm", [x, self.init(name + ".weight", w), self.init(name + ".bias", b)],
                          key, transB=1)
        else:
            xq, s_in = self.qdq(key + ".in", x)
            wn, bn = self.weights(name + ".weight", name + ".bias", s_in, int(w.shape[0]))
            y = self.node("Gemm", [xq, wn, bn], key, transB=1)
        if relu:
            y = self.node("Relu", [y], key + ".relu")
        if self.ranges is not None and quant:
            y = self.qdq(key + ".out", y)[0]
        return y

    def bn_relu(self, x, prefix):
        s = np.asarray(self.t[prefix + ".scale"], np.float32).reshape(1, -1, 1, 1)
        b = np.asarray(self.t[prefix + ".shift"], np.float32).reshape(1, -1, 1, 1)
        y = self.node("Mul", [x, self.init(prefix + ".s4", s)], prefix + ".mul")
        y = self.node("Add", [y, self.init(prefix + ".b4", b)], prefix + ".add")
        return self.node("Relu", [y], prefix + ".relu")

    def maxpool(self, x):
        return self.node("MaxPool", [x], "pool0", kernel_shape=[3, 3], strides=[2, 2],
                         pads=[1, 1, 1, 1])

    def avgpool(self, x):
        return self.node("AveragePool", [x], "pool", kernel_shape=[2, 2], strides=[2, 2])

    def concat(self, xs, axis):
        return self.node("Concat", list(xs), "cat", axis=axis)

    def bands(self, x, bands):
        """PyTorch's adaptive average pooling to (bands, 1): band i averages rows
        floor(i*h/bands) .. ceil((i+1)*h/bands)-1 of the h = H/32 rows."""
        h = self.h // 32
        parts = []
        for i in range(bands):
            r0, r1 = (i * h) // bands, -(-((i + 1) * h) // bands)
            sl = self.node("Slice", [x, self.init(f"band{i}.start", np.array([r0], np.int64)),
                                     self.init(f"band{i}.end", np.array([r1], np.int64)),
                                     self.init("axis2", np.array([2], np.int64))], f"band{i}")
            parts.append(self.node("ReduceMean", [sl], f"band{i}.mean", axes=[2, 3], keepdims=1))
        y = self.node("Concat", parts, "bands", axis=2)
        return self.node("Reshape", [y, self.init("shape_b_z", np.array([0, -1], np.int64))], "z")

    def view3(self, x, n):
        return self.node("Reshape", [x, self.init(f"shape_b_{n}_3", np.array([0, n, 3], np.int64))],
                         "view3")

    def normalize_dirs(self, x, n):
        v = self.view3(x, n)
        norm = self.node("ReduceL2", [v], "norm", axes=[-1], keepdims=1)
        norm = self.node("Max", [norm, self.init("eps12", np.array(1e-12, np.float32))], "normc")
        return self.node("Div", [v, norm], "dir")

    def flatten(self, x):
        return self.node("Flatten", [x], "flat", axis=1)

    def softplus(self, x):
        return self.node("Softplus", [x], "softplus")


def forward(ops, x, meta):
    """The .plm graph (= tools/export.py:folded_forward) over `ops`; returns {name: value}."""
    n = int(meta["n_lights"])
    v = ops.conv("conv0", x, "conv0.weight", "conv0.bias", 2, 3, True)
    v = ops.maxpool(v)
    for bi in range(1, 5):
        for li in range(1, export.BLOCKS[bi - 1] + 1):
            p = f"denseblock{bi}.denselayer{li}"
            y = ops.bn_relu(v, f"{p}.norm1")
            y = ops.conv(f"{p}.conv1", y, f"{p}.conv1.weight", f"{p}.conv1.bias", 1, 0, True)
            y = ops.conv(f"{p}.conv2", y, f"{p}.conv2.weight", None, 1, 1, False)
            v = ops.concat([v, y], 1)
        if bi < 4:
            p = f"transition{bi}"
            y = ops.bn_relu(v, f"{p}.norm")
            v = ops.avgpool(ops.conv(p, y, f"{p}.conv.weight", None, 1, 0, False))
    v = ops.bn_relu(v, "norm5")
    z = ops.bands(v, int(meta["bands"]))
    h = ops.linear("fc", z, "fc", True, True)
    d = ops.normalize_dirs(ops.linear("head_dir", h, "head_dir", False, False), n)
    hd = ops.linear("head_dist.fc1", ops.concat([z, ops.flatten(d)], 1), "head_dist.fc1", True,
                    False)
    return {
        "z": z,
        "dir": d,
        "distance": ops.softplus(ops.linear("head_dist.fc2", hd, "head_dist.fc2", False, False)),
        "size": ops.softplus(ops.linear("head_size", h, "head_size", False, False)),
        "rgb": ops.view3(ops.softplus(ops.linear("head_rgb", h, "head_rgb", False, False)), n),
        "ambient": ops.softplus(ops.linear("head_ambient", h, "head_ambient", False, False)),
    }


def write_onnx(ops, meta, path, doc):
    import onnx
    from onnx import helper, TensorProto
    h, w, n = int(meta["input_h"]), int(meta["input_w"]), int(meta["n_lights"])
    outs = forward(ops, "input", meta)
    shapes = {"z": [1, 1024 * int(meta["bands"])], "dir": [1, n, 3], "distance": [1, n],
              "size": [1, n], "rgb": [1, n, 3], "ambient": [1, 3]}
    nodes = list(ops.nodes)
    for k in OUT_KEYS:
        nodes.append(helper.make_node("Identity", [outs[k]], [k], name="out_" + k))
    graph = helper.make_graph(
        nodes, "parlight", [helper.make_tensor_value_info("input", TensorProto.FLOAT, [1, 3, h, w])],
        [helper.make_tensor_value_info(k, TensorProto.FLOAT, shapes[k]) for k in OUT_KEYS],
        ops.inits)
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 13)],
                              producer_name="parlight tools/bench/peers.py", doc_string=doc)
    model.ir_version = 7
    onnx.checker.check_model(model)
    onnx.save(model, path)


def cmd_onnx(args):
    meta, tensors = read_model(args.model)
    h, w = int(meta["input_h"]), int(meta["input_w"])
    frames = load_frames(args.frames, h, w)
    x = preprocess(frames[0])
    ref = reference(meta, tensors, x)
    tops = TorchOps(tensors)
    with torch.no_grad():
        err = rel_err(forward(tops, x, meta), ref)
        if err > 1e-5:
            raise RuntimeError(f"ONNX builder's forward differs from the .plm's: rel err {err:.2e}")
        for fr in frames[1:]:
            forward(tops, preprocess(fr), meta)
    os.makedirs(args.outdir, exist_ok=True)
    src = f"weights: {os.path.abspath(args.model)}; calibration: {len(frames)} frames of {args.frames}"
    write_onnx(OnnxOps(tensors, h), meta, os.path.join(args.outdir, "fp32.onnx"), "fp32; " + src)
    write_onnx(OnnxOps(tensors, h, tops.ranges), meta, os.path.join(args.outdir, "int8.onnx"),
               "QDQ int8 (per-channel symmetric s8 weights, u8 min/max activations); " + src)
    x.numpy().astype("<f4").tofile(os.path.join(args.outdir, "input.bin"))
    # the reference outputs, for ort_bench.js to check the fp32 model before timing it
    np.concatenate([ref[k].numpy().ravel() for k in OUT_KEYS]).astype("<f4").tofile(
        os.path.join(args.outdir, "ref.bin"))
    with open(os.path.join(args.outdir, "onnx.json"), "w") as f:
        json.dump({"input_shape": [1, 3, h, w], "outputs": list(OUT_KEYS),
                   "builder_rel_err_vs_plm": err, "calibration_frames": len(frames)}, f)
    print(f"peers: wrote fp32.onnx, int8.onnx, input.bin to {args.outdir} "
          f"(builder rel err vs .plm {err:.1e})")
    return 0


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    t = sub.add_parser("torch")
    t.add_argument("--model", required=True)
    t.add_argument("--frames", required=True)
    t.add_argument("--runs", type=int, default=30)
    t.add_argument("--warmup", type=int, default=5)
    t.add_argument("--threads", default="1,2")
    t.add_argument("--out")
    o = sub.add_parser("onnx")
    o.add_argument("--model", required=True)
    o.add_argument("--frames", required=True)
    o.add_argument("--outdir", required=True)
    args = ap.parse_args(argv)
    try:
        return cmd_torch(args) if args.cmd == "torch" else cmd_onnx(args)
    except (OSError, ValueError, RuntimeError, plm.PlmError) as e:
        print(f"peers {args.cmd}: {e}", file=sys.stderr)
        return 1


if __name__ == "__main__":
    sys.exit(main())
