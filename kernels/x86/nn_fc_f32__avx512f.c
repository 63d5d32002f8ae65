/* Fully connected fp32, AVX-512 (kernels/ref/nn_ref.h): four outputs at a time, each with two
 * 16-lane partial sums over the inputs (a masked load for the remainder), reduced at the end. */
#include <immintrin.h>
#include <stddef.h>

#include "kernels/x86/nn_f32_x86.h"

static float finish(__m512 s0, __m512 s1, const float *bias, int o, int relu)
{
    float v = _mm512_reduce_add_ps(_mm512_add_ps(s0, s1)) + (bias ? bias[o] : 0.0f);
    return relu && v < 0.0f ? 0.0f : v;
}

void nn_fc_f32__avx512f(const float *in, int n_in, const float *w, const float *bias, int relu,
                           float *out, int o_begin, int o_end)
{
    const int n32 = n_in & ~31, rem = n_in - n32;
    const __mmask16 mlo = (__mmask16)(rem >= 16 ? 0xffff : (1u << rem) - 1u);
    const __mmask16 mhi = (__mmask16)(rem > 16 ? (1u << (rem - 16)) - 1u : 0u);
    int o = o_begin;
    for (; o + 4 <= o_end; o += 4) {
        const float *w0 = w + (size_t)o * (size_t)n_in, *w1 = w0 + n_in, *w2 = w1 + n_in,
                    *w3 = w2 + n_in;
        __m512 a0 = _mm512_setzero_ps(), a1 = a0, a2 = a0, a3 = a0, b0 = a0, b1 = a0, b2 = a0,
               b3 = a0;
        for (int i = 0; i < n32; i += 32) {
            const __m512 x0 = _mm512_loadu_ps(in + i), x1 = _mm512_loadu_ps(in + i + 16);
            a0 = _mm512_fmadd_ps(_mm512_loadu_ps(w0 + i), x0, a0);
            b0 = _mm512_fmadd_ps(_mm512_loadu_ps(w0 + i + 16), x1, b0);
            a1 = _mm512_fmadd_ps(_mm512_loadu_ps(w1 + i), x0, a1);
            b1 = _mm512_fmadd_ps(_mm512_loadu_ps(w1 + i + 16), x1, b1);
            a2 = _mm512_fmadd_ps(_mm512_loadu_ps(w2 + i), x0, a2);
            b2 = _mm512_fmadd_ps(_mm512_loadu_ps(w2 + i + 16), x1, b2);
            a3 = _mm512_fmadd_ps(_mm512_loadu_ps(w3 + i), x0, a3);
            b3 = _mm512_fmadd_ps(_mm512_loadu_ps(w3 + i + 16), x1, b3);
        }
        if (rem) {
            const __m512 x0 = _mm512_maskz_loadu_ps(mlo, in + n32),
                         x1 = _mm512_maskz_loadu_ps(mhi, in + n32 + 16);
            a0 = _mm512_fmadd_ps(_mm512_maskz_loadu_ps(mlo, w0 + n32), x0, a0);
            b0 = _mm512_fmadd_ps(_mm512_maskz_loadu_ps(mhi, w0 + n32 + 16), x1, b0);
            a1 = _mm512_fmadd_ps(_mm512_maskz_loadu_ps(mlo, w1 + n32), x0, a1);
            b1 = _mm512_fmadd_ps(_mm512_maskz_loadu_ps(mhi, w1 + n32 + 16), x1, b1);
            a2 = _mm512_fmadd_ps(_mm512_maskz_loadu_ps(mlo, w2 + n32), x0, a2);
            b2 = _mm512_fmadd_ps(_mm512_maskz_loadu_ps(mhi, w2 + n32 + 16), x1, b2);
            a3 = _mm512_fmadd_ps(_mm512_maskz_loadu_ps(mlo, w3 + n32), x0, a3);
            b3 = _mm512_fmadd_ps(_mm512_maskz_loadu_ps(mhi, w3 + n32 + 16), x1, b3);
        }
        out[o] = finish(a0, b0, bias, o, relu);
        out[o + 1] = finish(a1, b1, bias, o + 1, relu);
        out[o + 2] = finish(a2, b2, bias, o + 2, relu);
        out[o + 3] = finish(a3, b3, bias, o + 3, relu);
    }
    for (; o < o_end; o++) {
        const float *w0 = w + (size_t)o * (size_t)n_in;
        __m512 a0 = _mm512_setzero_ps(), b0 = a0;
        for (int i = 0; i < n32; i += 32) {
            a0 = _mm512_fmadd_ps(_mm512_loadu_ps(w0 + i), _mm512_loadu_ps(in + i), a0);
            b0 = _mm512_fmadd_ps(_mm512_loadu_ps(w0 + i + 16), _mm512_loadu_ps(in + i + 16), b0);
        }
        if (rem) {
            a0 = _mm512_fmadd_ps(_mm512_maskz_loadu_ps(mlo, w0 + n32),
                                 _mm512_maskz_loadu_ps(mlo, in + n32), a0);
            b0 = _mm512_fmadd_ps(_mm512_maskz_loadu_ps(mhi, w0 + n32 + 16),
                                 _mm512_maskz_loadu_ps(mhi, in + n32 + 16), b0);
        }
        out[o] = finish(a0, b0, bias, o, relu);
    }
}
