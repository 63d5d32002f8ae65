#include "kernels/ref/nn_ref_s8.h"

/* TFLite reference_integer_ops::AveragePool: the window is clipped to the input and the divisor
 * is the number of input cells in it (padding counts in neither); the mean is rounded half away
 * from zero. The checks guarantee that every window holds at least one input cell. */
void nn_avgpool2d_s8__ref(const nn_pool_s8_params *p, const nn_dims *in_dims, const int8_t *in,
                          int in_c_stride, const nn_dims *out_dims, int8_t *out, int out_c_stride,
                          int c_begin, int c_end)
{
    const int ih = in_dims->h, iw = in_dims->w;
    for (int b = 0; b < out_dims->n; b++)
        for (int oy = 0; oy < out_dims->h; oy++)
            for (int ox = 0; ox < out_dims->w; ox++) {
                const int iy0 = oy * p->stride_h - p->pad_h, ix0 = ox * p->stride_w - p->pad_w;
                const int y_lo = iy0 < 0 ? 0 : iy0, x_lo = ix0 < 0 ? 0 : ix0;
                const int y_hi = iy0 + p->kernel_h < ih ? iy0 + p->kernel_h : ih;
                const int x_hi = ix0 + p->kernel_w < iw ? ix0 + p->kernel_w : iw;
                const int32_t count = (int32_t)(y_hi - y_lo) * (x_hi - x_lo);
                int8_t *o = out + nn_pixel_offset(out_dims, b, oy, ox, out_c_stride);
                for (int c = c_begin; c < c_end; c++) {
                    int32_t sum = 0;
                    for (int iy = y_lo; iy < y_hi; iy++)
                        for (int ix = x_lo; ix < x_hi; ix++)
                            sum += in[nn_pixel_offset(in_dims, b, iy, ix, in_c_stride) + c];
                    int32_t avg = sum > 0 ? (sum + count / 2) / count : (sum - count / 2) / count;
                    if (avg < p->act_min) avg = p->act_min;
                    if (avg > p->act_max) avg = p->act_max;
                    o[c] = (int8_t)avg;
                }
            }
}
