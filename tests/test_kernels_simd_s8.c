/* The packed int8 SIMD path (kernels/kernels_s8.h) against the reference kernels, tolerance 0,
 * on every SIMD path this CPU runs (x86: avx2, avxvnni, avx512vnni, amx; Arm: neon, dotprod,
 * i8mm; pl_kernels_for; paths it lacks are reported and skipped), and on x86 with AVX-512 VNNI
 * the AMX kernel with its tile instructions emulated in C:
 * k x k convolutions with strides, dilation and padding (nn_conv2d_s8__ref), 1x1 convolutions
 * with and without the per-input-channel clamp and with strides (nn_conv1x1_clamp_s8__ref,
 * nn_conv1x1_s8__ref), fully connected layers (nn_fc_s8__ref, per channel and per tensor), on
 * random shapes: tile remainders (pixels and channels), odd channel counts, input pixel strides,
 * outputs at a channel offset of a wider buffer (bytes outside the channels must stay untouched),
 * maxpool, average pool with the fused clamp and clamp (vs nn_maxpool2d_s8__ref,
 * nn_avgpool2d_s8__ref, nn_clamp_s8__ref); extreme values -128/127, input offsets over [-127, 128],
 * every shift in [-31, 30] (left shifts that saturate included), multipliers 0 and near 2^31,
 * biases near the int32 wrap, depths up to the network's 9*128 and 1024 channels; k x k
 * convolutions both through a_pad and through a_rows (the row taps folded into the channels, as for
 * the stem); outputs whose rows are apart (out_pitch) and written as u8 (out_xor); and the work
 * computed in random pieces of pixels and channels, in random order, equals the whole. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/util.h"
#include "kernels/dispatch.h"
#include "kernels/ref/nn_ref_s8_clamp.h"
#if defined(__x86_64__)
#include "kernels/x86/nn_s8_x86.h"
#endif
#include "tests/check.h"

/* int8 values; mode 0: random with a quarter at -128/127, 1: all -128, 2: all 127,
 * 3: only -128 and 127 */
static void fill_s8(int8_t *p, size_t n, int mode)
{
    for (size_t i = 0; i < n; i++) {
        const uint32_t r = rnd();
        switch (mode) {
        case 1: p[i] = -128; break;
        case 2: p[i] = 127; break;
        case 3: p[i] = (r & 1) ? 127 : -128; break;
        default: p[i] = (r & 3) == 0 ? ((r & 4) ? 127 : -128) : (int8_t)(r >> 8); break;
        }
    }
}

static void *xmalloc(size_t n)
{
    void *p = aligned_alloc(64, (n + 63) & ~(size_t)63);
    if (!p) {
        printf("out of memory\n");
        exit(1);
    }
    return p;
}

enum { GUARD = 0x5b, MAXC = 1100 };

/* Random requantisation: multipliers in [2^30, 2^31) (a few exactly 2^30, 2^31 - 1 or 0),
 * shifts mostly in [-14, 3] and sometimes anywhere in [-31, 30], biases small or near the wrap. */
static void random_quant(int n, int32_t *mult, int32_t *shift, int32_t *bias)
{
    for (int i = 0; i < n; i++) {
        const uint32_t r = rnd() % 16;
        mult[i] = r == 0   ? 0
                  : r == 1 ? (int32_t)(1u << 30)
                  : r == 2 ? INT32_MAX
                           : (int32_t)((1u << 30) | (rnd() & 0x3fffffffu));
        shift[i] = rnd() % 4 == 0 ? rint_in(-31, 30) : rint_in(-14, 3);
        const uint32_t rb = rnd() % 8;
        bias[i] = rb == 0   ? INT32_MAX - rint_in(0, 1 << 16)
                  : rb == 1 ? INT32_MIN + rint_in(0, 1 << 16)
                            : rint_in(-(1 << 20), 1 << 20);
    }
}

