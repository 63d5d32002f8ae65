/* Time per layer type of the int8 DenseNet-121 on the kernel table's packed path, one thread:
 * the network's exact shapes at H x W (default 192 x 256), random weights and inputs, each layer
 * run `reps` times and the median kept. Not a test (tests/run.sh runs only test_*): a tool for
 * docs/PERFORMANCE.md, "Kernels and dispatch".
 *
 *   PARLIGHT_ISA=avx512vnni build/tests/bench_simd_s8 [-v] [reps] [H W]
 *
 * Prints, per layer type: layers, MMAC, the median ms summed over the layers (A building and
 * convolution separately) and GMAC/s of the convolution; -v first prints one line per layer. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/util.h"
#include "kernels/dispatch.h"
#include "model/graph.h"

static uint64_t rng = 0x243f6a8885a308d3ULL;
static uint32_t rnd(void)
{
    rng ^= rng << 13;
    rng ^= rng >> 7;
    rng ^= rng << 17;
    return (uint32_t)(rng >> 16);
}

static void *xalloc(size_t n)
{
    void *p = aligned_alloc(64, (n + 63) & ~(size_t)63);
    if (!p) {
        fprintf(stderr, "out of memory\n");
        exit(1);
    }
    for (size_t i = 0; i < n; i++)
        ((uint8_t *)p)[i] = (uint8_t)rnd();
    return p;
}

static int cmp_i64(const void *a, const void *b)
{
    const int64_t x = *(const int64_t *)a, y = *(const int64_t *)b;
    return x < y ? -1 : x > y;
}

enum { T_STEM, T_MAXPOOL, T_CONV1, T_CONV2, T_TRANS, T_FC, T_COUNT };
static const char *const tname[T_COUNT] = {"stem conv0 7x7/2 3->64", "maxpool 3x3/2",
                                           "dense conv1 1x1+clamp",  "dense conv2 3x3 128->32",
                                           "transition pool+1x1",    "fc 3072->512"};
static double t_a[T_COUNT], t_run[T_COUNT], mmac[T_COUNT];
static int count[T_COUNT];
static int reps = 50;
static int verbose; /* -v: one line per layer */

