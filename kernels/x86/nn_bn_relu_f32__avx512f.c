/* Pre-activation batch norm + ReLU (kernels/ref/nn_ref.h), the reference's loop compiled for
 * this ISA's vector width: the same expression without contraction (-std=c11 sets
 * -ffp-contract=off), so it equals the reference bit for bit. */
#include <stddef.h>

#include "kernels/x86/nn_f32_x86.h"

void nn_bn_relu_f32__avx512f(const float *in, const float *scale, const float *shift, int hw,
                          float *out, int c_begin, int c_end)
{
    for (int c = c_begin; c < c_end; c++) {
        const float a = scale[c], b = shift[c];
        const float *x = in + (size_t)c * (size_t)hw;
        float *y = out + (size_t)c * (size_t)hw;
        for (int i = 0; i < hw; i++) {
            const float v = a * x[i] + b;
            y[i] = v > 0.0f ? v : 0.0f;
        }
    }
}
