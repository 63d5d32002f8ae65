/* Packed fp32 convolution, AVX-512F only (kernels/kernels_f32.h): an 8 x 48 micro-kernel, 24 zmm
 * accumulators, per K step three B loads, eight broadcasts of the weight panel and a prefetch. */
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

/* The 24 accumulators are named variables, each row loaded and stored through masks (none past
 * `rows`: a row past it reads and writes nothing), with no branch on the row: with an array and
 * per-row branches gcc kept them in a stack array between the prologue, loop and epilogue. */
#define ROW_INIT(r)                                                                                \
    const int on##r = (r) < rows;                                                                  \
    float *const cr##r = c + (size_t)(on##r ? (r) : 0) * ldc;                                      \
    __m512 c##r##0, c##r##1, c##r##2;                                                              \
    if (accumulate) {                                                                              \
        c##r##0 = _mm512_maskz_loadu_ps(on##r ? m0 : 0, cr##r);                                    \
        c##r##1 = _mm512_maskz_loadu_ps(on##r ? m1 : 0, cr##r + 16);                               \
        c##r##2 = _mm512_maskz_loadu_ps(on##r ? m2 : 0, cr##r + 32);                               \
    } else {                                                                                       \
        c##r##0 = c##r##1 = c##r##2 = _mm512_set1_ps(on##r && bias ? bias[r] : 0.0f);              \
    }
#define ROW_FMA(r)                                                                                 \
    do {                                                                                           \
        const __m512 av = _mm512_set1_ps(a[r]);                                                    \
        c##r##0 = _mm512_fmadd_ps(av, b0, c##r##0);                                                \
        c##r##1 = _mm512_fmadd_ps(av, b1, c##r##1);                                                \
        c##r##2 = _mm512_fmadd_ps(av, b2, c##r##2);                                                \
    } while (0)
#define ROW_RELU(r)                                                                                \
    do {                                                                                           \
        c##r##0 = _mm512_max_ps(c##r##0, z);                                                       \
        c##r##1 = _mm512_max_ps(c##r##1, z);                                                       \
        c##r##2 = _mm512_max_ps(c##r##2, z);                                                       \
    } while (0)
#define ROW_STORE(r)                                                                               \
    do {                                                                                           \
        _mm512_mask_storeu_ps(cr##r, on##r ? m0 : 0, c##r##0);                                     \
        _mm512_mask_storeu_ps(cr##r + 16, on##r ? m1 : 0, c##r##1);                                \
        _mm512_mask_storeu_ps(cr##r + 32, on##r ? m2 : 0, c##r##2);                                \
    } while (0)
#define ROWS(X)                                                                                    \
    X(0);                                                                                          \
    X(1);                                                                                          \
    X(2);                                                                                          \
    X(3);                                                                                          \
    X(4);                                                                                          \
    X(5);                                                                                          \
    X(6);                                                                                          \
    X(7)

/* noinline: inlined into the packing driver, its loop ran a third slower */
static __attribute__((noinline)) void ukr(int k, const float *a, const float *b, float *c,
                                          size_t ldc, int rows, int cols, const float *bias,
                                          int accumulate, int relu)
{
    const __mmask16 m0 = cols_mask(cols, 0), m1 = cols_mask(cols, 1), m2 = cols_mask(cols, 2);
    ROW_INIT(0)
    ROW_INIT(1)
    ROW_INIT(2)
    ROW_INIT(3)
    ROW_INIT(4)
    ROW_INIT(5)
    ROW_INIT(6)
    ROW_INIT(7)
    for (int i = 0; i < k; i++) {
        const __m512 b0 = _mm512_load_ps(b), b1 = _mm512_load_ps(b + 16),
                     b2 = _mm512_load_ps(b + 32);
        /* the weight panel 32 steps ahead: a layer of block 3 or 4 reads its weights once or
         * four times a frame, from L3 (measured: 512 floats ahead was slower; without it the
         * frame took 0.4 ms longer). Past the panel's end it reads nothing: prefetches never
         * fault. */
        _mm_prefetch((const char *)(a + 256), _MM_HINT_T0);
        ROWS(ROW_FMA);
        a += 8;
        b += 48;
    }
    if (relu) {
        const __m512 z = _mm512_setzero_ps();
        ROWS(ROW_RELU);
    }
    ROWS(ROW_STORE);
}

#undef ROW_INIT
#undef ROW_FMA
#undef ROW_RELU
#undef ROW_STORE
#undef ROWS

static void copy_masked(float *d, const float *s, const int32_t *mask)
{
    for (int v = 0; v < 3; v++) {
        /* mask lanes are 0 or -1: "< 0" is AVX-512F, where vpmovd2m would need DQ */
        const __mmask16 m =
            _mm512_cmplt_epi32_mask(_mm512_load_si512(mask + 16 * v), _mm512_setzero_si512());
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

#define CONV_GEMM_FN nn_conv_gemm_f32_8x48__avx512f
#include "kernels/nn_conv_gemm_f32_tmpl.h"

/* Winograd F(m x m, 3x3) on the same micro-kernel (kernels/nn_conv_wino_f32_tmpl.h) */
#define CONV_WINO_FN nn_conv_wino_f32_8x48__avx512f
#include "kernels/nn_conv_wino_f32_tmpl.h"
