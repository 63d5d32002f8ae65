/* int8 kernel slots of the kernel table (kernels/dispatch.h).
 *
 * The reference path (PL_ISA_REF) runs the kernels of kernels/ref/ directly; its table has
 * `packed == 0` and NULL run slots. The x86 SIMD paths run every convolution (k x k, 1 x 1 with
 * or without the per-input-channel clamp, and the fully connected layer as a 1 x 1 convolution
 * of one pixel) through one packed, implicit-GEMM kernel, in three steps:
 *
 *   1. at load, `pack` turns OHWI int8 weights into the path's layout and folds the input offset
 *      into the bias (below) — once, into memory the caller owns (`pl_s8_conv_packed_size`);
 *   2. per frame, the input becomes "A", a u8 buffer in which a value x is stored as x + 128
 *      (the sign bit flipped): `a_pack` for 1x1 convolutions (applies the clamp and the stride,
 *      one A pixel per output pixel), `a_pad` for k x k ones (a padded copy, the border filled
 *      with the input zero point), or `a_rows` for k x k ones on few channels (the stem's 3):
 *      a padded copy in which A pixel (y, x) holds the k_w input pixels output column x reads,
 *      so the convolution becomes k_h x 1 on k_w*in_c channels (less padding to 4 channels,
 *      fewer taps);
 *   3. `run` computes output pixels [pix_begin, pix_end) x channels [oc_begin, oc_end) from A.
 *
 * Why u8: VNNI's vpdpbusd multiplies u8 by s8. With u = x + 128,
 *   sum (x + input_offset) * w = sum u * w + (input_offset - 128) * sum w,
 * so the second term goes into the bias at pack time (modulo 2^32, as the reference's bias
 * addition wraps). Padded taps hold u = 128 - input_offset (the zero point), whose product
 * cancels that correction exactly, so the border needs no special case. vpdpbusd wraps (it is
 * not the saturating vpdpbusds); the AVX2 path, which has no VNNI, widens to 16 bits and uses
 * vpmaddwd (vpmaddubsw would saturate). The requantisation is pl_requantize_s8's arithmetic
 * lane by lane. The result equals the reference kernels bit for bit for every argument the
 * nn_*_s8_check functions accept (tests/test_kernels_simd_s8.c, tolerance 0).
 *
 * Layouts.
 *  - A: pixel (b, y, x) of an A buffer of geometry {n, a_h, a_w} starts at byte
 *    ((b*a_h + y)*a_w + x)*cs, cs = in_c rounded up to 4; bytes [in_c, cs) of a pixel are read
 *    but multiply zero weights, so they may hold anything.
 *  - Packed weights: output channels in blocks of PL_S8_OCB (the last block zero-padded), each
 *    block all K = k_h*k_w*cs inputs in groups of 4 (tap-major, zero weights for channels
 *    [in_c, cs)): VNNI paths [block][K/4][16][4] s8; AVX2 [block][K/4][2][16][2] s16 (pairs
 *    k0k1, k2k3). Then int32 [6][blocks*16]: the folded bias and the requantisation (below).
 *  - Output: NHWC, pixel stride out_c_stride, written at out + ((b*out_h + y)*pitch + x)*
 *    out_c_stride (pitch = out_pitch, or out_w when 0); only channels [oc_begin, oc_end) of
 *    pixels [pix_begin, pix_end) are written, pixels counted in order over {n, out_h, out_w}. Results do not depend on how the
 *    pixel or channel range is split (each value depends only on its own pixel and channel). */
#ifndef PL_KERNELS_KERNELS_S8_H
#define PL_KERNELS_KERNELS_S8_H

#include <stddef.h>
#include <stdint.h>

#include "kernels/isa.h"
#include "kernels/ref/nn_ref_s8_clamp.h"

#define PL_S8_OCB 16 /* output channels per packed block */

typedef enum pl_s8_layout {
    PL_S8_LAYOUT_NONE,  /* the reference path: nothing is packed */
    PL_S8_LAYOUT_VNNI,  /* s8 [block][K/4][16][4] */
    PL_S8_LAYOUT_AVX2,  /* s16 [block][K/4][2][16][2] */
    PL_S8_LAYOUT_SDOT,  /* Arm NEON and dotprod: the VNNI layout, the bias folded for signed A
                           (kernels/arm/nn_s8_arm.h) */
    PL_S8_LAYOUT_I8MM,  /* Arm i8mm: s8 [block][taps][round8(cs)/8][16][8] */
} pl_s8_layout;

/* A convolution prepared for a packed path: filled by pl_s8_conv_init, `w` and `bias` by the
 * table's `pack`. Geometry of the A buffer it reads: {n, a_h, a_w} pixels of cs bytes. */
