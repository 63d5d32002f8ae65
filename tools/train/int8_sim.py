#!/usr/bin/python3
"""Where a network loses accuracy in parlight's int8 executor: a PyTorch simulation of it.

    tools/train/int8_sim.py --ckpt FINAL.pt --int8 Q.plm --frames DIR [--threads 2]

Q.plm is `parlight quantize`'s int8 file made from the checkpoint's float export. The simulation
runs the checkpoint's network (tools/model.py) with the executor's roundings, read from Q.plm
(docs/QUANT.md):
- every activation the executor stores is rounded to its int8 grid and clipped to its 256 levels
  (`{L}.out`: a scale and zero point per channel): conv0 (after norm0 + ReLU), each bottleneck
  (conv1 after norm2 + ReLU), each conv2, each transition (after its pool), the band means z on
  the block-4 buffer's grid (then norm5's affine), and fc (h);
- every conv's and fc's weights are rounded as the executor stores them: folded with their
  input's per-channel step times its batch-norm factor (a*s), int8 per output channel, unfolded;
- layers Q.plm keeps float (`--keep-float`) read float inputs and round their own weights per row
  (a kept fc reads the exact band means and its output is not rounded).
Not simulated: the rounding of the consumers' clamp thresholds and of the 2x2 average pool's
int8 mean (each under a quarter step).

On the frames of DIR (PNG or JPEG, centre-cropped to 4:3 and box-resized to the model input as
the C pipeline does) it prints the SQNR of z and h against the float network's and the direction
error of each light (median, p95), first for the whole simulation, then with only one group of
roundings on at a time, activations and weights apart. A group whose rounding alone costs most is
where to look. On the all-data retrain this found that block 3's clipped channels and
transition3's folded weights cost the most (docs/QUANT.md, "What limited the all-data retrain").
Its whole-network figures track `parlight qcheck` on the same frames (there: z 18.9 dB, h 25.2 dB
in simulation against 19.4 and 25.2 dB measured, direction 1.2 deg against 1.3 deg median).
"""

import argparse
import os
import sys

import numpy as np
import torch
import torch.nn.functional as F
from PIL import Image

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.dirname(HERE))
import plm  # noqa: E402
import train  # noqa: E402
from model import BANDS, STD, ParLightNet  # noqa: E402


def bn_affine(bn):
    """(a, b) of an eval-mode batch norm: bn(x) = a*x + b per channel."""
    a = bn.weight / torch.sqrt(bn.running_var + bn.eps)
    return a, bn.bias - bn.running_mean * a


class Int8File:
    """What the simulation needs from an int8 .plm: each activation's grid (real = scale *
    (q - zero point), q in [-128, 127]; ReLU outputs have zero point -128) and the layers it
    keeps float."""

    def __init__(self, path):
        meta, t, _ = plm.read_plm(path)
        if meta.get("precision") != "int8":
            raise ValueError(f"{path}: not an int8 model (precision {meta.get('precision')})")
        self.grid = {}
        for name, arr in t.items():
            if name.endswith(".out"):
                arr = torch.from_numpy(np.array(arr, np.float32))
                zp = arr[1] if arr.dim() == 2 else torch.full_like(arr, -128.0)
                self.grid[name[:-4]] = (arr[0] if arr.dim() == 2 else arr, zp)
        self.kept = {n[:-len(".conv.weight")] for n, a in t.items()
                     if n.startswith("transition") and n.endswith(".conv.weight") and a.ndim == 2}
        if "fc.out" not in t:
            self.kept.add("fc")

    def get(self, layer):
        if layer not in self.grid:
            raise ValueError(f"the int8 model has no grid for '{layer}'")
        return self.grid[layer]


def round_act(x, scale, zp):
    """x rounded to scale*(q - zp), q in [-128, 127], per channel (dim 1)."""
    shape = (1, -1) + (1,) * (x.dim() - 2)
    s, z = scale.to(x.dtype).view(shape), zp.to(x.dtype).view(shape)
    return torch.clamp(torch.round(x / s + z), -128, 127) * s - z * s


