#include "kernels/ref/nn_ref.h"

#define LANES 32 /* partial sums per dot product: enough independent adds to keep the FP units
                    busy once the compiler vectorises the lane loop */

void nn_fc_w8_f32__ref(const float *in, int n_rows, int n_in, const int8_t *w,
                       const float *wscale, const float *bias, int relu, float *out,
                       int out_stride, int o_begin, int o_end)
{
    for (int r = 0; r < n_rows; r++) {
        const float *x = in + (size_t)r * n_in;
        for (int o = o_begin; o < o_end; o++) {
            const int8_t *wr = w + (size_t)o * n_in;
            float acc[LANES] = {0};
            int i = 0;
            for (; i + LANES <= n_in; i += LANES)
                for (int k = 0; k < LANES; k++)
                    acc[k] += (float)wr[i + k] * x[i + k];
            for (int s = LANES / 2; s > 0; s /= 2) /* pairwise, in a fixed order */
                for (int k = 0; k < s; k++)
                    acc[k] += acc[k + s];
            float sum = acc[0];
            for (; i < n_in; i++)
                sum += (float)wr[i] * x[i];
            const float v = wscale[o] * sum + (bias ? bias[o] : 0.0f);
            out[(size_t)r * out_stride + o] = relu && v < 0.0f ? 0.0f : v;
        }
    }
}
