/* The float layer with int8-stored weights (nn_fc_w8_f32, kernels/nn_fc_w8_f32_tmpl.h), AVX2:
 * the reference's 32 partial sums as four ymm per dot product; 2 input rows x 1 weight row
 * (8 accumulators, 4 weight vectors: 13 of the 16 ymm) per block, 2 weight rows for a single
 * input row. Equal to the reference bit for bit. */
#include <immintrin.h>

#include "kernels/x86/nn_f32_x86.h"

#define FCW8_FN nn_fc_w8_f32__avx2
#define FCW8_LOAD_W(p) _mm256_cvtepi32_ps(_mm256_cvtepi8_epi32(_mm_loadl_epi64((const __m128i *)(const void *)(p))))
#define FCW8_VL 8
#define FCW8_RB 2
#define FCW8_OB 1
#define FCW8_OB1 2
#include "kernels/nn_fc_w8_f32_tmpl.h"
