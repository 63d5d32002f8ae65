#!/usr/bin/python3
"""Training crops and their ground truth, made by `parlight crop` from the TRAIN panoramas only.

    tools/train/make_dataset.py [--out /work/cache/train-data] [--crops-per-pano 32]
                                [--size 256x192] [--seed 1] [--jobs 2] [--parlight build/parlight]
                                [--hdri ../shared/data/hdri] [--scenes indoor,indoor-semi,outdoor]
                                [--limit N] [--synthetic DIR [--synthetic-crops K]]

Reads HDRI/MANIFEST.tsv and takes the rows whose file is under train/ (never eval/: a row or a
panorama path outside train/ is refused). With --synthetic DIR it also takes the procedurally lit
rooms of tools/train/synth_rooms.py in DIR (DIR/MANIFEST.tsv, rows under synth/;
--synthetic-crops each, default --crops-per-pano); train.py trains on them and never holds them
out. For each panorama, K crops with random camera and photometric parameters (drawn by `crop_params`, a pure function of seed, panorama name and crop
index, so adding panoramas or changing K never changes the crops already made):

    yaw     uniform [0, 360) degrees        pitch  uniform [-15, 25] degrees
    fov     uniform [45, 80] degrees (horizontal)
    exposure offset uniform [-1, +1] stops around parlight crop's automatic exposure
    gamma   uniform [1.8, 2.6] (camera response v = clip(kL)^(1/gamma), 8 bits)

Each crop is what `parlight crop --hdr PANO --yaw --pitch --fov --size --exposure --gamma --out
X.png --gt X.json [--gt-map W]` writes: the C implementation renders the crop and writes the
ground truth (lights, ambient, exposure scale, and with --gt-map the panorama itself as a W x W/2
map, all in the crop's camera frame). This tool adds a "dataset" object to the
JSON (panorama, scene, licence, seed, index) and never computes any lighting itself.

--panos DIR takes every .exr/.hdr under DIR instead (a user's own panoramas, or a research set
such as the Laval Indoor HDR Dataset's folder of .exr files; any resolution, 2:1), named
"panos/<relative path>" (train.py treats them like train/ panoramas, held-out choice included),
with --scene and --license (or a MANIFEST.tsv in DIR) for each; files that are not 2:1 panoramas
are reported and left out. The shared eval/ panoramas are refused however they are reached.

Each panorama is one `parlight crop --list` process (the panorama read and its lights extracted
once, then its missing crops), --jobs of them at a time; the crops are byte-identical to one
`parlight crop` per crop.

Layout under --out:
    dataset.json        the configuration; a rerun with another seed, size, scenes or ranges is
                        refused (use another --out); more --crops-per-pano extends the set (crop
                        k's parameters do not depend on K)
    crops/<stem>_kNNN.png, .json   one crop; the .json is renamed into place last, so its
                        presence marks a complete crop: an interrupted run resumes where it stopped
    index.tsv           written at the end: png, json, panorama, scene (what train.py reads)
"""

import argparse
import concurrent.futures
import hashlib
import json
import os
import subprocess
import sys
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
VERSION = 1    # bump when crop_params changes what a seed means

RANGES = {"yaw": (0.0, 360.0), "pitch": (-15.0, 25.0), "fov": (45.0, 80.0),
          "exposure": (-1.0, 1.0), "gamma": (1.8, 2.6)}


def default_shared():
    return os.environ.get("PL_SHARED", os.path.join(os.path.dirname(ROOT), "shared"))


def name_key(name):
    return int.from_bytes(hashlib.sha256(name.encode()).digest()[:4], "little")


def crop_params(seed, pano_name, k):
    """The random parameters of crop k of a panorama (a dict of floats, rounded to what is
    written on the command line so that the recorded values are the values used)."""
    rng = np.random.default_rng([seed, name_key(pano_name), k])
    p = {key: float(rng.uniform(lo, hi)) for key, (lo, hi) in RANGES.items()}
    return {key: round(v, 4) for key, v in p.items()}


