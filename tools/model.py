#!/usr/bin/python3
"""ParLightNet: the PyTorch definition of parlight's network, the single Python source of truth.

A port of "Deep Parametric Indoor Lighting Estimation" (Gardner et al., ICCV 2019): one LDR frame
in, N parametric lights (direction, distance, solid angle, RGB) plus an RGB ambient term out.
The C executor (model/) implements exactly this graph on the tensors tools/export.py writes
(docs/FORMAT.md); tests/test_golden.sh compares the two on the same weights and frames.

Graph, for an input x of shape [B, 3, H, W] (RGB, normalised by `preprocess`; default H x W =
192 x 256, both multiples of 32):

    f   = relu(densenet121.features(x))          [B, 1024, H/32, W/32]   (1024 x 6 x 8 by default)
          conv0 7x7/2 pad 3, norm0, relu0, pool0 (3x3/2 max, pad 1), then dense blocks of 6, 12,
          24, 16 layers (each: norm1 -> relu -> conv1 1x1 to 128 -> norm2 -> relu -> conv2 3x3 to
          32, concatenated onto its input), transitions 1..3 after blocks 1..3 (norm -> relu ->
          1x1 conv halving the channels -> 2x2/2 average pool), norm5; all BN eps 1e-5.
    z   = adaptive_avg_pool2d(f, (3, 1)).flatten(1)   [B, 3072]
          three horizontal bands; z[c*3 + band] (channel-major). Band i averages rows
          floor(i*h/3) .. ceil((i+1)*h/3)-1 of the h = H/32 rows and all columns (PyTorch's
          adaptive pooling: for h = 6 that is rows 2i, 2i+1; bins overlap when 3 does not divide h).
    h   = relu(fc(z))                                 fc: 3072 -> 512
    dir      = normalize(head_dir(h).view(B, N, 3), dim=-1)     unit vectors, camera frame
    size     = softplus(head_size(h))                 [B, N]     solid angle, steradians
    rgb      = softplus(head_rgb(h)).view(B, N, 3)    [B, N, 3]  linear RGB (lobe peak radiance)
    ambient  = softplus(head_ambient(h))              [B, 3]     linear RGB
    distance = softplus(head_dist.fc2(relu(head_dist.fc1(cat([z, dir.flatten(1)], 1)))))
                                                      [B, N]     metres; fc1: 3072+3N -> 64,
                                                      fc2: 64 -> N ("conditioned on z and the
                                                      predicted directions", as in the paper)

softplus is PyTorch's default (beta 1, threshold 20: x itself above 20); normalize divides by
max(||v||, 1e-12). About 8.7 M parameters for N = 3 (the DenseNet-121 features are 6.95 M).

Run this file to print the parameter counts and check the output shapes.
"""

import numpy as np
import torch
import torch.nn as nn
import torch.nn.functional as F
import torchvision

# ImageNet statistics of RGB in [0, 1]; written into every .plm file as `mean` and `std`.
MEAN = (0.485, 0.456, 0.406)
STD = (0.229, 0.224, 0.225)
BANDS = 3
FC = 512
LATENT = 1024 * BANDS
N_LIGHTS_ALLOWED = (2, 3, 5)


class DistanceHead(nn.Module):
    """Distance of each light from [z, directions]: fc1 -> ReLU -> fc2 -> softplus (metres)."""

    def __init__(self, n_lights, hidden):
        super().__init__()
        self.fc1 = nn.Linear(LATENT + 3 * n_lights, hidden)
        self.fc2 = nn.Linear(hidden, n_lights)

    def forward(self, z, dirs):
        return F.softplus(self.fc2(F.relu(self.fc1(torch.cat([z, dirs.flatten(1)], 1)))))


