/* Fully connected fp32, NEON (kernels/ref/nn_ref.h): four outputs at a time, each with two 4-lane
 * partial sums over the inputs (fused multiply-add), reduced at the end; the last n_in % 8 inputs
 * in scalar. Within tests/test_kernels_simd_f32.c's tolerance of the reference, not bit-exact. */
#include <arm_neon.h>
#include <stddef.h>

#include "kernels/arm/nn_f32_arm.h"

static float finish(float v, const float *w0, const float *in, int from, int n_in,
                    const float *bias, int o, int relu)
{
    for (int i = from; i < n_in; i++)
        v += w0[i] * in[i];
    v += bias ? bias[o] : 0.0f;
    return relu && v < 0.0f ? 0.0f : v;
}

void nn_fc_f32__neon(const float *in, int n_in, const float *w, const float *bias, int relu,
                     float *out, int o_begin, int o_end)
{
    const int n8 = n_in & ~7;
    int o = o_begin;
    for (; o + 4 <= o_end; o += 4) {
        const float *w0 = w + (size_t)o * (size_t)n_in, *w1 = w0 + n_in, *w2 = w1 + n_in,
                    *w3 = w2 + n_in;
        float32x4_t a0 = vdupq_n_f32(0.0f), a1 = a0, a2 = a0, a3 = a0, b0 = a0, b1 = a0, b2 = a0,
                    b3 = a0;
        for (int i = 0; i < n8; i += 8) {
            const float32x4_t x0 = vld1q_f32(in + i), x1 = vld1q_f32(in + i + 4);
            a0 = vfmaq_f32(a0, vld1q_f32(w0 + i), x0);
            b0 = vfmaq_f32(b0, vld1q_f32(w0 + i + 4), x1);
            a1 = vfmaq_f32(a1, vld1q_f32(w1 + i), x0);
            b1 = vfmaq_f32(b1, vld1q_f32(w1 + i + 4), x1);
            a2 = vfmaq_f32(a2, vld1q_f32(w2 + i), x0);
            b2 = vfmaq_f32(b2, vld1q_f32(w2 + i + 4), x1);
            a3 = vfmaq_f32(a3, vld1q_f32(w3 + i), x0);
            b3 = vfmaq_f32(b3, vld1q_f32(w3 + i + 4), x1);
        }
        out[o] = finish(vaddvq_f32(vaddq_f32(a0, b0)), w0, in, n8, n_in, bias, o, relu);
        out[o + 1] = finish(vaddvq_f32(vaddq_f32(a1, b1)), w1, in, n8, n_in, bias, o + 1, relu);
        out[o + 2] = finish(vaddvq_f32(vaddq_f32(a2, b2)), w2, in, n8, n_in, bias, o + 2, relu);
        out[o + 3] = finish(vaddvq_f32(vaddq_f32(a3, b3)), w3, in, n8, n_in, bias, o + 3, relu);
    }
    for (; o < o_end; o++) {
        const float *w0 = w + (size_t)o * (size_t)n_in;
        float32x4_t a0 = vdupq_n_f32(0.0f), b0 = a0;
        for (int i = 0; i < n8; i += 8) {
            a0 = vfmaq_f32(a0, vld1q_f32(w0 + i), vld1q_f32(in + i));
            b0 = vfmaq_f32(b0, vld1q_f32(w0 + i + 4), vld1q_f32(in + i + 4));
        }
        out[o] = finish(vaddvq_f32(vaddq_f32(a0, b0)), w0, in, n8, n_in, bias, o, relu);
    }
}