def round_weight(w, in_scale=None):
    """w [out, in, ...] rounded to int8 per output channel: after folding each input channel's
    in_scale (a*s) when given, as the executor does (channels with in_scale 0 are constants
    there and left alone here); per row of w itself when not (a kept-float layer)."""
    k = torch.ones(w.shape[1], dtype=w.dtype) if in_scale is None else in_scale.to(w.dtype)
    k = torch.where(k != 0, k, torch.ones_like(k)).view((1, -1) + (1,) * (w.dim() - 2))
    wf = w * k
    ws = wf.abs().flatten(1).amax(1).clamp_min(1e-30).view((-1,) + (1,) * (w.dim() - 1)) / 127
    return torch.round(wf / ws) * ws / k


def simulate(model, x, q8, acts=lambda name: True, weights=lambda name: True):
    """model(x) with the executor's roundings of the activations and weights whose layer names
    the two predicates accept ("z" for the band means): {"z", "h", "dir"}."""
    f = model.features
    fq = lambda t, name: round_act(t, *q8.get(name)) if acts(name) else t  # noqa: E731

    def conv(mod, t, name, in_scale):
        if not weights(name):
            return mod(t)
        return mod._conv_forward(t, round_weight(mod.weight, in_scale), mod.bias)

    stem = 1.0 / torch.tensor(STD)  # the input normalisation, folded into conv0 per channel
    y = fq(f.relu0(f.norm0(conv(f.conv0, x, "conv0", stem))), "conv0")
    y = f.pool0(y)
    seg = [q8.get("conv0")[0]]  # the block buffer's per-channel steps
    for b in range(1, 5):
        feats = [y]
        for name, layer in getattr(f, f"denseblock{b}").items():
            nm = f"denseblock{b}.{name}"
            t = layer.relu1(layer.norm1(torch.cat(feats, 1)))
            t = conv(layer.conv1, t, nm + ".conv1", bn_affine(layer.norm1)[0] * torch.cat(seg))
            t = fq(layer.relu2(layer.norm2(t)), nm + ".conv1")
            feats.append(fq(conv(layer.conv2, t, nm + ".conv2", q8.get(nm + ".conv1")[0]),
                            nm + ".conv2"))
            seg.append(q8.get(nm + ".conv2")[0])
        y = torch.cat(feats, 1)
        if b < 4:
            tr, nm = getattr(f, f"transition{b}"), f"transition{b}"
            fold = None if nm in q8.kept else bn_affine(tr.norm)[0] * torch.cat(seg)
            y = fq(tr.pool(conv(tr.conv, tr.relu(tr.norm(y)), nm + ".conv", fold)), nm + ".conv")
            seg = [q8.get(nm + ".conv")[0]]
    z = F.adaptive_avg_pool2d(F.relu(f.norm5(y)), (BANDS, 1)).flatten(1)
    a5, b5 = bn_affine(f.norm5)
    s5, z5 = torch.cat(seg), torch.cat([q8.get("transition3.conv")[1]] + [
        q8.get(f"denseblock4.{n}.conv2")[1] for n, _ in f.denseblock4.items()])
    if acts("z") and "fc" not in q8.kept:  # each band mean on its channel's grid, then norm5
        step = (a5 * s5).repeat_interleave(BANDS).to(z.dtype)
        off = (b5 - a5 * s5 * z5).repeat_interleave(BANDS).to(z.dtype)
        live = step != 0
        step1 = torch.where(live, step, torch.ones_like(step))
        zq = torch.clamp(torch.round((z - off) / step1), -128, 127) * step1 + off
        z = torch.where(live, zq, z)
    fw = model.fc.weight
    if weights("fc"):
        fw = round_weight(fw, None if "fc" in q8.kept else (a5 * s5).repeat_interleave(BANDS))
    h = F.relu(F.linear(z, fw, model.fc.bias))
    if "fc" not in q8.kept:
        h = fq(h, "fc")
    dirs = F.normalize(model.head_dir(h).view(-1, model.n_lights, 3), dim=-1)
    return {"z": z, "h": h, "dir": dirs}


