/* Max and average pooling, fp32 (kernels/ref/nn_ref.h), written so the compiler vectorises
 * across the output row: each output keeps the reference's order of operations (taps in ky, kx
 * order, max as `v > m ? v : m` from -inf, the average's sum from 0 then times 1/k^2, no
 * contraction under -std=c11), so the results equal the reference bit for bit. The including
 * file defines MAXPOOL_FN and AVGPOOL_FN and is compiled with its ISA's flags. */
#include <math.h>
#include <stddef.h>
#include <string.h>

#include "kernels/x86/nn_f32_x86.h"

typedef float pool_v8 __attribute__((vector_size(32)));
typedef int pool_i8 __attribute__((vector_size(32)));

/* v > m ? v : m lane by lane (GNU C vectors, gcc >= 12 or clang) */
static inline __attribute__((always_inline)) pool_v8 pool_max8(pool_v8 v, pool_v8 m)
{
    const pool_i8 gt = v > m;
    return (pool_v8)((gt & (pool_i8)v) | (~gt & (pool_i8)m));
}

void MAXPOOL_FN(const nn_pool_params *p, const float *in, float *out, int c_begin, int c_end)
{
    const int s = p->stride;
    for (int c = c_begin; c < c_end; c++) {
        const float *x = in + (size_t)c * p->in_h * p->in_w;
        float *y = out + (size_t)c * p->out_h * p->out_w;
        for (int oy = 0; oy < p->out_h; oy++) {
            float *yr = y + (size_t)oy * p->out_w;
            for (int ox = 0; ox < p->out_w; ox++) yr[ox] = -INFINITY;
            for (int ky = 0; ky < p->k; ky++) {
                const int iy = oy * s - p->pad + ky;
                if (iy < 0 || iy >= p->in_h) continue;
                if (p->k == 3 && s == 2) {
                    /* the stem's 3x3/2: the columns whose three taps all lie inside take them in
                     * one pass (same kx order), the others tap by tap below */
                    const int pad = p->pad, lo = (pad + 1) / 2;
                    int hi = p->in_w - 3 + pad < 0 ? 0 : (p->in_w - 3 + pad) / 2 + 1;
                    if (hi > p->out_w) hi = p->out_w;
                    const float *restrict xr = x + (size_t)iy * p->in_w;
                    float *restrict ym = yr;
                    int ox = lo;
                    /* 8 outputs at a time where the 18 columns they read lie inside the row:
                     * taps deinterleaved by shuffles, `v > m ? v : m` as a mask select */
                    for (; ox + 8 <= hi && 2 * ox - pad + 18 <= p->in_w; ox += 8) {
                        const float *xo = xr + 2 * ox - pad;
                        pool_v8 a0, a1, b0, b1, mm;
                        memcpy(&a0, xo, sizeof a0);
                        memcpy(&a1, xo + 8, sizeof a1);
                        memcpy(&b0, xo + 2, sizeof b0);
                        memcpy(&b1, xo + 10, sizeof b1);
                        memcpy(&mm, ym + ox, sizeof mm);
                        mm = pool_max8(__builtin_shufflevector(a0, a1, 0, 2, 4, 6, 8, 10, 12, 14),
                                       mm);
                        mm = pool_max8(__builtin_shufflevector(a0, a1, 1, 3, 5, 7, 9, 11, 13, 15),
                                       mm);
                        mm = pool_max8(__builtin_shufflevector(b0, b1, 0, 2, 4, 6, 8, 10, 12, 14),
                                       mm);
                        memcpy(ym + ox, &mm, sizeof mm);
                    }
                    for (; ox < hi; ox++) {
                        const float *xo = xr + 2 * ox - pad;
                        float mm = ym[ox];
                        mm = xo[0] > mm ? xo[0] : mm;
                        mm = xo[1] > mm ? xo[1] : mm;
                        ym[ox] = xo[2] > mm ? xo[2] : mm;
                    }
                    for (int oe = 0; oe < p->out_w; oe++) { /* the edges: [0, lo), [hi, out_w) */
                        if (oe == lo && hi > lo) oe = hi;
                        if (oe >= p->out_w) break;
                        for (int kx = 0; kx < 3; kx++) {
                            const int ix = oe * 2 - pad + kx;
                            if (ix < 0 || ix >= p->in_w) continue;
                            ym[oe] = xr[ix] > ym[oe] ? xr[ix] : ym[oe];
                        }
                    }
                    continue;
                }
                for (int kx = 0; kx < p->k; kx++) {
                    /* output columns whose input column ox*s - pad + kx lies in [0, in_w) */
                    const int lo = p->pad - kx > 0 ? (p->pad - kx + s - 1) / s : 0;
                    int hi = (p->in_w - 1 + p->pad - kx) / s + 1;
                    if (hi > p->out_w) hi = p->out_w;
                    const float *xr = x + (size_t)iy * p->in_w + kx - p->pad;
                    for (int ox = lo; ox < hi; ox++) {
                        const float v = xr[ox * s];
                        yr[ox] = v > yr[ox] ? v : yr[ox];
                    }
                }
            }
        }
    }
}

void AVGPOOL_FN(const nn_pool_params *p, const float *in, float *out, int c_begin, int c_end)
{
    const float inv = 1.0f / (float)(p->k * p->k);
    const int s = p->stride;
    for (int c = c_begin; c < c_end; c++) {
        const float *x = in + (size_t)c * p->in_h * p->in_w;
        float *y = out + (size_t)c * p->out_h * p->out_w;
        if (p->k == 2 && s == 2) { /* the transitions' 2x2/2: one sum per output in registers */
            for (int oy = 0; oy < p->out_h; oy++) {
                float *restrict yr = y + (size_t)oy * p->out_w;
                const float *restrict r0 = x + (size_t)(2 * oy) * p->in_w;
                const float *restrict r1 = r0 + p->in_w;
                for (int ox = 0; ox < p->out_w; ox++) {
                    const float sum = ((0.0f + r0[2 * ox]) + r0[2 * ox + 1]) + r1[2 * ox];
                    yr[ox] = (sum + r1[2 * ox + 1]) * inv;
                }
            }
            continue;
        }
        for (int oy = 0; oy < p->out_h; oy++) {
            float *yr = y + (size_t)oy * p->out_w;
            for (int ox = 0; ox < p->out_w; ox++) yr[ox] = 0.0f;
            for (int ky = 0; ky < p->k; ky++) {
                const float *xr = x + (size_t)(oy * s + ky) * p->in_w;
                for (int kx = 0; kx < p->k; kx++)
                    for (int ox = 0; ox < p->out_w; ox++) yr[ox] += xr[ox * s + kx];
            }
            for (int ox = 0; ox < p->out_w; ox++) yr[ox] *= inv;
        }
    }
}
