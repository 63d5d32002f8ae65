#!/usr/bin/python3
"""The paper's two-step training of ParLightNet (tools/model.py) on crops from make_dataset.py.

    tools/train/train.py [--data /work/cache/train-data] [--ckpt-dir /work/cache/train-ckpt]
                         [--log /work/cache/train-log.txt] [--input 96x128] [--n-lights 3]
                         [--step1-epochs 60] [--step2-epochs 50] [--halve-every 25] [--lr 1e-3]
                         [--batch 16] [--bf16] [--threads 2] [--export OUT.plm]
                         [--w-d1 0] [--step2-loss paper|render|both] [--w-d 1]
                         [--step2-from STEP1.pt] [--val-panos 4] [--train-scenes all|indoor]
                         [--sphere-metric log|relative] [--z-dropout 0] [--erase 0] [--ema 0]
                         [--w-map 0] [--sphere-truth lights|map] [--w-primary 0] [--w-rank 0]
                         [--step1-max-size 0] [--w-src 0] [--device cpu|cuda] [--channels-last]
                         [--stream]
    tools/train/train.py --export-only CKPT OUT.plm [--force]

Step 1 (paper sec. 3.3.1, "radius, colour and position"): the whole network; the predicted
lights and the ground-truth lights are both rendered to a small equirectangular SG map
(tools/train/sg.py, eq. 4, the light/sg.c formula; both prefiltered by a pixel-sized lobe so
lights narrower than a pixel are not lost between the samples) and compared with an L2 loss,
weighted w_r = 20, plus the ambient L2 loss, w_a = 1. No correspondence between lights.
Radiance values (map pixels, ambient, colours) go through log1p before the L2 by default
(--radiance log): the ground truth spans 0.01 .. 20000 (a sun of 0.0002 sr), and a plain L2 is
then the error of the brightest pixel alone (--radiance linear is the paper's literal loss).

Step 2 (sec. 3.3.2, "depth and refinement"): the network up to the 512-d vector and the
direction head are frozen (batch norms in eval mode); for each predicted light, the closest
ground-truth light by angle, if within 45 degrees, gives L2 losses on distance, size and colour
(none otherwise), plus the ambient L2; only the size, colour, ambient and distance heads train.
Because everything they read (z, h, the directions) is frozen, step 2 computes z, h and the
directions once per crop and flip and trains the heads on those: 50 epochs cost seconds.

Not in the paper — the diffuse-sphere term (sg.diffuse: a white Lambertian sphere seen from the
camera, 16 x 16 pixels, lit by the lights and ambient through the SG map, after the radiance
transform; what `parlight eval` scores, there against the real panorama): --w-d1 W adds
W times it to step 1's loss; --step2-loss render replaces step 2's per-light terms by --w-d
times it (plus the ambient term), --step2-loss both adds it to them. --step2-from CKPT runs only
step 2, from a step-1 checkpoint (into its own --ckpt-dir).

--init CKPT starts from another checkpoint's encoder (tools/train/distill.py: MobileNetV2
features distilled into the DenseNet; the paper starts from ImageNet weights, which we lack).

Adam (beta1 0.9), lr 1e-3 halved every --halve-every epochs, restarting at --lr for step 2.
Augmentation: horizontal flips (image mirrored, light x negated; the crops themselves already
vary yaw, pitch, fov, exposure and gamma). Validation: --val-panos panoramas held out (chosen
by name hash, half of them indoor or indoor-semi, half outdoor; only real train/ panoramas:
the synthetic rooms of make_dataset.py --synthetic always train), loss logged each epoch.
Regularisers (not in the paper; off by default): --z-dropout P drops the latent z's entries
with probability P before the fc and the distance head in step 1 (training mode only; the
exported graph has none); --erase P blanks, in each step-1 training image with probability P,
one rectangle (5-25% of the area, aspect 1:2..2:1) with the image's mean colour (random erasing:
a lamp hidden that way is a lamp just outside the frame, so the lighting has to come from what
the room shows). Both draw from generators seeded by the seed, the epoch and the batch, so a
resumed run stays bit-identical.
Weight averaging (not in the paper; off by default): --ema D keeps an exponential moving average
of the step-1 network's weights and batch-norm statistics, updated after every step with decay
min(D, (1 + t) / (10 + t)) at step t; the validation loss of the average is logged beside the
network's, step 1 ends on the average (step1.pt, then step 2 and the export), and the last
weights of the run itself are kept in step1_raw.pt (`--step2-from` it for the same run without
the average). The average never feeds back into training: the run's own weights are the same
with or without it.
Denser supervision (not in the paper; off by default; needs a dataset made with make_dataset.py
--gt-map, whose ground truth carries each crop's panorama rotated into its camera frame on its
scale, W x W/2): --w-map W adds W times an auxiliary loss in step 1: a linear head from the 512-d
vector h (AuxHead, training only, never exported: the .plm and the C graph do not change) regresses
the map after log1p, L2 weighted by each row's solid angle. --sphere-truth map lights the
diffuse-sphere terms' truth (--w-d1, --step2-loss render) by that real panorama instead of the
extracted lights + ambient: what `parlight eval` scores against, light the extraction left out
included. --w-map 1 is in the shipped recipe since 2026-12-06 (MODEL_CARD.md, "The map head, a
second pair": against its control, paired on eval/, -4.0 and -7.7 deg of primary-light angle in
two seeds, shape level); --sphere-truth map has not passed its rule.
Direction first (not in the paper; off by default): --w-primary W adds W times primary_loss in
step 1, the angular error of the primary light (the one pl_lighting_primary reports and an AR app
casts shadows from), which neither the map's nor the sphere's L2 measures. tools/train/heads.py
trains the fc and heads of a finished .plm with it on the frozen encoder (measured, not shipped:
MODEL_CARD.md, "Direction first"; through the whole network, --w-primary 1 cut eval/'s crops
off by more than 90 deg from 24-25 to 15 in two pairs of runs but not the median angle, and
kept int8 within its targets in one of the two: "Direction first through the whole network",
"The direction term, replicated").
--w-rank W adds W times rank_loss in step 1: a pairwise (RankNet) loss asking that of two
predicted lights standing for two different truth lights (each for its nearest) the one whose
truth light is brighter be brighter; it moves no direction. Measured only on M3's trunk with
block 4 trainable (heads.py --train-block4 --w-rank 1: MODEL_CARD.md, "Block 4 and a
brightness-order term"), where it learned little of the order; untried in a whole step 1.
Small lights in step 1 (not in the paper; off by default): --step1-max-size S renders step 1's
lights with their solid angle bounded smoothly by S steradians (S tanh(s / S), the loss's view
only; step 2 fits the size head unbounded, with the directions frozen). Without it the heads
learn three fixed broad lobes (2-4 sr, where the extracted lights are 0.01-0.2 sr): the L2 on
the map is best served under uncertainty by the blurred mean, while a small light of given
energy is best placed at the most likely direction (MODEL_CARD.md, "Where the lights point").
Measured, not shipped (MODEL_CARD.md, "Small lights in step 1": --step1-max-size 0.5 in two
seeds): the lobes stayed fixed, and the primary light's angle on eval/ got 14-21 deg worse.
Where the light comes from (not in the paper; off by default; needs --gt-map data as --w-map):
--w-src W adds W times source_loss in step 1: a second training-only head on h (AuxHead,
never exported) gives a distribution over the radiance map's pixels, trained by KL divergence
towards each pixel's share of the panorama's luminous energy (luminance x solid angle). The
map's L2 sees mostly the walls (the lights are a few pixels of 512); this term sees mostly the
lights, and its distribution can keep several candidate directions where a regressed one
settles on their mean. Its argmax is a direction readout of the encoder for diagnosis.
Measured, not shipped (MODEL_CARD.md, "Where the light comes from": --w-src 1 in two seeds): the
lights followed the room more but were ranked worse; the primary light's angle on eval/ got 1-10
deg worse.
--train-scenes indoor trains on the indoor and indoor-semi panoramas' crops only, synthetic
rooms included (the held-out ones of both kinds stay the validation).

Checkpoints (--ckpt-dir): last.pt every --ckpt-minutes and at each epoch end (model, optimiser,
step, epoch, batch within the epoch, RNG states, configuration), step1.pt when step 1 ends,
final.pt at the end; written to a temporary file and renamed. Rerunning the same command resumes
from last.pt (an epoch's batch order is a function of the seed and the epoch, so a resumed epoch
continues where it stopped). A checkpoint made with another configuration is refused. The
configuration keeps the thread counts the run used (the export's provenance names them): on this
CPU a run is bit-for-bit repeatable with the same data, start, seed and --threads, and another
thread count gives another network (reduction order), as another distilled encoder does.

Data and devices: the crops' pixels are decoded once at load and held in memory (M x H x W x 3
bytes), or with --stream decoded from their files at each use by a pool of threads (memory
independent of the dataset's size); both give the same bytes, hence the same network. --device
cuda (or cuda:N) trains on a GPU: the network, ground truth, maps and operators move there, the
decoded crops too when they fit in a quarter of its memory (else they are copied per batch), bf16
autocast runs on that device, and step 1 reads its loss back only at checkpoints and epoch ends
(a non-finite loss then stops the run before anything is saved); batch order, flips and seeds are
drawn on the CPU as before. --channels-last runs the network in that memory layout (cuDNN's own
for bf16 convolutions; the checkpoints hold the default layout). --device cpu (the default) is
bit-identical to the runs before the options existed. The first GPU run (model card, "The paper's
input on a GPU", 2026-12-06, H100) had none of these three and trained at 160-225 img/s at
192x256 beside a second run; what they gain there has not been measured. A run may be resumed
on another device (the devices used are recorded, like the thread counts): it continues, but is
not bit-identical to an uninterrupted one.

The log (--log) gets one line per epoch: date, step, epoch, lr, train and validation losses,
images per second. The model is exported with tools/export.py's code path (folded tensors,
metadata, plm.write_plm) to --export at the end, or from any checkpoint with --export-only.
"""