/* Half of the cases: what the shorter AVX-512 requantisation takes (pl_s8_conv.short_requant: no
 * left shift, the full activation range, |bias| + 255 * sum|w| < 2^30): shifts in [-31, 0] (0,
 * -1 and -31 often), multipliers as random_quant's; the biases of some channels at the bound's
 * edge, 2^30 - 1 - 255 * sum|w| (still short), in a quarter of the cases one channel's one
 * more (the general path), either sign; the others in [-2^20, 2^20].
 * n_short counts the packed convolutions that qualified (pl_s8_conv.short_requant), n_long the
 * others. */
static int n_short, n_long;
static void short_quant(int out_c, int per_oc, const int8_t *w, int32_t *shift, int32_t *bias,
                        int32_t *act_min, int32_t *act_max)
{
    *act_min = -128;
    *act_max = 127;
    const int over = rnd() % 4 == 0 ? rint_in(0, out_c - 1) : -1; /* this channel one over */
    for (int o = 0; o < out_c; o++) {
        const uint32_t r = rnd() % 8;
        shift[o] = r == 0 ? 0 : r == 1 ? -1 : r == 2 ? -31 : rint_in(-20, 0);
        int64_t sa = 0;
        for (int i = 0; i < per_oc; i++)
            sa += abs(w[(size_t)o * (size_t)per_oc + (size_t)i]);
        const int64_t edge = ((int64_t)1 << 30) - 1 - 255 * sa + (o == over);
        bias[o] = rint_in(-(1 << 20), 1 << 20);
        if ((o == over || rnd() % 4 == 0) && edge > 0)
            bias[o] = (int32_t)(rnd() % 2 ? edge : -edge);
    }
}

static void random_act(int32_t *act_min, int32_t *act_max)
{
    *act_min = rnd() % 2 ? -128 : rint_in(-128, 0);
    *act_max = rnd() % 2 ? 127 : rint_in(*act_min, 127);
}

/* random cut points of [0, n) into at most k pieces: returns the count, bounds in cut[0..count] */
static int random_cuts(int n, int k, int *cut)
{
    int count = 1;
    cut[0] = 0;
    for (int i = 1; i < k; i++)
        cut[count++] = rint_in(0, n);
    cut[count] = n;
    for (int i = 1; i < count; i++) /* insertion sort */
        for (int j = i; j > 0 && cut[j] < cut[j - 1]; j--) {
            const int t = cut[j];
            cut[j] = cut[j - 1];
            cut[j - 1] = t;
        }
    return count;
}

/* One case, described by reference arguments. */
typedef enum { K_CONV, K_1X1, K_1X1_CLAMP, K_FC } kind;
typedef struct {
    kind k;
    nn_conv_s8_params p;
    nn_fc_s8_params fp;
    nn_dims in, filt, out;
    int in_s, out_s, out_off;
    int rows; /* K_CONV: build A with a_rows (k_w folded into the channels) instead of a_pad */
    const int8_t *x, *w, *lo, *hi;
    const int32_t *bias;
    nn_per_channel_quant q;
} tcase;

static size_t npix(const nn_dims *d)
{
    return (size_t)d->n * (size_t)d->h * (size_t)d->w;
}

static size_t out_bytes(const tcase *t)
{
    return npix(&t->out) * (size_t)t->out_s;
}

static void run_ref(const tcase *t, int8_t *out)
{
    int8_t *o = out + t->out_off;
    switch (t->k) {
    case K_CONV:
        nn_conv2d_s8__ref(&t->p, &t->q, &t->in, t->x, t->in_s, &t->filt, t->w, t->bias, &t->out, o,
                          t->out_s, 0, t->out.c);
        break;
    case K_1X1:
        nn_conv1x1_s8__ref(&t->p, &t->q, &t->in, t->x, t->in_s, &t->filt, t->w, t->bias, &t->out,
                           o, t->out_s, 0, t->out.c);
        break;
    case K_1X1_CLAMP:
        nn_conv1x1_clamp_s8__ref(&t->p, &t->q, &t->in, t->x, t->in_s, t->lo, t->hi, &t->filt,
                                 t->w, t->bias, &t->out, o, t->out_s, 0, t->out.c);
        break;
    case K_FC:
        nn_fc_s8__ref(&t->fp, &t->q, t->in.n, t->in.c, t->x, t->in_s, t->w, t->bias, t->out.c, o,
                      t->out_s, 0, t->out.c);
        break;
    }
}