def read_manifest(hdri, scenes, prefix="train/"):
    """The MANIFEST.tsv rows of HDRI under `prefix` (train/, or synth/ for synth_rooms.py's
    output) of the given scenes, each with its folder as "root"."""
    path = os.path.join(hdri, "MANIFEST.tsv")
    with open(path, encoding="utf-8") as f:
        lines = [ln.rstrip("\n").split("\t") for ln in f if ln.strip()]
    head = lines[0]
    for col in ("file", "scene", "license"):
        if col not in head:
            raise ValueError(f"{path}: no column {col!r} in the header")
    rows = []
    for i, cols in enumerate(lines[1:], 2):
        row = dict(zip(head, cols))
        name = row.get("file", "")
        if not name.startswith(prefix):
            continue
        if "/" in name[len(prefix):] or ".." in name:
            raise ValueError(f"{path}:{i}: unexpected panorama path {name!r}")
        if row.get("scene") not in scenes:
            continue
        full = os.path.join(hdri, name)
        if not os.path.isfile(full):
            raise ValueError(f"{path}:{i}: {full} is listed but missing")
        row["root"] = hdri
        rows.append(row)
    return rows


def crop_base(name, k):
    """The file name (no extension) of crop k of panorama `name`: synth/ rooms get "synth_", a
    --panos folder's files "panos_" and their relative path with "/" as "__" (two files of the
    same name in different subfolders stay apart)."""
    if name.startswith("panos/"):
        stem = "panos_" + os.path.splitext(name[len("panos/"):])[0].replace("/", "__")
    else:
        stem = (("synth_" if name.startswith("synth/") else "")
                + os.path.splitext(os.path.basename(name))[0])
    return f"{stem}_k{k:03d}"


def make_pano(parlight, row, ks, seed, size, out, gt_map=0):
    """The crops ks of one panorama that are not made yet, by one `parlight crop --list` (the
    panorama is read and its lights extracted once). Resumable: a crop is complete when its .json
    is in crops/ (renamed there last); an interrupted panorama's temporary files are remade.
    Returns the number of crops made."""
    name = row["file"]
    todo = []
    for k in ks:
        base = crop_base(name, k)
        png = os.path.join(out, "crops", base + ".png")
        js = os.path.join(out, "crops", base + ".json")
        if not (os.path.exists(js) and os.path.exists(png)):
            todo.append((k, base, png, js))
    if not todo:
        return 0
    tmp = os.path.join(out, "tmp")
    lst = os.path.join(tmp, crop_base(name, 0)[:-5] + ".list")
    with open(lst, "w", encoding="utf-8") as f:
        for k, base, _, _ in todo:
            p = crop_params(seed, name, k)
            f.write("\t".join([os.path.join(tmp, base + ".png"), os.path.join(tmp, base + ".json")]
                              + [repr(p[key]) for key in ("yaw", "pitch", "fov", "exposure",
                                                          "gamma")]) + "\n")
    cmd = [parlight, "crop", "--hdr", row.get("src") or os.path.join(row["root"], name),
           "--list", lst,
           "--size", f"{size[1]}x{size[0]}", "--force"]
    if gt_map:
        cmd += ["--gt-map", str(gt_map)]
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        raise RuntimeError(f"{name}: parlight crop exit {r.returncode}: {r.stderr.strip()}")
    for k, base, png, js in todo:
        tmp_png, tmp_js = os.path.join(tmp, base + ".png"), os.path.join(tmp, base + ".json")
        with open(tmp_js, encoding="utf-8") as f:
            gt = json.load(f)
        gt["image"] = base + ".png"
        gt["dataset"] = {"panorama": name, "scene": row["scene"], "license": row["license"],
                         "seed": seed, "crop_index": k, "params": crop_params(seed, name, k),
                         "tool": "tools/train/make_dataset.py", "version": VERSION}
        with open(tmp_js, "w", encoding="utf-8") as f:
            json.dump(gt, f)
        os.replace(tmp_png, png)
        os.replace(tmp_js, js)
    os.remove(lst)
    return len(todo)


