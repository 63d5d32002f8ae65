#!/usr/bin/python3
"""Writes a ParLightNet (tools/model.py) as a float .plm model file (docs/FORMAT.md).

    tools/export.py --n-lights 3 --seed 1234 --out build/seeded-n3.plm [--check]
    tools/export.py --n-lights 3 --state-dict ckpt.pt --out model.plm [--input 192x256]

The weights come from a trained checkpoint (--state-dict: a state_dict, or a dict holding one
under 'state_dict' or 'model') or from a seeded random initialisation (--seed, see seeded_init),
which stands in for a trained model in tests and demos. The model is put in eval mode and its
batch norms are folded as docs/FORMAT.md says: norm0 into conv0 and each dense layer's norm2 into
its conv1 (giving biases); the pre-activation norms (norm1, transition norms, norm5) become
per-channel scale = gamma / sqrt(var + eps) and shift = beta - mean * scale. Folding is done in
float64 and rounded once to float32.

For --seed the file is a pure function of (seed, N, input size, torch version): the provenance
says so and carries no date, so two exports are byte-identical. --check runs the folded tensors
through folded_forward and compares with the unfolded model.
"""

import argparse
import datetime
import hashlib
import os
import sys

import numpy as np
import torch
import torch.nn.functional as F

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import plm  # noqa: E402
from model import BANDS, FC, LATENT, MEAN, STD, ParLightNet, preprocess  # noqa: E402

BLOCKS = (6, 12, 24, 16)
BLOCK_IN = (64, 128, 256, 512)
GROWTH, BOTTLENECK = 32, 128
SEED_INIT_VERSION = 1   # bump when seeded_init changes what a seed means


# ---- seeded random weights ------------------------------------------------------------------

def _synthetic_frames(gen, n, h, w):
    """n photo-like u8 frames [n, h, w, 3]: smooth random colour fields plus a bright blob and
    fine noise, so every layer sees varied, spatially correlated input."""
    frames = []
    for _ in range(n):
        coarse = torch.rand(1, 3, 4, 5, generator=gen)
        mid = torch.rand(1, 3, 12, 16, generator=gen)
        img = (0.7 * F.interpolate(coarse, (h, w), mode="bilinear", align_corners=False)
               + 0.3 * F.interpolate(mid, (h, w), mode="bilinear", align_corners=False))
        cy, cx = torch.rand(2, generator=gen).tolist()
        yy = torch.linspace(0, 1, h).view(h, 1)
        xx = torch.linspace(0, 1, w).view(1, w)
        blob = torch.exp(-((yy - cy) ** 2 + (xx - cx) ** 2) / 0.01)
        img = img * (0.3 + 0.9 * torch.rand(1, generator=gen)) + blob
        img = img + 0.03 * torch.randn(1, 3, h, w, generator=gen)
        frames.append((img.clamp(0, 1) * 255).round().to(torch.uint8)[0].permute(1, 2, 0))
    return torch.stack(frames)