/* One conv: build A (a_pad when kxk, a_pack with clamp when clamp, avgpool when pool) and run. */
static void bench_conv(const pl_kernels_s8 *K, int type, int n_in_h, int n_in_w, int in_c,
                       int in_stride, int out_c, int k, int stride, int pad, int clamp, int pool)
{
    const int ih = pool ? n_in_h / 2 : n_in_h, iw = pool ? n_in_w / 2 : n_in_w;
    const int oh = (ih + 2 * pad - k) / stride + 1, ow = (iw + 2 * pad - k) / stride + 1;
    nn_conv_s8_params p = {128, 0, stride, stride, pad, pad, 1, 1, -128, 127};
    const nn_dims in = {1, ih, iw, in_c}, filt = {out_c, k, k, in_c}, out = {1, oh, ow, out_c};
    const nn_dims src = {1, n_in_h, n_in_w, in_c};
    int32_t *mult = xalloc(4 * (size_t)out_c), *shift = xalloc(4 * (size_t)out_c);
    int32_t *bias = xalloc(4 * (size_t)out_c);
    for (int o = 0; o < out_c; o++) {
        mult[o] = (int32_t)((1u << 30) | (rnd() & 0x3fffffff));
        shift[o] = -8;
        bias[o] = (int32_t)(rnd() % 2048) - 1024;
    }
    const nn_per_channel_quant q = {mult, shift};
    pl_s8_conv c;
    const int dense = k == 1, rows = in_c < 8;
    pl_s8_conv_init(&c, &p, &q, &in, &filt, &out,
                    dense  ? PL_S8_A_PACK
                    : rows ? PL_S8_A_ROWS
                           : PL_S8_A_PAD);
    int8_t *w = xalloc((size_t)out_c * (size_t)(k * k) * (size_t)in_c);
    void *mem = xalloc(pl_s8_conv_packed_size(&c, K->layout));
    K->pack(&c, w, bias, mem);
    int8_t *x = xalloc((size_t)n_in_h * (size_t)n_in_w * (size_t)in_stride);
    int8_t *lo = xalloc((size_t)in_c), *hi = xalloc((size_t)in_c);
    for (int i = 0; i < in_c; i++) {
        lo[i] = (int8_t)(-(int)(rnd() % 100));
        hi[i] = 127;
    }
    uint8_t *a = xalloc(pl_s8_conv_a_size(&c));
    int8_t *o = xalloc((size_t)oh * (size_t)ow * (size_t)out_c);
    const nn_pool_s8_params ap = {2, 2, 2, 2, 0, 0, -128, 127};
    int64_t *ta = xalloc(sizeof(int64_t) * (size_t)reps),
            *tr = xalloc(sizeof(int64_t) * (size_t)reps);
    for (int r = 0; r < reps; r++) {
        const int64_t t0 = pl_now_ns();
        if (pool)
            K->avgpool(&ap, &src, x, in_stride, lo, hi, &in, a, c.cs, 0x80, 0, oh * ow);
        else if (dense)
            K->a_pack(&in, x, in_stride, clamp ? lo : NULL, clamp ? hi : NULL, 1, 1, &out, a, c.cs,
                      0, oh * ow);
        else if (rows)
            K->a_rows(&in, x, in_stride, pad, pad, pl_s8_pad_u(128), k, stride, 1, c.a_h, c.a_w, a,
                      c.cs, 0, c.a_h);
        else
            K->a_pad(&in, x, in_stride, pad, pad, pl_s8_pad_u(128), c.a_h, c.a_w, a, c.cs, 0,
                     c.a_h);
        const int64_t t1 = pl_now_ns();
        K->run(&c, a, o, out_c, 0, oh * ow, 0, out_c);
        const int64_t t2 = pl_now_ns();
        ta[r] = t1 - t0;
        tr[r] = t2 - t1;
    }
    qsort(ta, (size_t)reps, sizeof *ta, cmp_i64);
    qsort(tr, (size_t)reps, sizeof *tr, cmp_i64);
    if (verbose)
        printf("  %-26s %4d -> %4d  %3d x %3d  A %7.3f ms  conv %7.3f ms  %6.1f GMAC/s\n",
               tname[type], in_c, out_c, oh, ow, (double)ta[reps / 2] / 1e6,
               (double)tr[reps / 2] / 1e6,
               (double)oh * ow * out_c * k * k * in_c / (double)tr[reps / 2]);
    t_a[type] += (double)ta[reps / 2] / 1e6;
    t_run[type] += (double)tr[reps / 2] / 1e6;
    mmac[type] += (double)oh * ow * out_c * k * k * in_c / 1e6;
    count[type]++;
    free(ta);
    free(tr);
    free(mult);
    free(shift);
    free(bias);
    free(w);
    free(mem);
    free(x);
    free(lo);
    free(hi);
    free(a);
    free(o);
}

/* The max pool of n into a tensor of out_cs channels a pixel. */
static void bench_maxpool(const pl_kernels_s8 *K, const pl_gnode *n, int out_cs)
{
    const nn_pool_s8_params mp = {n->k, n->k, n->stride, n->stride, n->pad, n->pad, -128, 127};
    const nn_dims in = {1, n->in_h, n->in_w, n->in_c}, out = {1, n->out_h, n->out_w, n->in_c};
    int8_t *x = xalloc((size_t)n->in_c * (size_t)n->in_h * (size_t)n->in_w);
    int8_t *o = xalloc((size_t)out_cs * (size_t)n->out_h * (size_t)n->out_w);
    int64_t *t = xalloc(sizeof(int64_t) * (size_t)reps);
    for (int r = 0; r < reps; r++) {
        const int64_t t0 = pl_now_ns();
        K->maxpool(&mp, &in, x, n->in_c, &out, o, out_cs, 0, n->out_h * n->out_w);
        t[r] = pl_now_ns() - t0;
    }
    qsort(t, (size_t)reps, sizeof *t, cmp_i64);
    t_run[T_MAXPOOL] += (double)t[reps / 2] / 1e6;
    count[T_MAXPOOL]++;
    free(x);
    free(o);
    free(t);
}

