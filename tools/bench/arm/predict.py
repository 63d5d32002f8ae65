#!/usr/bin/python3
"""Predicts a board's ms per frame from first principles, without the board (docs/PERFORMANCE.md,
"Arm predicted by simulation").

  tools/bench/arm/predict.py --board rpi5 --model models/parlight-n3-int8.plm [--isa dotprod]

1. Instruction counts of a real frame: the board's cross build of `parlight bench` runs under
   qemu-aarch64 with tools/bench/arm/tbcount.c (a TCG plugin counting each translation block's
   executions), once with --runs 1 and once with --runs 2 (--warmup 0, --threads 1); the
   difference is one frame, model loading and start-up cancel out.
2. Cycles: the blocks that make up --cover (99.9%) of the frame's instructions are disassembled
   from the ELF file and given to llvm-mca for the board's core; a block costs (its executions)
   x (llvm-mca's cycles per iteration of it as a loop body: steady state, L1 hits, branches
   predicted). The remaining blocks are charged the priced ones' mean cycles per instruction,
   blocks outside the program (libc) 1 cycle per instruction.
3. ms/frame = cycles / clock, against the memory bound (the model's weight bytes, streamed once a
   frame, over the board's DRAM bandwidth): the prediction is the larger of the two, the sum
   the top of its range.

Board facts (clock, DRAM bandwidth, cores, llvm-mca model, qemu CPU) are read from
boards/<board>.mk (BOARD_PREDICT_*), the MAC peaks per ISA from llvm-mca itself on a stream of
independent multiply instructions. Prints a table; --json writes the same as JSON."""
import argparse
import bisect
import collections
import json
import os
import re
import subprocess
import sys
import tempfile

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", "..", ".."))
# the target: aarch64 (the boards), or x86_64 (--host-x86: the method checked against this
# machine's measured time, docs/PERFORMANCE.md)
T = {"cross": "aarch64-linux-gnu-", "qemu": ["qemu-aarch64", "-L", "/usr/aarch64-linux-gnu"],
     "triple": "aarch64", "mattr": ["-mattr=+dotprod,+i8mm,+fullfp16,+v8.6a"],
     "branch": r"^(b|bl|b\.\w+|cbn?z|tbn?z|adrp?|ldr|ldrsw|prfm)\s", "comment": "//"}
T_X86 = {"cross": "", "qemu": ["qemu-x86_64"], "triple": "x86_64", "mattr": [],
         "branch": r"^(j\w+|call|callq|jmp|jmpq)\s", "comment": "#"}
MCA = os.environ.get("LLVM_MCA", "llvm-mca-19")
MC = os.environ.get("LLVM_MC", "llvm-mc-19")

# multiply-accumulates of one instruction, by mnemonic and arrangement of the destination
MAC_RE = [
    (re.compile(r"^[su]dot\s+v\d+\.4s"), 16, "int8"),
    (re.compile(r"^[su]dot\s+v\d+\.2s"), 8, "int8"),
    (re.compile(r"^(us|s|u)mmla\s"), 32, "int8"),
    (re.compile(r"^[su](mull|mlal)2?\s+v\d+\.8h"), 8, "int8"),
    (re.compile(r"^fmla\s+v\d+\.4s"), 4, "fp32"),
    (re.compile(r"^fmla\s+v\d+\.2s"), 2, "fp32"),
]
# the instruction whose independent stream sets each path's int8 peak
PEAK_INSN = {
    "neon": "smull v{a}.8h, v1.8b, v2.8b",
    "dotprod": "sdot v{a}.4s, v1.16b, v2.4b[0]",
    "i8mm": "usmmla v{a}.4s, v1.16b, v2.16b",
    "fp32": "fmla v{a}.4s, v1.4s, v2.s[0]",
}


def board_vars(board):
    path = os.path.join(ROOT, "boards", board + ".mk")
    out = {}
    with open(path) as f:
        for line in f:
            m = re.match(r"^(BOARD_[A-Z0-9_]+)\s*:?=\s*(.*?)\s*(#.*)?$", line)
            if m:
                out[m.group(1)] = m.group(2)
    for k in ("BOARD_PREDICT_CLOCK_GHZ", "BOARD_PREDICT_DRAM_GBS", "BOARD_PREDICT_MCA_CPU",
              "BOARD_QEMU_CPU", "BOARD_THREADS"):
        if k not in out:
            sys.exit(f"predict: {path} has no {k}")
    return out


