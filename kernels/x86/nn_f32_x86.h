/* x86 fp32 kernels (kernels/kernels_f32.h describes the slots and layouts). The suffix says
 * the instructions a file needs: __avx512f only AVX-512F (so an AVX-512 CPU without VNNI runs
 * them), __avx2 AVX2 + FMA. */
#ifndef PL_KERNELS_X86_NN_F32_X86_H
#define PL_KERNELS_X86_NN_F32_X86_H

#include "kernels/kernels_f32.h"

void nn_conv_gemm_f32_8x48__avx512f(const pl_f32_conv *c, const float *in, float *out,
                                       float *scratch, int tile_begin, int tile_end,
                                       int panel_begin, int panel_end);
void nn_conv_gemm_f32_4x24__avx2(const pl_f32_conv *c, const float *in, float *out,
                                 float *scratch, int tile_begin, int tile_end, int panel_begin,
                                 int panel_end);

/* Winograd F(2x2 or 4x4, 3x3) on the same micro-kernels (kernels/nn_conv_wino_f32_tmpl.h) */
void nn_conv_wino_f32_8x48__avx512f(const pl_f32_conv *c, const float *in, float *out,
                                       float *scratch, int block_begin, int block_end,
                                       int panel_begin, int panel_end);
void nn_conv_wino_f32_4x24__avx2(const pl_f32_conv *c, const float *in, float *out, float *scratch,
                                 int block_begin, int block_end, int panel_begin, int panel_end);
void nn_bn_relu_f32__avx512f(const float *in, const float *scale, const float *shift, int hw,
                                float *out, int c_begin, int c_end);
void nn_bn_relu_f32__avx2(const float *in, const float *scale, const float *shift, int hw,
                          float *out, int c_begin, int c_end);

/* nn_pool_f32__<isa>.c: bit for bit equal to the reference kernels */
void nn_maxpool2d_f32__avx512f(const nn_pool_params *p, const float *in, float *out,
                                  int c_begin, int c_end);
void nn_avgpool2d_f32__avx512f(const nn_pool_params *p, const float *in, float *out,
                                  int c_begin, int c_end);
void nn_maxpool2d_f32__avx2(const nn_pool_params *p, const float *in, float *out, int c_begin,
                            int c_end);
void nn_avgpool2d_f32__avx2(const nn_pool_params *p, const float *in, float *out, int c_begin,
                            int c_end);

void nn_fc_f32__avx512f(const float *in, int n_in, const float *w, const float *bias, int relu,
                           float *out, int o_begin, int o_end);
void nn_fc_f32__avx2(const float *in, int n_in, const float *w, const float *bias, int relu,
                     float *out, int o_begin, int o_end);

/* nn_fc_w8_f32__<isa>.c (kernels/nn_fc_w8_f32_tmpl.h): bit for bit equal to the reference */
void nn_fc_w8_f32__avx512f(const float *in, int n_rows, int n_in, const int8_t *w,
                           const float *wscale, const float *bias, int relu, float *out,
                           int out_stride, int o_begin, int o_end);
void nn_fc_w8_f32__avx2(const float *in, int n_rows, int n_in, const int8_t *w,
                        const float *wscale, const float *bias, int relu, float *out,
                        int out_stride, int o_begin, int o_end);

#endif
