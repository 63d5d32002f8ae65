#!/usr/bin/python3
"""Retrain the fc and the lighting heads of a float .plm on its frozen encoder ("direction
first", issue 21).

    tools/train/heads.py --model BASE.plm --data DATASET --out OUT.plm
                         [--val-panos 0] [--epochs 30] [--halve-every 10] [--lr 1e-3]
                         [--batch 16] [--w-primary 1] [--w-r 20] [--w-a 1] [--w-d1 20]
                         [--step2-epochs 0] [--step2-scenes indoor|all] [--z-noise 0]
                         [--w-rank 0] [--train-block4] [--weight-decay 0]
                         [--int8 INT8.plm [--zdump build/tools/zdump]]
                         [--seed 1] [--threads 2] [--work DIR] [--log FILE] [--force]

The DenseNet part of BASE (its folded tensors, exactly what the C executor runs: export.py
folded_features) is frozen; its latent z of every crop of DATASET (make_dataset.py) and of the
crop's mirror image is computed once and cached in the work folder. Then the fc and the
direction, size, colour and ambient heads train from BASE's values on train.py's step-1 loss (SG
map w_r, ambient w_a, diffuse sphere w_d1) plus --w-primary times train.primary_loss, the angular
error of the primary light, which the paper's losses do not measure and which an AR app's shadows
depend on. The distance head keeps BASE's weights (it reads z and the predicted directions; no
step-1 term trains it). A linear probe on the frozen z of a network trained without the term
finds the primary light 12 degrees closer than that network's own heads on held-out rooms
(MODEL_CARD.md, "Direction first"): the cue is in z, the heads had not been asked for it.

--w-rank W adds W times train.rank_loss to step 1: the lights' brightness order (each predicted
light stands for its nearest truth light; a logistic loss on the log energies of every pair that
stands for two different truth lights), the choice pl_lighting_primary makes, without moving a
direction.

--train-block4 trains DenseNet's block 4 and norm5 (their folded tensors) with the fc and heads in
step 1: the encoder below it stays frozen, and its output (transition3's maps, 512 x H/32 x W/32
per crop and mirror: 24 KB a crop at 96 x 128) is computed once and cached in the work folder as
v3.pt instead of z.pt. Block 4 is about 4% of the network's multiply-adds, so an epoch costs about
twice a heads-only one (66 s for 4,800 crops on one core here, against 35-50 s), where the whole
network's step 1 costs 25x that on this CPU. Step 2 then runs on the z of the trained block 4.
Not with --z-noise or --int8 (both act on a fixed z).

--weight-decay D trains both steps with AdamW's decoupled weight decay D (each step shrinks the
trained weights by lr x D) instead of Adam: heads of less effective capacity, which the ridge
baseline's showing (a few hundred parameters carry direction across rooms) asks to try.

--epochs 0 skips to step 2. --step2-epochs N then runs train.py's step 2 of the shipped recipe
(--step2-loss render) on the same latents: the fc and the direction head frozen, the size,
colour and ambient heads trained on the diffuse sphere's L2 and the ambient's, on the indoor
crops (--step2-scenes indoor, the default) for N epochs, the learning rate restarting at --lr.
The primary light can still change in it (energies move), so the validation angle is logged
there too.

--z-noise S trains both steps on z + S * rms(z) * N(0, 1), fresh noise in every batch: heads
that read z through large, finely balanced weights amplify the int8 encoder's error in z (its
SQNR is about 28 dB, noise near 4% of z's rms; `parlight qcheck` lists it as layer z), and the
int8 twin then misses the targets that the float model's own noise floor would meet. Noise a
little above that level in training asks the heads for a direction that survives it; measured,
it was not enough (0.06 on the shipped network: MODEL_CARD, "Direction first"); --int8
trains on the int8 error itself, and measured, that was not enough either (same section).

--int8 INT8.plm trains both steps on the int8 executor's own latents half of the time: each
crop of a batch reads, with probability 1/2, z as INT8.plm computes it (build/tools/zdump,
tools/train/zdump.c; cached in the work folder as z8.pt, keyed by INT8.plm's sha256) instead of
the float one. INT8.plm must be BASE's trunk quantised the way the result will be (same
`parlight quantize` command and calibration frames): the fc is kept float there, so the trunk's
int8 error in z does not depend on the heads, and heads trained on it learn to read z through
that error. Gaussian noise (--z-noise) is a weaker stand-in: the int8 error is correlated across
z's values, independent noise is mostly averaged away by the fc.

OUT is BASE with those five layers replaced (with --train-block4, block 4 and norm5 too): the rest
of the trunk's bytes and the metadata (the intensity anchor included) the same, the provenance
extended. Quantise it as any float model (parlight quantize).
Only train/ panoramas train (train.load_dataset refuses others); --val-panos N holds out
train.py's validation panoramas and logs their loss and median primary-light angle per epoch.

Work folder (--work, default OUT.heads/): z.pt (the cached latents, keyed by the trunk's and the
dataset's sha256 and reused by any run on both; v3.pt with --train-block4), last.pt (checkpoint
at each epoch end); rerunning the command resumes from it and ends with the same bytes as an
uninterrupted run (the batch order and flips of an epoch are a function of --seed and the epoch).
Deterministic on the CPU for the same --threads. About 35 s an epoch for 4,800 crops on one loaded
core here.
"""

