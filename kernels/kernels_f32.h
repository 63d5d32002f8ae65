/* fp32 kernel slots of the kernel table (kernels/dispatch.h). Each slot has the reference
 * kernel's signature and semantics (kernels/ref/nn_ref.h); SIMD implementations agree with the
 * reference within the tolerance stated in docs/PERFORMANCE.md. */
#ifndef PL_KERNELS_KERNELS_F32_H
#define PL_KERNELS_KERNELS_F32_H

#include "kernels/isa.h"
#include "kernels/ref/nn_ref.h"

typedef void (*pl_conv_f32_fn)(const nn_conv_params *p, const float *in, const float *w,
                               const float *bias, float *out, int oc_begin, int oc_end);

typedef struct pl_kernels_f32 {
    pl_conv_f32_fn conv2d;
    const char *conv2d_name;
} pl_kernels_f32;

/* Fills every slot with the fastest implementation `isa` includes (kernels/isa.h). */
void pl_kernels_f32_fill(pl_kernels_f32 *t, pl_isa isa);

#endif
