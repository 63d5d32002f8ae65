#!/usr/bin/python3
"""Feature distillation: teach the DenseNet-121 encoder ImageNet features from the shared
MobileNetV2 (uint8 TFLite, run by tools/train/tflite_teacher.py), before step 1 of train.py.

    tools/train/distill.py [--data /work/cache/train-data] [--out /work/cache/distill/encoder.pt]
                           [--input 96x128] [--epochs 20] [--batch 16] [--lr 1e-3] [--bf16]
                           [--threads 1] [--val-panos 4] [--max-steps N] [--limit N]
    then: tools/train/train.py --init /work/cache/distill/encoder.pt ...

Teacher: MobileNetV2's last feature map (1280 channels, the input of its average pool), computed
on the stored crops at their own resolution (256x192 -> 6x8 cells), average-pooled 2x2 to the
student's 3x4 grid at 96x128, for each crop and its mirror image, once (cached next to --out),
then standardised per channel over the training crops. Student: relu(densenet121.features(x))
(ParLightNet.latent's map) -> 1x1 conv 1024 -> 1280 (trained with it, then dropped) -> L2 to the
standardised teacher map. The crops of train.py's held-out panoramas (same --val-panos rule) are
left out, and their distillation loss is logged as validation. Checkpoint every epoch (resumes
by rerunning, with a larger --epochs to continue; another seed, input, teacher, batch, lr, bf16
or dataset into the same --out is refused); the checkpoint's "model" is a whole ParLightNet
state_dict (heads at their initialisation) that train.py --init reads the encoder from. On the
CPU a run is repeatable for a given --threads; the counts used are recorded in the checkpoint.
--device cuda and --stream as in train.py (the student trains on the device; the teacher maps are
computed once on the CPU and cached; --device cpu is bit-identical to runs before the option).
"""

import argparse
import datetime
import os
import sys
import time

import numpy as np
import torch
import torch.nn.functional as F
from PIL import Image

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.dirname(HERE))
import plm  # noqa: E402
import tflite_teacher  # noqa: E402
import train  # noqa: E402
from model import ParLightNet  # noqa: E402


# what a resumed run must share with the checkpoint it continues (keys an older checkpoint lacks
# are not compared); --epochs may grow, and the thread count is recorded, not compared
RESUME_KEYS = ("input", "teacher_sha256", "seed", "bf16", "batch", "lr", "data_index_sha256",
               "held_out")


def teacher_maps(teacher, data, idx_rows, grid):
    """[M, 2, 1280, gh, gw] teacher maps of the stored crops (unflipped, flipped)."""
    pool = [o for o in teacher.ops if o["op"] == "AVERAGE_POOL_2D"][0]["in"][0]
    out = []
    with torch.no_grad():
        for png in idx_rows:
            with Image.open(os.path.join(data, png)) as im:
                u8 = np.asarray(im.convert("RGB"))
            x = (torch.from_numpy(u8.copy()).permute(2, 0, 1)[None].float() - 128.0) / 128.0
            x = torch.cat([x, x.flip(3)])
            m = teacher.run(x, keep=(pool,))[pool]
            out.append(F.adaptive_avg_pool2d(m, grid))
    return torch.stack(out)


