/* x86 int8 kernels of the packed path (kernels/kernels_s8.h describes the slots, layouts and
 * arithmetic). Each file is compiled with the ISA flags its name ends with (Makefile); call a
 * kernel only when kernels/isa.h says the CPU has its path. */
#ifndef PL_KERNELS_X86_NN_S8_X86_H
#define PL_KERNELS_X86_NN_S8_X86_H

#include "kernels/kernels_s8.h"

/* Building A (kernels_s8.h: pl_s8_a_pack_fn, pl_s8_a_pad_fn). */
void nn_a_pack_s8__avx2(const nn_dims *in_dims, const int8_t *in, int in_c_stride,
                        const int8_t *lo, const int8_t *hi, int stride_h, int stride_w,
                        const nn_dims *out_dims, uint8_t *a, int cs, int pix_begin, int pix_end);
void nn_a_pad_s8__avx2(const nn_dims *in_dims, const int8_t *in, int in_c_stride, int pad_h,
                       int pad_w, uint8_t pad_u, int a_h, int a_w, uint8_t *a, int cs,
                       int row_begin, int row_end);
void nn_a_rows_s8__avx2(const nn_dims *in_dims, const int8_t *in, int in_c_stride, int pad_h,
                        int pad_w, uint8_t pad_u, int k_w, int stride_w, int dilation_w, int a_h,
                        int a_w, uint8_t *a, int cs, int row_begin, int row_end);
void nn_a_rows_s8__avx512skx(const nn_dims *in_dims, const int8_t *in, int in_c_stride,
                              int pad_h, int pad_w, uint8_t pad_u, int k_w, int stride_w,
                              int dilation_w, int a_h, int a_w, uint8_t *a, int cs, int row_begin,
                              int row_end);
void nn_a_pack_s8__avx512skx(const nn_dims *in_dims, const int8_t *in, int in_c_stride,
                              const int8_t *lo, const int8_t *hi, int stride_h, int stride_w,
                              const nn_dims *out_dims, uint8_t *a, int cs, int pix_begin,
                              int pix_end);
void nn_a_pad_s8__avx512skx(const nn_dims *in_dims, const int8_t *in, int in_c_stride,
                             int pad_h, int pad_w, uint8_t pad_u, int a_h, int a_w, uint8_t *a,
                             int cs, int row_begin, int row_end);

/* Pooling and clamping (pl_s8_maxpool_fn, pl_s8_avgpool_fn, pl_s8_clamp_fn). */
void nn_maxpool2d_s8__avx2(const nn_pool_s8_params *p, const nn_dims *in_dims, const int8_t *in,
                           int in_c_stride, const nn_dims *out_dims, int8_t *out,
                           int out_c_stride, int pix_begin, int pix_end);
void nn_avgpool2d_s8__avx2(const nn_pool_s8_params *p, const nn_dims *in_dims, const int8_t *in,
                           int in_c_stride, const int8_t *lo, const int8_t *hi,
                           const nn_dims *out_dims, uint8_t *out, int out_c_stride,
                           uint8_t out_xor, int pix_begin, int pix_end);
void nn_clamp_s8__avx2(const nn_dims *d, int8_t *data, int c_stride, const int8_t *lo,
                       const int8_t *hi, int pix_begin, int pix_end);
void nn_maxpool2d_s8__avx512skx(const nn_pool_s8_params *p, const nn_dims *in_dims,
                                 const int8_t *in, int in_c_stride, const nn_dims *out_dims,
                                 int8_t *out, int out_c_stride, int pix_begin, int pix_end);
void nn_avgpool2d_s8__avx512skx(const nn_pool_s8_params *p, const nn_dims *in_dims,
                                 const int8_t *in, int in_c_stride, const int8_t *lo,
                                 const int8_t *hi, const nn_dims *out_dims, uint8_t *out,
                                 int out_c_stride, uint8_t out_xor, int pix_begin, int pix_end);
void nn_clamp_s8__avx512skx(const nn_dims *d, int8_t *data, int c_stride, const int8_t *lo,
                             const int8_t *hi, int pix_begin, int pix_end);

/* The packed convolution (pl_s8_run_fn). Tiles: AVX-512 VNNI 14 pixels x 32 channels (28 zmm
 * accumulators), AVX-VNNI 6 pixels x 16 channels (12 ymm), AVX2 4 x 16 (8 ymm: its 16-bit
 * products need 4 weight vectors per group, and more accumulators spill). The VNNI kernels need the
 * PL_S8_LAYOUT_VNNI packing, the AVX2 one PL_S8_LAYOUT_AVX2. */
void nn_conv_packed_s8_14x32c4__avx512vnni(const pl_s8_conv *c, const uint8_t *a, int8_t *out,
                                   int out_c_stride, int pix_begin, int pix_end, int oc_begin,
                                   int oc_end);
void nn_conv_packed_s8_6x16c4__avxvnni(const pl_s8_conv *c, const uint8_t *a, int8_t *out,
                                int out_c_stride, int pix_begin, int pix_end, int oc_begin,
                                int oc_end);
void nn_conv_packed_s8_4x16c4__avx2(const pl_s8_conv *c, const uint8_t *a, int8_t *out, int out_c_stride,
                             int pix_begin, int pix_end, int oc_begin, int oc_end);
/* AMX (the amx path, PARLIGHT_ISA=amx only): tdpbusd on tiles of 16 pixels x 32 channels, the
 * VNNI packing (a block's [K/4][16][4] weights are its B tiles), AVX-512 requantisation; and the
 * same kernel with the tile instructions emulated in C, for the tests on CPUs without AMX. */
void nn_conv_packed_s8_16x32c4__amx(const pl_s8_conv *c, const uint8_t *a, int8_t *out,
                                    int out_c_stride, int pix_begin, int pix_end, int oc_begin,
                                    int oc_end);
void nn_conv_packed_s8_16x32c4_amxemu__avx512vnni(const pl_s8_conv *c, const uint8_t *a,
                                                  int8_t *out, int out_c_stride, int pix_begin,
                                                  int pix_end, int oc_begin, int oc_end);

#endif
