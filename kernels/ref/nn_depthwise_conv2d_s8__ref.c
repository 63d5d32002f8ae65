#include "kernels/ref/nn_ref_s8.h"

#include "kernels/requant.h"

/* Output channel oc = ic*depth_multiplier + m reads input channel ic = oc / depth_multiplier and
 * weights [ky][kx][oc] (1HWO). Taps outside the input are skipped. */
void nn_depthwise_conv2d_s8__ref(const nn_conv_s8_params *p, const nn_per_channel_quant *q,
                                 const nn_dims *in_dims, const int8_t *in, int in_c_stride,
                                 const nn_dims *filter_dims, const int8_t *weights,
                                 const int32_t *bias, const nn_dims *out_dims, int8_t *out,
                                 int out_c_stride, int oc_begin, int oc_end)
{
    const int ih = in_dims->h, iw = in_dims->w, out_c = out_dims->c;
    const int kh = filter_dims->h, kw = filter_dims->w;
    const int mult = out_c / in_dims->c;
    const int32_t in_off = p->input_offset;

    for (int b = 0; b < out_dims->n; b++)
        for (int oy = 0; oy < out_dims->h; oy++)
            for (int ox = 0; ox < out_dims->w; ox++) {
                const int iy0 = oy * p->stride_h - p->pad_h, ix0 = ox * p->stride_w - p->pad_w;
                int8_t *o = out + nn_pixel_offset(out_dims, b, oy, ox, out_c_stride);
                for (int oc = oc_begin; oc < oc_end; oc++) {
                    const int ic = oc / mult;
                    int32_t acc = 0;
                    for (int ky = 0; ky < kh; ky++) {
                        const int iy = iy0 + ky * p->dilation_h;
                        if (iy < 0 || iy >= ih) continue;
                        for (int kx = 0; kx < kw; kx++) {
                            const int ix = ix0 + kx * p->dilation_w;
                            if (ix < 0 || ix >= iw) continue;
                            const int8_t x =
                                in[nn_pixel_offset(in_dims, b, iy, ix, in_c_stride) + ic];
                            acc += (x + in_off) * weights[((size_t)ky * kw + kx) * out_c + oc];
                        }
                    }
                    if (bias) acc = (int32_t)((uint32_t)acc + (uint32_t)bias[oc]); /* wraps */
                    o[oc] = pl_requantize_s8(acc, q->multiplier[oc], q->shift[oc], p->output_offset,
                                             p->act_min, p->act_max);
                }
            }
}