def mac_of(insn):
    for rx, n, kind in MAC_RE:
        if rx.match(insn):
            return n, kind
    return 0, None


def run_counted(binary, qemu_cpu, plugin, model, isa, runs, out, extra):
    env = dict(os.environ, PARLIGHT_ISA=isa)
    cmd = T["qemu"] + ["-cpu", qemu_cpu, "-plugin", f"{plugin},out={out}", binary, "bench", "--model", model, "--threads", "1", "--runs",
           str(runs), "--warmup", "0", "--json"] + extra
    r = subprocess.run(cmd, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    if r.returncode != 0:
        sys.exit(f"predict: {' '.join(cmd)} failed ({r.returncode}): {r.stderr.strip()[-400:]}")
    counts = {}
    info = json.loads(r.stdout)
    with open(out) as f:
        start = int(f.readline().split()[1], 16)
        for line in f:
            a, n, c = line.split()
            key = (int(a, 16), int(n))
            counts[key] = counts.get(key, 0) + int(c)
    return start, counts, info


def text_vaddr(binary):
    """The link-time address of the executable segment, which qemu's start_code is the load
    address of (0 on the aarch64 builds; x86-64 puts a read-only segment first)."""
    r = subprocess.run([T["cross"] + "readelf", "-lW", binary], stdout=subprocess.PIPE, text=True,
                       check=True)
    for line in r.stdout.splitlines():
        p = line.split()
        if p and p[0] == "LOAD" and "E" in p[-2:-1][0]:
            return int(p[2], 16)
    return 0


def symbols(binary):
    r = subprocess.run([T["cross"] + "nm", "-n", "--defined-only", binary], stdout=subprocess.PIPE,
                       text=True, check=True)
    syms = []
    for line in r.stdout.splitlines():
        p = line.split()
        if len(p) == 3 and p[1] in "tTwW":
            syms.append((int(p[0], 16), p[2], p[1] in "TW"))
    # a static function whose name several files use (each kernel file's tile_any) is named
    # after the next global function, the kernel that its file defines after it
    names = collections.Counter(s[1] for s in syms)
    out = []
    for i, (a, name, glob) in enumerate(syms):
        if not glob and names[name] > 1:
            nxt = next((s[1] for s in syms[i + 1:] if s[2]), "?")
            name = f"{nxt}/{name}"
        out.append((a, name))
    return out


def disassemble(binary):
    r = subprocess.run([T["cross"] + "objdump", "-d", "--no-show-raw-insn", binary],
                       stdout=subprocess.PIPE, text=True, check=True)
    insns = {}
    for line in r.stdout.splitlines():
        m = re.match(r"^\s+([0-9a-f]+):\s+(.*)$", line)
        if m:
            insns[int(m.group(1), 16)] = m.group(2).split(T["comment"])[0].strip()
    return insns


def mca_text(insn, label):
    """objdump's text as llvm-mc reads it: branch and literal targets become a local label."""
    insn = re.sub(r"\s*<[^>]*>\s*$", "", insn).replace("\t", " ")
    return re.sub(r"(^|[ ,])(#?0x)?[0-9a-f]{3,}$", lambda m: m.group(1) + label, insn) \
        if re.match(T["branch"], insn) and not re.search(r"[\[(]", insn) else insn


def mca_cycles(blocks, cpu):
    """{name: [insn text]} -> {name: cycles per iteration} for llvm-mca's model of cpu."""
    with tempfile.TemporaryDirectory() as d:
        src = os.path.join(d, "b.s")
        lines = []
        for k, (name, body) in enumerate(blocks.items()):
            lines.append(f"# LLVM-MCA-BEGIN {name}")
            lines.append(f".Lt{k}:")
            lines += ["  " + mca_text(t, f".Lt{k}") for t in body]
            lines.append("# LLVM-MCA-END")
        # lines llvm-mc cannot parse (a rare system instruction) become a nop
        for _ in range(50):
            with open(src, "w") as f:
                f.write("\n".join(lines) + "\n")
            r = subprocess.run([MC, "-triple=" + T["triple"]] + T["mattr"] + ["-filetype=null", src],
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
            bad = {int(m.group(1)) for m in re.finditer(r"b\.s:(\d+):\d+: error", r.stderr)}
            if not bad:
                break
            for n in bad:
                lines[n - 1] = "  nop"
        r = subprocess.run([MCA, "-mtriple=" + T["triple"], f"-mcpu={cpu}"] + T["mattr"] +
                           ["-iterations=100", "-all-views=false", "-summary-view", src],
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        if r.returncode != 0:
            sys.exit(f"predict: llvm-mca failed: {r.stderr[-400:]}")
    out, name = {}, None
    for line in r.stdout.splitlines():
        m = re.match(r"^\[\d+\] Code Region - (\S+)", line)
        if m:
            name = m.group(1)
        m = re.match(r"^Total Cycles:\s+(\d+)", line)
        if m and name:
            out[name] = int(m.group(1)) / 100.0
    if len(blocks) == 1 and not out:  # a single region is not headed by its name
        m = re.search(r"Total Cycles:\s+(\d+)", r.stdout)
        out[next(iter(blocks))] = int(m.group(1)) / 100.0
    return out


def peak_macs(cpu, kind):
    body = [PEAK_INSN[kind].format(a=4 + i) for i in range(16)]
    cyc = mca_cycles({"peak": body}, cpu)["peak"]
    n, _ = mac_of(body[0])
    return 16 * n / cyc


def summary(paths):
    print("| board | core, clock | path | input | M insns/frame | IPC | predicted ms, 1 thread "
          "(range) | all cores, ideal | floor ms | floor / predicted | conv loop, % of peak |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for p in paths:
        with open(p) as f:
            r = json.load(f)
        conv = [h for h in r["hot_blocks"] if h["function"].startswith("nn_conv_packed_s8")]
        print(f"| {r['board']} | {r['core']} {r['clock_ghz']:g} GHz | {r['isa']} | {r['input']} | "
              f"{r['frame_insns'] / 1e6:.0f} | {r['ipc']:.2f} | **{r['ms_predicted']:.1f}** "
              f"({r['ms_predicted']:.1f}–{r['ms_high']:.1f}) | {r['ms_all_cores']:.1f} "
              f"({r['threads']}) | {r['ms_floor']:.1f} | "
              f"{100 * r['ms_floor'] / r['ms_predicted']:.0f}% | "
              f"{100 * conv[0]['of_peak'] if conv else 0:.0f}% |")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--board")
    ap.add_argument("--model")
    ap.add_argument("--summary", nargs="+", metavar="JSON",
                    help="print one table of earlier --json results and exit")
    ap.add_argument("--isa", help="PARLIGHT_ISA (default: the best the board's core has)")
    ap.add_argument("--build", help="the board's build folder (default build/<board>)")
    ap.add_argument("--plugin", default=os.path.join(ROOT, "build", "tools", "tbcount.so"))
    ap.add_argument("--cover", type=float, default=0.999,
                    help="share of the frame's instructions given to llvm-mca block by block")
    ap.add_argument("--loops", type=int, default=8, help="hot blocks to list")
    ap.add_argument("--json", help="write the result here too")
    ap.add_argument("--host-x86", action="store_true",
                    help="check the method on this x86-64 machine instead: build/parlight under "
                         "qemu-x86_64 -cpu max (its avx2 path), llvm-mca -mcpu=--mca-cpu, at "
                         "--clock-ghz; compare with parlight bench's CPU time here")
    ap.add_argument("--mca-cpu", help="with --host-x86: llvm-mca's model of this CPU")
    ap.add_argument("--clock-ghz", help="with --host-x86: this CPU's clock")
    a = ap.parse_args()
    if a.summary:
        summary(a.summary)
        return
    if a.host_x86:
        if not (a.model and a.mca_cpu and a.clock_ghz):
            ap.error("--host-x86 needs --model, --mca-cpu and --clock-ghz")
        T.update(T_X86)
        a.board = "host-x86"
        a.build = a.build or os.path.join(ROOT, "build")
        a.isa = a.isa or "avx2"
    elif not a.board or not a.model:
        ap.error("--board and --model are needed")

    bv = board_vars(a.board) if not a.host_x86 else {
        "BOARD_PREDICT_CLOCK_GHZ": a.clock_ghz, "BOARD_PREDICT_DRAM_GBS": "10",
        "BOARD_PREDICT_MCA_CPU": a.mca_cpu, "BOARD_QEMU_CPU": "max", "BOARD_THREADS": "1",
        "BOARD_CPU": "this machine"}
    build = a.build or os.path.join(ROOT, "build", a.board)
    binary = os.path.join(build, "parlight")
    clock = float(bv["BOARD_PREDICT_CLOCK_GHZ"]) * 1e9
    dram = float(bv["BOARD_PREDICT_DRAM_GBS"]) * 1e9
    cpu = bv["BOARD_PREDICT_MCA_CPU"]
    isa = a.isa or bv.get("BOARD_PREDICT_ISA", "neon")

    with tempfile.TemporaryDirectory() as d:
        start, c1, info = run_counted(binary, bv["BOARD_QEMU_CPU"], a.plugin, a.model, isa, 1,
                                os.path.join(d, "1.txt"), [])
        _, c2, _ = run_counted(binary, bv["BOARD_QEMU_CPU"], a.plugin, a.model, isa, 2,
                            os.path.join(d, "2.txt"), [])
    frame = {}
    for key, c in c2.items():
        n = c - c1.get(key, 0)
        if n > 0:
            frame[key] = n
    total_insns = sum(n * k[1] for k, n in frame.items())
    start -= text_vaddr(binary)

    syms = symbols(binary)
    sym_addr = [s[0] for s in syms]
    insns = disassemble(binary)
    ilist = sorted(insns.items())
    at = {addr: i for i, (addr, _) in enumerate(ilist)}

    def func_of(rel):
        i = bisect.bisect_right(sym_addr, rel) - 1
        return syms[i][1] if i >= 0 else "?"

    # the blocks that make up `cover` of the frame's instructions go to llvm-mca one by one
    order = sorted(frame.items(), key=lambda kv: -kv[1] * kv[0][1])
    blocks, meta, acc, outside = {}, {}, 0, 0
    for (vaddr, n), cnt in order:
        rel = vaddr - start
        i = at.get(rel)  # x86 instructions have no fixed length: the n after the first
        body = [t for _, t in ilist[i:i + n]] if i is not None else []
        if len(body) < n:
            outside += cnt * n
            continue
        if acc >= a.cover * (total_insns - outside):
            break
        name = f"tb_{rel:x}_{n}"
        blocks[name] = body
        meta[name] = (rel, n, cnt)
        acc += cnt * n
    cyc = mca_cycles(blocks, cpu)
    covered_cycles = sum(cyc[k] * meta[k][2] for k in blocks)
    rest_insns = total_insns - acc - outside
    cpi_covered = covered_cycles / acc if acc else 1.0
    cycles = covered_cycles + rest_insns * cpi_covered + outside * 1.0

    per_func = collections.defaultdict(lambda: [0.0, 0, 0])
    for k in blocks:
        rel, n, cnt = meta[k]
        f = per_func[func_of(rel)]
        f[0] += cyc[k] * cnt
        f[1] += n * cnt
        f[2] += sum(mac_of(t)[0] for t in blocks[k]) * cnt
    kinds = ("neon", "dotprod", "fp32") if T["triple"] == "aarch64" else ()
    peaks = {kind: peak_macs(cpu, kind) for kind in kinds} or {"neon": float("nan")}
    if isa == "i8mm":
        peaks["i8mm"] = peak_macs(cpu, "i8mm")
    peak_isa = peaks.get(isa, peaks["neon"])

    loops = []
    for k in sorted(blocks, key=lambda k: -cyc[k] * meta[k][2])[: a.loops]:
        rel, n, cnt = meta[k]
        macs = sum(mac_of(t)[0] for t in blocks[k])
        kinds = {mac_of(t)[1] for t in blocks[k]} - {None}
        kind = "fp32" if kinds == {"fp32"} else isa
        pk = peaks.get(kind, peak_isa)
        loops.append({"function": func_of(rel), "offset": f"0x{rel:x}", "insns": n, "runs": cnt,
                      "cycles_per_run": cyc[k], "macs_per_run": macs,
                      "share": cyc[k] * cnt / cycles,
                      "mac_per_cycle": macs / cyc[k] if cyc[k] else 0,
                      "peak_mac_per_cycle": pk,
                      "of_peak": (macs / cyc[k] / pk) if cyc[k] and macs else 0})

    weight_bytes = os.path.getsize(a.model)
    t_compute = cycles / clock * 1e3
    t_mem = weight_bytes / dram * 1e3
    threads = int(bv["BOARD_THREADS"])
    int8_macs = sum(f[2] for f in per_func.values())
    res = {
        "board": a.board, "core": bv.get("BOARD_CPU"), "isa": isa, "model": a.model,
        "mca_cpu": cpu, "qemu_cpu": bv["BOARD_QEMU_CPU"], "clock_ghz": clock / 1e9,
        "dram_gbs": dram / 1e9, "frame_insns": total_insns, "insns_outside": outside,
        "insns_mca": acc, "cycles": cycles, "ipc": total_insns / cycles,
        "macs_run": int8_macs, "peak_mac_per_cycle": peaks,
        "ms_compute": t_compute, "ms_memory": t_mem,
        "ms_predicted": max(t_compute, t_mem), "ms_high": t_compute + t_mem,
        "gmac_per_frame": info["gmac_per_frame"],
        "input": f"{info['input_h']}x{info['input_w']}",
        "ms_floor": info["gmac_per_frame"] * 1e9 / (peak_isa * clock) * 1e3,
        "threads": threads,
        "ms_all_cores": max(t_compute / threads, t_mem),
        "functions": sorted(([k, v[0] / cycles, v[1], v[2]] for k, v in per_func.items()),
                            key=lambda x: -x[1])[:12],
        "hot_blocks": loops,
    }
    print(f"{a.board} ({res['core']}, {clock / 1e9:.2f} GHz, {dram / 1e9:.0f} GB/s) "
          f"PARLIGHT_ISA={isa} {os.path.basename(a.model)}: llvm-mca -mcpu={cpu}, "
          f"qemu -cpu {bv['BOARD_QEMU_CPU']}")
    print(f"  frame: {total_insns / 1e6:.1f} M instructions ({outside / 1e6:.2f} M outside "
          f"parlight), {cycles / 1e6:.1f} M cycles, IPC {res['ipc']:.2f}, "
          f"{int8_macs / 1e6:.0f} M MAC instructions' MACs")
    print(f"  predicted {res['ms_predicted']:.2f} ms/frame at 1 thread (compute "
          f"{t_compute:.2f}, memory {t_mem:.2f}; up to {res['ms_high']:.2f}), "
          f"{res['ms_all_cores']:.2f} ms on {threads} cores if it scaled; floor "
          f"{res['ms_floor']:.2f} ms ({peak_isa:.1f} MAC/cycle)")
    print("  functions: " + ", ".join(f"{f[0]} {100 * f[1]:.1f}%" for f in res["functions"][:6]))
    print("  hot blocks (cycles/run from llvm-mca; % of peak = MAC/cycle over the path's peak):")
    for lp in loops:
        print(f"    {100 * lp['share']:5.1f}%  {lp['function']}+{lp['offset']}  "
              f"{lp['insns']} insns  {lp['cycles_per_run']:.2f} cyc  {lp['macs_per_run']} MAC"
              f"  {lp['mac_per_cycle']:.1f} MAC/cyc = {100 * lp['of_peak']:.0f}% of "
              f"{lp['peak_mac_per_cycle']:.0f}")
    if a.json:
        with open(a.json, "w") as f:
            json.dump(res, f, indent=1)


if __name__ == "__main__":
    main()
