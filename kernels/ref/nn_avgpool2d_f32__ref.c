#include "kernels/ref/nn_ref.h"

void nn_avgpool2d_f32__ref(const nn_pool_params *p, const float *in, float *out, int c_begin,
                           int c_end)
{
    const float inv = 1.0f / (float)(p->k * p->k);
    for (int c = c_begin; c < c_end; c++) {
        const float *x = in + (size_t)c * p->in_h * p->in_w;
        float *y = out + (size_t)c * p->out_h * p->out_w;
        for (int oy = 0; oy < p->out_h; oy++)
            for (int ox = 0; ox < p->out_w; ox++) {
                float sum = 0.0f;
                for (int ky = 0; ky < p->k; ky++)
                    for (int kx = 0; kx < p->k; kx++)
                        sum += x[(oy * p->stride + ky) * p->in_w + ox * p->stride + kx];
                y[oy * p->out_w + ox] = sum * inv;
            }
    }
}
