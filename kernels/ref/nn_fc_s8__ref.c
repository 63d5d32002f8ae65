#include "kernels/ref/nn_ref_s8.h"

#include "kernels/requant.h"

void nn_fc_s8__ref(const nn_fc_s8_params *p, const nn_per_channel_quant *q, int batches, int depth,
                   const int8_t *in, int in_stride, const int8_t *weights, const int32_t *bias,
                   int out_c, int8_t *out, int out_stride, int oc_begin, int oc_end)
{
    (void)out_c; /* the channel count the quantisation arrays and out_stride were checked for */
    const int32_t in_off = p->input_offset, w_off = p->weights_offset;
    for (int b = 0; b < batches; b++) {
        const int8_t *x = in + (size_t)b * in_stride;
        int8_t *o = out + (size_t)b * out_stride;
        for (int oc = oc_begin; oc < oc_end; oc++) {
            const int8_t *w = weights + (size_t)oc * depth;
            int32_t acc = 0;
            for (int d = 0; d < depth; d++)
                acc += (x[d] + in_off) * (w[d] + w_off);
            if (bias) acc = (int32_t)((uint32_t)acc + (uint32_t)bias[oc]); /* wraps */
            const int qc = p->per_channel ? oc : 0;
            o[oc] = pl_requantize_s8(acc, q->multiplier[qc], q->shift[qc], p->output_offset,
                                     p->act_min, p->act_max);
        }
    }
}
