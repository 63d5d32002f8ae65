/* Packed fp32 convolution, AVX-512 (kernels/kernels_f32.h): an 8 x 48 micro-kernel, 24 zmm
 * accumulators, per K step three B loads and eight broadcasts of the weight panel. */
#include <immintrin.h>
#include <stddef.h>
#include <stdint.h>

#include "kernels/kernels_f32.h"
#include "kernels/x86/nn_f32_x86.h"

_Static_assert(PL_F32_MR == 8 && PL_F32_NR == 48, "the micro-kernel is 8 x 48");

static __mmask16 cols_mask(int cols, int v)
{
    const int r = cols - 16 * v;
    return r >= 16 ? (__mmask16)0xffff : r <= 0 ? (__mmask16)0 : (__mmask16)((1u << r) - 1u);
}

static void ukr(int k, const float *a, const float *b, float *c, size_t ldc, int rows, int cols,
                const float *bias, int accumulate, int relu)
{
    const __mmask16 m0 = cols_mask(cols, 0), m1 = cols_mask(cols, 1), m2 = cols_mask(cols, 2);
    __m512 acc[8][3];
    for (int r = 0; r < 8; r++) {
        if (r >= rows) {
            acc[r][0] = acc[r][1] = acc[r][2] = _mm512_setzero_ps();
        } else if (accumulate) {
            const float *cr = c + (size_t)r * ldc;
            acc[r][0] = _mm512_maskz_loadu_ps(m0, cr);
            acc[r][1] = _mm512_maskz_loadu_ps(m1, cr + 16);
            acc[r][2] = _mm512_maskz_loadu_ps(m2, cr + 32);
        } else {
            acc[r][0] = acc[r][1] = acc[r][2] = _mm512_set1_ps(bias ? bias[r] : 0.0f);
        }
    }
    for (int i = 0; i < k; i++) {
        const __m512 b0 = _mm512_load_ps(b), b1 = _mm512_load_ps(b + 16),
                     b2 = _mm512_load_ps(b + 32);
        for (int r = 0; r < 8; r++) {
            const __m512 av = _mm512_set1_ps(a[r]);
            acc[r][0] = _mm512_fmadd_ps(av, b0, acc[r][0]);
            acc[r][1] = _mm512_fmadd_ps(av, b1, acc[r][1]);
            acc[r][2] = _mm512_fmadd_ps(av, b2, acc[r][2]);
        }
        a += 8;
        b += 48;
    }
    if (relu) {
        const __m512 z = _mm512_setzero_ps();
        for (int r = 0; r < 8; r++)
            for (int v = 0; v < 3; v++) acc[r][v] = _mm512_max_ps(acc[r][v], z);
    }
    for (int r = 0; r < rows; r++) {
        float *cr = c + (size_t)r * ldc;
        _mm512_mask_storeu_ps(cr, m0, acc[r][0]);
        _mm512_mask_storeu_ps(cr + 16, m1, acc[r][1]);
        _mm512_mask_storeu_ps(cr + 32, m2, acc[r][2]);
    }
}

static void copy_masked(float *d, const float *s, const int32_t *mask)
{
    for (int v = 0; v < 3; v++) {
        const __mmask16 m = _mm512_movepi32_mask(_mm512_load_si512(mask + 16 * v));
        _mm512_store_ps(d + 16 * v, _mm512_maskz_loadu_ps(m, s + 16 * v));
    }
}

static void gather_row(float *d, const float *x, const int32_t *tab, int ky, int kx, int h, int w)
{
    const __m512i vky = _mm512_set1_epi32(ky), vkx = _mm512_set1_epi32(kx);
    const __m512i vh = _mm512_set1_epi32(h), vw = _mm512_set1_epi32(w);
    const __m512i off = _mm512_set1_epi32(ky * w + kx);
    for (int v = 0; v < 3; v++) {
        const __m512i iy = _mm512_add_epi32(_mm512_load_si512(tab + 48 + 16 * v), vky);
        const __m512i ix = _mm512_add_epi32(_mm512_load_si512(tab + 96 + 16 * v), vkx);
        const __mmask16 m = _mm512_cmplt_epu32_mask(iy, vh) & _mm512_cmplt_epu32_mask(ix, vw);
        const __m512i idx = _mm512_add_epi32(_mm512_load_si512(tab + 16 * v), off);
        _mm512_store_ps(d + 16 * v, _mm512_mask_i32gather_ps(_mm512_setzero_ps(), m, idx, x, 4));
    }
}

#define CONV_GEMM_FN nn_conv_gemm_f32_8x48__avx512vnni
#include "kernels/nn_conv_gemm_f32_tmpl.h"

/* Winograd F(m x m, 3x3) on the same micro-kernel (kernels/nn_conv_wino_f32_tmpl.h) */
#define CONV_WINO_FN nn_conv_wino_f32_8x48__avx512vnni
#include "kernels/nn_conv_wino_f32_tmpl.h"