def seeded_init(model, seed):
    """Deterministic, numerically well-behaved random weights for `model` (in place).

    1. Default PyTorch/torchvision init from torch.manual_seed(seed) (the model is built after
       seeding by build_seeded), then BN gamma ~ U(0.5, 1.5), beta ~ U(-0.2, 0.2).
    2. Running statistics calibrated on 8 seeded synthetic frames (train-mode batch statistics),
       so activations keep unit scale through all 120 layers. Every value computed by a forward
       pass is rounded to bfloat16 precision (_coarse) before it shapes a weight, so that
       summation order (threads, ISA) does not change the file.
    3. Each running mean moved by U(-0.2, 0.2) standard deviations and each variance scaled by
       U(0.7, 1.4), so the folding is exercised with non-trivial statistics.
    4. The heads' biases are set so that, on the calibration frames, the pre-activations are
       centred (directions spread over the sphere, softplus outputs varied, about 0.1..5), and
       the FC and head weights are scaled up x2 so that outputs depend visibly on the image
       (x4 gave implausible values, up to 30 sr, and 5x the float32 error)."""
    gen = torch.Generator().manual_seed(seed + 1)
    bns = [m for m in model.modules() if isinstance(m, torch.nn.BatchNorm2d)]
    with torch.no_grad():
        for bn in bns:
            bn.weight.copy_(torch.rand(bn.num_features, generator=gen) + 0.5)
            bn.bias.copy_(torch.rand(bn.num_features, generator=gen) * 0.4 - 0.2)
            bn.reset_running_stats()
            bn.momentum = None   # cumulative average: one batch gives its exact statistics
        h, w = model.input_hw
        frames = _synthetic_frames(gen, 8, h, w)
        x = torch.cat([preprocess(f) for f in frames])
        model.train()
        model.features(x)
        model.eval()
        for bn in bns:
            bn.momentum = 0.1
            mean = _coarse(bn.running_mean)
            var = _coarse(bn.running_var.clamp_min(1e-4))
            c = bn.num_features
            bn.running_mean.copy_(mean + (torch.rand(c, generator=gen) * 0.4 - 0.2) * var.sqrt())
            bn.running_var.copy_(var * (torch.rand(c, generator=gen) * 0.7 + 0.7))
            bn.num_batches_tracked.zero_()
        for lin in (model.fc, model.head_dir, model.head_size, model.head_rgb,
                    model.head_ambient, model.head_dist.fc1, model.head_dist.fc2):
            lin.weight.mul_(2.0)
        z = _coarse(model.latent(x))
        model.fc.bias.sub_(_coarse(model.fc(z).mean(0) - 0.1))   # centre h, most units active
        hid = F.relu(model.fc(z))
        for lin in (model.head_dir, model.head_size, model.head_rgb, model.head_ambient):
            lin.bias.sub_(_coarse(lin(hid).mean(0)))
        dirs = F.normalize(model.head_dir(hid).view(len(frames), model.n_lights, 3), dim=-1)
        zd = torch.cat([z, dirs.flatten(1)], 1)
        fc1 = model.head_dist.fc1
        fc1.bias.sub_(_coarse(fc1(zd).mean(0) - 0.1))
        fc2 = model.head_dist.fc2
        fc2.bias.sub_(_coarse(fc2(F.relu(fc1(zd))).mean(0) - 1.0))
    return model


def _coarse(t):
    """Rounded to bfloat16 precision (8 significant bits): a value computed by a float32
    forward pass, whose last bits may depend on threads or ISA, becomes reproducible."""
    return t.to(torch.bfloat16).float()


def build_seeded(n_lights, seed, input_hw=(192, 256), dist_hidden=64):
    """The seeded model export.py and golden.py both use (eval mode, float32)."""
    torch.manual_seed(seed)
    model = ParLightNet(n_lights, input_hw, dist_hidden)
    return seeded_init(model, seed).eval()


def load_checkpoint(path, n_lights, input_hw):
    """ParLightNet (eval mode) with the weights of a checkpoint; dist_hidden is taken from it."""
    try:
        obj = torch.load(path, map_location="cpu", weights_only=True)
    except (OSError, EOFError) as e:
        raise ValueError(f"{path}: cannot read ({e})") from None
    except Exception as e:  # pickle / zip errors come in many types
        raise ValueError(f"{path}: not a PyTorch checkpoint of tensors "
                         f"({type(e).__name__}: {e})") from None
    if isinstance(obj, dict):
        for key in ("state_dict", "model"):
            if key in obj and isinstance(obj[key], dict):
                obj = obj[key]
                break
    if not isinstance(obj, dict) or not all(torch.is_tensor(v) for v in obj.values()):
        raise ValueError(f"{path}: not a state_dict of tensors")
    obj = {k[len("module."):] if k.startswith("module.") else k: v for k, v in obj.items()}
    size = obj.get("head_size.weight")
    if size is not None and size.dim() == 2 and size.shape[0] != n_lights:
        raise ValueError(f"{path}: the checkpoint has {size.shape[0]} lights, --n-lights "
                         f"is {n_lights}")
    fc1 = obj.get("head_dist.fc1.weight")
    hidden = int(fc1.shape[0]) if fc1 is not None and fc1.dim() == 2 else 64
    model = ParLightNet(n_lights, input_hw, hidden)
    missing, unexpected = model.load_state_dict(obj, strict=False)
    if missing or unexpected:
        raise ValueError(f"{path}: does not match ParLightNet(n_lights={n_lights}): "
                         f"missing {missing[:5]}{'...' if len(missing) > 5 else ''}, "
                         f"unexpected {unexpected[:5]}{'...' if len(unexpected) > 5 else ''}")
    return model.eval()