typedef struct pl_s8_conv {
    int n, out_h, out_w, out_c;    /* output geometry */
    int a_h, a_w, cs, in_c;        /* A geometry; in_c real input channels, cs = round4(in_c) */
    int k_h, k_w;                  /* taps; 1 x 1 for a_pack'ed inputs */
    int stride_h, stride_w;        /* in A pixels (1 for a_pack'ed inputs) */
    int dilation_h, dilation_w;
    int32_t input_offset;          /* as in nn_conv_s8_params */
    int32_t output_offset, act_min, act_max;
    uint8_t out_xor;               /* 0, or 0x80 to write u8 (x + 128): the A of a following
                                      packed convolution */
    int out_pitch;                 /* output pixels from one output row to the next (>= out_w;
                                      0: out_w), e.g. to write the interior of a padded A */
    const int32_t *multiplier, *shift; /* [out_c], owned by the caller */
    const void *w;                 /* packed weights (pack) */
    const int32_t *bias;           /* [6][blocks*16] (pack): the folded bias, the multipliers,
                                      the left shifts max(shift, 0), the right shifts
                                      e = max(-shift, 0), 2^e - 1 and (2^e - 1) >> 1, padded
                                      with zeros to whole blocks */
    int any_left_shift;            /* (pack) some shift > 0: the kernels' slower requantisation
                                      with the saturating left shift */
    int short_requant;             /* (pack) no shift > 0, act_min = -128, act_max = 127 and
                                      every output channel's accumulator bounded, |bias| +
                                      255 * sum|w| < 2^30: the AVX-512 kernel's shorter
                                      requantisation (kernels/x86/nn_conv_packed_s8_tmpl.h),
                                      same results */
} pl_s8_conv;

/* a_pack: A pixel p (output order over out_dims {n, h, w}) = input pixel
 * (b, y*stride_h, x*stride_w), each channel c < in_dims->c clamped to [lo[c], hi[c]] (lo/hi NULL:
 * no clamp) and stored as u8 x + 128; pixels [pix_begin, pix_end). */
typedef void (*pl_s8_a_pack_fn)(const nn_dims *in_dims, const int8_t *in, int in_c_stride,
                                const int8_t *lo, const int8_t *hi, int stride_h, int stride_w,
                                const nn_dims *out_dims, uint8_t *a, int cs, int pix_begin,
                                int pix_end);
/* a_pad: A row r of image b (rows [row_begin, row_end) of n*a_h) = input row r - pad_h shifted
 * right by pad_w, as u8 x + 128; cells outside the input hold pad_u. */
typedef void (*pl_s8_a_pad_fn)(const nn_dims *in_dims, const int8_t *in, int in_c_stride,
                               int pad_h, int pad_w, uint8_t pad_u, int a_h, int a_w, uint8_t *a,
                               int cs, int row_begin, int row_end);
/* a_rows: A row r of image b (rows [row_begin, row_end) of n*a_h), pixel x < a_w, channels
 * [kx*in_c, (kx+1)*in_c) = input pixel (r - pad_h, x*stride_w - pad_w + kx*dilation_w) as u8
 * x + 128 (pad_u outside the input), kx < k_w; channels [k_w*in_c, cs) are written 0. */
typedef void (*pl_s8_a_rows_fn)(const nn_dims *in_dims, const int8_t *in, int in_c_stride,
                                int pad_h, int pad_w, uint8_t pad_u, int k_w, int stride_w,
                                int dilation_w, int a_h, int a_w, uint8_t *a, int cs,
                                int row_begin, int row_end);
/* pack: weights OHWI [out_c][k_h][k_w][in_c], bias [out_c] or NULL, into `mem`
 * (pl_s8_conv_packed_size bytes, 64-byte aligned); sets c->w and c->bias. */
typedef void (*pl_s8_pack_fn)(pl_s8_conv *c, const int8_t *weights, const int32_t *bias,
                              void *mem);
typedef void (*pl_s8_run_fn)(const pl_s8_conv *c, const uint8_t *a, int8_t *out,
                             int out_c_stride, int pix_begin, int pix_end, int oc_begin,
                             int oc_end);
/* Pooling and clamping, split over output pixels (in order over out_dims {n, h, w}) instead of
 * the reference's channel ranges; all channels of those pixels. maxpool = nn_maxpool2d_s8__ref.
 * avgpool = nn_avgpool2d_s8__ref of the input clamped per channel to [lo[c], hi[c]] (lo/hi NULL:
 * no clamp), each output byte xor'ed with out_xor (0x80: the result is the A of a 1x1 packed
 * convolution, cs = out_c_stride): a DenseNet transition's BN + ReLU + pool in one pass.
 * clamp = nn_clamp_s8__ref over all channels of pixels [pix_begin, pix_end) of d. */
typedef void (*pl_s8_maxpool_fn)(const nn_pool_s8_params *p, const nn_dims *in_dims,
                                 const int8_t *in, int in_c_stride, const nn_dims *out_dims,
                                 int8_t *out, int out_c_stride, int pix_begin, int pix_end);
typedef void (*pl_s8_avgpool_fn)(const nn_pool_s8_params *p, const nn_dims *in_dims,
                                 const int8_t *in, int in_c_stride, const int8_t *lo,
                                 const int8_t *hi, const nn_dims *out_dims, uint8_t *out,
                                 int out_c_stride, uint8_t out_xor, int pix_begin, int pix_end);
