/* Arm fp32 kernels (kernels/kernels_f32.h describes the slots and layouts). NEON is the AArch64
 * baseline, so these serve every Arm path (neon, dotprod, i8mm add nothing to fp32):
 *  - nn_conv_gemm_f32_8x12__neon: the packed GEMM, the 8 x 48 block as four 8 x 12 micro-tiles
 *    (24 accumulators, 3 B and 2 A registers; fmla by element);
 *  - nn_fc_f32__neon: four outputs at a time, two 4-lane partial sums each;
 *  - pooling: the x86 paths' plain C (kernels/x86/nn_pool_f32_tmpl.h), which vectorises across
 *    the output row and equals the reference bit for bit.
 * fc_w8 stays the reference kernel too: gcc vectorises its 32 partial sums for NEON, and a NEON
 * version that widens the int8 weights in registers (kernels/nn_fc_w8_f32_tmpl.h) was predicted
 * slower on the Pi 5 (make bench-arm: 14.27 -> 14.88 ms a frame; docs/PERFORMANCE.md).
 * bn_relu stays the reference kernel: its loop is already vectorised with NEON at -O3, and the
 * same expression without contraction is what bit-exactness asks for. */
#ifndef PL_KERNELS_ARM_NN_F32_ARM_H
#define PL_KERNELS_ARM_NN_F32_ARM_H

#include "kernels/kernels_f32.h"

void nn_conv_gemm_f32_8x12__neon(const pl_f32_conv *c, const float *in, float *out, float *scratch,
                                 int tile_begin, int tile_end, int panel_begin, int panel_end);
/* Winograd F(2x2 or 4x4, 3x3) on the same micro-kernel (kernels/nn_conv_wino_f32_tmpl.h) */
void nn_conv_wino_f32_8x12__neon(const pl_f32_conv *c, const float *in, float *out, float *scratch,
                                 int block_begin, int block_end, int panel_begin, int panel_end);
void nn_fc_f32__neon(const float *in, int n_in, const float *w, const float *bias, int relu,
                     float *out, int o_begin, int o_end);
void nn_maxpool2d_f32__neon(const nn_pool_params *p, const float *in, float *out, int c_begin,
                            int c_end);
void nn_avgpool2d_f32__neon(const nn_pool_params *p, const float *in, float *out, int c_begin,
                            int c_end);

#endif