/* The packed path: init, pack, build A, run in random pieces. */
static void run_simd(const pl_kernels_s8 *K, const tcase *t, int8_t *out, int pitch, uint8_t xr)
{
    pl_s8_conv c;
    const int dense = t->k != K_CONV;
    pl_s8_conv_init(&c, &t->p, &t->q, &t->in, &t->filt, &t->out,
                    dense ? PL_S8_A_PACK : t->rows ? PL_S8_A_ROWS : PL_S8_A_PAD);
    void *mem = xmalloc(pl_s8_conv_packed_size(&c, K->layout));
    K->pack(&c, t->w, t->bias, mem);
    if (c.short_requant)
        n_short++;
    else
        n_long++;
    c.out_pitch = pitch;
    c.out_xor = xr;
    uint8_t *a = xmalloc(pl_s8_conv_a_size(&c));
    memset(a, 0xcd, pl_s8_conv_a_size(&c)); /* whatever was there before */
    int cut[9];
    if (dense) {
        const int np = (int)npix(&t->out), n = random_cuts(np, rint_in(1, 4), cut);
        for (int i = 0; i < n; i++)
            K->a_pack(&t->in, t->x, t->in_s, t->k == K_1X1_CLAMP ? t->lo : NULL,
                      t->k == K_1X1_CLAMP ? t->hi : NULL, t->p.stride_h, t->p.stride_w, &t->out, a,
                      c.cs, cut[i], cut[i + 1]);
    } else if (t->rows) {
        const int rows = c.n * c.a_h, n = random_cuts(rows, rint_in(1, 4), cut);
        for (int i = 0; i < n; i++)
            K->a_rows(&t->in, t->x, t->in_s, t->p.pad_h, t->p.pad_w,
                      pl_s8_pad_u(t->p.input_offset), t->filt.w, t->p.stride_w, t->p.dilation_w,
                      c.a_h, c.a_w, a, c.cs, cut[i], cut[i + 1]);
    } else {
        const int rows = c.n * c.a_h, n = random_cuts(rows, rint_in(1, 4), cut);
        for (int i = 0; i < n; i++)
            K->a_pad(&t->in, t->x, t->in_s, t->p.pad_h, t->p.pad_w,
                     pl_s8_pad_u(t->p.input_offset), c.a_h, c.a_w, a, c.cs, cut[i], cut[i + 1]);
    }
    /* pixel pieces x channel pieces, in a shuffled order */
    int pc[9], cc[9], order[64];
    const int np = random_cuts((int)npix(&t->out), rint_in(1, 5), pc);
    const int nc = random_cuts(t->out.c, rint_in(1, 4), cc);
    const int total = np * nc;
    for (int i = 0; i < total; i++)
        order[i] = i;
    for (int i = total - 1; i > 0; i--) {
        const int j = (int)(rnd() % (uint32_t)(i + 1)), tmp = order[i];
        order[i] = order[j];
        order[j] = tmp;
    }
    for (int i = 0; i < total; i++) {
        const int pi = order[i] / nc, ci = order[i] % nc;
        K->run(&c, a, out + t->out_off, t->out_s, pc[pi], pc[pi + 1], cc[ci], cc[ci + 1]);
    }
    free(a);
    free(mem);
}

