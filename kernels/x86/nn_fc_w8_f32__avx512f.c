/* The float layer with int8-stored weights (nn_fc_w8_f32, kernels/nn_fc_w8_f32_tmpl.h), AVX-512F:
 * the reference's 32 partial sums as two zmm per dot product; 4 input rows x 2 weight rows
 * (16 accumulators) per block, 4 weight rows for a single input row. Equal to the reference bit
 * for bit. */
#include <immintrin.h>

#include "kernels/x86/nn_f32_x86.h"

#define FCW8_FN nn_fc_w8_f32__avx512f
#define FCW8_LOAD_W(p) _mm512_cvtepi32_ps(_mm512_cvtepi8_epi32(_mm_loadu_si128((const __m128i *)(const void *)(p))))
#define FCW8_VL 16
#define FCW8_RB 4
#define FCW8_OB 2
#define FCW8_OB1 4
#include "kernels/nn_fc_w8_f32_tmpl.h"
