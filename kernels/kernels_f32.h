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
#include <stdint.h>

#include "kernels/isa.h"
#include "kernels/ref/nn_ref.h"

#define PL_F32_MR 8  /* output channels per packed weight panel */
#define PL_F32_NR 48 /* output pixels per tile */
/* rows of K per block of B: KC x NR floats are 72 KiB, from L2. Measured (docs/PERFORMANCE.md):
 * 384 ran the seeded 192x256 frame ~0.5 ms faster than 192 (within L1 of some cores), 512 and
 * 1024 as 384; results do not depend on it (each chunk goes on from the stored sums exactly). */
#define PL_F32_KC 384

/* A convolution prepared for the packed path. `p` is the reference kernel's description
 * (kernels/ref/nn_ref.h; p.relu applies to the output). `w` holds pl_f32_pack_weights' panels;
 * `bias` (out_c values) may be NULL. `in_scale`/`in_shift` (in_c values each, both or neither)
 * apply max(0, in_scale[c]*x + in_shift[c]) to the input first — 1x1, stride 1, pad 0 only. */
typedef struct pl_f32_conv {
    nn_conv_params p;
    const float *w, *bias, *in_scale, *in_shift;
    int wino; /* 0: `w` holds pl_f32_pack_weights' panels, run by `conv`; 2 or 4: Winograd
               * F(wino x wino, 3x3), `w` holds pl_f32_wino_pack_weights' panels, run by `wino` */
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

/* nn_fc_w8_f32 (kernels/ref/nn_ref.h): a float layer with int8-stored weights, as the int8
 * executor runs a layer kept float; every implementation equals the reference bit for bit, so
 * the int8 path's results stay the same on every instruction-set path */
typedef void (*pl_f32_fc_w8_fn)(const float *in, int n_rows, int n_in, const int8_t *w,
                                const float *wscale, const float *bias, int relu, float *out,
                                int out_stride, int o_begin, int o_end);

typedef struct pl_kernels_f32 {
    int packed;          /* 1: `conv` is filled and convolutions take packed weights */
    pl_f32_conv_fn conv; /* NULL on the reference path (nn_conv2d_f32__ref instead) */
    pl_f32_conv_fn wino; /* Winograd 3x3 (see below); filled with `conv`, NULL without it */
    pl_f32_bn_relu_fn bn_relu;
    pl_f32_pool_fn maxpool, avgpool;
    pl_f32_fc_fn fc;
    pl_f32_fc_w8_fn fc_w8; /* every path, the reference included */
    const char *conv_name, *wino_name, *bn_relu_name, *maxpool_name, *avgpool_name, *fc_name,
        *fc_w8_name;
} pl_kernels_f32;

/* Fills every slot with the fastest implementation `isa` includes (kernels/isa.h). */
void pl_kernels_f32_fill(pl_kernels_f32 *t, pl_isa isa);

/* The slots as (operation, implementation) pairs for `parlight info`: up to `max` entries,
 * returns how many there are. */
int pl_kernels_f32_list(const pl_kernels_f32 *t, const char **op, const char **impl, int max);

/* Panels and tiles of a convolution. Inline: the micro-kernel files use them too, and a call
 * into kernels_f32.c (which holds the table that points at them) would make a circle. */
static inline int pl_f32_conv_panels(const nn_conv_params *p)
{
    return (p->out_c + PL_F32_MR - 1) / PL_F32_MR;
}
static inline int pl_f32_conv_tiles(const nn_conv_params *p)
{
    return (p->out_h * p->out_w + PL_F32_NR - 1) / PL_F32_NR;
}
/* Floats of packed weights for `p` (panels * K * MR). */
size_t pl_f32_packed_weights_floats(const nn_conv_params *p);
/* PyTorch [out_c][in_c][k_h][k_w] weights -> panels; dst holds pl_f32_packed_weights_floats. */
void pl_f32_pack_weights(const nn_conv_params *p, const float *w, float *dst);
/* Floats of scratch `conv` needs for `p` (a multiple of 16; at most (KC + 49) * NR). */
size_t pl_f32_conv_scratch_floats(const nn_conv_params *p);

/* Winograd F(m x m, 3x3), m = 2 or 4, for 3x3 convolutions with stride 1, padding 1 and the
 * output the input's size (pl_f32_wino_fits), without the 1x1 pre-activation:
 *
 *   1. at load, pl_f32_wino_pack_weights computes U = G g G^T (T x T, T = m + 2; in double,
 *      rounded once to float) for every (oc, ic) and packs it as T*T GEMM operands in the
 *      `conv` layout: [T*T][panels][in_c][MR] (the last panel zero-padded);
 *   2. per frame, `wino` takes the output in m x m tiles (tiles_y = ceil(out_h/m), tiles_x
 *      likewise, counted row by row) and those in blocks of NR tiles; per block and per chunk of
 *      PL_F32_WINO_KC input channels it builds V = B^T d B of every tile's (m+2) x (m+2) input
 *      patch (padding and the parts past the map as zeros) straight into T*T B blocks of the
 *      GEMM (KC x NR each), runs the T*T products M = U V with the path's micro-kernel (the
 *      same `ukr` as `conv`, summing in input-channel order), then writes Y = A^T M A (+ bias,
 *      ReLU) into the output planes, skipping the pixels of partial tiles past the map.
 *
 * `wino` has `conv`'s signature with "tiles" meaning blocks of NR Winograd tiles
 * (pl_f32_wino_blocks). As with `conv`, every output's arithmetic is fixed by m and in_c only, so
 * results do not depend on the block or panel split, nor on the thread count.
 *
 * Accuracy: y differs from the direct convolution by rounding in the transforms and the sum over
 * channels. First-order bound (tests/test_kernels_simd_f32.c checks it per output):
 *   |y - y_exact| <= gamma(in_c + 16) * (|bias| + W),
 *   W = sum_ic [|A^T| ((|G||g||G^T|) o (|B^T||d||B|)) |A|] (o: elementwise),
 * with gamma(n) = n u / (1 - n u), u = 2^-24: 16 covers the rounding of U, the two passes of
 * each transform (at most 4 and 3 roundings each) and the bias. The bracket grows with m (F(4x4)'s
 * transforms have entries up to 8 and 5): F(4x4) is the less accurate one (docs/PERFORMANCE.md). */
#define PL_F32_WINO_KC 128 /* input channels per chunk of V */

int pl_f32_wino_fits(const pl_f32_conv *c);
/* The m the executor uses for `p`: 4, 2 or 0 (direct) from the number of tiles, or
 * PARLIGHT_WINOGRAD=0|2|4 (0: never; 2, 4: that m for every fitting convolution; unset or
 * "auto": by tiles). -1: PARLIGHT_WINOGRAD holds anything else (the caller reports it). */
int pl_f32_wino_choose(const nn_conv_params *p);
int pl_f32_wino_blocks(const nn_conv_params *p, int m);
size_t pl_f32_wino_weights_floats(const nn_conv_params *p, int m);
void pl_f32_wino_pack_weights(const nn_conv_params *p, int m, const float *w, float *dst);
/* Floats of scratch `wino` needs for `p` and m (a multiple of 16). */
size_t pl_f32_wino_scratch_floats(const nn_conv_params *p, int m);

#endif