# ---- folding ----------------------------------------------------------------------------------

def _bn_scale_shift(bn):
    var = bn.running_var.double()
    scale = bn.weight.double() / torch.sqrt(var + bn.eps)
    shift = bn.bias.double() - bn.running_mean.double() * scale
    return scale, shift


def _fold_conv(conv, bn):
    scale, shift = _bn_scale_shift(bn)
    w = conv.weight.double() * scale.view(-1, 1, 1, 1)
    b = shift if conv.bias is None else shift + conv.bias.double() * scale
    return w, b


def folded_tensors(model):
    """[(name, float32 ndarray)] in docs/FORMAT.md order, batch norms folded."""
    out = []

    def put(name, t):
        out.append((name, t.detach().double().numpy().astype(np.float32)))

    f = model.features
    w, b = _fold_conv(f.conv0, f.norm0)
    put("conv0.weight", w)
    put("conv0.bias", b)
    for bi in range(1, 5):
        block = getattr(f, f"denseblock{bi}")
        for li in range(1, BLOCKS[bi - 1] + 1):
            layer = getattr(block, f"denselayer{li}")
            p = f"denseblock{bi}.denselayer{li}"
            s, t = _bn_scale_shift(layer.norm1)
            put(f"{p}.norm1.scale", s)
            put(f"{p}.norm1.shift", t)
            w, b = _fold_conv(layer.conv1, layer.norm2)
            put(f"{p}.conv1.weight", w)
            put(f"{p}.conv1.bias", b)
            put(f"{p}.conv2.weight", layer.conv2.weight)
        if bi < 4:
            tr = getattr(f, f"transition{bi}")
            s, t = _bn_scale_shift(tr.norm)
            put(f"transition{bi}.norm.scale", s)
            put(f"transition{bi}.norm.shift", t)
            put(f"transition{bi}.conv.weight", tr.conv.weight)
    s, t = _bn_scale_shift(f.norm5)
    put("norm5.scale", s)
    put("norm5.shift", t)
    for name in ("fc", "head_dir", "head_size", "head_rgb", "head_ambient", "head_dist.fc1",
                 "head_dist.fc2"):
        lin = model.get_submodule(name)
        put(f"{name}.weight", lin.weight)
        put(f"{name}.bias", lin.bias)
    return out