def main(argv=None):
    ap = argparse.ArgumentParser(description="Distil MobileNetV2 (TFLite) features into the "
                                 "DenseNet-121 encoder.")
    ap.add_argument("--data", default="/work/cache/train-data")
    ap.add_argument("--out", default="/work/cache/distill/encoder.pt")
    ap.add_argument("--teacher", default=os.path.join(tflite_teacher.SHARED, "data", "pretrained",
                                                      "mobilenet_v2_1.0_224_quant.tflite"))
    ap.add_argument("--input", type=train.parse_hw, default=(96, 128), metavar="HxW")
    ap.add_argument("--epochs", type=int, default=20)
    ap.add_argument("--batch", type=int, default=16)
    ap.add_argument("--lr", type=float, default=1e-3)
    ap.add_argument("--val-panos", type=int, default=4)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--bf16", action="store_true")
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--max-steps", type=int, default=0)
    ap.add_argument("--limit", type=int, default=0)
    ap.add_argument("--device", default="cpu", help="cpu (default), cuda or cuda:N")
    ap.add_argument("--stream", action="store_true", help="decode the crops from their files at "
                    "each use instead of holding them all in memory (same results)")
    args = ap.parse_args(argv)
    torch.set_num_threads(max(1, args.threads))
    torch.set_flush_denormal(True)
    log = os.path.splitext(args.out)[0] + "-log.txt"
    try:
        if args.epochs < 1 or args.batch < 1:
            raise ValueError("--epochs and --batch must be >= 1")
        os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
        dev = train.parse_device(args.device)
        note = train.cpu_bf16_note(dev, args.bf16)
        if note:
            print(note, file=sys.stderr)
        imgs, _gt, val, held, digest = train.load_dataset(args.data, args.input, args.val_panos,
                                                          args.limit, stream=args.stream)
        with open(os.path.join(args.data, "index.tsv"), encoding="utf-8") as f:
            pngs = [ln.split("\t")[0] for ln in f][1:][:len(imgs)]
        tr = torch.nonzero(~val).flatten()
        va = torch.nonzero(val).flatten()
        if len(tr) < args.batch:
            raise ValueError(f"{args.data}: {len(tr)} training crops, fewer than one batch of "
                             f"{args.batch}")
        grid = (args.input[0] // 32, args.input[1] // 32)
        tsha = plm.file_sha256(args.teacher)
        cfg = {"input": list(args.input), "teacher": args.teacher, "teacher_sha256": tsha,
               "seed": args.seed, "epochs": args.epochs, "bf16": args.bf16, "batch": args.batch,
               "lr": args.lr, "threads": [max(1, args.threads)],   # the weights depend on it
               "devices": [args.device],
               "data_index_sha256": digest, "held_out": held}
        ck = None
        if os.path.exists(args.out):   # checked before the teacher maps, which take minutes
            ck = train.load_ckpt(args.out)
            if not isinstance(ck, dict) or not {"model", "proj", "optimizer", "state",
                                                "config"} <= set(ck):
                raise ValueError(f"{args.out}: not a distill.py checkpoint; use another --out")
            old = ck["config"]
            diff = [k for k in RESUME_KEYS if k in old and old[k] != cfg[k]]
            if diff:
                raise ValueError(f"{args.out}: made with another configuration ({', '.join(diff)} "
                                 f"differ); use another --out")
            cfg["threads"] = train.threads_used(old.get("threads"), cfg["threads"])
            cfg["devices"] = train.threads_used(old.get("devices", ["cpu"]), cfg["devices"])
        cache = (os.path.splitext(args.out)[0]
                 + f"-teacher-{digest[:12]}-{tsha[:8]}-{grid[0]}x{grid[1]}.pt")
        if os.path.exists(cache):
            tmaps = train.load_ckpt(cache)
        else:
            t0 = time.time()
            tmaps = teacher_maps(tflite_teacher.Teacher(args.teacher), args.data, pngs, grid)
            torch.save(tmaps, cache + ".tmp")
            os.replace(cache + ".tmp", cache)
            train.log_line(log, f"teacher maps of {len(pngs)} crops x2 in {time.time() - t0:.0f} s")
        mu = tmaps[tr].mean(dim=(0, 1, 3, 4), keepdim=True)[0]
        sd = tmaps[tr].std(dim=(0, 1, 3, 4), keepdim=True)[0].clamp_min(1e-3)
        target = ((tmaps - mu) / sd).to(dev)

        torch.manual_seed(args.seed)
        model = ParLightNet(3, args.input).to(dev)
        proj = torch.nn.Conv2d(1024, tmaps.shape[2], 1).to(dev)
        params = list(model.features.parameters()) + list(proj.parameters())
        opt = torch.optim.Adam(params, lr=args.lr)
        state = {"epoch": 0, "steps": 0}
        if ck is not None:
            model.load_state_dict(ck["model"])
            proj.load_state_dict(ck["proj"])
            opt.load_state_dict(ck["optimizer"])
            state = ck["state"]
            train.log_line(log, f"resumed {args.out} at epoch {state['epoch']}")
        bs = args.batch
        while state["epoch"] < args.epochs:
            ep = state["epoch"]
            gen = torch.Generator().manual_seed(args.seed * 7919 + ep)
            perm = tr[torch.randperm(len(tr), generator=gen)]
            flips = (torch.rand(len(tr), generator=gen) < 0.5).long()
            model.train()
            t0, tot, n = time.time(), 0.0, 0
            for b in range(0, len(perm) - bs + 1, bs):
                j, fl = perm[b:b + bs], flips[b:b + bs]
                u8 = torch.where(fl.bool().view(-1, 1, 1, 1), imgs[j].flip(2), imgs[j]).to(dev)
                with torch.autocast(dev.type, dtype=torch.bfloat16, enabled=args.bf16):
                    f = F.relu(model.features(train.to_input(u8)))
                    y = proj(f)
                loss = F.mse_loss(y.float(), target[j, fl])
                opt.zero_grad(set_to_none=True)
                loss.backward()
                opt.step()
                tot += float(loss)
                n += 1
                state["steps"] += 1
                if args.max_steps and state["steps"] >= args.max_steps:
                    break
            model.eval()
            with torch.no_grad():
                vl = float("nan")
                if len(va):
                    ys = [proj(F.relu(model.features(
                        train.to_input(imgs[va[i:i + 32]].to(dev)))))
                          for i in range(0, len(va), 32)]
                    vl = float(F.mse_loss(torch.cat(ys), target[va, 0]))
            state["epoch"] = ep + 1
            obj = {"model": model.state_dict(), "proj": proj.state_dict(),
                   "optimizer": opt.state_dict(), "state": state,
                   "config": dict(cfg, date=datetime.datetime.now(datetime.timezone.utc)
                                  .strftime("%Y-%m-%dT%H:%M:%SZ"))}
            torch.save(obj, args.out + ".tmp")
            os.replace(args.out + ".tmp", args.out)
            dt = time.time() - t0
            train.log_line(log, f"distill epoch {ep + 1}/{args.epochs} loss {tot / max(n, 1):.5g} "
                           f"val {vl:.5g} | {n * bs / max(dt, 1e-9):.2f} img/s, {dt:.0f} s")
            if args.max_steps and state["steps"] >= args.max_steps:
                break
    except (OSError, ValueError, RuntimeError) as e:
        print(f"distill: {e}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