import argparse
import hashlib
import json
import math
import os
import subprocess
import sys
import time

import numpy as np
import torch
import torch.nn.functional as F

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.dirname(HERE))
import export  # noqa: E402
import plm  # noqa: E402
import sg  # noqa: E402
import train  # noqa: E402
from model import BANDS, ParLightNet  # noqa: E402

TRAINED = ("fc", "head_dir", "head_size", "head_rgb", "head_ambient")
BLOCK4 = ("denseblock4.", "norm5.")     # what --train-block4 trains as well
# what must match for last.pt to resume (--epochs may grow: the schedule depends on the epoch only)
RESUME_KEYS = ("base_trunk_sha256", "data_index_sha256", "val_panos", "halve_every",
               "lr", "batch", "w_primary", "w_r", "w_a", "w_d1", "seed", "z_noise", "int8_sha256",
               "w_rank", "train_block4", "weight_decay")
RESUME_DEFAULTS = {"z_noise": 0.0, "int8_sha256": None, "w_rank": 0.0, "train_block4": False,
                   "weight_decay": 0.0}


def trunk_sha256(tensors):
    h = hashlib.sha256()
    for name, arr in tensors.items():
        if not name.startswith(TRAINED + ("head_dist",)):
            h.update(name.encode())
            h.update(np.ascontiguousarray(arr).tobytes())
    return h.hexdigest()


