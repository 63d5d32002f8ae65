#include "kernels/ref/nn_ref.h"

/* Loop order: output channel, input channel, kernel tap, output row, then a contiguous run of
 * output pixels; the innermost loop is a strided (stride 1: contiguous) axpy the compiler
 * vectorises. Borders are handled by clipping each row's run, never by branches inside it. */
void nn_conv2d_f32__ref(const nn_conv_params *p, const float *in, const float *w,
                        const float *bias, float *out, int oc_begin, int oc_end)
{
    const int ih = p->in_h, iw = p->in_w, oh = p->out_h, ow = p->out_w, s = p->stride;
    const size_t in_plane = (size_t)ih * iw, out_plane = (size_t)oh * ow;
    const size_t w_oc = (size_t)p->in_c * p->k_h * p->k_w;

    for (int oc = oc_begin; oc < oc_end; oc++) {
        float *o = out + (size_t)oc * out_plane;
        const float b = bias ? bias[oc] : 0.0f;
        for (size_t i = 0; i < out_plane; i++) o[i] = b;
        for (int ic = 0; ic < p->in_c; ic++) {
            const float *x = in + (size_t)ic * in_plane;
            const float *wk = w + (size_t)oc * w_oc + (size_t)ic * p->k_h * p->k_w;
            for (int ky = 0; ky < p->k_h; ky++) {
                for (int kx = 0; kx < p->k_w; kx++) {
                    const float wv = wk[ky * p->k_w + kx];
                    /* output columns whose input column ox*s - pad + kx lies in [0, iw) */
                    int lo = p->pad - kx > 0 ? (p->pad - kx + s - 1) / s : 0;
                    int hi = (iw - 1 + p->pad - kx) / s + 1;
                    if (hi > ow) hi = ow;
                    if (lo >= hi) continue;
                    for (int oy = 0; oy < oh; oy++) {
                        const int iy = oy * s - p->pad + ky;
                        if (iy < 0 || iy >= ih) continue;
                        const float *xr = x + (size_t)iy * iw - p->pad + kx;
                        float *orow = o + (size_t)oy * ow;
                        if (s == 1) {
                            for (int ox = lo; ox < hi; ox++) orow[ox] += wv * xr[ox];
                        } else {
                            for (int ox = lo; ox < hi; ox++) orow[ox] += wv * xr[ox * s];
                        }
                    }
                }
            }
        }
        if (p->relu)
            for (size_t i = 0; i < out_plane; i++) o[i] = o[i] > 0.0f ? o[i] : 0.0f;
    }
}
