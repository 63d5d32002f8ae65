/* The float layer with int8-stored weights (nn_fc_w8_f32, kernels/nn_fc_w8_f32_tmpl.h), NEON:
 * the reference's 32 partial sums as eight q registers per dot product; 2 input rows x 1 weight
 * row (16 accumulators, 8 weight vectors: 25 of the 32) per block, 2 weight rows for a single
 * input row. Equal to the reference bit for bit. */
#include <arm_neon.h>
#include <string.h>

#include "kernels/arm/nn_f32_arm.h"

/* four int8 (read as one 32-bit word: never past the row) widened to float */
static inline float32x4_t load_w4(const int8_t *p)
{
    int32_t word;
    memcpy(&word, p, sizeof word);
    const int16x8_t h = vmovl_s8(vreinterpret_s8_s32(vdup_n_s32(word)));
    return vcvtq_f32_s32(vmovl_s16(vget_low_s16(h)));
}

#define FCW8_FN nn_fc_w8_f32__neon
#define FCW8_LOAD_W(p) load_w4(p)
#define FCW8_VL 4
#define FCW8_RB 2
#define FCW8_OB 1
#define FCW8_OB1 2
#include "kernels/nn_fc_w8_f32_tmpl.h"
