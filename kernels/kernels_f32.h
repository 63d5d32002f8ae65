/* fp32 kernel slots of the kernel table (kernels/dispatch.h).
 *
 * The reference path (PL_ISA_REF) runs the kernels of kernels/ref/nn_ref.h directly; its table
 * has `packed == 0` and a NULL `conv` slot. The x86 SIMD paths (AVX2+FMA, AVX-512) run every
 * convolution of the float executor — the 7x7/2 stem, the dense layers' 1x1 bottlenecks with
 * their pre-activation BN+ReLU, the 3x3 convolutions and the transitions' 1x1 — through one
 * packed GEMM, C[oc][pixel] = W[oc][K] x B[K][pixel], K = in_c*k_h*k_w in PyTorch's order
 * (ic, ky, kx):
 *
 *   1. at load, pl_f32_pack_weights turns [out_c][K] weights into panels of PL_F32_MR output
 *      channels, [ceil(out_c/MR)][K][MR] (the last panel zero-padded) — plain C, every path;
 *   2. per frame, `conv` takes PL_F32_NR output pixels at a time (a "tile", counted in CHW
 *      order over out_h*out_w) and builds B's K x NR block in a scratch buffer: an implicit
 *      im2col (padding as zeros) that also applies the optional per-input-channel
 *      max(0, scale*x + shift) of a 1x1 convolution, then multiplies every panel with it.
 *
 * Scratch is owned by the caller, pl_f32_conv_scratch_floats() floats, 64-byte aligned, one
 * buffer per concurrent caller. Output channels are written as CHW planes of out_h*out_w at
 * `out` (which may point into a larger buffer, e.g. a dense block at a channel offset).
 *
 * Accuracy: SIMD kernels sum in a different order than the reference (FMA, blocked sums), so
 * they agree with it within a tolerance, not bit for bit; tests/test_kernels_simd_f32.c checks
 * |simd - ref| <= 1e-5 * (sum |w*x| + |bias|) + 1e-30 per output (docs/PERFORMANCE.md). Results do
 * not depend on the work split (tiles, panel ranges) — each output's summation order depends on
 * its K only — so the float path's outputs are the same for every thread count. */
#ifndef PL_KERNELS_KERNELS_F32_H
#define PL_KERNELS_KERNELS_F32_H

#include <stddef.h>

#include "kernels/isa.h"
#include "kernels/ref/nn_ref.h"

#define PL_F32_MR 8  /* output channels per packed weight panel */
#define PL_F32_NR 48 /* output pixels per tile */
#define PL_F32_KC 192 /* rows of K per block of B: KC x NR floats are 36 KiB, within L1 */

/* A convolution prepared for the packed path. `p` is the reference kernel's description
 * (kernels/ref/nn_ref.h; p.relu applies to the output). `w` holds pl_f32_pack_weights' panels;
 * `bias` (out_c values) may be NULL. `in_scale`/`in_shift` (in_c values each, both or neither)
 * apply max(0, in_scale[c]*x + in_shift[c]) to the input first — 1x1, stride 1, pad 0 only. */
typedef struct pl_f32_conv {
    nn_conv_params p;
    const float *w, *bias, *in_scale, *in_shift;
} pl_f32_conv;

/* Output channels [panel_begin*MR, min(panel_end*MR, out_c)) of output pixels
 * [tile_begin*NR, min(tile_end*NR, out_h*out_w)). `scratch`: see above. */
typedef void (*pl_f32_conv_fn)(const pl_f32_conv *c, const float *in, float *out, float *scratch,
                               int tile_begin, int tile_end, int panel_begin, int panel_end);

typedef void (*pl_f32_bn_relu_fn)(const float *in, const float *scale, const float *shift,
                                  int hw, float *out, int c_begin, int c_end);
typedef void (*pl_f32_pool_fn)(const nn_pool_params *p, const float *in, float *out, int c_begin,
                               int c_end);
typedef void (*pl_f32_fc_fn)(const float *in, int n_in, const float *w, const float *bias,
                             int relu, float *out, int o_begin, int o_end);

typedef struct pl_kernels_f32 {
    int packed;          /* 1: `conv` is filled and convolutions take packed weights */
    pl_f32_conv_fn conv; /* NULL on the reference path (nn_conv2d_f32__ref instead) */
    pl_f32_bn_relu_fn bn_relu;
    pl_f32_pool_fn maxpool, avgpool;
    pl_f32_fc_fn fc;
    const char *conv_name, *bn_relu_name, *maxpool_name, *avgpool_name, *fc_name;
} pl_kernels_f32;

/* Fills every slot with the fastest implementation `isa` includes (kernels/isa.h). */
void pl_kernels_f32_fill(pl_kernels_f32 *t, pl_isa isa);

/* The slots as (operation, implementation) pairs for `parlight info`: up to `max` entries,
 * returns how many there are. */
int pl_kernels_f32_list(const pl_kernels_f32 *t, const char **op, const char **impl, int max);

/* Panels and tiles of a convolution. */
int pl_f32_conv_panels(const nn_conv_params *p);
int pl_f32_conv_tiles(const nn_conv_params *p);
/* Floats of packed weights for `p` (panels * K * MR). */
size_t pl_f32_packed_weights_floats(const nn_conv_params *p);
/* PyTorch [out_c][in_c][k_h][k_w] weights -> panels; dst holds pl_f32_packed_weights_floats. */
void pl_f32_pack_weights(const nn_conv_params *p, const float *w, float *dst);
/* Floats of scratch `conv` needs for `p` (a multiple of 16; at most (KC + 49) * NR). */
size_t pl_f32_conv_scratch_floats(const nn_conv_params *p);

#endif
