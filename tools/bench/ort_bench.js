// ONNX Runtime peer for `make bench` (tools/bench/run.sh), through npm's onnxruntime-node.
//
//   node tools/bench/ort_bench.js --ort DIR --onnx DIR [--runs R] [--warmup W] [--threads 1,2]
//
// DIR (--ort) is the onnxruntime-node package folder; --onnx is what `peers.py onnx` wrote:
// fp32.onnx, int8.onnx, input.bin (the normalised input, float32 1x3xHxW), ref.bin (the .plm's
// folded float forward on it, outputs concatenated in onnx.json's order) and onnx.json.
// The fp32 model must reproduce ref.bin (relative error <= 1e-4) before it is timed; the int8
// model's error against it is reported. Prints one JSON line per (precision, threads): engine,
// precision, threads, runs, warmup, median_ms, min_ms, max_ms, median_cpu_ms (CPU time of the
// whole process per run), rel_err_vs_plm, status.
'use strict';
const fs = require('fs');
const path = require('path');

function parseArgs(argv) {
    const a = { runs: 30, warmup: 5, threads: '1,2' };
    for (let i = 0; i < argv.length; i += 2) {
        const k = argv[i], v = argv[i + 1];
        if (v === undefined) throw new Error(`${k} needs a value`);
        if (k === '--ort') a.ort = v;
        else if (k === '--onnx') a.onnx = v;
        else if (k === '--runs') a.runs = parseInt(v, 10);
        else if (k === '--warmup') a.warmup = parseInt(v, 10);
        else if (k === '--threads') a.threads = v;
        else throw new Error(`unknown option ${k}`);
    }
    if (!a.ort || !a.onnx) throw new Error('--ort and --onnx are required');
    if (!(a.runs >= 1) || !(a.warmup >= 0)) throw new Error('--runs >= 1, --warmup >= 0');
    return a;
}

function readF32(file) {
    const b = fs.readFileSync(file);
    return new Float32Array(b.buffer, b.byteOffset, b.byteLength / 4);
}

function relErr(outs, names, ref) {
    let off = 0, worst = 0;
    for (const k of names) {
        const got = outs[k].data;
        let num = 0, den = 0;
        for (let i = 0; i < got.length; i++) {
            const r = ref[off + i], d = got[i] - r;
            num += d * d;
            den += r * r;
        }
        off += got.length;
        worst = Math.max(worst, Math.sqrt(num) / Math.max(Math.sqrt(den), 1e-30));
    }
    if (off !== ref.length) throw new Error(`outputs hold ${off} values, ref.bin ${ref.length}`);
    return worst;
}

async function main() {
    const a = parseArgs(process.argv.slice(2));
    const ort = require(path.resolve(a.ort));
    const meta = JSON.parse(fs.readFileSync(path.join(a.onnx, 'onnx.json'), 'utf8'));
    const input = new ort.Tensor('float32', readF32(path.join(a.onnx, 'input.bin')),
                                 meta.input_shape);
    const ref = readF32(path.join(a.onnx, 'ref.bin'));
    const threads = a.threads.split(',').map((v) => parseInt(v, 10));
    for (const prec of ['fp32', 'int8']) {
        for (const n of threads) {
            const row = {
                engine: 'onnxruntime', precision: prec, threads: n,
                how: prec === 'fp32' ? 'CPU EP, all graph optimisations'
                    : 'QDQ (u8 activations, per-channel s8 weights) fused by ORT',
            };
            try {
                const sess = await ort.InferenceSession.create(path.join(a.onnx, `${prec}.onnx`), {
                    executionProviders: ['cpu'], intraOpNumThreads: n, interOpNumThreads: 1,
                    executionMode: 'sequential', graphOptimizationLevel: 'all',
                });
                const feeds = { input };
                const first = await sess.run(feeds);
                row.rel_err_vs_plm = relErr(first, meta.outputs, ref);
                if (prec === 'fp32' && !(row.rel_err_vs_plm <= 1e-4))
                    throw new Error(`fp32 outputs differ from the .plm's: rel err ${row.rel_err_vs_plm}`);
                for (let i = 0; i < a.warmup; i++) await sess.run(feeds);
                const ms = [], cpu = [];
                for (let i = 0; i < a.runs; i++) {
                    const c0 = process.cpuUsage();
                    const t0 = process.hrtime.bigint();
                    await sess.run(feeds);
                    ms.push(Number(process.hrtime.bigint() - t0) / 1e6);
                    const c = process.cpuUsage(c0);
                    cpu.push((c.user + c.system) / 1e3);
                }
                ms.sort((x, y) => x - y);
                cpu.sort((x, y) => x - y);
                const m = ms.length;
                const med = (v) => (m % 2 ? v[(m - 1) / 2] : (v[m / 2 - 1] + v[m / 2]) / 2);
                Object.assign(row, {
                    runs: a.runs, warmup: a.warmup,
                    median_ms: med(ms), median_cpu_ms: med(cpu),
                    min_ms: ms[0], max_ms: ms[m - 1], version: ort.env.versions ?
                        ort.env.versions.common : undefined, status: 'ok',
                });
                if (sess.release) await sess.release();
            } catch (e) {
                row.status = `failed: ${String(e.message || e).split('\n')[0]}`;
            }
            console.log(JSON.stringify(row));
        }
    }
}

main().catch((e) => {
    console.error(`ort_bench: ${e.message || e}`);
    process.exit(1);
});
