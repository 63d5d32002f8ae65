/* The packed fp32 convolution's driver (kernels/kernels_f32.h), shared by the x86 and Arm paths
 * (kernels/x86/nn_conv_gemm_f32_*.c, kernels/arm/nn_conv_gemm_f32_*.c).
 *
 * The including file includes its prototypes (kernels/<arch>/nn_f32_<arch>.h) and defines, before
 * including this one:
 *   CONV_GEMM_FN            the kernel's name
 *   static void ukr(int k, const float *a, const float *b, float *c, size_t ldc, int rows,
 *                   int cols, const float *bias, int accumulate, int relu)
 *       an MR x NR block: c[r*ldc + j] for r < rows, j < cols, from a [k][MR] panel and a
 *       [k][NR] B block, starting from bias[r] (NULL: 0) or, with `accumulate`, from c itself;
 *       ReLU at the end when `relu`
 *   static void copy_masked(float *d, const float *s, const int32_t *mask)
 *       d[j] = mask[j] ? s[j] : 0 for j < NR, never reading s[j] where mask[j] == 0
 *   static void gather_row(float *d, const float *x, const int32_t *tab, int ky, int kx,
 *                          int h, int w)
 *       with iy = tab[NR + j] + ky, ix = tab[2*NR + j] + kx: d[j] = x[tab[j] + ky*w + kx] where
 *       0 <= iy < h and 0 <= ix < w, else 0 (a masked gather), for j < NR
 *
 * Loop order per tile: for each block of KC rows of K, build that block of B (KC x NR, written
 * and then read from L1), then multiply every panel of the range with it while the weight panels
 * stream from L2. The summation order of an output depends only on K, never on the tile or panel
 * range. */
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "kernels/kernels_f32.h"

#define KC PL_F32_KC

typedef float gemm_v8 __attribute__((vector_size(32)));

/* The address s + delta (delta may lead outside the plane: copy_masked never reads there). */
static const float *offset_ptr(const float *s, ptrdiff_t delta)
{
    return (const float *)((uintptr_t)s + (uintptr_t)(delta * (ptrdiff_t)sizeof(float)));
}

/* B rows [k0, k1) of a tile into b.
 *
 * Each packer prefetches what the next tile will read of the rows it reads: with one stream per
 * input channel (hundreds, a plane apart) the hardware prefetchers do not keep up, and a block's
 * planes are larger than L2. */

/* The NR + 16 floats from s (prefetching never faults, s may lie outside the plane). */
static void prefetch_next(const float *s)
{
    for (int i = 0; i < PL_F32_NR + 16; i += 16) __builtin_prefetch(s + i); /* read, T0 */
}

/* 1x1, stride 1, pad 0: B row k is input channel k, optionally through max(0, scale*x + shift). */
static void pack_1x1(const pl_f32_conv *c, const float *in, size_t plane, int n0, int cols,
                     int k0, int k1, float *b)
{
    for (int k = k0; k < k1; k++) {
        const float *x = in + (size_t)k * plane + n0;
        float *d = b + (size_t)(k - k0) * PL_F32_NR;
        prefetch_next(offset_ptr(x, PL_F32_NR));
        if (c->in_scale) {
            const float s = c->in_scale[k], t = c->in_shift[k];
            for (int j = 0; j < cols; j++) {
                const float v = s * x[j] + t;
                d[j] = v > 0.0f ? v : 0.0f;
            }
        } else {
            for (int j = 0; j < cols; j++) d[j] = x[j];
        }
        for (int j = cols; j < PL_F32_NR; j++) d[j] = 0.0f;
    }
}

/* Stride 1 with in_w == out_w: pixel n's tap (ky, kx) reads input n + (ky-pad)*w + (kx-pad), so
 * each B row is a shifted copy of the input plane under a per-tap validity mask (shift_masks,
 * once per tile). */