static void compare(const pl_kernels_s8 *K, const char *isa, const tcase *t, const char *what,
                    int iter)
{
    const size_t nb = out_bytes(t);
    int8_t *want = xmalloc(nb), *got = xmalloc(nb);
    memset(want, GUARD, nb);
    memset(got, GUARD, nb);
    run_ref(t, want);
    if (rnd() % 3) {
        run_simd(K, t, got, 0, 0);
    } else { /* into rows `pitch` pixels apart, as u8 (x + 128) half of the time; back to dense */
        const int pitch = t->out.w + rint_in(0, 3), rows = t->out.n * t->out.h;
        const uint8_t xr = rnd() % 2 ? 0x80 : 0;
        const size_t pb = (size_t)rows * (size_t)pitch * (size_t)t->out_s;
        int8_t *pit = xmalloc(pb);
        memset(pit, GUARD, pb);
        run_simd(K, t, pit, pitch, xr);
        for (int r = 0; r < rows; r++)
            for (int x = 0; x < pitch; x++) {
                int8_t *src = pit + ((size_t)r * (size_t)pitch + (size_t)x) * (size_t)t->out_s;
                if (x >= t->out.w) { /* the gap between rows stays untouched */
                    for (int i = 0; i < t->out_s; i++)
                        CHECK(src[i] == GUARD, "%s %s iter %d: wrote the gap of a pitched output",
                              isa, what, iter);
                    continue;
                }
                int8_t *dst = got + ((size_t)r * (size_t)t->out.w + (size_t)x) * (size_t)t->out_s;
                memcpy(dst, src, (size_t)t->out_s);
                for (int ch = 0; ch < t->out.c; ch++)
                    dst[t->out_off + ch] ^= (int8_t)xr;
            }
        free(pit);
    }
    size_t bad = 0, first = 0;
    for (size_t i = 0; i < nb; i++)
        if (want[i] != got[i] && bad++ == 0) first = i;
    CHECK(bad == 0,
          "%s %s iter %d: %zu bytes differ, first at %zu (want %d got %d); in %dx%dx%dx%d "
          "(stride %d) filt %dx%dx%d out %dx%dx%dx%d (stride %d, offset %d) in_off %d",
          isa, what, iter, bad, first, want[bad ? first : 0], got[bad ? first : 0], t->in.n,
          t->in.h, t->in.w, t->in.c, t->in_s, t->filt.n, t->filt.h, t->filt.w, t->out.n, t->out.h,
          t->out.w, t->out.c, t->out_s, t->out_off, t->p.input_offset);
    free(want);
    free(got);
}