def expected_shapes(n_lights, dist_hidden=64):
    """{name: shape} of every tensor of densenet121-parametric fp32, in file order."""
    s = {"conv0.weight": (64, 3, 7, 7), "conv0.bias": (64,)}
    for bi in range(1, 5):
        c0 = BLOCK_IN[bi - 1]
        for li in range(1, BLOCKS[bi - 1] + 1):
            c = c0 + GROWTH * (li - 1)
            p = f"denseblock{bi}.denselayer{li}"
            s[f"{p}.norm1.scale"] = s[f"{p}.norm1.shift"] = (c,)
            s[f"{p}.conv1.weight"] = (BOTTLENECK, c, 1, 1)
            s[f"{p}.conv1.bias"] = (BOTTLENECK,)
            s[f"{p}.conv2.weight"] = (GROWTH, BOTTLENECK, 3, 3)
        if bi < 4:
            c = c0 + GROWTH * BLOCKS[bi - 1]
            s[f"transition{bi}.norm.scale"] = s[f"transition{bi}.norm.shift"] = (c,)
            s[f"transition{bi}.conv.weight"] = (c // 2, c, 1, 1)
    s["norm5.scale"] = s["norm5.shift"] = (1024,)
    n, hd = n_lights, dist_hidden
    for name, o, i in (("fc", FC, LATENT), ("head_dir", 3 * n, FC), ("head_size", n, FC),
                       ("head_rgb", 3 * n, FC), ("head_ambient", 3, FC),
                       ("head_dist.fc1", hd, LATENT + 3 * n), ("head_dist.fc2", n, hd)):
        s[f"{name}.weight"] = (o, i)
        s[f"{name}.bias"] = (o,)
    return s


def _pre(t, name, v):
    """Pre-activation BN (folded to scale and shift) + ReLU."""
    return F.relu(v * t[f"{name}.scale"].view(1, -1, 1, 1) + t[f"{name}.shift"].view(1, -1, 1, 1))


def _dense_block(t, bi, v):
    for li in range(1, BLOCKS[bi - 1] + 1):
        p = f"denseblock{bi}.denselayer{li}"
        y = F.relu(F.conv2d(_pre(t, f"{p}.norm1", v), t[f"{p}.conv1.weight"], t[f"{p}.conv1.bias"]))
        y = F.conv2d(y, t[f"{p}.conv2.weight"], padding=1)
        v = torch.cat([v, y], 1)
    return v


def folded_lower(t, x):
    """The DenseNet on folded tensors up to transition3's output [B, 512, H/32, W/32]
    (tools/train/heads.py --train-block4 caches it and trains what follows)."""
    v = F.relu(F.conv2d(x, t["conv0.weight"], t["conv0.bias"], stride=2, padding=3))
    v = F.max_pool2d(v, 3, stride=2, padding=1)
    for bi in range(1, 4):
        v = _dense_block(t, bi, v)
        p = f"transition{bi}"
        v = F.avg_pool2d(F.conv2d(_pre(t, f"{p}.norm", v), t[f"{p}.conv.weight"]), 2, 2)
    return v


def folded_upper(t, v):
    """relu(norm5(denseblock4(v))) on folded tensors, v = folded_lower's output."""
    return _pre(t, "norm5", _dense_block(t, 4, v))


def folded_features(t, x):
    """relu(norm5(features(x))) [B, 1024, H/32, W/32] on folded tensors {name: tensor}: the
    DenseNet part of folded_forward (tools/train/heads.py caches it for a frozen encoder)."""
    return folded_upper(t, folded_lower(t, x))


def folded_forward(t, x, n_lights):
    """The network on folded tensors {name: tensor} (what the C executor computes), x [B,3,H,W].
    Same dict as ParLightNet.forward."""
    z = F.adaptive_avg_pool2d(folded_features(t, x), (BANDS, 1)).flatten(1)
    h = F.relu(F.linear(z, t["fc.weight"], t["fc.bias"]))
    n = n_lights
    d = F.normalize(F.linear(h, t["head_dir.weight"], t["head_dir.bias"]).view(-1, n, 3), dim=-1)
    hd = F.relu(F.linear(torch.cat([z, d.flatten(1)], 1), t["head_dist.fc1.weight"],
                         t["head_dist.fc1.bias"]))
    return {
        "z": z,
        "dir": d,
        "distance": F.softplus(F.linear(hd, t["head_dist.fc2.weight"], t["head_dist.fc2.bias"])),
        "size": F.softplus(F.linear(h, t["head_size.weight"], t["head_size.bias"])),
        "rgb": F.softplus(F.linear(h, t["head_rgb.weight"], t["head_rgb.bias"])).view(-1, n, 3),
        "ambient": F.softplus(F.linear(h, t["head_ambient.weight"], t["head_ambient.bias"])),
    }


def check_fold(model, tensors, seed=0):
    """Max relative error (per output, L2-relative) of the folded float32 tensors against the
    unfolded model, both evaluated in float64 on two random inputs."""
    gen = torch.Generator().manual_seed(seed)
    h, w = model.input_hw
    x = torch.randn(2, 3, h, w, generator=gen, dtype=torch.float64)
    t = {k: torch.from_numpy(np.array(v)).double() for k, v in tensors}
    with torch.no_grad():
        ref = model.double()(x)
        got = folded_forward(t, x, model.n_lights)
    model.float()
    return {k: float((got[k] - ref[k]).norm() / ref[k].norm().clamp_min(1e-30)) for k in got}


# ---- metadata and the command line ----------------------------------------------------------

def metadata(model, provenance):
    h, w = model.input_hw
    return {
        "arch": "densenet121-parametric",
        "precision": "fp32",
        "n_lights": model.n_lights,
        "input_h": h,
        "input_w": w,
        "mean": ",".join(repr(v) for v in MEAN),
        "std": ",".join(repr(v) for v in STD),
        "bands": BANDS,
        "fc": FC,
        "dist_hidden": model.dist_hidden,
        "provenance": provenance,
        "created_by": "tools/export.py",
    }


def seeded_provenance(seed):
    return (f"seeded random weights (not trained): seed {seed}, tools/export.py seeded_init "
            f"v{SEED_INIT_VERSION}, torch {torch.__version__}")


def checked_tensors(model):
    tensors = folded_tensors(model)
    want = expected_shapes(model.n_lights, model.dist_hidden)
    got = {k: v.shape for k, v in tensors}
    if list(got) != list(want) or any(tuple(got[k]) != want[k] for k in want):
        bad = [k for k in want if tuple(got.get(k, ())) != want[k]]
        raise RuntimeError(f"internal: folded tensors differ from docs/FORMAT.md at {bad[:5]}")
    return tensors


def parse_hw(text):
    try:
        h, w = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"--input {text!r}: expected HxW, e.g. 192x256")
    if h % 32 or w % 32 or not (64 <= h <= 1024 and 64 <= w <= 1024):
        raise argparse.ArgumentTypeError(f"--input {text!r}: H and W must be multiples of 32 in "
                                         "64..1024")
    return h, w


