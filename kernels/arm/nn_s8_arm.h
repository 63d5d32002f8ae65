/* Arm int8 kernels of the packed path (kernels/kernels_s8.h describes the slots and the
 * arithmetic). Each file is compiled with the ISA flags its name ends with (Makefile: __neon
 * none beyond the AArch64 baseline, __neondot -march=armv8.2-a+dotprod, __neoni8mm
 * -march=armv8.6-a+dotprod+i8mm); call a kernel only when kernels/isa.h says the CPU has its path.
 *
 * A is the same u8 buffer (x + 128) as on x86, so the A builders, pools and clamp are shared by
 * the three paths (plain C vectorised for the AArch64 baseline, kernels/x86/nn_a_s8_tmpl.h and
 * nn_pool_s8_tmpl.h compiled here with the __neon suffix). The convolutions differ:
 *
 *  - neon (Cortex-A72, no dot product): A is turned back into s8 x = u ^ 0x80 (one eor per 16
 *    bytes), then smull/smull2 (s8 x s8 -> 8 s16 products, each |p| <= 2^14 so exact) and sadalp
 *    (pairwise add into s32): 16 products in 2 + 2 instructions. Layout PL_S8_LAYOUT_SDOT, which is
 *    the VNNI layout [block][K/4][16][4] s8 with the bias folded as bias + input_offset * sum(w)
 *    (signed A): a padded tap holds u = 128 - input_offset, x = -input_offset, whose product
 *    cancels the correction. Tile: 1 pixel x 16 channels (8 s32 accumulators holding pairs of
 *    partial sums, added pairwise at the end with addp; with 2 pixels gcc spills).
 *  - dotprod (Cortex-A76/A78, Neoverse N1): sdot by element on the same layout and signed A: one
 *    16-byte load of A per pixel covers 4 groups of 4 channels (lanes 0..3 of sdot's element
 *    form). Tile: 4 pixels x 16 channels (16 accumulators + 4 A + up to 8 weight
 *    registers; 5 pixels spill).
 *  - i8mm (Armv8.6: Neoverse V1/N2, Cortex-A710+, Apple M2+): usmmla multiplies u8 A (no eor,
 *    the x86 bias folding) by s8 weights as 2x8 by 8x2 matrices: two pixels x 8 channels against
 *    two output channels x 8. Layout PL_S8_LAYOUT_I8MM, [block][taps][round8(cs)/8][16][8];
 *    a tap's channels [cs, round8(cs)) have zero weights, so reading 4 bytes past a pixel (the
 *    next pixel, or the A buffer's 64 bytes of slack) adds nothing. Tile: 4 pixels (2 pairs) x 16
 *    channels (16 accumulators), the 2x2 results unzipped into pixel rows with zip1/zip2.
 *
 * Requantisation, all paths, four lanes at a time, equal to pl_requantize_s8 bit for bit:
 *   x = sqshl(acc, lsh)                   the saturating left shift of pl_requantize
 *   h = sqrdmulh(x, mult)                 gemmlowp's SaturatingRoundingDoublingHighMul, exactly
 *   r = srshl(sqadd(h, (h & -e) >> 31), -e)   RoundingDivideByPOT: srshl rounds ties up, the -1
 *                                         fix-up on negative h (only when e > 0) makes ties go away
 *                                         from zero; sqadd keeps INT32_MIN exact
 * then sqxtn to s16 (saturating: any |r| > 2^15 clamps to the activation range anyway), sqadd of
 * the output offset, min/max with the activation range, sqxtn to s8, eor out_xor. */
#ifndef PL_KERNELS_ARM_NN_S8_ARM_H
#define PL_KERNELS_ARM_NN_S8_ARM_H

#include "kernels/kernels_s8.h"

/* Building A (kernels_s8.h: pl_s8_a_pack_fn, pl_s8_a_pad_fn, pl_s8_a_rows_fn). */
void nn_a_pack_s8__neon(const nn_dims *in_dims, const int8_t *in, int in_c_stride, const int8_t *lo,
                        const int8_t *hi, int stride_h, int stride_w, const nn_dims *out_dims,
                        uint8_t *a, int cs, int pix_begin, int pix_end);
void nn_a_pad_s8__neon(const nn_dims *in_dims, const int8_t *in, int in_c_stride, int pad_h,
                       int pad_w, uint8_t pad_u, int a_h, int a_w, uint8_t *a, int cs,
                       int row_begin, int row_end);
void nn_a_rows_s8__neon(const nn_dims *in_dims, const int8_t *in, int in_c_stride, int pad_h,
                        int pad_w, uint8_t pad_u, int k_w, int stride_w, int dilation_w, int a_h,
                        int a_w, uint8_t *a, int cs, int row_begin, int row_end);

/* Pooling and clamping (pl_s8_maxpool_fn, pl_s8_avgpool_fn, pl_s8_clamp_fn). */
void nn_maxpool2d_s8__neon(const nn_pool_s8_params *p, const nn_dims *in_dims, const int8_t *in,
                           int in_c_stride, const nn_dims *out_dims, int8_t *out, int out_c_stride,
                           int pix_begin, int pix_end);
void nn_avgpool2d_s8__neon(const nn_pool_s8_params *p, const nn_dims *in_dims, const int8_t *in,
                           int in_c_stride, const int8_t *lo, const int8_t *hi,
                           const nn_dims *out_dims, uint8_t *out, int out_c_stride, uint8_t out_xor,
                           int pix_begin, int pix_end);
void nn_clamp_s8__neon(const nn_dims *d, int8_t *data, int c_stride, const int8_t *lo,
                       const int8_t *hi, int pix_begin, int pix_end);

/* The packed convolution (pl_s8_run_fn): neon and dotprod need PL_S8_LAYOUT_SDOT packing, i8mm
 * PL_S8_LAYOUT_I8MM. */
void nn_conv_packed_s8_1x16c4__neon(const pl_s8_conv *c, const uint8_t *a, int8_t *out, int out_c_stride,
                             int pix_begin, int pix_end, int oc_begin, int oc_end);
void nn_conv_packed_s8_4x16c4__neondot(const pl_s8_conv *c, const uint8_t *a, int8_t *out,
                                int out_c_stride, int pix_begin, int pix_end, int oc_begin,
                                int oc_end);
void nn_conv_packed_s8_4x16c8__neoni8mm(const pl_s8_conv *c, const uint8_t *a, int8_t *out, int out_c_stride,
                             int pix_begin, int pix_end, int oc_begin, int oc_end);

#endif