import argparse
import concurrent.futures
import datetime
import hashlib
import json
import math
import os
import random
import sys
import time

import numpy as np
import torch
import torch.nn.functional as F
from PIL import Image

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.dirname(HERE))
import export  # noqa: E402
import plm  # noqa: E402
import sg  # noqa: E402
from model import MEAN, STD, ParLightNet  # noqa: E402

MAX_GT = 16
COS45 = math.cos(math.radians(45.0))
# configuration keys that must match to resume a checkpoint
RESUME_KEYS = ("data_index_sha256", "input", "n_lights", "batch", "lr", "halve_every", "seed",
               "map_width", "radiance", "w_r", "w_a", "val_panos", "step1_epochs",
               "step2_loss", "w_d", "w_d1", "train_scenes", "sphere_metric", "z_dropout",
               "erase", "ema", "w_map", "sphere_truth", "w_primary", "step1_max_size", "w_src",
               "w_rank")
# what a checkpoint made before a key existed was trained with
RESUME_DEFAULTS = {"step2_loss": "paper", "w_d": 1.0, "w_d1": 0.0, "train_scenes": "all",
                   "sphere_metric": "log", "z_dropout": 0.0, "erase": 0.0,
                   "ema": 0.0, "w_map": 0.0, "sphere_truth": "lights", "w_primary": 0.0,
                   "step1_max_size": 0.0, "w_src": 0.0, "w_rank": 0.0}
AUX_PREFIX = ("aux_map.", "aux_src.")   # the auxiliary heads' tensors: trained, never exported


def log_line(path, text):
    line = f"{datetime.datetime.now(datetime.timezone.utc):%Y-%m-%dT%H:%M:%SZ} {text}"
    print(line, flush=True)
    if path:
        with open(path, "a", encoding="utf-8") as f:
            f.write(line + "\n")


# ---- data -------------------------------------------------------------------------------------

def read_index(data, limit=0):
    """The rows of index.tsv (png, json, panorama, scene), the first `limit` when > 0."""
    with open(os.path.join(data, "index.tsv"), encoding="utf-8") as f:
        rows = [ln.rstrip("\n").split("\t") for ln in f][1:]
    return rows[:limit] if limit else rows


def crop_outdoor(data, limit=0):
    """Boolean per crop of read_index(data, limit): whether it is of an outdoor panorama."""
    return torch.tensor([r[3] == "outdoor" for r in read_index(data, limit)], dtype=torch.bool)


class CropImages:
    """The crops' pixels at the training size hw: images[idx] is u8 [B, H, W, 3] for a 1-D index
    tensor. In memory (every crop decoded once here), or with stream=True decoded from its file at
    each use by `workers` threads (memory independent of the dataset's size). Decoding is the
    same either way (RGB, resized to hw with PIL's box filter when the crop is another size), so
    the bytes, and a network trained on them, are the same."""

    def __init__(self, paths, hw, stream=False, workers=4):
        self.paths, self.hw, self.stream = list(paths), hw, stream
        self.arr, self.pool = None, None
        if stream:
            for p in self.paths:
                if not os.path.isfile(p):
                    raise ValueError(f"{p}: no such crop")
            self.pool = concurrent.futures.ThreadPoolExecutor(max(1, workers))
        else:
            h, w = hw
            arr = np.zeros((len(self.paths), h, w, 3), np.uint8)
            for i in range(len(self.paths)):
                arr[i] = self.decode(i)
            self.arr = torch.from_numpy(arr)

    def decode(self, i):
        h, w = self.hw
        try:
            with Image.open(self.paths[i]) as im:
                im = im.convert("RGB")
                if im.size != (w, h):
                    im = im.resize((w, h), Image.BOX)
                return np.asarray(im)
        except (OSError, ValueError) as e:
            raise ValueError(f"{self.paths[i]}: cannot read the crop ({e})") from None

    def __len__(self):
        return len(self.paths)

    def to_device(self, dev, budget):
        """Moves the decoded crops to dev when they take at most `budget` bytes (a GPU then
        indexes and mirrors each batch itself: no host copy, no host sync per batch); returns
        whether they moved."""
        if self.arr is None or self.arr.numel() > budget:
            return False
        self.arr = self.arr.to(dev)
        return True

    def __getitem__(self, idx):
        if self.arr is not None:
            return self.arr[idx]
        ids = torch.as_tensor(idx).flatten().tolist()
        return torch.from_numpy(np.stack(list(self.pool.map(self.decode, ids))))


