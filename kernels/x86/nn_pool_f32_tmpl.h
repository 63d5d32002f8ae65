/* Max and average pooling, fp32 (kernels/ref/nn_ref.h), written so the compiler vectorises
 * across the output row: each output keeps the reference's order of operations (taps in ky, kx
 * order, max as `v > m ? v : m` from -inf, the average's sum from 0 then times 1/k^2, no
 * contraction under -std=c11), so the results equal the reference bit for bit. The including
 * file defines MAXPOOL_FN and AVGPOOL_FN and is compiled with its ISA's flags. */
#include <math.h>
#include <stddef.h>

#include "kernels/x86/nn_f32_x86.h"

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