def per_crop(fn, imgs, what, bs=64, log=None):
    """fn(x) [B, ...] of every crop (index 0) and of its mirror (index 1): [2, M, ...]."""
    m = len(imgs)
    out = None
    t0 = time.time()
    with torch.no_grad():
        for i in range(0, m, bs):
            u8 = imgs[torch.arange(i, min(m, i + bs))]
            for f in (0, 1):
                y = fn(train.to_input(u8.flip(2) if f else u8))
                if out is None:
                    out = torch.zeros((2, m) + tuple(y.shape[1:]))
                out[f, i:i + len(u8)] = y
            if log and (i // bs) % 20 == 0:
                log(f"{what} {i + len(u8)}/{m} ({time.time() - t0:.0f} s)")
    return out


def latents(t, imgs, log=None):
    """z [2, M, 1024 * BANDS] of every crop and of its mirror."""
    return per_crop(lambda x: F.adaptive_avg_pool2d(export.folded_features(t, x),
                                                    (BANDS, 1)).flatten(1), imgs, "latents",
                    log=log)


def lower_maps(t, imgs, log=None):
    """transition3's output [2, M, 512, H/32, W/32] of every crop and of its mirror: what
    --train-block4 caches, block 4 and the heads train on it."""
    return per_crop(lambda x: export.folded_lower(t, x), imgs, "block-3 maps", log=log)


def int8_latents(args, work, digest, m, d, log):
    """z8 [2, m, d] of the dataset's crops and mirrors through args.int8 (zdump), cached in
    work/z8.pt; and the int8 file's sha256."""
    with open(args.int8, "rb") as f:
        sha = hashlib.sha256(f.read()).hexdigest()
    meta, _, _ = plm.read_plm(args.int8)
    if meta.get("precision") != "int8":
        raise ValueError(f"--int8 {args.int8}: precision {meta.get('precision')}, expected int8")
    path = os.path.join(work, "z8.pt")
    key = [sha, digest]
    if os.path.exists(path):
        zc = torch.load(path, weights_only=False)
        if zc.get("key") == key:
            return zc["z"], sha
    if not os.access(args.zdump, os.X_OK):
        raise ValueError(f"--zdump {args.zdump}: not an executable (make builds build/tools/zdump)")
    rows = train.read_index(args.data)
    if len(rows) != m:
        raise ValueError(f"{args.data}: {len(rows)} index rows, {m} crops loaded")
    lst, raw = os.path.join(work, "z8.list"), os.path.join(work, "z8.f32")
    with open(lst, "w", encoding="utf-8") as f:
        f.writelines(os.path.join(os.path.abspath(args.data), r[0]) + "\n" for r in rows)
    if os.path.exists(raw):
        os.remove(raw)
    log(f"int8 latents of {m} crops and their mirrors through {args.int8} ({args.zdump})")
    t0 = time.time()
    r = subprocess.run([args.zdump, args.int8, lst, raw, str(args.threads)],
                       stderr=subprocess.PIPE, text=True, check=False)
    if r.returncode != 0:
        raise RuntimeError(f"zdump: {r.stderr.strip()}")
    a = np.fromfile(raw, np.float32)
    if a.size != 2 * m * d:
        raise RuntimeError(f"zdump wrote {a.size} values, expected 2 x {m} x {d}")
    z8 = torch.from_numpy(a.reshape(m, 2, d).transpose(1, 0, 2).copy())
    torch.save({"key": key, "z": z8}, path + ".tmp")
    os.replace(path + ".tmp", path)
    os.remove(raw)
    os.remove(lst)
    log(f"int8 latents done ({time.time() - t0:.0f} s)")
    return z8, sha


def forward(net, z):
    n = net.n_lights
    h = F.relu(net.fc(z))
    d = F.normalize(net.head_dir(h).view(-1, n, 3), dim=-1)
    return {"dir": d, "size": F.softplus(net.head_size(h)),
            "rgb": F.softplus(net.head_rgb(h)).view(-1, n, 3),
            "ambient": F.softplus(net.head_ambient(h))}


def primary_angles(out, gt):
    """Degrees between pl_lighting_primary's light (largest energy) and the truth's primary, for
    the crops that have a light."""
    e = train.light_energy(out["rgb"], out["size"])
    i = e.argmax(1)
    pd = out["dir"][torch.arange(len(i)), i]
    d, has = train.gt_primary(gt)
    return torch.rad2deg(torch.acos((pd * d).sum(1).clamp(-1, 1)))[has], has


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--model", required=True, help="the float .plm whose encoder stays")
    ap.add_argument("--data", required=True, help="a make_dataset.py folder")
    ap.add_argument("--out", required=True)
    ap.add_argument("--val-panos", type=int, default=0)
    ap.add_argument("--epochs", type=int, default=30)
    ap.add_argument("--halve-every", type=int, default=10)
    ap.add_argument("--lr", type=float, default=1e-3)
    ap.add_argument("--batch", type=int, default=16)
    ap.add_argument("--w-primary", type=float, default=1.0)
    ap.add_argument("--w-r", type=float, default=20.0)
    ap.add_argument("--w-a", type=float, default=1.0)
    ap.add_argument("--w-d1", type=float, default=20.0)
    ap.add_argument("--w-rank", type=float, default=0.0,
                    help="weight of train.rank_loss (the lights' brightness order) in step 1")
    ap.add_argument("--train-block4", action="store_true",
                    help="train DenseNet block 4 (and norm5) with the fc and heads in step 1")
    ap.add_argument("--weight-decay", type=float, default=0.0,
                    help="AdamW's decoupled weight decay in both steps (0: Adam, no decay)")
    ap.add_argument("--step2-epochs", type=int, default=0)
    ap.add_argument("--step2-scenes", choices=("indoor", "all"), default="indoor")
    ap.add_argument("--z-noise", type=float, default=0.0,
                    help="train on z plus this much Gaussian noise, relative to z's rms")
    ap.add_argument("--int8", help="train half of the time on this int8 model's latents")
    ap.add_argument("--zdump", default=os.path.join(os.path.dirname(os.path.dirname(HERE)),
                                                    "build", "tools", "zdump"),
                    help="the zdump program (default: build/tools/zdump of this checkout)")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--work", help="cache and checkpoint folder (default OUT.heads/)")
    ap.add_argument("--log", help="append one line per epoch here too")
    ap.add_argument("--force", action="store_true", help="replace an existing --out")
    args = ap.parse_args(argv)

    def log(text):
        line = f"{time.strftime('%Y-%m-%dT%H:%M:%SZ', time.gmtime())} {text}"
        print(line, flush=True)
        if args.log:
            with open(args.log, "a", encoding="utf-8") as f:
                f.write(line + "\n")

    try:
        for name, v, lo in (("--epochs", args.epochs, 0), ("--halve-every", args.halve_every, 1),
                            ("--batch", args.batch, 1), ("--val-panos", args.val_panos, 0),
                            ("--step2-epochs", args.step2_epochs, 0),
                            ("--threads", args.threads, 1)):
            if v < lo:
                raise ValueError(f"{name} {v}: expected >= {lo}")
        for name, v in (("--w-primary", args.w_primary), ("--w-r", args.w_r),
                        ("--w-a", args.w_a), ("--w-d1", args.w_d1), ("--w-rank", args.w_rank),
                        ("--weight-decay", args.weight_decay)):
            if not (v >= 0 and math.isfinite(v)):
                raise ValueError(f"{name} {v}: expected a weight >= 0")
        if not (0 <= args.z_noise <= 1):
            raise ValueError(f"--z-noise {args.z_noise}: expected 0..1 (relative to z's rms)")
        if args.train_block4 and (args.z_noise or args.int8):
            raise ValueError("--train-block4 trains on the float encoder's block-3 maps; "
                             "--z-noise and --int8 act on a fixed z and do not combine with it")
        if not (args.lr > 0 and math.isfinite(args.lr)):
            raise ValueError(f"--lr {args.lr}: expected a positive number")
        if os.path.lexists(args.out) and not args.force:
            raise ValueError(f"{args.out} exists; not replacing it (use --force)")
        torch.set_num_threads(args.threads)
        meta, tensors, _ = plm.read_plm(args.model)
        if meta.get("arch") != "densenet121-parametric" or meta.get("precision") != "fp32":
            raise ValueError(f"{args.model}: {meta.get('arch')} {meta.get('precision')}: expected "
                             "a float densenet121-parametric model (retrain the float model, then "
                             "quantise)")
        n = int(meta["n_lights"])
        hw = (int(meta["input_h"]), int(meta["input_w"]))
        if int(meta.get("bands", BANDS)) != BANDS:
            raise ValueError(f"{args.model}: bands {meta.get('bands')}, this tool pools {BANDS}")
        t = {k: torch.from_numpy(np.array(v, dtype=np.float32)) for k, v in tensors.items()}
        work = args.work or args.out + ".heads"
        os.makedirs(work, exist_ok=True)

        imgs, gt, val, held, digest = train.load_dataset(args.data, hw, args.val_panos,
                                                         stream=True)
        cfg = {"base_trunk_sha256": trunk_sha256(tensors), "data_index_sha256": digest,
               "val_panos": args.val_panos, "epochs": args.epochs,
               "halve_every": args.halve_every, "lr": args.lr, "batch": args.batch,
               "w_primary": args.w_primary, "w_r": args.w_r, "w_a": args.w_a, "w_d1": args.w_d1,
               "seed": args.seed, "z_noise": args.z_noise, "int8_sha256": None,
               "w_rank": args.w_rank, "train_block4": bool(args.train_block4),
               "weight_decay": args.weight_decay,
               "threads": args.threads,
               "map_width": 64, "radiance": "log",
               "sphere_truth": "lights", "step2_loss": "render", "w_d": 1.0,
               "sphere_metric": "log", "step2_scenes": args.step2_scenes}
        # the cache: z, or with --train-block4 transition3's maps (v3.pt)
        zpath = os.path.join(work, "v3.pt" if args.train_block4 else "z.pt")
        key = [cfg["base_trunk_sha256"], digest, list(hw)]
        z = None
        if os.path.exists(zpath):
            zc = torch.load(zpath, weights_only=False)
            if zc.get("key") == key:
                z = zc["z"]
        if z is None:
            if args.train_block4:
                log(f"block-3 maps of {len(imgs)} crops and their mirrors through {args.model}")
                z = lower_maps(t, imgs, log=log)
            else:
                log(f"latents of {len(imgs)} crops and their mirrors through {args.model}'s "
                    "encoder")
                z = latents(t, imgs, log=log)
            torch.save({"key": key, "z": z}, zpath + ".tmp")
            os.replace(zpath + ".tmp", zpath)
        v3 = None
        b4 = {}
        if args.train_block4:      # z is computed from v3 by the block 4 being trained
            v3, z = z, None
            b4 = {k: torch.nn.Parameter(v.clone()) for k, v in t.items() if k.startswith(BLOCK4)}

        def z_of(v):
            """z of block-3 maps v through the current block 4."""
            return F.adaptive_avg_pool2d(export.folded_upper(b4, v), (BANDS, 1)).flatten(1)

        def all_z():
            """z [2, M, d] of every crop and mirror through the current block 4."""
            with torch.no_grad():
                return torch.stack([torch.cat([z_of(v3[f][j]) for j in
                                               torch.arange(v3.shape[1]).split(256)])
                                    for f in (0, 1)])

        z8 = None
        if args.int8:
            z8, cfg["int8_sha256"] = int8_latents(args, work, digest, len(imgs), z.shape[2], log)

        net = ParLightNet(n, hw)
        for name in TRAINED + ("head_dist.fc1", "head_dist.fc2"):
            lin = net.get_submodule(name)
            lin.weight.data.copy_(t[f"{name}.weight"])
            lin.bias.data.copy_(t[f"{name}.bias"])
        params = [p for name in TRAINED for p in net.get_submodule(name).parameters()]
        params += list(b4.values())
        def optimiser(ps):
            if args.weight_decay > 0:
                return torch.optim.AdamW(ps, lr=args.lr, betas=(0.9, 0.999),
                                         weight_decay=args.weight_decay)
            return torch.optim.Adam(ps, lr=args.lr, betas=(0.9, 0.999))

        opt = optimiser(params)
        epoch, epoch2 = 0, 0
        last = os.path.join(work, "last.pt")
        if os.path.exists(last):
            ck = torch.load(last, weights_only=False)
            old = {**RESUME_DEFAULTS, **ck["config"]}   # older checkpoints
            diff = [k for k in RESUME_KEYS if old.get(k) != cfg[k]]
            if diff:
                raise ValueError(f"{last}: made with another configuration ({', '.join(diff)} "
                                 "differ); use another --work folder")
            net.load_state_dict(ck["net"])
            with torch.no_grad():
                for k, p in b4.items():
                    p.copy_(ck["block4"][k])
            epoch, epoch2 = ck["epoch"], ck.get("step2_epoch", 0)
            if epoch2 == 0:
                opt.load_state_dict(ck["optimizer"])
            if epoch2 and ck["config"].get("step2_scenes") != cfg["step2_scenes"]:
                raise ValueError(f"{last}: its step 2 trains on {ck['config'].get('step2_scenes')} "
                                 "crops; use another --work folder")
            log(f"resumed {last} at epoch {epoch}" + (f", step 2 epoch {epoch2}" if epoch2 else ""))
            if epoch2 and epoch < args.epochs:
                raise ValueError(f"{last}: step 2 has started after {epoch} step-1 epochs; "
                                 f"--epochs {args.epochs} would go back to step 1")

        udirs = sg.equirect_dirs(cfg["map_width"])
        render = (udirs, sg.diffuse_operator(cfg["map_width"], sg.sphere_normals(16)), None, None)
        m = len(imgs)
        with torch.no_grad():      # the truth's maps, of each crop and of its mirror
            gms = [torch.cat([train.gt_map(train.flip_gt(train.take(gt, j), torch.full(
                (len(j),), bool(f))), udirs, cfg) for j in torch.arange(m).split(256)])
                for f in (0, 1)]
        tr = torch.nonzero(~val).flatten()
        va = torch.nonzero(val).flatten()
        indoor = ~train.crop_outdoor(args.data)
        z_sd = args.z_noise * float(z[0][tr].square().mean().sqrt()) if args.z_noise else 0.0

        def noisy(zb, gen):
            """zb plus the --z-noise Gaussian (a function of the generator's state)."""
            if z_sd == 0:
                return zb
            return zb + z_sd * torch.randn(zb.shape, generator=gen)

        if len(tr) < args.batch:
            raise ValueError(f"{len(tr)} training crops: fewer than one batch of {args.batch}")
        if epoch == 0:
            log(f"start: {len(tr)} train + {len(va)} val crops (held out {held}), base "
                f"{args.model}, config {json.dumps(cfg)}")

        def validate(step=1):
            if len(va) == 0:
                return ""
            with torch.no_grad():
                g = train.take(gt, va)
                o = forward(net, z[0][va] if v3 is None else z_of(v3[0][va]))
                loss = float(train.step1_loss(o, g, udirs, cfg, render, gms[0][va])[0] if step == 1
                             else train.step2_loss(o, g, cfg, render)[0])
                a, has = primary_angles(o, g)
                ind = indoor[va][has]
                return (f" | val loss {loss:.5g}, primary angle median {a.median():.1f} deg"
                        + (f" (indoor {a[ind].median():.1f})" if ind.any() else ""))

        def run_epochs(step, opt, crops, done, total, batch_loss):
            """Trains epochs done+1..total of step 1 or 2 on crops and returns total;
            batch_loss(j, flips, gen) gives a batch's (loss, parts). An epoch's batch order,
            flips and noise are a function of --seed, the step and the epoch; last.pt is written
            at each epoch's end."""
            name = "epoch" if step == 1 else "step 2 epoch"
            while done < total:
                for grp in opt.param_groups:
                    grp["lr"] = args.lr * 0.5 ** (done // args.halve_every)
                gen = torch.Generator().manual_seed(args.seed * 100003 + (step - 1) * 50000 + done)
                perm = crops[torch.randperm(len(crops), generator=gen)]
                flips = torch.rand(len(crops), generator=gen) < 0.5
                t0, sums, nb = time.time(), {}, 0
                for b in range(0, len(crops) - args.batch + 1, args.batch):
                    loss, parts = batch_loss(perm[b:b + args.batch], flips[b:b + args.batch], gen)
                    if not torch.isfinite(loss):
                        raise RuntimeError(f"{name} {done} batch {b // args.batch}: loss "
                                           f"{float(loss)}")
                    opt.zero_grad(set_to_none=True)
                    loss.backward()
                    opt.step()
                    for k, v in [("loss", float(loss))] + list(parts.items()):
                        sums[k] = sums.get(k, 0.0) + v
                    nb += 1
                done += 1
                log(f"{name} {done}/{total} lr {opt.param_groups[0]['lr']:.3g} "
                    + " ".join(f"{k} {v / nb:.5g}" for k, v in sums.items())
                    + f" ({time.time() - t0:.0f} s){validate(step)}")
                state = {"epoch": done} if step == 1 else {"epoch": epoch, "step2_epoch": done}
                torch.save({"config": cfg, "net": net.state_dict(), "optimizer": opt.state_dict(),
                            "block4": {k: p.detach() for k, p in b4.items()}, **state},
                           last + ".tmp")
                os.replace(last + ".tmp", last)
            return done

        def z_rows(j, fl, gen):
            """The batch's latents: mirrored where fl, the int8 ones for half of the crops
            (--int8), plus the --z-noise noise; with --train-block4, z of the block-3 maps
            through the block 4 being trained."""
            if v3 is not None:
                return z_of(torch.where(fl[:, None, None, None], v3[1][j], v3[0][j]))
            zb = torch.where(fl[:, None], z[1][j], z[0][j])
            if z8 is not None:
                q = torch.rand(len(j), generator=gen) < 0.5
                zb = torch.where(q[:, None], torch.where(fl[:, None], z8[1][j], z8[0][j]), zb)
            return noisy(zb, gen)

        def step1_batch(j, fl, gen):
            g = train.flip_gt(train.take(gt, j), fl)
            o = forward(net, z_rows(j, fl, gen))
            gm = torch.where(fl.view(-1, 1, 1, 1), gms[1][j], gms[0][j])
            return train.step1_loss(o, g, udirs, cfg, render, gm)

        epoch = run_epochs(1, opt, tr, epoch, args.epochs, step1_batch)
        if v3 is not None:         # block 4 is final: step 2 reads its z
            z, v3 = all_z(), None

        # step 2 (train.py's, --step2-loss render): fc and directions frozen
        tr2 = tr[indoor[tr]] if args.step2_scenes == "indoor" else tr
        if args.step2_epochs > epoch2 and len(tr2) < args.batch:
            raise ValueError(f"{len(tr2)} {args.step2_scenes} training crops: fewer than one "
                             f"batch of {args.batch}")
        params2 = [p for name in ("head_size", "head_rgb", "head_ambient")
                   for p in net.get_submodule(name).parameters()]
        opt2 = optimiser(params2)
        if epoch2 and os.path.exists(last):
            opt2.load_state_dict(torch.load(last, weights_only=False)["optimizer"])

        def step2_batch(j, fl, gen):
            g = train.flip_gt(train.take(gt, j), fl)
            with torch.no_grad():
                h = F.relu(net.fc(z_rows(j, fl, gen)))
                d = F.normalize(net.head_dir(h).view(-1, n, 3), dim=-1)
            o = {"dir": d, "size": F.softplus(net.head_size(h)),
                 "rgb": F.softplus(net.head_rgb(h)).view(-1, n, 3),
                 "ambient": F.softplus(net.head_ambient(h))}
            return train.step2_loss(o, g, cfg, render)

        run_epochs(2, opt2, tr2, epoch2, args.step2_epochs, step2_batch)

        out_t = dict(tensors)
        for name in TRAINED:
            lin = net.get_submodule(name)
            out_t[f"{name}.weight"] = lin.weight.detach().numpy().astype(np.float32)
            out_t[f"{name}.bias"] = lin.bias.detach().numpy().astype(np.float32)
        for k, p in b4.items():
            out_t[k] = p.detach().numpy().astype(np.float32)
        meta = dict(meta)
        meta["provenance"] = (meta.get("provenance", "") + "; fc and heads"
                              + (" and DenseNet block 4" if args.train_block4 else "")
                              + " retrained by tools/train/heads.py on the frozen encoder"
                              + (" below it" if args.train_block4 else "")
                              + f": data index sha256 {digest[:16]}, {len(tr)} crops, "
                              f"{args.epochs} epochs, w_primary {args.w_primary}, val_panos "
                              f"{args.val_panos}, step 2 {args.step2_epochs} epochs on "
                              f"{args.step2_scenes} crops"
                              + (f", z noise {args.z_noise}" if args.z_noise else "")
                              + (f", w_rank {args.w_rank}" if args.w_rank else "")
                              + (f", weight decay {args.weight_decay}" if args.weight_decay
                                 else "")
                              + (f", half on the latents of int8 sha256 {cfg['int8_sha256'][:16]}"
                                 if z8 is not None else ""))
        size = plm.write_plm(args.out, meta, [(k, np.asarray(v, np.float32))
                                              for k, v in out_t.items()], force=args.force)
        log(f"wrote {args.out} ({size:,} bytes)")
    except (OSError, ValueError, RuntimeError, plm.PlmError) as e:
        print(f"heads: {e}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