static void shift_masks(const nn_conv_params *p, int n0, int cols, int32_t *masks)
{
    const int w = p->out_w, oy0 = n0 / w, ox0 = n0 % w;
    for (int ky = 0; ky < p->k_h; ky++) {
        for (int kx = 0; kx < p->k_w; kx++) {
            int32_t *m = masks + (ky * p->k_w + kx) * PL_F32_NR;
            int oy = oy0, ox = ox0;
            for (int j = 0; j < PL_F32_NR; j++) {
                const int iy = oy + ky - p->pad, ix = ox + kx - p->pad;
                m[j] = j < cols && iy >= 0 && iy < p->in_h && ix >= 0 && ix < p->in_w ? -1 : 0;
                if (++ox == w) {
                    ox = 0;
                    oy++;
                }
            }
        }
    }
}

static void pack_shift(const nn_conv_params *p, const float *in, int n0, int k0, int k1,
                       float *b, const int32_t *masks)
{
    const int taps = p->k_h * p->k_w, w = p->out_w;
    const size_t plane = (size_t)p->in_h * p->in_w;
    int ic = k0 / taps, t = k0 % taps;
    for (int k = k0; k < k1; k++) {
        const int ky = t / p->k_w, kx = t % p->k_w;
        const ptrdiff_t delta = (ptrdiff_t)(ky - p->pad) * w + (kx - p->pad);
        if (kx == 0) prefetch_next(offset_ptr(in + (size_t)ic * plane + n0, delta + PL_F32_NR));
        copy_masked(b + (size_t)(k - k0) * PL_F32_NR,
                    offset_ptr(in + (size_t)ic * plane + n0, delta), masks + t * PL_F32_NR);
        if (++t == taps) {
            t = 0;
            ic++;
        }
    }
}

/* Any other stride and padding: an explicit im2col of the tile by masked gathers,
 * from the first input row/column of each of its pixels and the index of that corner
 * (generic_origins, once per tile; pixels past the tile's end get a row that is never valid). */
static void generic_origins(const nn_conv_params *p, int n0, int cols, int32_t *tab)
{
    int32_t *idx = tab, *iy = tab + PL_F32_NR, *ix = tab + 2 * PL_F32_NR;
    for (int j = 0; j < PL_F32_NR; j++) {
        const int n = j < cols ? n0 + j : n0;
        iy[j] = j < cols ? n / p->out_w * p->stride - p->pad : -(1 << 20);
        ix[j] = n % p->out_w * p->stride - p->pad;
        idx[j] = j < cols ? iy[j] * p->in_w + ix[j] : 0;
    }
}

static void pack_generic(const nn_conv_params *p, const float *in, int k0, int k1, float *b,
                         const int32_t *tab)
{
    const int taps = p->k_h * p->k_w;
    const size_t plane = (size_t)p->in_h * p->in_w;
    for (int k = k0; k < k1; k++) {
        const int ic = k / taps, ky = k % taps / p->k_w, kx = k % p->k_w;
        gather_row(b + (size_t)(k - k0) * PL_F32_NR, in + (size_t)ic * plane, tab, ky, kx,
                   p->in_h, p->in_w);
    }
}

/* Stride 2 (the 7x7/2 stem): B row (ic, ky, kx) is, for each output row the tile crosses, every
 * other pixel of one input row, zero where the tap falls in the padding: plain loads the compiler
 * vectorises, instead of generic_origins' gathers. The values are the gathers' exactly. */
