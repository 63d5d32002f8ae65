#include "kernels/ref/nn_ref.h"

void nn_fc_f32__ref(const float *in, int n_in, const float *w, const float *bias, int relu,
                    float *out, int o_begin, int o_end)
{
    for (int o = o_begin; o < o_end; o++) {
        const float *wr = w + (size_t)o * n_in;
        float acc = 0.0f;
        for (int i = 0; i < n_in; i++) acc += wr[i] * in[i];
        acc += bias ? bias[o] : 0.0f;
        out[o] = relu && acc < 0.0f ? 0.0f : acc;
    }
}
