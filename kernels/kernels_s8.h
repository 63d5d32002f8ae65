/* int8 kernel slots of the kernel table (kernels/dispatch.h). Each slot has the reference
 * kernel's signature and semantics (kernels/ref/nn_ref_s8.h, nn_ref_s8_clamp.h); a SIMD
 * implementation must equal the reference bit for bit. */
#ifndef PL_KERNELS_KERNELS_S8_H
#define PL_KERNELS_KERNELS_S8_H

#include "kernels/isa.h"
#include "kernels/ref/nn_ref_s8_clamp.h"

typedef void (*pl_conv_s8_fn)(const nn_conv_s8_params *p, const nn_per_channel_quant *q,
                              const nn_dims *in_dims, const int8_t *in, int in_c_stride,
                              const nn_dims *filter_dims, const int8_t *weights,
                              const int32_t *bias, const nn_dims *out_dims, int8_t *out,
                              int out_c_stride, int oc_begin, int oc_end);

typedef struct pl_kernels_s8 {
    pl_conv_s8_fn conv2d; /* k x k with stride, padding, dilation */
    const char *conv2d_name;
} pl_kernels_s8;

/* Fills every slot with the fastest implementation `isa` includes (kernels/isa.h). */
void pl_kernels_s8_fill(pl_kernels_s8 *t, pl_isa isa);

#endif
