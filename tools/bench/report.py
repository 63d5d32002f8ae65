#!/usr/bin/python3
"""The table of `make bench` (tools/bench/run.sh) from its rows, printed and written as JSON.

    report.py --rows build/bench/rows.jsonl --model M.plm --int8 Q.plm --rss-kib K
              [--load-start "a b c"] [--load-end "a b c"] [--seconds S] --out-dir build/bench

Columns: engine, precision, threads, median/min/max ms per frame, parlight/peer (parlight's
median over the peer's at the same precision and thread count: below 1, parlight is faster),
GMAC/s at the median and the share of the arithmetic floor. The floors are this machine
class's (../shared/DESIGN.md, "Where the figures stand"): one core does the 2.775 GMAC in 6.5 ms
with AVX-512 VNNI int8, 0.84 ms with AMX, 23-26 ms fp32; with T threads on the 2 cores the
floor is the one-core floor / T. The share uses the VNNI floor for int8 (the path the kernels
take) and 23 ms for fp32; the JSON also gives the AMX share. The MAC count is parlight bench's
(computed from the model's input size and architecture) and divides every engine's time.
"here": with --peak-json (tools/bench/peak.c's measurement of this core's VNNI and FMA rates),
each row also gets the floor of this very machine, gmac / peak / T, and its share ("here"
column): a core that issues one 512-bit VNNI or FMA a cycle has twice the DESIGN.md floor.

Writes build/bench/bench-<UTC date>.json and build/bench/latest.json: machine, rows, peak RSS.
"""

import argparse
import datetime
import json
import os
import platform
import subprocess
import sys

FLOOR_MS = {"int8": 6.5, "fp32": 23.0}     # one core, at 2.775 GMAC (DESIGN.md)
FLOOR_AMX_MS = 0.84
FLOOR_GMAC = 2.775
TARGETS = {("int8", 1): 8.0, ("int8", 2): 5.0, ("fp32", 1): 40.0}   # ms, docs/PERFORMANCE.md
RSS_TARGET_MB = 32.0
ENGINE_NAMES = {"parlight": "parlight", "pytorch": "PyTorch", "onnxruntime": "ONNX Runtime"}


def cpu_name():
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown CPU"


def git_rev():
    try:
        rev = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True,
                             text=True, check=True).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"],
                               capture_output=True, text=True).stdout.strip()
        return rev + ("+changes" if dirty else "")
    except (OSError, subprocess.CalledProcessError):
        return "unknown"