static void pack_stride2(const nn_conv_params *p, const float *in, int n0, int cols, int k0,
                         int k1, float *b)
{
    const int taps = p->k_h * p->k_w;
    const size_t plane = (size_t)p->in_h * p->in_w;
    for (int k = k0; k < k1; k++) {
        const int ic = k / taps, ky = k % taps / p->k_w, kx = k % p->k_w;
        float *d = b + (size_t)(k - k0) * PL_F32_NR;
        const float *x = in + (size_t)ic * plane;
        int j = 0, oy = n0 / p->out_w, ox = n0 % p->out_w;
        while (j < cols) {
            const int seg = cols - j < p->out_w - ox ? cols - j : p->out_w - ox;
            const int iy = oy * 2 - p->pad + ky, ix0 = ox * 2 - p->pad + kx;
            float *restrict dd = d + j;
            int lo = 0, hi = 0; /* taps [lo, hi) of the segment read inside the row */
            if (iy >= 0 && iy < p->in_h && ix0 <= p->in_w - 1) {
                lo = ix0 < 0 ? (1 - ix0) / 2 : 0;
                hi = (p->in_w - 1 - ix0) / 2 + 1;
                if (hi > seg) hi = seg;
                if (lo > hi) lo = hi;
            }
            const float *restrict xr = x + (size_t)(iy < 0 ? 0 : iy) * (size_t)p->in_w;
            for (int i = 0; i < lo; i++) dd[i] = 0.0f;
            int i = lo;
            /* 8 at a time where the 16 floats they are taken from lie inside the row: the even
             * ones of two vectors (GNU C vectors, gcc >= 12 or clang, as in the Winograd
             * kernel), one store */
            for (; i + 8 <= hi && ix0 + 2 * i + 16 <= p->in_w; i += 8) {
                gemm_v8 a0, a1;
                memcpy(&a0, xr + ix0 + 2 * i, sizeof a0);
                memcpy(&a1, xr + ix0 + 2 * i + 8, sizeof a1);
                const gemm_v8 e = __builtin_shufflevector(a0, a1, 0, 2, 4, 6, 8, 10, 12, 14);
                memcpy(dd + i, &e, sizeof e);
            }
            for (; i < hi; i++) dd[i] = xr[ix0 + 2 * i];
            for (i = hi; i < seg; i++) dd[i] = 0.0f;
            j += seg;
            ox = 0;
            oy++;
        }
        for (; j < PL_F32_NR; j++) d[j] = 0.0f;
    }
}

void CONV_GEMM_FN(const pl_f32_conv *c, const float *in, float *out, float *scratch,
                  int tile_begin, int tile_end, int panel_begin, int panel_end)
{
    const nn_conv_params *p = &c->p;
    const int K = p->in_c * p->k_h * p->k_w, npix = p->out_h * p->out_w;
    const size_t ldc = (size_t)npix, plane = (size_t)p->in_h * p->in_w;
    float *b = scratch;
    int32_t *tab = (int32_t *)(scratch + (size_t)KC * PL_F32_NR);
    const int is_1x1 = p->k_h == 1 && p->k_w == 1 && p->stride == 1 && p->pad == 0 &&
                       p->in_h == p->out_h && p->in_w == p->out_w;
    const int is_shift = p->stride == 1 && p->in_w == p->out_w;

    for (int t = tile_begin; t < tile_end; t++) {
        const int n0 = t * PL_F32_NR;
        const int cols = npix - n0 < PL_F32_NR ? npix - n0 : PL_F32_NR;
        if (!is_1x1 && is_shift)
            shift_masks(p, n0, cols, tab);
        else if (!is_1x1 && p->stride != 2)
            generic_origins(p, n0, cols, tab);
        for (int k0 = 0; k0 < K; k0 += KC) {
            const int kc = K - k0 < KC ? K - k0 : KC;
            const int last = k0 + kc == K;
            if (is_1x1)
                pack_1x1(c, in, plane, n0, cols, k0, k0 + kc, b);
            else if (is_shift)
                pack_shift(p, in, n0, k0, k0 + kc, b, tab);
            else if (p->stride == 2)
                pack_stride2(p, in, n0, cols, k0, k0 + kc, b);
            else
                pack_generic(p, in, k0, k0 + kc, b, tab);
            for (int pn = panel_begin; pn < panel_end; pn++) {
                const int oc0 = pn * PL_F32_MR;
                const int rows = p->out_c - oc0 < PL_F32_MR ? p->out_c - oc0 : PL_F32_MR;
                ukr(kc, c->w + ((size_t)pn * K + (size_t)k0) * PL_F32_MR, b, out + (size_t)oc0 * ldc + (size_t)n0, ldc, rows,
                    cols, c->bias ? c->bias + oc0 : NULL, k0 > 0, last && p->relu);
            }
        }
    }
}