/* A random case; big: the network's sizes (more channels, fewer pixels). */
static void test_case(const pl_kernels_s8 *K, const char *isa, kind k, int iter, int big)
{
    tcase t;
    memset(&t, 0, sizeof t);
    t.k = k;
    nn_conv_s8_params *p = &t.p;
    const int n = rint_in(1, 2);
    int ih = rint_in(1, 15), iw = rint_in(1, 27), in_c = rint_in(1, 70), out_c = rint_in(1, 70);
    if (big) {
        ih = rint_in(1, 6);
        iw = rint_in(1, 14);
        in_c = rnd() % 2 ? 128 : rint_in(64, MAXC);
        out_c = rnd() % 2 ? 32 : rint_in(1, 140);
    }
    int kh = 1, kw = 1, oh, ow;
    p->stride_h = p->stride_w = p->dilation_h = p->dilation_w = 1;
    if (k == K_CONV) {
        const int maxk = big ? 3 : 5;
        kh = rint_in(1, maxk);
        kw = rint_in(1, maxk);
        p->stride_h = rint_in(1, 3);
        p->stride_w = rint_in(1, 3);
        p->dilation_h = rint_in(1, 2);
        p->dilation_w = rint_in(1, 2);
        if (big && in_c * kh * kw > 65536) in_c = 65536 / (kh * kw);
        p->pad_h = rint_in(0, (kh - 1) * p->dilation_h);
        p->pad_w = rint_in(0, (kw - 1) * p->dilation_w);
        const int mh = (ih + p->pad_h - 1) / p->stride_h + 1,
                  mw = (iw + p->pad_w - 1) / p->stride_w + 1;
        oh = rnd() % 2 ? mh : rint_in(1, mh);
        ow = rnd() % 2 ? mw : rint_in(1, mw);
    } else if (k == K_FC) {
        ih = iw = 1;
        oh = ow = 1;
        in_c = rint_in(1, big ? 3072 : 300);
        out_c = rint_in(1, big ? 600 : 70);
    } else {
        p->stride_h = rnd() % 3 ? 1 : rint_in(1, 3);
        p->stride_w = rnd() % 3 ? 1 : rint_in(1, 3);
        oh = (ih - 1) / p->stride_h + 1;
        ow = (iw - 1) / p->stride_w + 1;
    }
    t.in = (nn_dims){n, ih, iw, in_c};
    t.filt = (nn_dims){out_c, kh, kw, in_c};
    t.out = (nn_dims){n, oh, ow, out_c};
    t.in_s = in_c + (rnd() % 2 ? 0 : rint_in(1, 9));
    t.out_off = rnd() % 2 ? 0 : rint_in(1, 7);
    t.out_s = out_c + t.out_off + (rnd() % 2 ? 0 : rint_in(0, 9));
    p->input_offset = rnd() % 4 == 0 ? 128 : rnd() % 4 == 0 ? -127 : rint_in(-127, 128);
    p->output_offset = rint_in(-128, 127);
    random_act(&p->act_min, &p->act_max);
    if (k == K_FC) {
        t.fp = (nn_fc_s8_params){p->input_offset, 0, p->output_offset, p->act_min, p->act_max, 1};
        CHECK(nn_fc_s8_check(&t.fp, n, in_c, t.in_s, out_c, t.out_s) == PL_OK, "fc check: %s",
              pl_last_error());
    } else if (k == K_CONV) {
        CHECK(nn_conv2d_s8_check(p, &t.in, t.in_s, &t.filt, &t.out, t.out_s) == PL_OK,
              "conv check: %s", pl_last_error());
    } else {
        CHECK(nn_conv1x1_s8_check(p, &t.in, t.in_s, &t.filt, &t.out, t.out_s) == PL_OK,
              "conv1x1 check: %s", pl_last_error());
    }

    const size_t n_w = (size_t)out_c * (size_t)kh * (size_t)kw * (size_t)in_c;
    const size_t n_x = npix(&t.in) * (size_t)t.in_s;
    int8_t *w = xmalloc(n_w), *x = xmalloc(n_x);
    int8_t lo[MAXC * 4], hi[MAXC * 4];
    const int mode = iter % 8 < 4 ? iter % 8 : 0; /* extremes: all -128, all 127, only +-extremes */
    fill_s8(w, n_w, mode);
    fill_s8(x, n_x, mode == 0 ? 0 : 4 - mode);
    for (int ch = 0; ch < in_c; ch++) {
        int a = rint_in(-128, 127), b = rint_in(-128, 127);
        if (rnd() % 4 == 0) a = -128;
        if (rnd() % 4 == 0) b = 127;
        lo[ch] = (int8_t)(a < b ? a : b);
        hi[ch] = (int8_t)(a < b ? b : a);
    }
    int32_t *mult = xmalloc(sizeof(int32_t) * (size_t)out_c),
            *shift = xmalloc(sizeof(int32_t) * (size_t)out_c),
            *bias = xmalloc(sizeof(int32_t) * (size_t)out_c);
    random_quant(out_c, mult, shift, bias);
    if (k == K_FC && rnd() % 3 == 0) { /* per tensor, as repeated values */
        for (int o = 1; o < out_c; o++) {
            mult[o] = mult[0];
            shift[o] = shift[0];
        }
    }
    if (iter % 2) {
        short_quant(out_c, kh * kw * in_c, w, shift, bias, &p->act_min, &p->act_max);
        t.fp.act_min = p->act_min;
        t.fp.act_max = p->act_max;
    }
    t.q = (nn_per_channel_quant){mult, shift};
    t.x = x;
    t.w = w;
    t.lo = lo;
    t.hi = hi;
    t.bias = rnd() % 4 ? bias : NULL;
    static const char *const names[] = {"conv2d", "conv1x1", "conv1x1_clamp", "fc"};
    compare(K, isa, &t, names[k], iter);
    if (k == K_CONV) { /* the same convolution with the row taps folded into the channels */
        t.rows = 1;
        compare(K, isa, &t, "conv2d (a_rows)", iter);
    }
    free(w);
    free(x);
    free(mult);
    free(shift);
    free(bias);
}