def read_folder(folder, scene, license_, shared_hdri):
    """Rows for every .exr/.hdr under `folder` (recursively, sorted), named "panos/<relative
    path>": a user's own panoramas or a research set (e.g. the Laval Indoor HDR Dataset's folder
    of .exr files). A MANIFEST.tsv in `folder` with columns file (relative path), scene and
    license overrides --scene and --license per file. The shared evaluation panoramas are refused
    wherever they are reached from."""
    folder = os.path.abspath(folder)
    if not os.path.isdir(folder):
        raise ValueError(f"--panos {folder}: not a folder")
    evald = os.path.realpath(os.path.join(shared_hdri, "eval"))
    if os.path.realpath(folder) == evald or os.path.realpath(folder).startswith(evald + os.sep):
        raise ValueError(f"--panos {folder}: the evaluation panoramas are never trained on")
    meta = {}
    mpath = os.path.join(folder, "MANIFEST.tsv")
    if os.path.isfile(mpath):
        with open(mpath, encoding="utf-8") as f:
            lines = [ln.rstrip("\n").split("\t") for ln in f if ln.strip()]
        head = lines[0] if lines else []
        if "file" not in head:
            raise ValueError(f"{mpath}: no column 'file' in the header")
        for cols in lines[1:]:
            meta[cols[head.index("file")]] = dict(zip(head, cols))
    rows = []
    for dirpath, dirnames, files in os.walk(folder, followlinks=True):
        dirnames.sort()
        for fn in sorted(files):
            if not fn.lower().endswith((".exr", ".hdr")):
                continue
            full = os.path.join(dirpath, fn)
            rel = os.path.relpath(full, folder)
            if "\t" in rel or "\n" in rel:
                raise ValueError(f"{full}: a tab or newline in the name")
            real = os.path.realpath(full)
            if real.startswith(evald + os.sep):
                raise ValueError(f"{full}: is an evaluation panorama ({real}); never trained on")
            m = meta.get(rel, {})
            sc = m.get("scene") or scene
            if sc not in ("indoor", "indoor-semi", "outdoor"):
                raise ValueError(f"{rel}: scene {sc!r}: expected indoor, indoor-semi or outdoor")
            rows.append({"file": "panos/" + rel, "scene": sc,
                         "license": m.get("license") or license_, "root": folder,
                         "src": full})
    if not rows:
        raise ValueError(f"--panos {folder}: no .exr or .hdr files")
    return rows


def parse_size(text):
    try:
        w, h = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"--size {text!r}: expected WxH, e.g. 256x192")
    if not (32 <= w <= 4096 and 32 <= h <= 4096):
        raise argparse.ArgumentTypeError(f"--size {text!r}: sides must be in 32..4096")
    return h, w


