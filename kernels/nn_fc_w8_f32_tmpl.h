/* nn_fc_w8_f32 (kernels/ref/nn_ref.h) on SIMD, equal to the reference bit for bit
 * (kernels/x86/nn_fc_w8_f32__*.c; Arm keeps the reference, which gcc vectorises for NEON: a NEON
 * build of this file was predicted slower on the Pi 5, kernels/arm/nn_f32_arm.h).
 *
 * The reference fixes each dot product's order: 32 partial sums, lane k taking the products of
 * inputs i with i % 32 == k in increasing i, then reduced pairwise (k += k + 16, k += k + 8, ...),
 * then the last n_in % 32 products one by one, then wscale * sum + bias and the ReLU. The 32 lanes
 * are NV vectors of VL floats here, each multiplied and added separately (no fused multiply-add:
 * the build's -ffp-contract=off keeps the compiler from contracting them, as it does the
 * reference's), so every
 * partial sum sees the same roundings in the same order; only the pairwise tail is done in plain
 * C, once per output. The int8 weights are widened to float (exact) as they are read.
 *
 * Register blocking: RB input rows x OB weight rows share each weight vector and each input
 * vector (a kept-float transition has its pooled pixels as rows; the kept-float fc one row, with
 * OB1 weight rows at a time). The including file defines FCW8_FN (the name), FCW8_VL (floats per
 * vector), FCW8_LOAD_W(p) (VL int8 at p as a vector of floats), FCW8_RB, FCW8_OB and FCW8_OB1,
 * chosen so that RB*OB*NV accumulators, OB*NV weight vectors and one input vector fit the path's
 * registers. */
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#define FCW8_LANES 32 /* the reference's LANES */
#define NV (FCW8_LANES / FCW8_VL)

typedef float fcw8_vf __attribute__((vector_size(FCW8_VL * sizeof(float))));

#define INLINE static inline __attribute__((always_inline))

INLINE fcw8_vf load_f(const float *p)
{
    fcw8_vf v;
    memcpy(&v, p, sizeof v);
    return v;
}

/* VL int8 weights widened to float: FCW8_LOAD_W(p), the path's intrinsics (gcc 12 widens a
 * generic byte vector one element at a time) */
INLINE fcw8_vf load_w(const int8_t *p)
{
    return (fcw8_vf)FCW8_LOAD_W(p);
}

/* The reference's end of a dot product: the pairwise reduction of the 32 lanes, the products
 * past the last multiple of 32 in order, the scale, the bias and the ReLU. */
static float finish(const fcw8_vf acc[NV], const float *x, const int8_t *wr, int i0, int n_in,
                    float scale, float bias, int relu)
{
    float a[FCW8_LANES];
    memcpy(a, acc, sizeof a);
    for (int s = FCW8_LANES / 2; s > 0; s /= 2)
        for (int k = 0; k < s; k++)
            a[k] += a[k + s];
    float sum = a[0];
    for (int i = i0; i < n_in; i++)
        sum += (float)wr[i] * x[i];
    const float v = scale * sum + bias;
    return relu && v < 0.0f ? 0.0f : v;
}

/* nr input rows from r0 x no weight rows from o (nr <= RB, no <= OB or OB1: constants once
 * inlined, so the accumulators live in registers). */
INLINE void block(const int nr, const int no, const float *in, int r0, int n_in, const int8_t *w,
                  int o, const float *wscale, const float *bias, int relu, float *out,
                  size_t out_stride)
{
    enum { OBMAX = FCW8_OB > FCW8_OB1 ? FCW8_OB : FCW8_OB1 };
    fcw8_vf acc[FCW8_RB][OBMAX][NV];
#pragma GCC unroll 16
    for (int r = 0; r < nr; r++)
#pragma GCC unroll 16
        for (int b = 0; b < no; b++)
#pragma GCC unroll 16
            for (int v = 0; v < NV; v++)
                acc[r][b][v] = (fcw8_vf){0};
    const int n32 = n_in & ~(FCW8_LANES - 1);
    const int8_t *wr[OBMAX];
    const float *xr[FCW8_RB];
#pragma GCC unroll 16
    for (int b = 0; b < no; b++)
        wr[b] = w + (size_t)(o + b) * (size_t)n_in;
#pragma GCC unroll 16
    for (int r = 0; r < nr; r++)
        xr[r] = in + (size_t)(r0 + r) * (size_t)n_in;
    for (int i = 0; i < n32; i += FCW8_LANES) {
        fcw8_vf wv[OBMAX][NV];
#pragma GCC unroll 16
        for (int b = 0; b < no; b++)
#pragma GCC unroll 16
            for (int v = 0; v < NV; v++)
                wv[b][v] = load_w(wr[b] + i + v * FCW8_VL);
#pragma GCC unroll 16
        for (int r = 0; r < nr; r++)
#pragma GCC unroll 16
            for (int v = 0; v < NV; v++) {
                const fcw8_vf x = load_f(xr[r] + i + v * FCW8_VL);
#pragma GCC unroll 16
                for (int b = 0; b < no; b++)
                    acc[r][b][v] += wv[b][v] * x; /* rounded product, then rounded sum */
            }
    }
    for (int r = 0; r < nr; r++)
        for (int b = 0; b < no; b++)
            out[(size_t)(r0 + r) * out_stride + (size_t)(o + b)] =
                finish(acc[r][b], xr[r], wr[b], n32, n_in, wscale[o + b],
                       bias ? bias[o + b] : 0.0f, relu);
}

void FCW8_FN(const float *in, int n_rows, int n_in, const int8_t *w, const float *wscale,
             const float *bias, int relu, float *out, int out_stride, int o_begin, int o_end)
{
    const size_t os = (size_t)out_stride;
    if (n_rows == 1) {
        int o = o_begin;
        for (; o + FCW8_OB1 <= o_end; o += FCW8_OB1)
            block(1, FCW8_OB1, in, 0, n_in, w, o, wscale, bias, relu, out, os);
        for (; o < o_end; o++)
            block(1, 1, in, 0, n_in, w, o, wscale, bias, relu, out, os);
        return;
    }
    int o = o_begin;
    for (; o + FCW8_OB <= o_end; o += FCW8_OB) {
        int r = 0;
        for (; r + FCW8_RB <= n_rows; r += FCW8_RB)
            block(FCW8_RB, FCW8_OB, in, r, n_in, w, o, wscale, bias, relu, out, os);
        for (; r < n_rows; r++)
            block(1, FCW8_OB, in, r, n_in, w, o, wscale, bias, relu, out, os);
    }
    for (; o < o_end; o++) {
        int r = 0;
        for (; r + FCW8_RB <= n_rows; r += FCW8_RB)
            block(FCW8_RB, 1, in, r, n_in, w, o, wscale, bias, relu, out, os);
        for (; r < n_rows; r++)
            block(1, 1, in, r, n_in, w, o, wscale, bias, relu, out, os);
    }
}

#undef NV
#undef INLINE
