/* int8 reference kernels with a per-input-channel clamp: how DenseNet's pre-activation BN + ReLU
 * runs on int8 data (docs/QUANT.md, "DenseNet folding"). relu(a*x + b) on a quantised input is
 * A*clamp(q, lo_c, hi_c) + B: the clamp stays in the kernel, A is folded into the consumer's
 * weights and B into its bias. For a > 0 the clamp is from below (lo_c = t_q, hi_c = 127), for
 * a < 0 from above (lo_c = -128, hi_c = t_q).
 *
 * Same layouts, semantics, limits and work split as kernels/ref/nn_ref_s8.h (NHWC with pixel
 * strides, OHWI weights, int32 bias at the accumulator's scale, per-output-channel
 * requantisation); validate with nn_conv1x1_s8_check plus lo_c <= hi_c for every channel. */
#ifndef PL_KERNELS_REF_NN_REF_S8_CLAMP_H
#define PL_KERNELS_REF_NN_REF_S8_CLAMP_H

#include <stdint.h>

#include "kernels/ref/nn_ref_s8.h"

/* 1x1 convolution of the clamped input: every input value x of channel c is first replaced by
 * min(max(x, clamp_lo[c]), clamp_hi[c]), then
 *   acc = bias[oc] + sum_c (clamped + input_offset) * w[oc][c]
 * and requantised as nn_conv1x1_s8__ref does. clamp_lo/clamp_hi hold in_dims->c entries with
 * clamp_lo[c] <= clamp_hi[c]. Equal, bit for bit, to nn_conv1x1_s8__ref on a pre-clamped copy of
 * the input. Output channels [oc_begin, oc_end). */
void nn_conv1x1_clamp_s8__ref(const nn_conv_s8_params *p, const nn_per_channel_quant *q,
                              const nn_dims *in_dims, const int8_t *in, int in_c_stride,
                              const int8_t *clamp_lo, const int8_t *clamp_hi,
                              const nn_dims *filter_dims, const int8_t *weights,
                              const int32_t *bias, const nn_dims *out_dims, int8_t *out,
                              int out_c_stride, int oc_begin, int oc_end);

/* In place: x = min(max(x, clamp_lo[c]), clamp_hi[c]) for channels [c_begin, c_end) of every
 * pixel of a tensor with dims d and pixel stride c_stride (a transition's or norm5's
 * pre-activation before pooling). */
void nn_clamp_s8__ref(const nn_dims *d, int8_t *data, int c_stride, const int8_t *clamp_lo,
                      const int8_t *clamp_hi, int c_begin, int c_end);

#endif