int main(int argc, char **argv)
{
    int H = 192, W = 256;
    if (argc > 1 && strcmp(argv[1], "-v") == 0) {
        verbose = 1;
        argc--;
        argv++;
    }
    if (argc > 1) reps = atoi(argv[1]);
    if (argc > 3) {
        H = atoi(argv[2]);
        W = atoi(argv[3]);
    }
    if (reps < 1 || H < 32 || W < 32 || H % 32 || W % 32) {
        fprintf(stderr, "usage: bench_simd_s8 [-v] [reps >= 1] [H W, multiples of 32]\n");
        return 2;
    }
    const pl_kernels *k;
    if (pl_kernels_get(&k) < 0) {
        fprintf(stderr, "%s\n", pl_last_error());
        return 1;
    }
    if (!k->s8.packed) {
        fprintf(stderr, "path %s has no packed int8 kernels (set PARLIGHT_ISA)\n",
                pl_isa_name(k->isa));
        return 1;
    }
    const pl_kernels_s8 *K = &k->s8;
    /* every conv of the network's graph at H x W (N = 3, 3 bands, fc 512) */
    const pl_net_shape shape = {3, H, W, 3, 512, 256, {0, 0, 0}, {1, 1, 1}};
    static pl_graph g;
    if (pl_graph_build(&shape, &g) < 0) {
        fprintf(stderr, "%s\n", pl_last_error());
        return 1;
    }
    for (int i = 0; i < g.n_nodes; i++) {
        const pl_gnode *n = &g.nodes[i];
        const int cs = g.tensors[n->in].c, p = n->pad;
        if (n->op == PL_NODE_FC)
            bench_conv(K, T_FC, 1, 1, n->in_c, n->in_c, n->out_c, 1, 1, 0, 0, 0);
        if (n->op == PL_NODE_MAXPOOL) bench_maxpool(K, n, g.tensors[n->out].c);
        if (n->op != PL_NODE_CONV) continue;
        if (n->in == g.input) /* the input arrives padded */
            bench_conv(K, T_STEM, n->in_h + 2 * p, n->in_w + 2 * p, n->in_c, cs, n->out_c, n->k,
                       n->stride, 0, 0, 0);
        else if (n->pool2)
            bench_conv(K, T_TRANS, n->in_h, n->in_w, n->in_c, cs, n->out_c, 1, 1, 0, 0, 1);
        else
            bench_conv(K, n->norm[0] ? T_CONV1 : T_CONV2, n->in_h, n->in_w, n->in_c, cs, n->out_c,
                       n->k, n->stride, p, n->norm[0] != 0, 0);
    }

    printf("path %s (%s), %d x %d, median of %d runs per layer, 1 thread\n", pl_isa_name(k->isa),
           K->run_name, H, W, reps);
    printf("%-26s %6s %9s %9s %9s %9s\n", "layer type", "layers", "MMAC", "A ms", "conv ms",
           "GMAC/s");
    double sa = 0, sr = 0, sm = 0;
    for (int i = 0; i < T_COUNT; i++) {
        printf("%-26s %6d %9.1f %9.3f %9.3f %9.1f\n", tname[i], count[i], mmac[i], t_a[i], t_run[i],
               t_run[i] > 0 && mmac[i] > 0 ? mmac[i] / t_run[i] : 0.0);
        sa += t_a[i];
        sr += t_run[i];
        sm += mmac[i];
    }
    printf("%-26s %6s %9.1f %9.3f %9.3f %9.1f\n", "total", "", sm, sa, sr, sm / sr);
    return 0;
}