def fmt(v, spec):
    return "-" if v is None else format(v, spec)


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("--rows", required=True)
    ap.add_argument("--model", required=True)
    ap.add_argument("--int8", required=True)
    ap.add_argument("--rss-kib", default="")
    ap.add_argument("--base-rss-kib", default="")
    ap.add_argument("--load-start", default="")
    ap.add_argument("--load-end", default="")
    ap.add_argument("--seconds", type=int, default=0)
    ap.add_argument("--out-dir", required=True)
    ap.add_argument("--peak-json", default="")
    args = ap.parse_args(argv)
    peak = None
    if args.peak_json:
        try:
            with open(args.peak_json) as f:
                peak = json.load(f)
        except (OSError, ValueError):
            peak = None
    peak_gmac_s = {"int8": peak.get("vnni_gmac_s"), "fp32": peak.get("fma_gmac_s")} if peak else {}

    rows = []
    with open(args.rows) as f:
        for line in f:
            line = line.strip()
            if line:
                rows.append(json.loads(line))
    order = {"parlight": 0, "pytorch": 1, "onnxruntime": 2}
    rows.sort(key=lambda r: (order.get(r["engine"], 9), r["precision"] != "int8", r["threads"]))

    gmac = next((r["gmac_per_frame"] for r in rows if r.get("gmac_per_frame")), None)
    ours = {(r["precision"], r["threads"]): r["median_ms"] for r in rows
            if r["engine"] == "parlight" and r.get("status") == "ok"}
    ours_cpu = {(r["precision"], r["threads"]): r.get("median_cpu_ms") for r in rows
                if r["engine"] == "parlight" and r.get("status") == "ok"}
    for r in rows:
        if r.get("status") != "ok":
            continue
        med, prec, n = r["median_ms"], r["precision"], r["threads"]
        if gmac:
            r["gmac_per_s"] = gmac / (med * 1e-3)
        floor = FLOOR_MS.get(prec)
        if floor and gmac:
            scale = gmac / FLOOR_GMAC / n
            r["floor_ms"] = floor * scale
            r["floor_share"] = floor * scale / med
            if prec == "int8":
                r["floor_share_amx"] = FLOOR_AMX_MS * scale / med
        if gmac and peak_gmac_s.get(prec):
            r["floor_here_ms"] = gmac / peak_gmac_s[prec] * 1e3 / n
            r["floor_here_share"] = r["floor_here_ms"] / med
        if r["engine"] != "parlight" and (prec, n) in ours:
            r["parlight_over_peer"] = ours[(prec, n)] / med
            if ours_cpu.get((prec, n)) and r.get("median_cpu_ms"):
                r["parlight_over_peer_cpu"] = ours_cpu[(prec, n)] / r["median_cpu_ms"]

    rss_kib = int(args.rss_kib) if args.rss_kib.strip().isdigit() else None
    base_kib = int(args.base_rss_kib) if args.base_rss_kib.strip().isdigit() else None
    now = datetime.datetime.now(datetime.timezone.utc)
    isa = next((r.get("isa") for r in rows if r["engine"] == "parlight" and r.get("isa")), "?")
    runs = next((r.get("runs") for r in rows if r.get("runs")), None)
    warmup = next((r.get("warmup") for r in rows if r.get("warmup") is not None), None)
    report = {
        "date": now.strftime("%Y-%m-%dT%H:%M:%SZ"),
        "machine": {"cpu": cpu_name(), "cores": os.cpu_count(), "kernel": platform.release(),
                    "load_avg_start": args.load_start, "load_avg_end": args.load_end},
        "git": git_rev(),
        "command": "make bench",
        "model": args.model,
        "int8_model": args.int8,
        "parlight_isa": isa,
        "gmac_per_frame": gmac,
        "runs": runs,
        "warmup": warmup,
        "floors_ms_one_core": {"int8_vnni": FLOOR_MS["int8"], "int8_amx": FLOOR_AMX_MS,
                               "fp32": [23.0, 26.0]},
        "peak_one_core": peak,
        "rows": rows,
        "estimate_int8_peak_rss_kib": rss_kib,
        "help_peak_rss_kib": base_kib,
        "targets": {"int8_1t_ms": 8.0, "int8_2t_ms": 5.0, "fp32_1t_ms": 40.0,
                    "rss_mb": RSS_TARGET_MB},
        "seconds": args.seconds,
    }

    print()
    print(f"make bench  {report['date']}  {report['machine']['cpu']}, {os.cpu_count()} cores, "
          f"git {report['git']}")
    print(f"model {args.model} (int8: {args.int8}), {fmt(gmac, '.3f')} GMAC/frame, "
          f"medians of {runs} runs after {warmup} warm-up; parlight ISA path {isa}")
    print(f"load average at start {args.load_start or '?'}, at end {args.load_end or '?'} "
          "(a shared machine: compare medians)")
    # the targets are for the 192x256 input: 2.777 GMAC a frame
    at_target_size = gmac is not None and abs(gmac - 2.777) < 0.01
    print()
    head = (f"{'engine':<13} {'prec':<5} {'thr':>3} {'median':>9} {'min':>9} {'max':>9} "
            f"{'CPU':>8} {'parl/peer':>9} {'GMAC/s':>7} {'floor':>6} {'here':>6}  notes")
    print(head)
    print("-" * len(head))
    for r in rows:
        name = ENGINE_NAMES.get(r["engine"], r["engine"])
        if r.get("status") != "ok":
            print(f"{name:<13} {r['precision']:<5} {r['threads']:>3} {'-':>9} {'-':>9} {'-':>9} "
                  f"{'-':>8} {'-':>9} {'-':>7} {'-':>6} {'-':>6}  {r.get('status')}")
            continue
        share = r.get("floor_share")
        note = r.get("how", "")
        tgt = TARGETS.get((r["precision"], r["threads"])) if r["engine"] == "parlight" else None
        if tgt and not at_target_size:
            note = "(targets are for 192x256)"
        elif tgt:
            note = f"target <= {tgt:g} ms: {'met' if r['median_ms'] <= tgt else 'not met'}"
        print(f"{name:<13} {r['precision']:<5} {r['threads']:>3} {r['median_ms']:>9.2f} "
              f"{r['min_ms']:>9.2f} {r['max_ms']:>9.2f} {fmt(r.get('median_cpu_ms'), '8.2f')} "
              f"{fmt(r.get('parlight_over_peer'), '9.2f')} "
              f"{fmt(r.get('gmac_per_s'), '7.1f')} {fmt(None if share is None else 100 * share, '5.1f')}%"
              + (f" {'-':>6}" if 'floor_here_share' not in r else f" {100 * r['floor_here_share']:5.1f}%")
              + f"  {note}")
    print()
    print("ms per frame; CPU: median CPU time of the whole process per frame (all threads; at 1 "
          "thread, close to a quiet machine's wall time);")
    print("parl/peer: parlight's median over the peer's (same precision and threads; "
          "< 1: parlight faster);")
    print(f"floor: the arithmetic floor's share of the median (one core: int8 VNNI "
          f"{FLOOR_MS['int8']} ms, fp32 23-26 ms (23 used), AMX {FLOOR_AMX_MS} ms; / threads)")
    if peak:
        print(f"here: the same for this machine's measured peak (tools/bench/peak.c, one core: "
              f"VNNI {peak.get('vnni_gmac_s')} GMAC/s, FMA {peak.get('fma_gmac_s')} GFMA/s, "
              f"clock {peak.get('clock_ghz')} GHz)")
    if rss_kib is not None:
        mb = rss_kib * 1024 / 1e6
        print(f"peak RSS of parlight estimate --model {args.int8} --input tests/data/frames: "
              f"{rss_kib} KiB = {mb:.1f} MB (target <= {RSS_TARGET_MB:g} MB: "
              f"{'met' if mb <= RSS_TARGET_MB else 'not met'})")
        if base_kib is not None:
            print(f"  of which the process before any model (parlight --help: executable and "
                  f"shared libraries): {base_kib} KiB = {base_kib * 1024 / 1e6:.1f} MB")
    else:
        print("peak RSS of parlight estimate: not measured (no int8 model or no /usr/bin/time)")

    os.makedirs(args.out_dir, exist_ok=True)
    stamp = now.strftime("%Y%m%dT%H%M%SZ")
    for name in (f"bench-{stamp}.json", "latest.json"):
        path = os.path.join(args.out_dir, name)
        with open(path + ".tmp", "w") as f:
            json.dump(report, f, indent=1)
            f.write("\n")
        os.replace(path + ".tmp", path)
    print(f"written: {os.path.join(args.out_dir, f'bench-{stamp}.json')} (and latest.json), "
          f"{args.seconds} s in all")
    return 0


if __name__ == "__main__":
    sys.exit(main())