/* Pooling and clamping: maxpool vs nn_maxpool2d_s8__ref, avgpool (with and without the clamp,
 * with out_xor 0 and 0x80) vs nn_clamp_s8__ref + nn_avgpool2d_s8__ref, clamp vs nn_clamp_s8__ref,
 * over random windows (clipped ones included, so divisors that are not powers of two), pixel
 * strides and pixel pieces. */
static void test_pools(const pl_kernels_s8 *K, const char *isa, int iter)
{
    const int n = rint_in(1, 2), ih = rint_in(1, 12), iw = rint_in(1, 12);
    const int C = rnd() % 4 == 0 ? rint_in(200, 600) : rint_in(1, 70);
    nn_pool_s8_params p;
    p.kernel_h = rint_in(1, 4);
    p.kernel_w = rint_in(1, 4);
    p.stride_h = rint_in(1, 3);
    p.stride_w = rint_in(1, 3);
    p.pad_h = rint_in(0, p.kernel_h - 1);
    p.pad_w = rint_in(0, p.kernel_w - 1);
    if (iter % 3 == 0) p = (nn_pool_s8_params){2, 2, 2, 2, 0, 0, -128, 127};
    random_act(&p.act_min, &p.act_max);
    const int mh = (ih + p.pad_h - 1) / p.stride_h + 1, mw = (iw + p.pad_w - 1) / p.stride_w + 1;
    const int oh = rnd() % 2 ? mh : rint_in(1, mh), ow = rnd() % 2 ? mw : rint_in(1, mw);
    const nn_dims in = {n, ih, iw, C}, out = {n, oh, ow, C};
    const int in_s = C + (rnd() % 2 ? 0 : rint_in(1, 9)), out_s = C + (rnd() % 2 ? 0 : 3);
    CHECK(nn_pool2d_s8_check(&p, &in, in_s, &out, out_s) == PL_OK, "pool check: %s",
          pl_last_error());
    const size_t nx = npix(&in) * (size_t)in_s, no = npix(&out) * (size_t)out_s;
    int8_t *x = xmalloc(nx), *xc = xmalloc(nx), *want = xmalloc(no), *got = xmalloc(no);
    int8_t lo[600], hi[600];
    fill_s8(x, nx, iter % 8 < 4 ? iter % 8 : 0);
    for (int ch = 0; ch < C; ch++) {
        const int a = rint_in(-128, 127), b = rint_in(-128, 127);
        lo[ch] = (int8_t)(a < b ? a : b);
        hi[ch] = (int8_t)(a < b ? b : a);
    }
    int cut[9];
    const int np = (int)npix(&out);

    memset(want, GUARD, no);
    memset(got, GUARD, no);
    nn_maxpool2d_s8__ref(&p, &in, x, in_s, &out, want, out_s, 0, C);
    int pieces = random_cuts(np, rint_in(1, 4), cut);
    for (int i = 0; i < pieces; i++)
        K->maxpool(&p, &in, x, in_s, &out, got, out_s, cut[i], cut[i + 1]);
    CHECK(memcmp(want, got, no) == 0, "%s maxpool iter %d (in %dx%dx%dx%d, k %dx%d)", isa, iter,
          n, ih, iw, C, p.kernel_h, p.kernel_w);

    const int clamp = rnd() % 2;
    const uint8_t xr = rnd() % 2 ? 0x80 : 0;
    memcpy(xc, x, nx);
    if (clamp) nn_clamp_s8__ref(&in, xc, in_s, lo, hi, 0, C);
    memset(want, GUARD, no);
    memset(got, GUARD, no);
    nn_avgpool2d_s8__ref(&p, &in, xc, in_s, &out, want, out_s, 0, C);
    for (int o = 0; o < np; o++)
        for (int ch = 0; ch < C; ch++)
            want[(size_t)o * (size_t)out_s + (size_t)ch] ^= (int8_t)xr;
    pieces = random_cuts(np, rint_in(1, 4), cut);
    for (int i = 0; i < pieces; i++)
        K->avgpool(&p, &in, x, in_s, clamp ? lo : NULL, clamp ? hi : NULL, &out, (uint8_t *)got,
                   out_s, xr, cut[i], cut[i + 1]);
    CHECK(memcmp(want, got, no) == 0, "%s avgpool iter %d (clamp %d, xor %d, in %dx%dx%dx%d, k %dx%d)",
          isa, iter, clamp, xr, n, ih, iw, C, p.kernel_h, p.kernel_w);

    memcpy(xc, x, nx);
    nn_clamp_s8__ref(&in, xc, in_s, lo, hi, 0, C);
    int8_t *xs = xmalloc(nx);
    memcpy(xs, x, nx);
    pieces = random_cuts((int)npix(&in), rint_in(1, 4), cut);
    for (int i = 0; i < pieces; i++)
        K->clamp(&in, xs, in_s, lo, hi, cut[i], cut[i + 1]);
    CHECK(memcmp(xc, xs, nx) == 0, "%s clamp iter %d", isa, iter);
    free(xs);
    free(x);
    free(xc);
    free(want);
    free(got);
}

