#include "kernels/ref/nn_ref.h"

void nn_bn_relu_f32__ref(const float *in, const float *scale, const float *shift, int hw,
                         float *out, int c_begin, int c_end)
{
    for (int c = c_begin; c < c_end; c++) {
        const float a = scale[c], b = shift[c];
        const float *x = in + (size_t)c * hw;
        float *y = out + (size_t)c * hw;
        for (int i = 0; i < hw; i++) {
            const float v = a * x[i] + b;
            y[i] = v > 0.0f ? v : 0.0f;
        }
    }
}
