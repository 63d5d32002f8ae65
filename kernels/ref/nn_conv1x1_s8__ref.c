#include "kernels/ref/nn_ref_s8.h"

#include "kernels/requant.h"

/* A 1x1 convolution is a matrix product over pixels: each output pixel (b, oy, ox) reads input
 * pixel (b, oy*stride_h, ox*stride_w) and dots its in_c channels with each weight row. */
void nn_conv1x1_s8__ref(const nn_conv_s8_params *p, const nn_per_channel_quant *q,
                        const nn_dims *in_dims, const int8_t *in, int in_c_stride,
                        const nn_dims *filter_dims, const int8_t *weights, const int32_t *bias,
                        const nn_dims *out_dims, int8_t *out, int out_c_stride, int oc_begin,
                        int oc_end)
{
    (void)filter_dims; /* {out_c, 1, 1, in_c}: implied by in_dims and out_dims */
    const int in_c = in_dims->c;
    const int32_t in_off = p->input_offset;

    for (int b = 0; b < out_dims->n; b++)
        for (int oy = 0; oy < out_dims->h; oy++)
            for (int ox = 0; ox < out_dims->w; ox++) {
                const int8_t *x = in + nn_pixel_offset(in_dims, b, oy * p->stride_h,
                                                       ox * p->stride_w, in_c_stride);
                int8_t *o = out + nn_pixel_offset(out_dims, b, oy, ox, out_c_stride);
                for (int oc = oc_begin; oc < oc_end; oc++) {
                    const int8_t *w = weights + (size_t)oc * in_c;
                    int32_t acc = 0;
                    for (int ic = 0; ic < in_c; ic++)
                        acc += (x[ic] + in_off) * w[ic];
                    if (bias) acc = (int32_t)((uint32_t)acc + (uint32_t)bias[oc]); /* wraps */
                    o[oc] = pl_requantize_s8(acc, q->multiplier[oc], q->shift[oc], p->output_offset,
                                             p->act_min, p->act_max);
                }
            }
}
