/* Fully connected fp32, AVX2 + FMA (kernels/ref/nn_ref.h): four outputs at a time, each with two
 * 8-lane partial sums over the inputs, reduced at the end; the last n_in % 16 inputs in scalar. */
#include <immintrin.h>
#include <stddef.h>

#include "kernels/x86/nn_f32_x86.h"

static float hsum(__m256 s0, __m256 s1)
{
    const __m256 s = _mm256_add_ps(s0, s1);
    __m128 v = _mm_add_ps(_mm256_castps256_ps128(s), _mm256_extractf128_ps(s, 1));
    v = _mm_add_ps(v, _mm_movehl_ps(v, v));
    v = _mm_add_ss(v, _mm_movehdup_ps(v));
    return _mm_cvtss_f32(v);
}

static float finish(float v, const float *w0, const float *in, int from, int n_in,
                    const float *bias, int o, int relu)
{
    for (int i = from; i < n_in; i++) v += w0[i] * in[i];
    v += bias ? bias[o] : 0.0f;
    return relu && v < 0.0f ? 0.0f : v;
}

void nn_fc_f32__avx2(const float *in, int n_in, const float *w, const float *bias, int relu,
                     float *out, int o_begin, int o_end)
{
    const int n16 = n_in & ~15;
    int o = o_begin;
    for (; o + 4 <= o_end; o += 4) {
        const float *w0 = w + (size_t)o * (size_t)n_in, *w1 = w0 + n_in, *w2 = w1 + n_in,
                    *w3 = w2 + n_in;
        __m256 a0 = _mm256_setzero_ps(), a1 = a0, a2 = a0, a3 = a0, b0 = a0, b1 = a0, b2 = a0,
               b3 = a0;
        for (int i = 0; i < n16; i += 16) {
            const __m256 x0 = _mm256_loadu_ps(in + i), x1 = _mm256_loadu_ps(in + i + 8);
            a0 = _mm256_fmadd_ps(_mm256_loadu_ps(w0 + i), x0, a0);
            b0 = _mm256_fmadd_ps(_mm256_loadu_ps(w0 + i + 8), x1, b0);
            a1 = _mm256_fmadd_ps(_mm256_loadu_ps(w1 + i), x0, a1);
            b1 = _mm256_fmadd_ps(_mm256_loadu_ps(w1 + i + 8), x1, b1);
            a2 = _mm256_fmadd_ps(_mm256_loadu_ps(w2 + i), x0, a2);
            b2 = _mm256_fmadd_ps(_mm256_loadu_ps(w2 + i + 8), x1, b2);
            a3 = _mm256_fmadd_ps(_mm256_loadu_ps(w3 + i), x0, a3);
            b3 = _mm256_fmadd_ps(_mm256_loadu_ps(w3 + i + 8), x1, b3);
        }
        out[o] = finish(hsum(a0, b0), w0, in, n16, n_in, bias, o, relu);
        out[o + 1] = finish(hsum(a1, b1), w1, in, n16, n_in, bias, o + 1, relu);
        out[o + 2] = finish(hsum(a2, b2), w2, in, n16, n_in, bias, o + 2, relu);
        out[o + 3] = finish(hsum(a3, b3), w3, in, n16, n_in, bias, o + 3, relu);
    }
    for (; o < o_end; o++) {
        const float *w0 = w + (size_t)o * (size_t)n_in;
        __m256 a0 = _mm256_setzero_ps(), b0 = a0;
        for (int i = 0; i < n16; i += 16) {
            a0 = _mm256_fmadd_ps(_mm256_loadu_ps(w0 + i), _mm256_loadu_ps(in + i), a0);
            b0 = _mm256_fmadd_ps(_mm256_loadu_ps(w0 + i + 8), _mm256_loadu_ps(in + i + 8), b0);
        }
        out[o] = finish(hsum(a0, b0), w0, in, n16, n_in, bias, o, relu);
    }
}