def held_out_panoramas(rows, val_panos):
    """The set of panoramas --val-panos holds out, from index.tsv rows (png, json, panorama,
    scene): chosen by name hash, half of them indoor or indoor-semi, half outdoor (when both
    exist), among the shared train/ and make_dataset.py --panos panoramas. Only real panoramas
    are held out: synthetic rooms (synth/, make_dataset.py --synthetic) always train, so adding
    them leaves the validation set as it was. Used by
    load_dataset and by tools/train/fit_ridge.py (the same held-out rooms for both)."""
    panos = sorted({(r[2], r[3]) for r in rows if r[2].startswith(("train/", "panos/"))},
                   key=lambda p: hashlib.sha256(p[0].encode()).hexdigest())
    if val_panos and val_panos >= len(panos):
        raise ValueError(f"--val-panos {val_panos}: only {len(panos)} real panoramas in the "
                         "data (synthetic rooms are never held out)")
    indoor = [p for p, s in panos if s != "outdoor"]
    outdoor = [p for p, s in panos if s == "outdoor"]
    k_in = min(len(indoor), (val_panos + 1) // 2)
    k_out = min(len(outdoor), val_panos - k_in)
    # half the held-out panoramas indoor (or indoor-semi), half outdoor, when both exist
    held = set(indoor[:k_in] + outdoor[:k_out])
    held |= set([p for p, _ in panos if p not in held][:val_panos - len(held)])
    return held


def load_dataset(data, hw, val_panos, limit=0, need_map=False, stream=False):
    """Crops of index.tsv resized to hw (area filter) as CropImages (in memory, or streamed from
    their files with stream), their ground truth padded to MAX_GT lights, and a boolean
    validation mask (whole panoramas held out). With
    need_map, gt["map"] [M, H', W', 3] is each crop's radiance_map (make_dataset.py --gt-map:
    the panorama in the crop's camera frame on its scale), which every crop must have."""
    index = os.path.join(data, "index.tsv")
    rows = read_index(data, limit)
    if not rows:
        raise ValueError(f"{index}: no crops")
    held = held_out_panoramas(rows, val_panos)
    m = len(rows)
    gt = {"dir": torch.zeros(m, MAX_GT, 3), "size": torch.ones(m, MAX_GT),
          "rgb": torch.zeros(m, MAX_GT, 3), "dist": torch.ones(m, MAX_GT),
          "mask": torch.zeros(m, MAX_GT), "ambient": torch.zeros(m, 3)}
    val = torch.zeros(m, dtype=torch.bool)
    for i, (png, js, pano, _scene) in enumerate(rows):
        if not pano.startswith(("train/", "panos/", "synth/")):
            # the shared eval/ panoramas never reach a dataset (make_dataset.py refuses them)
            raise ValueError(f"{index}: {pano} is neither a train panorama, a --panos folder's "
                             "panorama nor a synthetic room")
        with open(os.path.join(data, js), encoding="utf-8") as f:
            obj = json.load(f)
        try:
            d, s, c, dist, amb = sg.lights_from_json(obj, MAX_GT)
        except ValueError as e:
            raise ValueError(f"{js}: {e}") from None
        n = d.shape[0]
        gt["dir"][i, :n] = d.float()
        gt["size"][i, :n] = s.float()
        gt["rgb"][i, :n] = c.float()
        gt["dist"][i, :n] = dist.float()
        gt["mask"][i, :n] = 1
        gt["ambient"][i] = amb.float()
        if need_map:
            try:
                rm = radiance_map(obj)
            except ValueError as e:
                raise ValueError(f"{js}: {e} (make the dataset with make_dataset.py --gt-map)") \
                    from None
            if "map" not in gt:
                gt["map"] = torch.zeros(m, *rm.shape)
            elif gt["map"].shape[1:] != rm.shape:
                raise ValueError(f"{js}: radiance_map {tuple(rm.shape)}, the others "
                                 f"{tuple(gt['map'].shape[1:])}")
            gt["map"][i] = rm
        val[i] = pano in held
    with open(index, "rb") as f:
        digest = hashlib.sha256(f.read()).hexdigest()
    imgs = CropImages([os.path.join(data, r[0]) for r in rows], hw, stream)
    return imgs, gt, val, sorted(held), digest


def radiance_map(obj):
    """The radiance_map of a ground-truth JSON (parlight crop --gt-map) as float [H, W, 3]."""
    rm = obj.get("radiance_map")
    if not isinstance(rm, dict):
        raise ValueError("no radiance_map")
    w, h, rgb = rm.get("width"), rm.get("height"), rm.get("rgb")
    if not (isinstance(w, int) and isinstance(h, int) and 4 <= w <= 256 and w == 2 * h and
            isinstance(rgb, list) and len(rgb) == w * h * 3):
        raise ValueError("radiance_map: expected width = 2 x height in 4..256 and "
                         "width x height x 3 values")
    t = torch.tensor(rgb, dtype=torch.float32).view(h, w, 3)
    if not bool(torch.isfinite(t).all()) or bool((t < 0).any()):
        raise ValueError("radiance_map: negative or non-finite values")
    return t


class AuxHead(torch.nn.Module):
    """Training only: a linear head from the 512-d vector h to a tensor [B, *shape] over the
    crop's radiance-map pixels; dropped at export (AUX_PREFIX), so the .plm and the C graph do
    not change.
    - aux_map (--w-map), shape [H, W, 3]: the radiance map after log1p. It makes h, which every
      light head reads, carry the whole panorama's layout rather than only the three extracted
      lights.
    - aux_src (--w-src), shape [H, W]: logits whose softmax is trained towards where the
      panorama's light energy comes from (source_share). A distribution over directions can hold
      several modes where a regressed direction or the map's L2 settle on a blurred mean."""

    def __init__(self, shape, fc=512):
        super().__init__()
        self.shape = tuple(shape)
        self.lin = torch.nn.Linear(fc, math.prod(self.shape))

    def forward(self, h):
        return self.lin(h).view(-1, *self.shape)


def make_model(cfg):
    """ParLightNet for cfg, with the auxiliary map head when cfg["w_map"] > 0 and the source
    head when cfg["w_src"] > 0 (both made after the network, so the network's initialisation
    does not depend on them)."""
    model = ParLightNet(cfg["n_lights"], tuple(cfg["input"]))
    if cfg.get("w_map", 0.0) > 0:
        model.aux_map = AuxHead((cfg["gt_map_width"] // 2, cfg["gt_map_width"], 3))
    if cfg.get("w_src", 0.0) > 0:
        model.aux_src = AuxHead((cfg["gt_map_width"] // 2, cfg["gt_map_width"]))
    return model


def to_layout(model, cfg):
    """model in the channels-last memory layout with --channels-last (else unchanged)."""
    return model.to(memory_format=torch.channels_last) if cfg.get("channels_last") else model


def device_of(cfg):
    return torch.device(cfg.get("device", "cpu"))


def net_input(u8, cfg):
    """to_input of u8 on the run's device, in channels-last layout with --channels-last."""
    x = to_input(u8.to(device_of(cfg)))
    return x.contiguous(memory_format=torch.channels_last) if cfg.get("channels_last") else x


def run_net(model, u8, cfg):
    """The network's outputs for u8 images (copied to the run's device), with "aux_map" and
    "aux_src" when the model has those auxiliary heads (under the same autocast as the
    network)."""
    dev = device_of(cfg)
    with torch.autocast(dev.type, dtype=torch.bfloat16, enabled=cfg["bf16"]):
        out = model(net_input(u8, cfg))
        if hasattr(model, "aux_map"):
            out["aux_map"] = model.aux_map(out["h"])
        if hasattr(model, "aux_src"):
            out["aux_src"] = model.aux_src(out["h"])
    return out


def load_net(model, sd):
    """Loads a checkpoint's network into model: an auxiliary head's tensors only when model has
    the head (a network trained with one loads into one without, and the other way round the
    head keeps its fresh initialisation); every other tensor must match."""
    have = model.state_dict()
    keep = {k: v for k, v in sd.items() if not k.startswith(AUX_PREFIX) or k in have}
    model.load_state_dict({**{k: v for k, v in have.items() if k.startswith(AUX_PREFIX)}, **keep})


def without_aux(sd):
    """A state dict without the auxiliary heads' tensors (what ParLightNet itself holds)."""
    return {k: v for k, v in sd.items() if not k.startswith(AUX_PREFIX)}


def map_weights(h, w):
    """[H, W, 1] solid-angle weights of an equirectangular map's rows, mean 1."""
    theta = (0.5 - (torch.arange(h, dtype=torch.float64) + 0.5) / h) * math.pi
    c = torch.cos(theta)
    return (c / c.mean()).float().view(h, 1, 1).expand(h, w, 1)


def to_input(u8):
    """u8 [B, H, W, 3] -> normalised float [B, 3, H, W] (model.preprocess, batched), on u8's
    device."""
    x = u8.permute(0, 3, 1, 2).float() / 255.0
    mean = torch.tensor(MEAN, device=u8.device).view(1, 3, 1, 1)
    std = torch.tensor(STD, device=u8.device).view(1, 3, 1, 1)
    return (x - mean) / std


def flip_batch(u8, gt, flip):
    """Mirror the images with flip[b] set and negate their lights' x (the crop camera is
    symmetric and the room-box distances are symmetric in x, so the ground truth stays exact)."""
    return torch.where(flip.to(u8.device).view(-1, 1, 1, 1), u8.flip(2), u8), flip_gt(gt, flip)


def flip_gt(gt, flip):
    flip = flip.to(gt["dir"].device)
    g = dict(gt)
    sx = torch.where(flip, -1.0, 1.0).view(-1, 1)
    g["dir"] = torch.cat([gt["dir"][..., :1] * sx.unsqueeze(-1), gt["dir"][..., 1:]], -1)
    if "map" in gt:
        # x -> -x is longitude phi -> -phi: column c -> W - 1 - c (light/equirect.c)
        g["map"] = torch.where(flip.view(-1, 1, 1, 1), gt["map"].flip(2), gt["map"])
    return g


def erase_params(n, p, gen):
    """Per image: erase?, then the rectangle's area fraction, log aspect, centre x and y."""
    r = torch.rand(n, 5, generator=gen)
    r[:, 1] = 0.05 + 0.20 * r[:, 1]
    r[:, 2] = (r[:, 2] * 2 - 1) * math.log(2.0)
    return r[:, 0] < p, r[:, 1:]


def erase_batch(u8, on, prm):
    """Random erasing on a copy of u8 [B, H, W, 3] (u8 itself is not changed): the images with
    on[b] get one rectangle (prm[b] = area fraction, log aspect, centre x, centre y in [0, 1])
    filled with their own mean colour."""
    if not bool(on.any()):
        return u8
    out = u8.clone()
    H, W = u8.shape[1], u8.shape[2]
    for b in torch.nonzero(on).flatten().tolist():
        area, logar, cx, cy = (float(v) for v in prm[b])
        ar = math.exp(logar)
        h = max(1, min(H, round(math.sqrt(area * H * W / ar))))
        w = max(1, min(W, round(math.sqrt(area * H * W * ar))))
        y0 = min(H - h, int(cy * (H - h + 1)))
        x0 = min(W - w, int(cx * (W - w + 1)))
        mean = u8[b].float().mean(dim=(0, 1)).round().to(u8.dtype)
        out[b, y0:y0 + h, x0:x0 + w] = mean
    return out


def take(gt, idx):
    return {k: v[idx] for k, v in gt.items()}


# ---- losses -----------------------------------------------------------------------------------

def radiance_tf(x, mode):
    return torch.log1p(x) if mode == "log" else x


def gt_map(gt, udirs, cfg):
    """The ground-truth lights' prefiltered SG map of step1_loss."""
    return sg.render(gt["dir"], gt["size"], gt["rgb"], udirs, mask=gt["mask"],
                     prefilter_sigma=sg.pixel_sigma(cfg["map_width"]))


def source_share(m, wts):
    """[B, H, W]: each pixel's share of radiance maps m [B, H, W, 3] in their luminous energy
    (luminance x the row's solid-angle weight wts [H, W, 1]); 1 in all per map (a black map:
    all 0)."""
    e = (m.float() @ torch.tensor(LUMA, device=m.device)) * wts[..., 0]
    return e / e.sum((1, 2), keepdim=True).clamp_min(1e-30)


def source_loss(logits, m, wts):
    """KL(source_share(m) || softmax(logits)) over each map's pixels, mean over the maps: 0 when
    the head's distribution is the energy's, and a pixel without energy adds nothing of its own."""
    p = source_share(m, wts).flatten(1)
    lq = torch.log_softmax(logits.float().flatten(1), 1)
    return (p * (torch.log(p.clamp_min(1e-30)) - lq)).sum(1).mean()


def bound_size(out, s_max):
    """out with its lights' solid angles bounded smoothly: s_max tanh(size / s_max) (about the
    size itself when small, at most s_max, a gradient everywhere)."""
    return dict(out, size=s_max * torch.tanh(out["size"].float() / s_max))


def step1_loss(out, gt, udirs, cfg, render=None, gm=None, sync=True):
    """w_r * L2(map(pred), map(gt)) + w_a * L2(ambient) (both after the radiance transform), plus
    w_d1 * diffuse_loss when --w-d1 > 0 (not in the paper), plus w_map * the auxiliary map
    head's loss when --w-map > 0, plus w_src * the source head's source_loss when --w-src > 0,
    plus w_primary * primary_loss when --w-primary > 0, plus w_rank * rank_loss when
    --w-rank > 0; every term
    sees the lights' sizes bounded by bound_size with --step1-max-size. render = (udirs, op, op
    of the crops' radiance maps or None, their rows' solid-angle weights or None); gm:
    gt_map(gt, udirs, cfg) when the caller has it already. parts: the terms as floats, or with
    sync=False as detached tensors (reading a float waits for a GPU)."""
    num = float if sync else torch.Tensor.detach
    if cfg.get("step1_max_size", 0.0) > 0:
        out = bound_size(out, cfg["step1_max_size"])
    pf = sg.pixel_sigma(cfg["map_width"])
    pm = sg.render(out["dir"].float(), out["size"].float(), out["rgb"].float(), udirs,
                   prefilter_sigma=pf)
    if gm is None:
        gm = gt_map(gt, udirs, cfg)
    lr = F.mse_loss(radiance_tf(pm, cfg["radiance"]), radiance_tf(gm, cfg["radiance"]))
    la = F.mse_loss(radiance_tf(out["ambient"].float(), cfg["radiance"]),
                    radiance_tf(gt["ambient"], cfg["radiance"]))
    total = cfg["w_r"] * lr + cfg["w_a"] * la
    parts = {"map": num(lr), "amb": num(la)}
    if cfg.get("w_d1", 0.0) > 0:
        ls = sphere_l2(pm, out["ambient"].float(), gm, gt, render, cfg)
        total = total + cfg["w_d1"] * ls
        parts["sphere"] = num(ls)
    if cfg.get("w_map", 0.0) > 0:
        lm = (((out["aux_map"].float() - torch.log1p(gt["map"])) ** 2) * render[3]).mean()
        total = total + cfg["w_map"] * lm
        parts["aux"] = num(lm)
    if cfg.get("w_src", 0.0) > 0:
        lsrc = source_loss(out["aux_src"], gt["map"], render[3])
        total = total + cfg["w_src"] * lsrc
        parts["src"] = num(lsrc)
    if cfg.get("w_primary", 0.0) > 0:
        lp = primary_loss(out, gt)
        total = total + cfg["w_primary"] * lp
        parts["primary"] = num(lp)
    if cfg.get("w_rank", 0.0) > 0:
        lk = rank_loss(out, gt)
        total = total + cfg["w_rank"] * lk
        parts["rank"] = num(lk)
    return total, parts


LUMA = (0.2126, 0.7152, 0.0722)


def light_energy(rgb, size):
    """[B, N] luminance(rgb) x SG integral of each light (light/sg.c pl_sg_integral): what
    pl_lighting_primary ranks the lights by."""
    sigma = size.clamp_min(1e-12) / (4 * math.pi)
    lum = rgb @ torch.tensor(LUMA, dtype=rgb.dtype, device=rgb.device)
    return lum * 2 * math.pi * sigma * -torch.expm1(-2 / sigma)


def gt_primary(gt):
    """Unit direction [B, 3] of each crop's primary ground-truth light and whether it has one."""
    e = light_energy(gt["rgb"], gt["size"]) * gt["mask"]
    i = e.argmax(1)
    return gt["dir"][torch.arange(len(i), device=i.device), i], gt["mask"].sum(1) > 0


def primary_loss(out, gt):
    """Direction first (not in the paper; --w-primary): the angular error of the primary light,
    the one an AR app casts shadows from. pl_lighting_primary takes the predicted light of the
    largest energy; here each predicted light's 1 - cos to the ground truth's primary is weighted
    by the softmax of the lights' log energies (a differentiable stand-in for that choice), mean
    over the crops that have a light. Under uncertainty its optimum is the mean direction of
    what the crop could be lit from, where the map's L2 rewards spreading the lights instead."""
    e = light_energy(out["rgb"].float(), out["size"].float())
    w = torch.softmax(torch.log(e.clamp_min(1e-30)), 1)
    d, has = gt_primary(gt)
    err = ((1 - (out["dir"].float() * d[:, None, :]).sum(-1)) * w).sum(1)
    return (err * has).sum() / has.sum().clamp_min(1)


def rank_loss(out, gt):
    """Which light is brighter (not in the paper; --w-rank): a pairwise ranking loss (RankNet's
    logistic loss) on the predicted lights' log energies. Each predicted light stands for the
    ground-truth light nearest it by angle (the assignment is not differentiated: the term moves
    no direction); for every pair of predicted lights standing for two different truth lights, the
    one whose truth light has the larger energy should have the larger energy too:
    softplus(log e_lo - log e_hi), mean over such pairs of the batch (0 if there are none). It
    asks for the order pl_lighting_primary reads, and nothing of the size of the gap."""
    le = torch.log(light_energy(out["rgb"].float(), out["size"].float()).clamp_min(1e-30))
    ge = light_energy(gt["rgb"], gt["size"]) * gt["mask"]
    with torch.no_grad():
        idx, _ = match(out["dir"].float(), gt)                    # [B, N] truth light of each
        e = torch.gather(ge, 1, idx)                              # its truth energy
        hi = e[:, :, None] > e[:, None, :]                        # [B, N, N]: i's truth brighter
        pair = hi & (idx[:, :, None] != idx[:, None, :])
    loss = F.softplus(le[:, None, :] - le[:, :, None])           # [b, i, j] = sp(le_j - le_i)
    n = pair.sum()
    return (loss * pair).sum() / n.clamp_min(1)


def match(pred_dir, gt):
    """Index [B, N] of the closest ground-truth light of each predicted light and whether it is
    within 45 degrees (valid [B, N])."""
    cos = torch.einsum("bnk,bmk->bnm", pred_dir, gt["dir"])
    cos = cos.masked_fill(gt["mask"][:, None, :] == 0, -2.0)
    best, idx = cos.max(-1)
    return idx, best >= COS45


def sphere_l2(pm, pamb, gm, gt, render, cfg):
    """L2 between the diffuse spheres (sg.diffuse, after the radiance transform) lit by the
    predicted and the ground-truth maps of lights pm, gm plus their ambients: the whole
    lighting's energy and its low-frequency shape, which the per-light losses of step 2 do not
    see. op's weights sum to 1 per normal, so an ambient adds itself to every sphere pixel.
    --sphere-truth map: the truth sphere is lit by the crop's real panorama (gt["map"], through
    render[2], the operator of its width) instead of the extracted lights: what `parlight eval`
    scores against, including all the light the extraction leaves out.
    --sphere-metric relative: instead, the squared difference of the linear spheres divided by
    the square of the ground-truth sphere's mean, per crop: the square of the render RMSE that
    `parlight eval` scores, relative to the truth's mean (it punishes a too-bright estimate more
    than log1p does)."""
    op = render[1]
    ps = sg.diffuse(pm, op) + pamb[:, None, :]
    if cfg.get("sphere_truth", "lights") == "map":
        gs = sg.diffuse(gt["map"], render[2])
    else:
        gs = sg.diffuse(gm, op) + gt["ambient"][:, None, :]
    if cfg.get("sphere_metric", "log") == "relative":
        scale = gs.mean(dim=(1, 2), keepdim=True).clamp_min(1e-3)
        return F.mse_loss(ps / scale, gs / scale)
    return F.mse_loss(radiance_tf(ps, cfg["radiance"]), radiance_tf(gs, cfg["radiance"]))


def diffuse_loss(out, gt, render, cfg):
    """sphere_l2 of the predicted and ground-truth lightings (rendering their maps first)."""
    udirs = render[0]
    pf = sg.pixel_sigma(cfg["map_width"])
    pm = sg.render(out["dir"].float(), out["size"].float(), out["rgb"].float(), udirs,
                   prefilter_sigma=pf)
    gm = (None if cfg.get("sphere_truth", "lights") == "map" else
          sg.render(gt["dir"], gt["size"], gt["rgb"], udirs, mask=gt["mask"], prefilter_sigma=pf))
    return sphere_l2(pm, out["ambient"].float(), gm, gt, render, cfg)


def step2_loss(out, gt, cfg, render=None):
    """Ambient L2 + sum over matched predicted lights of L2 on distance, size and colour (the
    paper's step 2, --step2-loss paper); with `render` (step1_loss) and --step2-loss render or
    both, w_d times diffuse_loss instead of (render) or beside (both) the per-light terms."""
    mode = cfg.get("step2_loss", "paper")
    ld_sphere = (cfg["w_d"] * diffuse_loss(out, gt, render, cfg)
                 if mode != "paper" else torch.zeros(()))
    if mode == "render":
        la = F.mse_loss(radiance_tf(out["ambient"], cfg["radiance"]),
                        radiance_tf(gt["ambient"], cfg["radiance"]))
        return ld_sphere + la, {"amb": float(la), "sphere": float(ld_sphere)}
    idx, valid = match(out["dir"], gt)
    v = valid.float()
    g = lambda k: torch.gather(gt[k], 1, idx) if gt[k].dim() == 2 else torch.gather(  # noqa: E731
        gt[k], 1, idx.unsqueeze(-1).expand(-1, -1, gt[k].shape[-1]))
    ld = ((out["distance"] - g("dist")) ** 2 * v).sum(1).mean()
    ls = ((out["size"] - g("size")) ** 2 * v).sum(1).mean()
    lc = (((radiance_tf(out["rgb"], cfg["radiance"]) - radiance_tf(g("rgb"), cfg["radiance"])) ** 2)
          .mean(-1) * v).sum(1).mean()
    la = F.mse_loss(radiance_tf(out["ambient"], cfg["radiance"]),
                    radiance_tf(gt["ambient"], cfg["radiance"]))
    total = la + ld + ls + lc + ld_sphere
    parts = {"amb": float(la), "dist": float(ld), "size": float(ls), "rgb": float(lc),
             "matched": float(v.mean())}
    if mode == "both":
        parts["sphere"] = float(ld_sphere)
    return total, parts


# ---- checkpoints ------------------------------------------------------------------------------

def save_ckpt(path, model, opt, state, cfg, ema=None):
    # the network's tensors in the default layout whatever --channels-last trained them in
    # (contiguous() returns a tensor already in it unchanged)
    obj = {"model": {k: v.contiguous() for k, v in model.state_dict().items()},
           "optimizer": opt.state_dict() if opt else None,
           "state": state, "config": cfg, "ema": ema.state_dict() if ema is not None else None,
           "rng": {"torch": torch.get_rng_state(), "numpy": np.random.get_state(),
                   "python": random.getstate()}}
    tmp = path + ".tmp"
    torch.save(obj, tmp)
    os.replace(tmp, path)


def load_ckpt(path):
    try:
        return torch.load(path, map_location="cpu", weights_only=False)
    except Exception as e:  # pickle / zip errors come in many types
        raise ValueError(f"{path}: cannot read checkpoint ({type(e).__name__}: {e})") from None


def export_ckpt(ckpt_path, out, force=False, provenance_extra=""):
    ck = load_ckpt(ckpt_path)
    if not isinstance(ck, dict) or "model" not in ck or "config" not in ck:
        raise ValueError(f"{ckpt_path}: not a train.py checkpoint (no model/config)")
    cfg = ck["config"]
    model = ParLightNet(cfg["n_lights"], tuple(cfg["input"])).eval()
    model.load_state_dict(without_aux(ck["model"]))
    with open(ckpt_path, "rb") as f:
        digest = hashlib.sha256(f.read()).hexdigest()
    st = ck.get("state", {})
    prov = (f"trained by tools/train/train.py: checkpoint {os.path.basename(ckpt_path)} sha256 "
            f"{digest[:16]}, step {st.get('phase')} epoch {st.get('epoch')}, data "
            f"{cfg.get('data')} (index sha256 {str(cfg.get('data_index_sha256'))[:16]}), input "
            f"{cfg['input'][0]}x{cfg['input'][1]}, torch {torch.__version__}"
            + (f" on {', then '.join(map(str, cfg['threads']))} thread(s)"
               if cfg.get("threads") else "")
            + (f", devices {', then '.join(cfg['devices'])}"
               if cfg.get("devices", ["cpu"]) != ["cpu"] else "")
            + ", exported "
            f"{datetime.datetime.now(datetime.timezone.utc):%Y-%m-%dT%H:%M:%SZ}"
            + (f", {'network' if cfg.get('init_all') else 'encoder'} initialised from "
               f"{os.path.basename(cfg['init'])}" if cfg.get("init")
               else ", from scratch (no pretrained encoder)")
            + (f", step 1 ended on its weights' moving average (decay {cfg['step1_average']:g})"
               if cfg.get("step1_average") else "")
            + provenance_extra)
    tensors = export.checked_tensors(model)
    errs = export.check_fold(model, tensors)
    if not max(errs.values()) < 1e-5:
        raise RuntimeError(f"fold check failed: {errs}")
    return plm.write_plm(out, export.metadata(model, prov), tensors, force=force)


# ---- training ---------------------------------------------------------------------------------

def threads_used(old, now):
    """Every thread count a continued run has used (old: the checkpoint's record, a list or, in
    older checkpoints, one int; now: [this run's count]): the weights depend on the count."""
    used = [old] if isinstance(old, int) else list(old or [])
    return used + now if used[-1:] != now else used


def inherit(cfg, old):
    """What a run takes from the checkpoint it continues (old: that checkpoint's config): its
    starting point, whether step 1 ended on the moving average, and every thread count and
    device used so far (the weights depend on them: reduction order)."""
    cfg["init"] = old.get("init")
    cfg["step1_average"] = old.get("step1_average", 0.0)
    cfg["threads"] = threads_used(old.get("threads"), cfg["threads"])
    cfg["devices"] = threads_used(old.get("devices", ["cpu"]), cfg["devices"])


def cpu_bf16_note(dev, bf16, cpuinfo="/proc/cpuinfo"):
    """A line saying that --bf16 will be slow, when it runs on a CPU without native bf16
    (avx512_bf16 or amx_bf16 in cpuinfo's flags), else None. Measured 2026-12-06 on an AMD EPYC
    with AVX2 only: a step-1 batch 12x slower than without --bf16 (0.26 against ~3 img/s)."""
    if not bf16 or dev.type != "cpu":
        return None
    try:
        with open(cpuinfo) as f:
            flags = next((ln.split(":", 1)[1].split() for ln in f if ln.startswith("flags")), None)
    except OSError:
        return None
    if flags is None or {"avx512_bf16", "amx_bf16"} & set(flags):
        return None
    return ("note: --bf16 on a CPU without avx512_bf16 or amx_bf16 runs emulated, about 12x "
            "slower than without it here (docs/TRAINING.md, step 4)")


def parse_device(name):
    """torch.device of --device, refused with a reason when this torch cannot use it."""
    try:
        dev = torch.device(name)
    except RuntimeError as e:
        raise ValueError(f"--device {name!r}: {e}") from None
    if dev.type == "cuda":
        if not torch.cuda.is_available():
            raise ValueError(f"--device {name}: this torch ({torch.__version__}) sees no CUDA "
                             "device (torch.cuda.is_available() is false)")
        if dev.index is not None and dev.index >= torch.cuda.device_count():
            raise ValueError(f"--device {name}: only {torch.cuda.device_count()} CUDA device(s)")
        # fixed input sizes: let cuDNN time its algorithms once per shape (a GPU run is not
        # bit-reproducible anyway; the CPU path is untouched)
        torch.backends.cudnn.benchmark = True
    elif dev.type != "cpu":
        raise ValueError(f"--device {name}: expected cpu, cuda or cuda:N")
    return dev


def lr_at(cfg, epoch):
    return cfg["lr"] * 0.5 ** (epoch // cfg["halve_every"])


def evaluate(model, imgs, gt, idx, udirs, cfg, phase, bs=32, render=None):
    if len(idx) == 0:
        return float("nan")
    model.eval()
    tot = 0.0
    with torch.no_grad():
        for i in range(0, len(idx), bs):
            j = idx[i:i + bs]
            out = {k: v.float() for k, v in run_net(model, imgs[j], cfg).items()}
            g = take(gt, j)
            loss = (step1_loss(out, g, udirs, cfg, render)[0] if phase == 1
                    else step2_loss(out, g, cfg, render)[0])
            tot += float(loss) * len(j)
    return tot / len(idx)


def ema_pairs(ema, model):
    """(average, model) tensor pairs of the two state dicts, gathered once per run: the tensors
    share storage with the modules' parameters and buffers, which train in place."""
    src = model.state_dict()
    return [(v, src[k]) for k, v in ema.state_dict().items()]


def ema_update(pairs, step, decay):
    """ema <- d * ema + (1 - d) * model for every floating-point tensor of the pairs (weights
    and batch-norm statistics), d = min(decay, (1 + step) / (10 + step)); integer buffers
    (batch counts) are copied."""
    d = min(decay, (1.0 + step) / (10.0 + step))
    with torch.no_grad():
        for v, m in pairs:
            if v.dtype.is_floating_point:
                v.mul_(d).add_(m, alpha=1.0 - d)
            else:
                v.copy_(m)


def lazy_sums(cfg):
    """Whether step 1 keeps its loss sums on the device and checks the loss for finiteness only
    at the next checkpoint or epoch end (on a GPU: no host sync per batch). The CPU checks each
    batch, as it always has; the weights are the same either way."""
    return device_of(cfg).type != "cpu"


def flush_sums(sums, pend, ep, b):
    """Adds the device-side sums of the batches since the last flush (train_step1's `pend`) to
    `sums`; refuses (RuntimeError, nothing saved) when a loss among them was not finite."""
    if not pend:
        return
    if not bool(pend["ok"]):
        raise RuntimeError(f"step 1 epoch {ep} batches {pend['from']}-{b}: a loss was not finite")
    for key, v in pend.items():
        if key not in ("ok", "from", "n"):
            sums[key] = sums.get(key, 0.0) + float(v)
    sums["n"] += pend["n"]
    pend.clear()


def train_step1(model, opt, imgs, gt, tr, va, udirs, cfg, state, paths, render=None, ema=None):
    n_batches = len(tr) // cfg["batch"]
    lazy = lazy_sums(cfg)
    if n_batches == 0:
        raise ValueError(f"{len(tr)} training crops: fewer than one batch of {cfg['batch']}")
    last_save = time.time()
    pairs = ema_pairs(ema, model) if ema is not None else None
    while state["epoch"] < cfg["step1_epochs"]:
        ep = state["epoch"]
        for grp in opt.param_groups:
            grp["lr"] = lr_at(cfg, ep)
        gen = torch.Generator().manual_seed(cfg["seed"] * 100003 + ep)
        perm = tr[torch.randperm(len(tr), generator=gen)]
        flips = torch.rand(len(tr), generator=gen) < 0.5
        if cfg.get("erase", 0.0) > 0:
            erase_on, erase_prm = erase_params(len(tr), cfg["erase"], gen)
        model.train()
        model.z_dropout = cfg.get("z_dropout", 0.0)
        t0, seen, resumed_at = time.time(), 0, state["batch"]
        sums = state.setdefault("sums", {"loss": 0.0, "map": 0.0, "amb": 0.0, "n": 0})
        pend = {}       # lazy: the batches' terms since the last flush_sums, on the device
        for b in range(state["batch"], n_batches):
            j = perm[b * cfg["batch"]:(b + 1) * cfg["batch"]]
            sl = slice(b * cfg["batch"], (b + 1) * cfg["batch"])
            u8, g = flip_batch(imgs[j], take(gt, j), flips[sl])
            if cfg.get("erase", 0.0) > 0:
                u8 = erase_batch(u8, erase_on[sl], erase_prm[sl])
            if model.z_dropout > 0:
                torch.manual_seed((cfg["seed"] * 100003 + ep) * 100003 + b)
            out = run_net(model, u8, cfg)
            loss, parts = step1_loss(out, g, udirs, cfg, render, sync=not lazy)
            if not lazy and not torch.isfinite(loss):
                raise RuntimeError(f"step 1 epoch {ep} batch {b}: loss is {float(loss)}")
            opt.zero_grad(set_to_none=True)
            loss.backward()
            opt.step()
            if ema is not None:
                ema_update(pairs, state.get("steps", 0), cfg["ema"])
            if lazy:
                ok = torch.isfinite(loss.detach())
                pend["ok"] = pend["ok"] & ok if "ok" in pend else ok
                pend.setdefault("from", b)
                for key, v in [("loss", loss.detach())] + list(parts.items()):
                    pend[key] = pend[key] + v.double() if key in pend else v.double()
                pend["n"] = pend.get("n", 0) + 1
            else:
                sums["loss"] += float(loss)
                sums["map"] += parts["map"]
                sums["amb"] += parts["amb"]
                for key in ("sphere", "aux", "src", "primary"):
                    if key in parts:
                        sums[key] = sums.get(key, 0.0) + parts[key]
                sums["n"] += 1
            seen += len(j)
            state["batch"] = b + 1
            state["steps"] = state.get("steps", 0) + 1
            if cfg["max_steps"] and state["steps"] >= cfg["max_steps"]:
                flush_sums(sums, pend, ep, b)
                save_ckpt(paths["last"], model, opt, state, cfg, ema)
                log_line(paths["log"], f"step1 epoch {ep} batch {b + 1}/{n_batches}: stopped at "
                         f"--max-steps {cfg['max_steps']}, loss {float(loss):.6g}")
                return False
            if time.time() - last_save > 60 * cfg["ckpt_minutes"]:
                flush_sums(sums, pend, ep, b)
                save_ckpt(paths["last"], model, opt, state, cfg, ema)
                last_save = time.time()
                log_line(paths["log"], f"step1 epoch {ep + 1} batch {b + 1}/{n_batches}: "
                         f"checkpoint; mean loss so far {sums['loss'] / sums['n']:.6g}, "
                         f"{seen / max(time.time() - t0, 1e-9):.2f} img/s")
        flush_sums(sums, pend, ep, n_batches - 1)
        dt = time.time() - t0
        n = max(sums["n"], 1)
        vl = evaluate(model, imgs, gt, va, udirs, cfg, 1, render=render)
        vl_ema = (f" (average {evaluate(ema, imgs, gt, va, udirs, cfg, 1, render=render):.6g})"
                  if ema is not None else "")
        log_line(paths["log"], f"step1 epoch {ep + 1}/{cfg['step1_epochs']} lr {lr_at(cfg, ep):.3g} "
                 f"loss {sums['loss'] / n:.6g} (map {sums['map'] / n:.6g} amb {sums['amb'] / n:.6g}"
                 + (f" sphere {sums['sphere'] / n:.6g}" if "sphere" in sums else "")
                 + (f" aux {sums['aux'] / n:.6g}" if "aux" in sums else "")
                 + (f" src {sums['src'] / n:.6g}" if "src" in sums else "")
                 + (f" primary {sums['primary'] / n:.6g}" if "primary" in sums else "") + ") "
                 f"val {vl:.6g}{vl_ema} | {seen / max(dt, 1e-9):.2f} img/s, {dt:.0f} s"
                 + (" (resumed epoch: rate over its last part)" if resumed_at else ""))
        state.update(epoch=ep + 1, batch=0)
        state.pop("sums", None)
        save_ckpt(paths["last"], model, opt, state, cfg, ema)
        last_save = time.time()
    if ema is not None:
        # the run's own last weights, then the average takes their place for step 2
        save_ckpt(paths["step1_raw"], model, opt, state, cfg)
        model.load_state_dict(ema.state_dict())
        cfg["step1_average"] = cfg["ema"]   # what the network now is (provenance)
    save_ckpt(paths["step1"], model, opt, state, cfg)
    return True


STEP2_HEADS = ("head_size", "head_rgb", "head_ambient", "head_dist")


def step2_features(model, imgs, idx, cfg, bs=32):
    """z, h and directions of each crop in idx, unflipped and flipped (frozen network);
    None for no crops."""
    if len(idx) == 0:
        return None
    model.eval()
    feats = {f: {"z": [], "h": [], "dir": []} for f in (0, 1)}
    with torch.no_grad():
        for i in range(0, len(idx), bs):
            j = idx[i:i + bs]
            for f in (0, 1):
                u8 = (imgs[j].flip(2) if f else imgs[j]).to(device_of(cfg))
                with torch.autocast(u8.device.type, dtype=torch.bfloat16, enabled=cfg["bf16"]):
                    z = model.latent(net_input(u8, cfg))
                z = z.float()
                h = F.relu(model.fc(z))
                d = F.normalize(model.head_dir(h).view(-1, model.n_lights, 3), dim=-1)
                feats[f]["z"].append(z)
                feats[f]["h"].append(h)
                feats[f]["dir"].append(d)
    return {f: {k: torch.cat(v) for k, v in d.items()} for f, d in feats.items()}


def heads(model, z, h, d):
    n = model.n_lights
    return {"dir": d, "distance": model.head_dist(z, d),
            "size": F.softplus(model.head_size(h)),
            "rgb": F.softplus(model.head_rgb(h)).view(-1, n, 3),
            "ambient": F.softplus(model.head_ambient(h))}


def train_step2(model, imgs, gt, tr, va, cfg, state, paths, resume_opt=None, render=None):
    if state["epoch"] >= cfg["step2_epochs"]:
        return      # nothing to train (e.g. --step2-epochs 0): skip the frozen features
    params = [p for name in STEP2_HEADS for p in getattr(model, name).parameters()]
    for p in model.parameters():
        p.requires_grad_(False)
    for p in params:
        p.requires_grad_(True)
    opt = torch.optim.Adam(params, lr=cfg["lr"], betas=(0.9, 0.999))
    if resume_opt:
        opt.load_state_dict(resume_opt)
    t0 = time.time()
    ftr = step2_features(model, imgs, tr, cfg)
    fva = step2_features(model, imgs, va, cfg)
    log_line(paths["log"], f"step2: features of {len(tr)} + {len(va)} crops (x2 flips) in "
             f"{time.time() - t0:.0f} s")
    gtr, gva = take(gt, tr), take(gt, va)
    bs = cfg["batch"]
    while state["epoch"] < cfg["step2_epochs"]:
        ep = state["epoch"]
        for grp in opt.param_groups:
            grp["lr"] = lr_at(cfg, ep)
        gen = torch.Generator().manual_seed(cfg["seed"] * 100003 + 50000 + ep)
        perm = torch.randperm(len(tr), generator=gen)
        flips = torch.rand(len(tr), generator=gen) < 0.5
        sums, n = {}, 0
        for b in range(0, len(tr) - bs + 1, bs):
            j = perm[b:b + bs]
            fl = flips[b:b + bs].to(device_of(cfg))
            sel = lambda k: torch.where(fl.view(-1, *[1] * (ftr[0][k].dim() - 1)),  # noqa: E731
                                        ftr[1][k][j], ftr[0][k][j])
            g = flip_gt(take(gtr, j), fl)
            out = heads(model, sel("z"), sel("h"), sel("dir"))
            loss, parts = step2_loss(out, g, cfg, render)
            opt.zero_grad(set_to_none=True)
            loss.backward()
            opt.step()
            for k, v in [("loss", float(loss))] + list(parts.items()):
                sums[k] = sums.get(k, 0.0) + v
            n += 1
        with torch.no_grad():
            vl = float(step2_loss(heads(model, fva[0]["z"], fva[0]["h"], fva[0]["dir"]), gva,
                                  cfg, render)[0]) if fva is not None else float("nan")
        n = max(n, 1)
        log_line(paths["log"], f"step2 epoch {ep + 1}/{cfg['step2_epochs']} lr {lr_at(cfg, ep):.3g} "
                 + " ".join(f"{k} {v / n:.6g}" for k, v in sums.items()) + f" val {vl:.6g}")
        state.update(epoch=ep + 1)
        save_ckpt(paths["last"], model, opt, state, cfg)


def parse_hw(text):
    return export.parse_hw(text)


def main(argv=None):
    ap = argparse.ArgumentParser(description="Two-step training of ParLightNet (paper sec. 3.3) "
                                 "with checkpoints and automatic resume.")
    ap.add_argument("--data", default="/work/cache/train-data")
    ap.add_argument("--ckpt-dir", default="/work/cache/train-ckpt")
    ap.add_argument("--log", default="/work/cache/train-log.txt")
    ap.add_argument("--input", type=parse_hw, default=(96, 128), metavar="HxW")
    ap.add_argument("--n-lights", type=int, default=3, choices=(2, 3, 5))
    ap.add_argument("--batch", type=int, default=16)
    ap.add_argument("--lr", type=float, default=1e-3)
    ap.add_argument("--halve-every", type=int, default=25, metavar="EPOCHS")
    ap.add_argument("--step1-epochs", type=int, default=60)
    ap.add_argument("--step2-epochs", type=int, default=50)
    ap.add_argument("--map-width", type=int, default=64, help="SG map width for the step-1 loss")
    ap.add_argument("--radiance", choices=("log", "linear"), default="log")
    ap.add_argument("--w-r", type=float, default=20.0)
    ap.add_argument("--w-a", type=float, default=1.0)
    ap.add_argument("--step2-loss", choices=("paper", "render", "both"), default="paper",
                    help="step 2's loss: the paper's per-light terms, the diffuse-sphere render "
                    "term (w_d) with the ambient term, or both")
    ap.add_argument("--w-d", type=float, default=1.0, help="weight of step 2's diffuse-sphere "
                    "term")
    ap.add_argument("--w-d1", type=float, default=0.0, help="weight of a diffuse-sphere term "
                    "added to step 1's loss (0: the paper's step 1)")
    ap.add_argument("--step2-from", metavar="CKPT", help="skip step 1: start step 2 from this "
                    "checkpoint's network (a step1.pt of the same data and input size)")
    ap.add_argument("--val-panos", type=int, default=4)
    ap.add_argument("--sphere-metric", choices=("log", "relative"), default="log",
                    help="the diffuse-sphere terms' error: L2 after log1p, or the squared "
                         "relative error of the linear spheres (per crop, over the truth's mean)")
    ap.add_argument("--train-scenes", choices=("all", "indoor"), default="all",
                    help="train on crops of all panoramas, or of the indoor (and indoor-semi) "
                         "ones only; validation keeps its held-out panoramas of both kinds")
    ap.add_argument("--z-dropout", type=float, default=0.0, metavar="P",
                    help="step 1: dropout on z before the fc and the distance head")
    ap.add_argument("--erase", type=float, default=0.0, metavar="P",
                    help="step 1: random erasing of one rectangle per image with probability P")
    ap.add_argument("--ema", type=float, default=0.0, metavar="D",
                    help="step 1: keep an exponential moving average of the weights with decay D "
                         "(e.g. 0.999) and end step 1 on it (0: off)")
    ap.add_argument("--w-map", type=float, default=0.0, metavar="W",
                    help="step 1: weight of an auxiliary head (training only, not exported) "
                    "regressing the crop's radiance map after log1p from the 512-d vector "
                    "(needs a dataset made with make_dataset.py --gt-map; 0: off)")
    ap.add_argument("--w-primary", type=float, default=0.0, metavar="W",
                    help="weight of the primary light's angular loss in step 1 (primary_loss)")
    ap.add_argument("--w-rank", type=float, default=0.0, metavar="W",
                    help="weight of the lights' pairwise brightness-order loss in step 1 "
                         "(rank_loss)")
    ap.add_argument("--step1-max-size", type=float, default=0.0, metavar="SR",
                    help="step 1: bound the lights' solid angles the losses see by SR steradians "
                    "(SR tanh(size / SR); 0: off)")
    ap.add_argument("--w-src", type=float, default=0.0, metavar="W",
                    help="step 1: weight of an auxiliary head (training only, not exported) "
                    "giving a distribution over the radiance map's pixels, trained towards each "
                    "pixel's share of the panorama's light energy (needs make_dataset.py "
                    "--gt-map; 0: off)")
    ap.add_argument("--sphere-truth", choices=("lights", "map"), default="lights",
                    help="the diffuse-sphere terms' truth: the sphere lit by the extracted lights "
                    "and ambient, or by the crop's real panorama (--gt-map datasets)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--bf16", action="store_true", help="bf16 autocast for the network")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--device", default="cpu", help="cpu (default), cuda or cuda:N")
    ap.add_argument("--channels-last", action="store_true", help="run the network in the "
                    "channels-last memory layout (cuDNN's own for bf16 convolutions on a GPU; "
                    "the weights differ from the default layout's by rounding)")
    ap.add_argument("--stream", action="store_true", help="decode the crops from their files at "
                    "each use instead of holding them all in memory (same results)")
    ap.add_argument("--ckpt-minutes", type=float, default=5.0)
    ap.add_argument("--max-steps", type=int, default=0, help="stop after this many step-1 "
                    "batches in total (tests, sanity checks)")
    ap.add_argument("--limit", type=int, default=0, help="only the first N crops of the index")
    ap.add_argument("--init", metavar="CKPT", help="start step 1 from the encoder (features.*) "
                    "of this checkpoint, e.g. tools/train/distill.py's (ignored on resume)")
    ap.add_argument("--init-all", action="store_true", help="with --init: start from the whole "
                    "network of CKPT (a train.py checkpoint: heads too), e.g. to go on training a "
                    "finished run on new data")
    ap.add_argument("--export", metavar="OUT.plm", help="export the final model here")
    ap.add_argument("--export-only", nargs=2, metavar=("CKPT", "OUT.plm"))
    ap.add_argument("--force", action="store_true", help="replace an existing export")
    args = ap.parse_args(argv)
    torch.set_num_threads(max(1, args.threads))
    torch.set_flush_denormal(True)   # denormals made some CPU steps 20x slower (measured)

    try:
        if args.export_only:
            ck, out = args.export_only
            if os.path.lexists(out) and not args.force:
                raise ValueError(f"{out} exists; not replacing it (use --force)")
            size = export_ckpt(ck, out, force=args.force)
            print(f"wrote {out}: {size:,} bytes")
            return 0
        for name, v, lo in (("--batch", args.batch, 1), ("--halve-every", args.halve_every, 1),
                            ("--step1-epochs", args.step1_epochs, 0),
                            ("--step2-epochs", args.step2_epochs, 0), ("--val-panos", args.val_panos, 0),
                            ("--map-width", args.map_width, 8)):
            if v < lo:
                raise ValueError(f"{name} {v}: expected >= {lo}")
        if args.init_all and not args.init:
            raise ValueError("--init-all: needs --init CKPT")
        if args.step2_from and args.init:
            raise ValueError("--step2-from and --init: give one starting point")
        for name, v in (("--z-dropout", args.z_dropout), ("--erase", args.erase)):
            if not 0.0 <= v < 1.0:
                raise ValueError(f"{name} {v}: expected a probability in [0, 1)")
        if not 0.0 <= args.ema < 1.0:
            raise ValueError(f"--ema {args.ema}: expected a decay in [0, 1)")
        for name, v in (("--w-map", args.w_map), ("--w-primary", args.w_primary),
                        ("--w-src", args.w_src), ("--w-rank", args.w_rank)):
            if not (0.0 <= v and math.isfinite(v)):
                raise ValueError(f"{name} {v}: expected a weight >= 0")
        if not (0.0 <= args.step1_max_size <= 4 * math.pi):
            raise ValueError(f"--step1-max-size {args.step1_max_size}: expected steradians in "
                             "[0, 4 pi] (0: off)")
        need_map = args.w_map > 0 or args.w_src > 0 or args.sphere_truth == "map"
        if args.map_width % 2:
            raise ValueError(f"--map-width {args.map_width}: expected an even number")
        if not (args.lr > 0 and math.isfinite(args.lr)):
            raise ValueError(f"--lr {args.lr}: expected a positive number")
        if args.export and os.path.lexists(args.export) and not args.force:
            raise ValueError(f"{args.export} exists; not replacing it (use --force)")
        os.makedirs(args.ckpt_dir, exist_ok=True)
        paths = {"last": os.path.join(args.ckpt_dir, "last.pt"),
                 "step1": os.path.join(args.ckpt_dir, "step1.pt"),
                 "step1_raw": os.path.join(args.ckpt_dir, "step1_raw.pt"),
                 "final": os.path.join(args.ckpt_dir, "final.pt"), "log": args.log}

        t0 = time.time()
        dev = parse_device(args.device)
        note = cpu_bf16_note(dev, args.bf16)
        if note:
            print(note, file=sys.stderr)
        imgs, gt, val, held, digest = load_dataset(args.data, args.input, args.val_panos,
                                                   args.limit, need_map, args.stream)
        gt = {k: v.to(dev) for k, v in gt.items()}
        keep = ~val
        if args.train_scenes == "indoor":
            keep &= ~crop_outdoor(args.data, args.limit)
        tr = torch.nonzero(keep).flatten()
        va = torch.nonzero(val).flatten()
        if len(tr) == 0:
            raise ValueError(f"{args.data}: no training crops of scenes '{args.train_scenes}'")
        cfg = {"data": os.path.abspath(args.data), "data_index_sha256": digest,
               "input": list(args.input), "n_lights": args.n_lights, "batch": args.batch,
               "lr": args.lr, "halve_every": args.halve_every, "seed": args.seed,
               "step1_epochs": args.step1_epochs, "step2_epochs": args.step2_epochs,
               "map_width": args.map_width, "radiance": args.radiance, "w_r": args.w_r,
               "w_a": args.w_a, "val_panos": args.val_panos, "held_out": held,
               "step2_loss": args.step2_loss, "w_d": args.w_d, "w_d1": args.w_d1,
               "train_scenes": args.train_scenes, "sphere_metric": args.sphere_metric,
               "z_dropout": args.z_dropout, "erase": args.erase, "ema": args.ema, "bf16": args.bf16,
               "w_map": args.w_map, "sphere_truth": args.sphere_truth,
               "w_primary": args.w_primary, "step1_max_size": args.step1_max_size,
               "w_src": args.w_src, "w_rank": args.w_rank,
               "gt_map_width": int(gt["map"].shape[2]) if need_map else 0,
               "max_steps": args.max_steps, "ckpt_minutes": args.ckpt_minutes,
               "threads": [max(1, args.threads)], "device": args.device,
               "channels_last": bool(args.channels_last),
               "devices": [args.device],
               "limit": args.limit, "torch": torch.__version__,
               "init": os.path.abspath(args.init) if args.init else None,
               "init_all": bool(args.init and args.init_all)}
        udirs = sg.equirect_dirs(args.map_width)
        udirs = udirs.to(dev)
        render = (udirs, sg.diffuse_operator(args.map_width, sg.sphere_normals(16)).to(dev),
                  sg.diffuse_operator(cfg["gt_map_width"], sg.sphere_normals(16)).to(dev)
                  if need_map else None,
                  map_weights(cfg["gt_map_width"] // 2, cfg["gt_map_width"]).to(dev)
                  if need_map else None)

        if dev.type == "cuda" and imgs.to_device(
                dev, torch.cuda.get_device_properties(dev).total_memory // 4):
            log_line(args.log, f"the crops on {dev} ({imgs.arr.numel() / 2**20:.0f} MiB)")
        torch.manual_seed(args.seed)
        model = to_layout(make_model(cfg).to(dev), cfg)
        opt = torch.optim.Adam(model.parameters(), lr=args.lr, betas=(0.9, 0.999))
        state = {"phase": 1, "epoch": 0, "batch": 0, "steps": 0}
        step2_opt = None
        ema_resume = None
        if os.path.exists(paths["last"]):
            ck = load_ckpt(paths["last"])
            old = ck.get("config", {})
            diff = [k for k in RESUME_KEYS if old.get(k, RESUME_DEFAULTS.get(k)) != cfg.get(k)]
            if diff:
                raise ValueError(f"{paths['last']}: made with another configuration ({', '.join(diff)} "
                                 f"differ); use another --ckpt-dir")
            inherit(cfg, old)               # whatever --init says now
            cfg["init_all"] = old.get("init_all", False)
            model.load_state_dict(ck["model"])
            state = ck["state"]
            ema_resume = ck.get("ema")
            if state["phase"] == 1:
                opt.load_state_dict(ck["optimizer"])
            else:
                step2_opt = ck["optimizer"]
            torch.set_rng_state(ck["rng"]["torch"])
            np.random.set_state(ck["rng"]["numpy"])
            random.setstate(ck["rng"]["python"])
            log_line(args.log, f"resumed {paths['last']}: step {state['phase']} epoch "
                     f"{state['epoch']} batch {state['batch']}")
        elif args.step2_from:
            ck = load_ckpt(args.step2_from)
            old = ck.get("config", {}) if isinstance(ck, dict) else {}
            if "model" not in ck or old.get("input") != cfg["input"] or \
                    old.get("n_lights") != cfg["n_lights"]:
                raise ValueError(f"{args.step2_from}: not a train.py checkpoint of input "
                                 f"{cfg['input']} with {cfg['n_lights']} lights")
            load_net(model, ck["model"])
            inherit(cfg, old)
            cfg["step2_from"] = os.path.abspath(args.step2_from)
            state = {"phase": 2, "epoch": 0, "batch": 0, "steps": 0}
            log_line(args.log, f"start step 2 from {args.step2_from} (its step 1: "
                     f"{ck.get('state')}), config "
                     f"{json.dumps({k: v for k, v in cfg.items() if k != 'held_out'})}")
        else:
            if args.init:
                ck = load_ckpt(args.init)
                sd = ck.get("model") if isinstance(ck, dict) else None
                if args.init_all:
                    try:
                        load_net(model, sd or {})
                    except RuntimeError as e:
                        raise ValueError(f"{args.init}: not a network of this configuration "
                                         f"({str(e).splitlines()[0]})") from None
                else:
                    feats = {k[len("features."):]: v for k, v in (sd or {}).items()
                             if k.startswith("features.")}
                    if not feats:
                        raise ValueError(f"{args.init}: no features.* tensors in its 'model'")
                    model.features.load_state_dict(feats)
            log_line(args.log, f"start: {len(tr)} train + {len(va)} val crops (held out {held}), "
                     f"config {json.dumps({k: v for k, v in cfg.items() if k != 'held_out'})}")
        log_line(args.log, f"loaded {len(imgs)} crops in {time.time() - t0:.0f} s")

        if state["phase"] == 1:
            ema = None
            if args.ema > 0:
                ema = to_layout(make_model(cfg).to(dev), cfg).eval()
                ema.load_state_dict(ema_resume if ema_resume is not None else model.state_dict())
            if not train_step1(model, opt, imgs, gt, tr, va, udirs, cfg, state, paths, render,
                               ema):
                return 0
            state = {"phase": 2, "epoch": 0, "batch": 0, "steps": state.get("steps", 0)}
            save_ckpt(paths["last"], model, None, state, cfg)
        train_step2(model, imgs, gt, tr, va, cfg, state, paths, step2_opt, render)
        save_ckpt(paths["final"], model, None, state, cfg)
        log_line(args.log, f"done: {paths['final']}")
        if args.export:
            size = export_ckpt(paths["final"], args.export, force=args.force)
            log_line(args.log, f"exported {args.export} ({size:,} bytes)")
    except (OSError, ValueError, RuntimeError, plm.PlmError) as e:
        print(f"train: {e}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
