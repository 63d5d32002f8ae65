#include "kernels/ref/nn_ref.h"

#define OB 8 /* outputs summed side by side: each sum is a chain of dependent adds, and eight
                independent chains keep the adder busy where one waits on its latency */

void nn_fc_f32__ref(const float *in, int n_in, const float *w, const float *bias, int relu,
                    float *out, int o_begin, int o_end)
{
    int o = o_begin;
    for (; o + OB <= o_end; o += OB) {
        float acc[OB] = {0};
        for (int i = 0; i < n_in; i++)
            for (int j = 0; j < OB; j++) acc[j] += w[(size_t)(o + j) * n_in + i] * in[i];
        for (int j = 0; j < OB; j++) {
            const float v = acc[j] + (bias ? bias[o + j] : 0.0f);
            out[o + j] = relu && v < 0.0f ? 0.0f : v;
        }
    }
    /* each output's sum in the same order as above: in[0] first, then the bias */
    for (; o < o_end; o++) {
        const float *wr = w + (size_t)o * n_in;
        float acc = 0.0f;
        for (int i = 0; i < n_in; i++) acc += wr[i] * in[i];
        acc += bias ? bias[o] : 0.0f;
        out[o] = relu && acc < 0.0f ? 0.0f : acc;
    }
}