def main(argv=None):
    ap = argparse.ArgumentParser(description="Export ParLightNet weights to a .plm model file "
                                 "(docs/FORMAT.md).")
    ap.add_argument("--n-lights", type=int, required=True, choices=(2, 3, 5),
                    help="number of lights N")
    src = ap.add_mutually_exclusive_group(required=True)
    src.add_argument("--seed", type=int, help="seeded random weights (tests, demos)")
    src.add_argument("--state-dict", metavar="CKPT", help="PyTorch checkpoint with trained weights")
    ap.add_argument("--out", required=True, help="the .plm file to write")
    ap.add_argument("--input", type=parse_hw, default=(192, 256), metavar="HxW",
                    help="network input size (default 192x256)")
    ap.add_argument("--provenance", help="text replacing the recorded provenance")
    ap.add_argument("--force", action="store_true", help="replace --out if it exists")
    ap.add_argument("--check", action="store_true",
                    help="verify the folded tensors against the unfolded model (float64)")
    args = ap.parse_args(argv)

    if os.path.lexists(args.out) and not args.force:
        print(f"export: {args.out} exists; not replacing it (use --force)", file=sys.stderr)
        return 1
    folder = os.path.dirname(os.path.abspath(args.out))
    if not os.path.isdir(folder):
        print(f"export: cannot write {args.out}: no folder {folder}", file=sys.stderr)
        return 1
    try:
        if args.seed is not None:
            if args.seed < 0:
                raise ValueError(f"--seed {args.seed}: must be >= 0")
            model = build_seeded(args.n_lights, args.seed, args.input)
            prov = seeded_provenance(args.seed)
        else:
            model = load_checkpoint(args.state_dict, args.n_lights, args.input)
            with open(args.state_dict, "rb") as f:
                digest = hashlib.sha256(f.read()).hexdigest()
            date = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ")
            prov = (f"checkpoint {os.path.basename(args.state_dict)} sha256 {digest}, "
                    f"torch {torch.__version__}, exported {date}")
        if args.provenance:
            prov = args.provenance
        tensors = checked_tensors(model)
        if args.check:
            errs = check_fold(model, tensors)
            worst = max(errs.values())
            print("fold check (relative L2, float64): "
                  + ", ".join(f"{k} {v:.2e}" for k, v in errs.items()))
            if not worst < 1e-5:
                print(f"export: fold check failed: worst relative error {worst:.2e} >= 1e-5",
                      file=sys.stderr)
                return 1
        size = plm.write_plm(args.out, metadata(model, prov), tensors, force=args.force)
    except (OSError, ValueError, RuntimeError, plm.PlmError) as e:
        print(f"export: {e}", file=sys.stderr)
        return 1
    n_params = sum(v.size for _, v in tensors)
    print(f"wrote {args.out}: {len(tensors)} tensors, {n_params:,} parameters, {size:,} bytes")
    return 0


if __name__ == "__main__":
    sys.exit(main())