def load_frames(path, hw):
    names = sorted(n for n in os.listdir(path) if n.lower().endswith((".png", ".jpg", ".jpeg")))
    if not names:
        raise ValueError(f"{path}: no PNG or JPEG frames")
    h, w = hw
    out = np.zeros((len(names), h, w, 3), np.uint8)
    for i, n in enumerate(names):
        with Image.open(os.path.join(path, n)) as im:
            im = im.convert("RGB")
            W, H = im.size
            cw, ch = min(W, H * w // h), min(H, W * h // w)
            x0, y0 = (W - cw) // 2, (H - ch) // 2
            out[i] = np.asarray(im.crop((x0, y0, x0 + cw, y0 + ch)).resize((w, h), Image.BOX))
    return torch.from_numpy(out)


def sqnr_db(a, ref):
    """SQNR of a against ref, as text; 'same' when a is ref (nothing rounded upstream)."""
    if torch.equal(a, ref):
        return "same"
    return f"{float(10 * torch.log10((ref ** 2).sum() / ((a - ref) ** 2).sum())):.1f}"


def report(label, out, ref):
    a, b = out["dir"], ref["dir"]
    ang = torch.rad2deg(torch.atan2(torch.cross(a, b, dim=-1).norm(dim=-1), (a * b).sum(-1))).flatten()
    print(f"  {label:40s} {sqnr_db(out['z'], ref['z']):>7s} {sqnr_db(out['h'], ref['h']):>7s}"
          f" {float(ang.median()):8.2f} {float(torch.quantile(ang, 0.95)):7.2f}")


GROUPS = (("stem, blocks 1-2, transition 1", ("conv0", "denseblock1", "denseblock2",
                                               "transition1")),
          ("block 3, transition 2", ("denseblock3", "transition2")),
          ("transition 3", ("transition3",)),
          ("block 4", ("denseblock4",)),
          ("z (band means), fc", ("z", "fc")))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--ckpt", required=True, help="the trained network (train.py checkpoint)")
    ap.add_argument("--int8", required=True, help="its int8 model (parlight quantize)")
    ap.add_argument("--frames", required=True, help="a directory of check frames")
    ap.add_argument("--threads", type=int, default=2)
    a = ap.parse_args(argv)
    torch.set_num_threads(a.threads)
    ck = train.load_ckpt(a.ckpt)
    if not isinstance(ck, dict) or "model" not in ck or "config" not in ck:
        raise SystemExit(f"{a.ckpt}: not a train.py checkpoint (no model/config)")
    model = ParLightNet(ck["config"]["n_lights"], tuple(ck["config"]["input"])).eval()
    model.load_state_dict(ck["model"])
    try:
        q8 = Int8File(a.int8)
        x = train.to_input(load_frames(a.frames, model.input_hw))
    except (ValueError, OSError) as e:
        raise SystemExit(f"int8_sim: {e}") from None
    no = lambda name: False  # noqa: E731
    with torch.no_grad():
        ref = simulate(model, x, q8, acts=no, weights=no)
        print(f"{x.shape[0]} frames; kept float: {', '.join(sorted(q8.kept)) or 'none'}")
        print(f"  {'roundings on':40s} {'z dB':>7s} {'h dB':>7s} {'dir med':>8s} {'p95':>7s}")
        report("all", simulate(model, x, q8), ref)
        report("activations only", simulate(model, x, q8, weights=no), ref)
        report("weights only", simulate(model, x, q8, acts=no), ref)
        for label, prefixes in GROUPS:
            inside = lambda name, p=prefixes: name.startswith(p)  # noqa: E731
            report(label + ": activations", simulate(model, x, q8, acts=inside, weights=no), ref)
            report(label + ": weights", simulate(model, x, q8, acts=no, weights=inside), ref)
    return 0


if __name__ == "__main__":
    sys.exit(main())
