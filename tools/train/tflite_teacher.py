#!/usr/bin/python3
"""The shared ImageNet MobileNetV2 (uint8 TFLite flatbuffer) read in numpy and run in PyTorch:
a feasibility check for distilling ImageNet features into the DenseNet encoder (not used by
train.py yet).

    tools/train/tflite_teacher.py [--model ../shared/data/pretrained/mobilenet_v2_1.0_224_quant.tflite]
                                  [--labels .../imagenet_labels.txt] IMAGE...

prints the top-5 ImageNet classes of each image (resized to 224x224) and the time per image.

The reader is a minimal FlatBuffers decoder for the parts of the TFLite schema
(tensorflow/lite/schema/schema.fbs) a MobileNet needs: Model.{operator_codes, subgraphs, buffers},
SubGraph.{tensors, inputs, outputs, operators}, Tensor.{shape, type, buffer, name, quantization},
Operator.{opcode_index, inputs, outputs, builtin_options}, and the options of CONV_2D,
DEPTHWISE_CONV_2D, AVERAGE_POOL_2D, ADD, RESHAPE, SOFTMAX. Every offset is bounds-checked.
Execution is float: weights and biases dequantised ((q - zero_point) * scale), activations kept
in float and rounded to each tensor's uint8 grid after every op (fake quantisation), so it
follows the int8 model closely without integer kernels. TFLite SAME padding puts the odd pixel
at the end (bottom/right), done with an explicit F.pad.
"""

import argparse
import os
import struct
import sys
import time

import numpy as np
import torch
import torch.nn.functional as F

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SHARED = os.environ.get("PL_SHARED", os.path.join(os.path.dirname(ROOT), "shared"))

OPS = {0: "ADD", 1: "AVERAGE_POOL_2D", 3: "CONV_2D", 4: "DEPTHWISE_CONV_2D", 22: "RESHAPE",
       25: "SOFTMAX", 6: "DEQUANTIZE", 114: "QUANTIZE"}
TYPES = {0: np.float32, 2: np.int32, 3: np.uint8, 9: np.int8, 4: np.int64}
ACT = {0: None, 1: "relu", 3: "relu6"}


class FB:
    """Bounds-checked FlatBuffers table access over a bytes object."""

    def __init__(self, buf):
        self.b = buf

    def _u(self, fmt, pos):
        size = struct.calcsize(fmt)
        if pos < 0 or pos + size > len(self.b):
            raise ValueError(f"flatbuffer: read of {size} bytes at {pos} outside the file "
                             f"({len(self.b)} bytes)")
        return struct.unpack_from("<" + fmt, self.b, pos)[0]

    def root(self):
        return self._u("I", 0)

    def field(self, table, i):
        vt = table - self._u("i", table)
        vsize = self._u("H", vt)
        if 4 + 2 * i >= vsize:
            return 0
        return self._u("H", vt + 4 + 2 * i)

    def scalar(self, table, i, fmt, default=0):
        off = self.field(table, i)
        return self._u(fmt, table + off) if off else default

    def ref(self, table, i):
        off = self.field(table, i)
        if not off:
            return None
        p = table + off
        return p + self._u("I", p)

    def vector(self, table, i, fmt=None):
        """(start, length) of a vector field, or a numpy array for a scalar element fmt."""
        v = self.ref(table, i)
        if v is None:
            return None
        n = self._u("I", v)
        if fmt is None:
            return [v + 4 + 4 * k + self._u("I", v + 4 + 4 * k) for k in range(n)]
        size = np.dtype(fmt).itemsize
        if v + 4 + n * size > len(self.b):
            raise ValueError(f"flatbuffer: vector of {n} x {size} bytes at {v} outside the file")
        return np.frombuffer(self.b, fmt, n, v + 4)

    def string(self, table, i):
        v = self.ref(table, i)
        if v is None:
            return ""
        n = self._u("I", v)
        return self.b[v + 4:v + 4 + n].decode("utf-8", "replace")


