/* Packed fp32 convolution, NEON (kernels/kernels_f32.h): the 8 x 48 block of the packed layout
 * computed as four 8 x 12 micro-tiles. Per K step: two loads of the panel's 8 weights, three of
 * B's 12 pixels, 24 fmla by element into 24 accumulators (29 of the 32 vector registers). Each
 * output sums its K products in order with fused multiply-adds, as the x86 kernels do, so the
 * result does not depend on the tile or panel split. */
#include <arm_neon.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "kernels/arm/nn_f32_arm.h"

_Static_assert(PL_F32_MR == 8 && PL_F32_NR == 48, "the layout is 8 x 48");

/* Rows [0, rows) x columns [c0, c0 + 12) of the block (cols: columns left from c0). */
static void ukr_8x12(int k, const float *a, const float *b, float *c, size_t ldc, int rows,
                     int cols, const float *bias, int accumulate, int relu)
{
    float32x4_t acc[8][3];
    const int full = cols >= 12;
    for (int r = 0; r < 8; r++) {
        if (r >= rows) {
            acc[r][0] = acc[r][1] = acc[r][2] = vdupq_n_f32(0.0f);
        } else if (accumulate) {
            const float *cr = c + (size_t)r * ldc;
            if (full) {
                acc[r][0] = vld1q_f32(cr);
                acc[r][1] = vld1q_f32(cr + 4);
                acc[r][2] = vld1q_f32(cr + 8);
            } else {
                float tmp[12] = {0};
                memcpy(tmp, cr, (size_t)cols * sizeof(float));
                acc[r][0] = vld1q_f32(tmp);
                acc[r][1] = vld1q_f32(tmp + 4);
                acc[r][2] = vld1q_f32(tmp + 8);
            }
        } else {
            acc[r][0] = acc[r][1] = acc[r][2] = vdupq_n_f32(bias ? bias[r] : 0.0f);
        }
    }
    /* named accumulators: gcc keeps an array of them in registers but also stores it to the
     * stack on every iteration */
#define NN_ACC(r) c##r##0 = acc[r][0], c##r##1 = acc[r][1], c##r##2 = acc[r][2]
    float32x4_t NN_ACC(0), NN_ACC(1), NN_ACC(2), NN_ACC(3), NN_ACC(4), NN_ACC(5), NN_ACC(6),
        NN_ACC(7);
#undef NN_ACC
    for (int i = 0; i < k; i++) {
        const float32x4_t b0 = vld1q_f32(b), b1 = vld1q_f32(b + 4), b2 = vld1q_f32(b + 8);
        const float32x4_t a0 = vld1q_f32(a), a1 = vld1q_f32(a + 4);
#define NN_ROW(r, av, l)                                                                           \
    c##r##0 = vfmaq_laneq_f32(c##r##0, b0, av, l);                                                 \
    c##r##1 = vfmaq_laneq_f32(c##r##1, b1, av, l);                                                 \
    c##r##2 = vfmaq_laneq_f32(c##r##2, b2, av, l);
        NN_ROW(0, a0, 0)
        NN_ROW(1, a0, 1)
        NN_ROW(2, a0, 2)
        NN_ROW(3, a0, 3)
        NN_ROW(4, a1, 0)
        NN_ROW(5, a1, 1)
        NN_ROW(6, a1, 2)
        NN_ROW(7, a1, 3)
#undef NN_ROW
        a += 8;
        b += 48;
    }
#define NN_ACC(r) acc[r][0] = c##r##0, acc[r][1] = c##r##1, acc[r][2] = c##r##2
    NN_ACC(0), NN_ACC(1), NN_ACC(2), NN_ACC(3), NN_ACC(4), NN_ACC(5), NN_ACC(6), NN_ACC(7);
#undef NN_ACC
    if (relu) {
        const float32x4_t z = vdupq_n_f32(0.0f);
        for (int r = 0; r < 8; r++)
            for (int v = 0; v < 3; v++)
                acc[r][v] = vmaxq_f32(acc[r][v], z);
    }
    for (int r = 0; r < rows && r < 8; r++) {
        float *cr = c + (size_t)r * ldc;
        if (full) {
            vst1q_f32(cr, acc[r][0]);
            vst1q_f32(cr + 4, acc[r][1]);
            vst1q_f32(cr + 8, acc[r][2]);
        } else {
            float tmp[12];
            vst1q_f32(tmp, acc[r][0]);
            vst1q_f32(tmp + 4, acc[r][1]);
            vst1q_f32(tmp + 8, acc[r][2]);
            memcpy(cr, tmp, (size_t)cols * sizeof(float));
        }
    }
}

static void ukr(int k, const float *a, const float *b, float *c, size_t ldc, int rows, int cols,
                const float *bias, int accumulate, int relu)
{
    for (int ch = 0; ch < 4 && 12 * ch < cols; ch++)
        ukr_8x12(k, a, b + 12 * ch, c + 12 * ch, ldc, rows, cols - 12 * ch, bias, accumulate, relu);
}

/* d[j] = mask[j] ? s[j] : 0, never reading s[j] where mask[j] == 0 (s may lie outside the
 * plane there) */
static void copy_masked(float *d, const float *s, const int32_t *mask)
{
    for (int j = 0; j < PL_F32_NR; j++)
        d[j] = mask[j] ? s[j] : 0.0f;
}

static void gather_row(float *d, const float *x, const int32_t *tab, int ky, int kx, int h, int w)
{
    const int off = ky * w + kx;
    for (int j = 0; j < PL_F32_NR; j++) {
        const int iy = tab[PL_F32_NR + j] + ky, ix = tab[2 * PL_F32_NR + j] + kx;
        d[j] = iy >= 0 && iy < h && ix >= 0 && ix < w ? x[tab[j] + off] : 0.0f;
    }
}

#define CONV_GEMM_FN nn_conv_gemm_f32_8x12__neon
#include "kernels/nn_conv_gemm_f32_tmpl.h"

/* Winograd F(m x m, 3x3) on the same micro-kernel (kernels/nn_conv_wino_f32_tmpl.h) */
#define CONV_WINO_FN nn_conv_wino_f32_8x12__neon
#include "kernels/nn_conv_wino_f32_tmpl.h"