def main(argv=None):
    ap = argparse.ArgumentParser(description="Random crops of the train panoramas with ground "
                                 "truth, by parlight crop (resumable, deterministic).")
    ap.add_argument("--out", default="/work/cache/train-data", help="dataset folder")
    ap.add_argument("--hdri", default=os.path.join(default_shared(), "data", "hdri"),
                    help="folder with MANIFEST.tsv and train/ (default $PL_SHARED/data/hdri)")
    ap.add_argument("--crops-per-pano", type=int, default=32, metavar="K")
    ap.add_argument("--size", type=parse_size, default=(192, 256), metavar="WxH",
                    help="crop size (default 256x192)")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--gt-map", type=int, default=32, metavar="W",
                    help="also store each crop's panorama in its camera frame, W x W/2, in the "
                    "ground truth (parlight crop --gt-map; train.py --w-map); 0: none")
    ap.add_argument("--scenes", default="indoor,indoor-semi,outdoor",
                    help="MANIFEST scene classes to use (comma-separated)")
    ap.add_argument("--panos", metavar="DIR", help="crop every .exr/.hdr under DIR (recursively; "
                    "any size, 2:1) instead of the shared train/ panoramas: a user's own capture "
                    "set or a research set such as the Laval Indoor HDR Dataset's folder of .exr")
    ap.add_argument("--scene", default="indoor", choices=("indoor", "indoor-semi", "outdoor"),
                    help="--panos: the scene class of its panoramas (a MANIFEST.tsv in DIR with "
                    "columns file, scene, license overrides it per file)")
    ap.add_argument("--license", default="unknown (the user's own panoramas)",
                    help="--panos: the licence recorded with each crop (MANIFEST.tsv overrides)")
    ap.add_argument("--limit", type=int, default=0, help="only the first N panoramas (tests)")
    ap.add_argument("--synthetic", metavar="DIR", help="also crop the rooms of synth_rooms.py in DIR")
    ap.add_argument("--synthetic-crops", type=int, default=0, metavar="K",
                    help="crops per synthetic room (default: --crops-per-pano)")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--parlight", default=os.path.join(ROOT, os.environ.get("BUILD", "build"),
                                                      "parlight"))
    ap.add_argument("--quiet", action="store_true")
    args = ap.parse_args(argv)

    try:
        if not 1 <= args.crops_per_pano <= 10000:
            raise ValueError(f"--crops-per-pano {args.crops_per_pano}: expected 1..10000")
        if args.gt_map and not (4 <= args.gt_map <= 256 and args.gt_map % 2 == 0):
            raise ValueError(f"--gt-map {args.gt_map}: expected 0 or an even width in 4..256")
        if not 1 <= args.jobs <= 64:
            raise ValueError(f"--jobs {args.jobs}: expected 1..64")
        if not os.access(args.parlight, os.X_OK):
            raise ValueError(f"{args.parlight}: no parlight binary (build it, or --parlight)")
        scenes = [s for s in args.scenes.split(",") if s]
        if args.panos:
            rows = [r for r in read_folder(args.panos, args.scene, args.license, args.hdri)
                    if r["scene"] in scenes]
        else:
            rows = read_manifest(args.hdri, scenes)
        if args.limit > 0:
            rows = rows[:args.limit]
        if not rows:
            raise ValueError(f"no panoramas of scenes {scenes} in "
                             + (args.panos if args.panos else f"{args.hdri}/MANIFEST.tsv"))
        k_synth = args.synthetic_crops or args.crops_per_pano
        if not 1 <= k_synth <= 10000:
            raise ValueError(f"--synthetic-crops {args.synthetic_crops}: expected 1..10000")
        synth = []
        if args.synthetic:
            sj = os.path.join(args.synthetic, "synth.json")
            try:
                with open(sj, encoding="utf-8") as f:
                    made = json.load(f)
            except (OSError, ValueError) as e:
                raise ValueError(f"--synthetic {args.synthetic}: no readable synth.json ({e}); "
                                 "make it with tools/train/synth_rooms.py") from None
            if made.get("tool") != "tools/train/synth_rooms.py":
                raise ValueError(f"{sj}: not made by tools/train/synth_rooms.py")
            synth = read_manifest(args.synthetic, scenes, prefix="synth/")
            if not synth:
                raise ValueError(f"--synthetic {args.synthetic}: no rooms of scenes {scenes}")
        config = {"tool": "tools/train/make_dataset.py", "version": VERSION, "seed": args.seed,
                  "crops_per_pano": args.crops_per_pano, "size_wh": [args.size[1], args.size[0]],
                  "gt_map": args.gt_map,
                  "panos": os.path.abspath(args.panos) if args.panos else None,
                  "scenes": scenes, "ranges": RANGES, "limit": args.limit,
                  "panoramas": [r["file"] for r in rows],
                  "synthetic": ({"dir": os.path.abspath(args.synthetic), "crops_per_room": k_synth,
                                 "rooms": len(synth), "made": {k: made.get(k) for k in (
                                     "seed", "width", "version")}} if synth else None)}
        os.makedirs(os.path.join(args.out, "crops"), exist_ok=True)
        os.makedirs(os.path.join(args.out, "tmp"), exist_ok=True)
        cfg_path = os.path.join(args.out, "dataset.json")
        if os.path.exists(cfg_path):
            with open(cfg_path, encoding="utf-8") as f:
                old = json.load(f)
            old.setdefault("gt_map", 0)      # made before these keys existed
            old.setdefault("panos", None)
            # more crops, panoramas or synthetic rooms only add crops; anything else is refused
            extends = ("crops_per_pano", "panoramas", "synthetic")
            same = {k: v for k, v in old.items() if k not in extends}
            want = {k: v for k, v in json.loads(json.dumps(config)).items() if k not in extends}
            if same != want:
                raise ValueError(f"{cfg_path}: made with another configuration; use another "
                                 "--out (or delete the folder)")
            old_s, new_s = old.get("synthetic"), config["synthetic"]
            if old_s and (not new_s or any(old_s.get(k) != new_s[k] for k in ("dir", "made"))):
                # the crops already there would pass for crops of rooms they are not
                raise ValueError(f"{cfg_path}: holds crops of the rooms in {old_s.get('dir')} "
                                 f"({old_s.get('made')}); give the same --synthetic or use "
                                 "another --out")
        with open(cfg_path + ".tmp", "w", encoding="utf-8") as f:
            json.dump(config, f, indent=1)
        os.replace(cfg_path + ".tmp", cfg_path)

        tasks = ([(r, range(args.crops_per_pano)) for r in rows] +
                 [(r, range(k_synth)) for r in synth])
        made, skipped, t0 = 0, [], time.time()
        # one parlight process per panorama, --jobs of them at a time
        with concurrent.futures.ThreadPoolExecutor(args.jobs) as pool:
            futs = [pool.submit(make_pano, args.parlight, r, ks, args.seed, args.size, args.out,
                                args.gt_map) for r, ks in tasks]
            for i, fut in enumerate(futs):
                try:
                    made += fut.result()
                except RuntimeError as e:
                    if not args.panos:
                        raise
                    # a user's folder may hold files that are not 2:1 panoramas: say which
                    # and why, leave them out of the index, go on with the others
                    print(f"make_dataset: skipped {e}", file=sys.stderr)
                    skipped.append(tasks[i][0]["file"])
                if not args.quiet and ((i + 1) % 10 == 0 or i + 1 == len(futs)):
                    print(f"{i + 1}/{len(futs)} panoramas, {made} crops made "
                          f"({time.time() - t0:.0f} s)", flush=True)
        jobs = [(r, k) for r, ks in tasks if r["file"] not in skipped for k in ks]
        if not jobs:
            raise ValueError("no panorama could be cropped")
        with open(os.path.join(args.out, "index.tsv.tmp"), "w", encoding="utf-8") as f:
            f.write("png\tjson\tpanorama\tscene\n")
            for r, k in jobs:
                base = crop_base(r["file"], k)
                f.write(f"crops/{base}.png\tcrops/{base}.json\t{r['file']}\t{r['scene']}\n")
        os.replace(os.path.join(args.out, "index.tsv.tmp"), os.path.join(args.out, "index.tsv"))
    except (OSError, ValueError, RuntimeError) as e:
        print(f"make_dataset: {e}", file=sys.stderr)
        return 1
    print(f"{args.out}: {len(jobs)} crops of {len(rows) - len(skipped)} panoramas"
          + (f" and {len(synth)} synthetic rooms" if synth else "")
          + (f"; {len(skipped)} files skipped (see above)" if skipped else ""))
    return 0


if __name__ == "__main__":
    sys.exit(main())