def load(path):
    """(tensors, operators, inputs, outputs) of subgraph 0 of a TFLite file."""
    with open(path, "rb") as f:
        buf = f.read()
    if len(buf) < 8 or buf[4:8] != b"TFL3":
        raise ValueError(f"{path}: not a TFLite flatbuffer (no TFL3 identifier)")
    fb = FB(buf)
    model = fb.root()
    codes = []
    for oc in fb.vector(model, 1):
        dep = fb.scalar(oc, 0, "b")
        codes.append(max(dep, fb.scalar(oc, 3, "i")))
    buffers = [fb.vector(b, 0, "u1") for b in fb.vector(model, 4)]
    sub = fb.vector(model, 2)[0]
    tensors = []
    for t in fb.vector(sub, 0):
        q = fb.ref(t, 4)
        tt = fb.scalar(t, 1, "b")
        if tt not in TYPES:
            raise ValueError(f"{path}: tensor type {tt} not supported")
        info = {"shape": [int(v) for v in fb.vector(t, 0, "<i4")], "dtype": TYPES[tt],
                "name": fb.string(t, 3), "scale": None, "zp": None, "data": None}
        if q is not None:
            s, z = fb.vector(q, 2, "<f4"), fb.vector(q, 3, "<i8")
            if s is not None and len(s):
                info["scale"], info["zp"] = s.astype(np.float64), z.astype(np.float64)
        bi = fb.scalar(t, 2, "I")
        if bi >= len(buffers):
            raise ValueError(f"{path}: tensor {info['name']}: buffer {bi} of {len(buffers)}")
        data = buffers[bi]
        if data is not None and len(data):
            arr = np.frombuffer(data.tobytes(), info["dtype"])
            if arr.size != int(np.prod(info["shape"])):
                raise ValueError(f"{path}: tensor {info['name']}: {arr.size} values for shape "
                                 f"{info['shape']}")
            info["data"] = arr.reshape(info["shape"])
        tensors.append(info)
    ops = []
    for o in fb.vector(sub, 3):
        code = codes[fb.scalar(o, 0, "I")]
        if code not in OPS:
            raise ValueError(f"{path}: builtin operator {code} not supported")
        opt = fb.ref(o, 4)
        name = OPS[code]
        d = {"op": name, "in": [int(v) for v in fb.vector(o, 1, "<i4")],
             "out": [int(v) for v in fb.vector(o, 2, "<i4")]}
        if opt is not None and name in ("CONV_2D", "DEPTHWISE_CONV_2D", "AVERAGE_POOL_2D"):
            d["same"] = fb.scalar(opt, 0, "b") == 0
            d["stride"] = (fb.scalar(opt, 2, "i"), fb.scalar(opt, 1, "i"))
            if name == "AVERAGE_POOL_2D":
                d["k"] = (fb.scalar(opt, 4, "i"), fb.scalar(opt, 3, "i"))
                d["act"] = ACT.get(fb.scalar(opt, 5, "b"))
            else:
                d["act"] = ACT.get(fb.scalar(opt, 3 if name == "CONV_2D" else 4, "b"))
        elif opt is not None and name == "ADD":
            d["act"] = ACT.get(fb.scalar(opt, 0, "b"))
        ops.append(d)
    return tensors, ops, [int(v) for v in fb.vector(sub, 1, "<i4")], \
        [int(v) for v in fb.vector(sub, 2, "<i4")]


def dequant(t):
    a = t["data"].astype(np.float64)
    if t["scale"] is None:
        return torch.from_numpy(a).float()
    return torch.from_numpy((a - t["zp"][0]) * t["scale"][0]).float()


def fake_quant(x, t):
    if t["scale"] is None:
        return x
    s, z = float(t["scale"][0]), float(t["zp"][0])
    return (torch.clamp(torch.round(x / s) + z, 0, 255) - z) * s


