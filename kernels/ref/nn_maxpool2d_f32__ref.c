#include "kernels/ref/nn_ref.h"

#include <math.h>

void nn_maxpool2d_f32__ref(const nn_pool_params *p, const float *in, float *out, int c_begin,
                           int c_end)
{
    for (int c = c_begin; c < c_end; c++) {
        const float *x = in + (size_t)c * p->in_h * p->in_w;
        float *y = out + (size_t)c * p->out_h * p->out_w;
        for (int oy = 0; oy < p->out_h; oy++)
            for (int ox = 0; ox < p->out_w; ox++) {
                float m = -INFINITY;
                for (int ky = 0; ky < p->k; ky++) {
                    const int iy = oy * p->stride - p->pad + ky;
                    if (iy < 0 || iy >= p->in_h) continue;
                    for (int kx = 0; kx < p->k; kx++) {
                        const int ix = ox * p->stride - p->pad + kx;
                        if (ix < 0 || ix >= p->in_w) continue;
                        const float v = x[iy * p->in_w + ix];
                        m = v > m ? v : m;
                    }
                }
                y[oy * p->out_w + ox] = m;
            }
    }
}