/* The network's shapes at a reduced size: a dense layer's clamped 1x1 (cin 224 -> 128) and its
 * 3x3 128 -> 32 with input offset 128, the stem 7x7/2 on 3 channels (unpadded, offset 128). */
static void test_network_shapes(const pl_kernels_s8 *K, const char *isa)
{
    for (int s = 0; s < 3; s++) {
        tcase t;
        memset(&t, 0, sizeof t);
        nn_conv_s8_params *p = &t.p;
        p->stride_h = p->stride_w = p->dilation_h = p->dilation_w = 1;
        p->input_offset = 128;
        p->output_offset = s == 0 ? -128 : 0;
        p->act_min = s == 0 ? -128 : -128;
        p->act_max = 127;
        int ih = 12, iw = 16, in_c = 224, out_c = 128, kh = 1, kw = 1;
        t.k = K_1X1_CLAMP;
        t.rows = s == 2;
        if (s == 1) {
            t.k = K_CONV;
            in_c = 128;
            out_c = 32;
            kh = kw = 3;
            p->pad_h = p->pad_w = 1;
        } else if (s == 2) {
            t.k = K_CONV;
            in_c = 3;
            out_c = 64;
            kh = kw = 7;
            ih = 30;
            iw = 38;
            p->stride_h = p->stride_w = 2;
        }
        const int oh = (ih + 2 * p->pad_h - kh) / p->stride_h + 1,
                  ow = (iw + 2 * p->pad_w - kw) / p->stride_w + 1;
        t.in = (nn_dims){1, ih, iw, in_c};
        t.filt = (nn_dims){out_c, kh, kw, in_c};
        t.out = (nn_dims){1, oh, ow, out_c};
        t.in_s = s == 0 ? 256 : in_c;
        t.out_off = s == 1 ? 224 : 0;
        t.out_s = s == 1 ? 256 : out_c;
        const size_t n_w = (size_t)out_c * (size_t)kh * (size_t)kw * (size_t)in_c;
        int8_t *w = xmalloc(n_w), *x = xmalloc(npix(&t.in) * (size_t)t.in_s);
        int8_t lo[256], hi[256];
        fill_s8(w, n_w, 0);
        fill_s8(x, npix(&t.in) * (size_t)t.in_s, 0);
        for (int ch = 0; ch < in_c; ch++) {
            lo[ch] = (int8_t)rint_in(-128, 0);
            hi[ch] = 127;
        }
        int32_t mult[128], shift[128], bias[128];
        random_quant(out_c, mult, shift, bias);
        for (int o = 0; o < out_c; o++) {
            shift[o] = rint_in(-12, -6);
            bias[o] = rint_in(-(1 << 18), 1 << 18);
        }
        t.q = (nn_per_channel_quant){mult, shift};
        t.x = x;
        t.w = w;
        t.lo = lo;
        t.hi = hi;
        t.bias = bias;
        compare(K, isa, &t, s == 0 ? "dense conv1" : s == 1 ? "dense conv2" : "stem", s);
        free(w);
        free(x);
    }
}

