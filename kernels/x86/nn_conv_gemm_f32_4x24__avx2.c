/* Packed fp32 convolution, AVX2 + FMA (kernels/kernels_f32.h): the 8 x 48 block of the packed
 * layout computed as four 4 x 24 micro-tiles (12 ymm accumulators, three B loads and four
 * broadcasts per K step: 16 registers in all). */
#include <immintrin.h>
#include <stddef.h>
#include <stdint.h>

#include "kernels/kernels_f32.h"
#include "kernels/x86/nn_f32_x86.h"

_Static_assert(PL_F32_MR == 8 && PL_F32_NR == 48, "the layout is 8 x 48");

static __m256i cols_mask(int cols)
{
    return _mm256_cmpgt_epi32(_mm256_set1_epi32(cols), _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7));
}

/* Rows [r0, r0 + 4) of the panel, columns [c0, c0 + 24) of the block. */
static void ukr_4x24(int k, const float *a, const float *b, float *c, size_t ldc, int rows,
                     int cols, const float *bias, int accumulate, int relu)
{
    const __m256i m0 = cols_mask(cols), m1 = cols_mask(cols - 8), m2 = cols_mask(cols - 16);
    __m256 acc[4][3];
    for (int r = 0; r < 4; r++) {
        if (r >= rows) {
            acc[r][0] = acc[r][1] = acc[r][2] = _mm256_setzero_ps();
        } else if (accumulate) {
            const float *cr = c + (size_t)r * ldc;
            acc[r][0] = _mm256_maskload_ps(cr, m0);
            acc[r][1] = _mm256_maskload_ps(cr + 8, m1);
            acc[r][2] = _mm256_maskload_ps(cr + 16, m2);
        } else {
            acc[r][0] = acc[r][1] = acc[r][2] = _mm256_set1_ps(bias ? bias[r] : 0.0f);
        }
    }
    /* named accumulators: gcc keeps an array of them in registers but also stores it to the
     * stack on every iteration */
    __m256 c00 = acc[0][0], c01 = acc[0][1], c02 = acc[0][2], c10 = acc[1][0], c11 = acc[1][1],
           c12 = acc[1][2], c20 = acc[2][0], c21 = acc[2][1], c22 = acc[2][2], c30 = acc[3][0],
           c31 = acc[3][1], c32 = acc[3][2];
    for (int i = 0; i < k; i++) {
        const __m256 b0 = _mm256_load_ps(b), b1 = _mm256_load_ps(b + 8),
                     b2 = _mm256_load_ps(b + 16);
        __m256 av = _mm256_broadcast_ss(a);
        c00 = _mm256_fmadd_ps(av, b0, c00);
        c01 = _mm256_fmadd_ps(av, b1, c01);
        c02 = _mm256_fmadd_ps(av, b2, c02);
        av = _mm256_broadcast_ss(a + 1);
        c10 = _mm256_fmadd_ps(av, b0, c10);
        c11 = _mm256_fmadd_ps(av, b1, c11);
        c12 = _mm256_fmadd_ps(av, b2, c12);
        av = _mm256_broadcast_ss(a + 2);
        c20 = _mm256_fmadd_ps(av, b0, c20);
        c21 = _mm256_fmadd_ps(av, b1, c21);
        c22 = _mm256_fmadd_ps(av, b2, c22);
        av = _mm256_broadcast_ss(a + 3);
        c30 = _mm256_fmadd_ps(av, b0, c30);
        c31 = _mm256_fmadd_ps(av, b1, c31);
        c32 = _mm256_fmadd_ps(av, b2, c32);
        a += 8;
        b += 48;
    }
    acc[0][0] = c00, acc[0][1] = c01, acc[0][2] = c02, acc[1][0] = c10, acc[1][1] = c11;
    acc[1][2] = c12, acc[2][0] = c20, acc[2][1] = c21, acc[2][2] = c22, acc[3][0] = c30;
    acc[3][1] = c31, acc[3][2] = c32;
    if (relu) {
        const __m256 z = _mm256_setzero_ps();
        for (int r = 0; r < 4; r++)
            for (int v = 0; v < 3; v++) acc[r][v] = _mm256_max_ps(acc[r][v], z);
    }
    for (int r = 0; r < rows && r < 4; r++) {
        float *cr = c + (size_t)r * ldc;
        _mm256_maskstore_ps(cr, m0, acc[r][0]);
        _mm256_maskstore_ps(cr + 8, m1, acc[r][1]);
        _mm256_maskstore_ps(cr + 16, m2, acc[r][2]);
    }
}

static void ukr(int k, const float *a, const float *b, float *c, size_t ldc, int rows, int cols,
                const float *bias, int accumulate, int relu)
{
    for (int rh = 0; rh < 2 && 4 * rh < rows; rh++) {
        for (int ch = 0; ch < 2 && 24 * ch < cols; ch++) {
            ukr_4x24(k, a + 4 * rh, b + 24 * ch, c + (size_t)(4 * rh) * ldc + 24 * ch, ldc,
                     rows - 4 * rh, cols - 24 * ch, bias ? bias + 4 * rh : NULL, accumulate,
                     relu);
        }
    }
}

static void copy_masked(float *d, const float *s, const int32_t *mask)
{
    for (int v = 0; v < 6; v++) {
        const __m256i m = _mm256_load_si256((const __m256i *)(mask + 8 * v));
        _mm256_store_ps(d + 8 * v, _mm256_maskload_ps(s + 8 * v, m));
    }
}

static void gather_row(float *d, const float *x, const int32_t *tab, int ky, int kx, int h, int w)
{
    const __m256i vky = _mm256_set1_epi32(ky), vkx = _mm256_set1_epi32(kx);
    const __m256i vh = _mm256_set1_epi32(h), vw = _mm256_set1_epi32(w);
    const __m256i off = _mm256_set1_epi32(ky * w + kx), neg1 = _mm256_set1_epi32(-1);
    for (int v = 0; v < 6; v++) {
        const __m256i iy =
            _mm256_add_epi32(_mm256_load_si256((const __m256i *)(tab + 48 + 8 * v)), vky);
        const __m256i ix =
            _mm256_add_epi32(_mm256_load_si256((const __m256i *)(tab + 96 + 8 * v)), vkx);
        const __m256i m = _mm256_and_si256(
            _mm256_and_si256(_mm256_cmpgt_epi32(iy, neg1), _mm256_cmpgt_epi32(vh, iy)),
            _mm256_and_si256(_mm256_cmpgt_epi32(ix, neg1), _mm256_cmpgt_epi32(vw, ix)));
        const __m256i idx =
            _mm256_add_epi32(_mm256_load_si256((const __m256i *)(tab + 8 * v)), off);
        _mm256_store_ps(d + 8 * v, _mm256_mask_i32gather_ps(_mm256_setzero_ps(), x, idx,
                                                            _mm256_castsi256_ps(m), 4));
    }
}

#define CONV_GEMM_FN nn_conv_gemm_f32_4x24__avx2
#include "kernels/nn_conv_gemm_f32_tmpl.h"

/* Winograd F(m x m, 3x3) on the same micro-kernel (kernels/nn_conv_wino_f32_tmpl.h) */
#define CONV_WINO_FN nn_conv_wino_f32_4x24__avx2
#include "kernels/nn_conv_wino_f32_tmpl.h"