def same_pad(x, k, stride):
    ih, iw = x.shape[2:]
    oh, ow = -(-ih // stride[0]), -(-iw // stride[1])
    ph = max((oh - 1) * stride[0] + k[0] - ih, 0)
    pw = max((ow - 1) * stride[1] + k[1] - iw, 0)
    return F.pad(x, (pw // 2, pw - pw // 2, ph // 2, ph - ph // 2))


class Teacher:
    """The TFLite graph as float PyTorch ops; run(x) takes NCHW float in the input tensor's real
    units (for this model: (u8 - 128) / 128) and returns {tensor index: activation}: the graph's
    output, or, with keep, the kept tensors only (running stops once they are computed)."""

    def __init__(self, path):
        self.tensors, self.ops, self.inputs, self.outputs = load(path)
        self.w = {}
        for op in self.ops:
            if op["op"] == "CONV_2D":
                w = dequant(self.tensors[op["in"][1]]).permute(0, 3, 1, 2).contiguous()
            elif op["op"] == "DEPTHWISE_CONV_2D":
                w = dequant(self.tensors[op["in"][1]]).permute(3, 0, 1, 2).contiguous()
            else:
                continue
            b = self.tensors[op["in"][2]]
            bias = torch.from_numpy(b["data"].astype(np.float64) * b["scale"][0]).float()
            self.w[id(op)] = (w, bias)

    def run(self, x, keep=()):
        act = {self.inputs[0]: x}
        out = {}
        for op in self.ops:
            a = act[op["in"][0]]
            name = op["op"]
            if name in ("CONV_2D", "DEPTHWISE_CONV_2D"):
                w, bias = self.w[id(op)]
                k = w.shape[2:]
                if op["same"]:
                    a = same_pad(a, k, op["stride"])
                y = F.conv2d(a, w, bias, stride=op["stride"],
                             groups=a.shape[1] if name == "DEPTHWISE_CONV_2D" else 1)
            elif name == "AVERAGE_POOL_2D":
                y = F.avg_pool2d(a, op["k"], op["stride"])   # VALID over the whole map here
            elif name == "ADD":
                y = a + act[op["in"][1]]
            elif name == "RESHAPE":
                y = a.flatten(1)
            elif name == "SOFTMAX":
                y = torch.softmax(a, -1)
            else:
                raise ValueError(f"operator {name} not supported by Teacher.run")
            if op.get("act") == "relu":
                y = F.relu(y)
            elif op.get("act") == "relu6":
                y = torch.clamp(y, 0, 6)
            t = op["out"][0]
            act[t] = fake_quant(y, self.tensors[t])
            if t in keep:
                out[t] = act[t]
                if len(out) == len(keep):
                    return out   # the rest is not needed (and a 7x7 pool needs 224x224)
        out[self.outputs[0]] = act[self.outputs[0]]
        return out


def main(argv=None):
    from PIL import Image
    pre = os.path.join(SHARED, "data", "pretrained")
    ap = argparse.ArgumentParser(description="Run the shared MobileNetV2 TFLite model in PyTorch "
                                 "(top-5 ImageNet classes).")
    ap.add_argument("--model", default=os.path.join(pre, "mobilenet_v2_1.0_224_quant.tflite"))
    ap.add_argument("--labels", default=os.path.join(pre, "imagenet_labels.txt"))
    ap.add_argument("images", nargs="+")
    args = ap.parse_args(argv)
    torch.set_num_threads(2)
    try:
        t0 = time.time()
        teacher = Teacher(args.model)
        print(f"{args.model}: {len(teacher.tensors)} tensors, {len(teacher.ops)} operators "
              f"({', '.join(sorted({o['op'] for o in teacher.ops}))}), read in "
              f"{time.time() - t0:.2f} s")
        with open(args.labels, encoding="utf-8") as f:
            labels = [ln.strip() for ln in f]
        for path in args.images:
            with Image.open(path) as im:
                u8 = np.asarray(im.convert("RGB").resize((224, 224), Image.BILINEAR))
            x = (torch.from_numpy(u8.copy()).permute(2, 0, 1)[None].float() - 128.0) / 128.0
            t0 = time.time()
            with torch.no_grad():
                p = teacher.run(x)[teacher.outputs[0]][0]
            dt = time.time() - t0
            top = torch.topk(p, 5)
            print(f"{path} ({dt * 1000:.0f} ms): " + ", ".join(
                f"{labels[i] if i < len(labels) else i} {v:.2f}" for v, i in
                zip(top.values.tolist(), top.indices.tolist())))
    except (OSError, ValueError) as e:
        print(f"tflite_teacher: {e}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