/* Every test on one path's slots; returns 1 when it ran them all exactly. */
static int run_path(const pl_kernels_s8 *K, const char *isa)
{
    const int before = failures;
    for (int iter = 0; iter < 300; iter++) {
        test_case(K, isa, K_CONV, iter, 0);
        test_case(K, isa, K_1X1, iter, 0);
        test_case(K, isa, K_1X1_CLAMP, iter, 0);
        test_case(K, isa, K_FC, iter, 0);
    }
    for (int iter = 0; iter < 40; iter++) {
        test_case(K, isa, K_CONV, iter, 1);
        test_case(K, isa, K_1X1_CLAMP, iter, 1);
        test_case(K, isa, K_FC, iter, 1);
    }
    for (int iter = 0; iter < 200; iter++)
        test_pools(K, isa, iter);
    test_network_shapes(K, isa);
    CHECK(n_short > 300 && n_long > 300,
          "%s: %d convolutions qualified for the short requantisation, %d did not: both "
          "should be well covered",
          isa, n_short, n_long);
    printf("path %s: %d convolutions qualified for the short requantisation (AVX-512 runs "
           "it), %d did not\n",
           isa, n_short, n_long);
    n_short = n_long = 0;
    printf("path %s: %s (%s, %s, %s)\n", isa, failures == before ? "ok" : "FAILED", K->run_name,
           K->a_pack_name, K->a_pad_name);
    return failures == before;
}

int main(void)
{
    /* avx512f has no int8 kernel of its own (AVX-512 without VNNI runs avx2's); amx runs only
     * where the CPU has AMX and Linux grants the tile state */
    static const pl_isa paths[] = {PL_ISA_AVX2, PL_ISA_AVXVNNI, PL_ISA_AVX512VNNI, PL_ISA_AMX,
                                   PL_ISA_NEON, PL_ISA_DOTPROD, PL_ISA_I8MM};
    int ran = 0;
    for (size_t i = 0; i < sizeof paths / sizeof paths[0]; i++) {
        const char *isa = pl_isa_name(paths[i]);
        pl_kernels k;
        if (pl_kernels_for(paths[i], &k) < 0) {
            printf("path %s: not available here (%s), skipped\n", isa, pl_last_error());
            continue;
        }
        if (!k.s8.packed) {
            printf("path %s: no packed int8 kernels in this build, skipped\n", isa);
            continue;
        }
        run_path(&k.s8, isa);
        ran++;
    }
#if defined(__x86_64__)
    /* The AMX kernel with its tile instructions emulated (kernels/x86/nn_conv_packed_s8_tmpl.h):
     * its packing, tile shapes, accumulation and requantisation on any AVX-512 VNNI CPU. */
    pl_kernels k;
    if (pl_kernels_for(PL_ISA_AVX512VNNI, &k) == 0 && k.s8.packed) {
        k.s8.run = nn_conv_packed_s8_16x32c4_amxemu__avx512vnni;
        k.s8.run_name = "nn_conv_packed_s8_16x32c4_amxemu__avx512vnni";
        run_path(&k.s8, "amx (tiles emulated)");
        ran++;
    } else {
        printf("path amx (tiles emulated): needs avx512vnni, skipped\n");
    }
#endif
    if (failures) {
        printf("%d failures\n", failures);
        return 1;
    }
    if (!ran) {
        printf("no SIMD int8 path available on this CPU or build\n");
        return 77;
    }
    return 0;
}