class ParLightNet(nn.Module):
    """DenseNet-121 features -> 3-band latent z (3072) -> FC 512 -> parametric light heads."""

    def __init__(self, n_lights=3, input_hw=(192, 256), dist_hidden=64):
        super().__init__()
        if n_lights not in N_LIGHTS_ALLOWED:
            raise ValueError(f"n_lights must be one of {N_LIGHTS_ALLOWED}, got {n_lights}")
        h, w = input_hw
        if h % 32 or w % 32 or not (64 <= h <= 1024 and 64 <= w <= 1024):
            raise ValueError(f"input must be multiples of 32 in 64..1024, got {h}x{w}")
        self.n_lights = n_lights
        self.input_hw = (h, w)
        self.dist_hidden = dist_hidden
        self.features = torchvision.models.densenet121(weights=None).features
        self.fc = nn.Linear(LATENT, FC)
        self.head_dir = nn.Linear(FC, 3 * n_lights)
        self.head_size = nn.Linear(FC, n_lights)
        self.head_rgb = nn.Linear(FC, 3 * n_lights)
        self.head_ambient = nn.Linear(FC, 3)
        self.head_dist = DistanceHead(n_lights, dist_hidden)
        # training only (tools/train/train.py --z-dropout): dropout on z before the fc and the
        # distance head; no-op in eval mode, so exports and the C graph do not change
        self.z_dropout = 0.0

    def latent(self, x):
        """z [B, 3072], channel-major (index c*3 + band)."""
        f = F.relu(self.features(x))
        return F.adaptive_avg_pool2d(f, (BANDS, 1)).flatten(1)

    def forward(self, x):
        n = self.n_lights
        z = self.latent(x)
        zd = F.dropout(z, self.z_dropout, self.training) if self.z_dropout > 0 else z
        h = F.relu(self.fc(zd))
        dirs = F.normalize(self.head_dir(h).view(-1, n, 3), dim=-1)
        return {
            "z": z,
            "h": h,   # the 512-d vector the heads read (train.py's auxiliary map head reads it too)
            "dir": dirs,
            "distance": self.head_dist(zd, dirs),
            "size": F.softplus(self.head_size(h)),
            "rgb": F.softplus(self.head_rgb(h)).view(-1, n, 3),
            "ambient": F.softplus(self.head_ambient(h)),
        }


def preprocess(img, dtype=torch.float32):
    """RGB u8 image [H, W, 3] (numpy array or tensor) -> normalised tensor [1, 3, H, W].

    x / 255, then (x - mean) / std per channel with ImageNet statistics. No resize: the caller
    hands over an image of the model's input size."""
    t = img if torch.is_tensor(img) else torch.from_numpy(np.array(img))
    if t.dtype != torch.uint8 or t.dim() != 3 or t.shape[2] != 3:
        raise ValueError(f"expected a u8 H x W x 3 RGB image, got {tuple(t.shape)} {t.dtype}")
    x = t.permute(2, 0, 1).unsqueeze(0).to(dtype) / 255.0
    mean = torch.tensor(MEAN, dtype=dtype).view(1, 3, 1, 1)
    std = torch.tensor(STD, dtype=dtype).view(1, 3, 1, 1)
    return (x - mean) / std


def count_parameters(model):
    return sum(p.numel() for p in model.parameters())


if __name__ == "__main__":
    for n in N_LIGHTS_ALLOWED:
        m = ParLightNet(n).eval()
        feats = count_parameters(m.features)
        print(f"N={n}: {count_parameters(m):,} parameters ({feats:,} in the DenseNet-121 features)")
        with torch.no_grad():
            out = m(preprocess(torch.zeros(192, 256, 3, dtype=torch.uint8)))
        shapes = {k: tuple(v.shape) for k, v in out.items()}
        expect = {"z": (1, LATENT), "dir": (1, n, 3), "distance": (1, n), "size": (1, n),
                  "rgb": (1, n, 3), "ambient": (1, 3)}
        assert shapes == expect, shapes
        assert all(torch.isfinite(v).all() for v in out.values())
    print("ok")