typedef void (*pl_s8_clamp_fn)(const nn_dims *d, int8_t *data, int c_stride, const int8_t *lo,
                               const int8_t *hi, int pix_begin, int pix_end);

typedef struct pl_kernels_s8 {
    int packed;          /* 1: the packed slots below are filled; 0: use kernels/ref/ */
    pl_s8_layout layout; /* packed weight layout */
    pl_s8_pack_fn pack;
    pl_s8_a_pack_fn a_pack;
    pl_s8_a_pad_fn a_pad;
    pl_s8_a_rows_fn a_rows;
    pl_s8_run_fn run;
    pl_s8_maxpool_fn maxpool;
    pl_s8_avgpool_fn avgpool;
    pl_s8_clamp_fn clamp;
    const char *pack_name, *a_pack_name, *a_pad_name, *a_rows_name, *run_name;
    const char *maxpool_name, *avgpool_name, *clamp_name;
} pl_kernels_s8;

/* Fills every slot with the fastest implementation `isa` includes (kernels/isa.h). */
void pl_kernels_s8_fill(pl_kernels_s8 *t, pl_isa isa);

/* The slots as (operation, implementation) pairs for `parlight info`: up to `max` entries
 * (op or impl may be NULL), returns how many there are. On the reference path the operations are the kernels of
 * kernels/ref/ the executor calls. */
int pl_kernels_s8_list(const pl_kernels_s8 *t, const char **op, const char **impl, int max);

/* How a convolution's A is built (and so its geometry). */
typedef enum pl_s8_a_kind {
    PL_S8_A_PACK, /* 1x1 through a_pack: one A pixel per output pixel */
    PL_S8_A_PAD,  /* k x k through a_pad: the input padded by pad_h/pad_w on the top/left and as
                     needed on the bottom/right */
    PL_S8_A_ROWS, /* k x k through a_rows: the k_w taps folded into the channels (k_h x 1 on
                     k_w*in_c channels, A as wide as the output) */
} pl_s8_a_kind;

/* Geometry of a packed convolution from the reference arguments (validated before with
 * nn_conv2d_s8_check / nn_conv1x1_s8_check; PL_S8_A_PACK needs a 1x1 filter). The weights stay
 * OHWI for every kind (folding k_w into the channels keeps their order). q's arrays must outlive
 * c. */
void pl_s8_conv_init(pl_s8_conv *c, const nn_conv_s8_params *p, const nn_per_channel_quant *q,
                     const nn_dims *in_dims, const nn_dims *filter_dims, const nn_dims *out_dims,
                     pl_s8_a_kind kind);
/* Bytes `pack` needs for c in `layout` (0 for PL_S8_LAYOUT_NONE). */
size_t pl_s8_conv_packed_size(const pl_s8_conv *c, pl_s8_layout layout);
/* Bytes of c's A buffer: n*a_h*a_w*cs plus 64 bytes of slack (the kernels may load a few bytes
 * beyond the last pixel). */
size_t pl_s8_conv_a_size(const pl_s8_conv *c);
/* The pad value of a_pad for an input offset: the zero point as u8, 128 - input_offset. */
static inline uint8_t pl_s8_pad_u(int32_t input_offset)
{
    return (uint8_t)(128 - input_offset);
}

/* ---- chaining two packed convolutions through A ----------------------------------------------
 * A holds u8 (s8 + 128, i.e. x ^ PL_S8_A_XOR), which VNNI's u8 x s8 product wants. A producer
 * can write its output straight into the interior of a padded consumer's A, so the consumer
 * needs no a_pad pass: the executor calls pl_s8_conv_write_a on the producer once at load,
 * pl_s8_a_fill_pad on the consumer's A once per map size (the border is the zero point, and no
 * kernel writes it), runs the producer into pl_s8_a_at(consumer, a, pad_h, pad_w), then the
 * consumer's `run` on a. pl_s8_a_read_s8 reads an interior back as s8 (for the observer). */
#define PL_S8_A_XOR 0x80

/* The producer writes u8 A pixels (out_xor) with pixel rows a_w apart (out_pitch), for a
 * consumer whose A rows are a_w pixels. */
static inline void pl_s8_conv_write_a(pl_s8_conv *producer, int a_w)
{
    producer->out_xor = PL_S8_A_XOR;
    producer->out_pitch = a_w;
}
/* Every byte of c's A (n*a_h*a_w*cs) set to the zero point, pl_s8_pad_u(c->input_offset). */
void pl_s8_a_fill_pad(const pl_s8_conv *c, uint8_t *a);
/* The address of A pixel (y, x) of image 0. */
static inline uint8_t *pl_s8_a_at(const pl_s8_conv *c, uint8_t *a, int y, int x)
{
    return a + ((size_t)y * (size_t)c->a_w + (size_t)x) * (size_t)c->cs;
}
/* The h x w pixels of A from (y0, x0), cs channels each, as s8 into out (h*w*cs, packed). */
void pl_s8_a_read_s8(const pl_s8_conv *c, const uint8_t *a, int y0, int x0, int h, int w,
                     int8_t *out);

#endif
