/* The packed int8 convolution for the Arm paths (kernels/arm/nn_s8_arm.h explains the tiles,
 * layouts and requantisation). The including file defines one of NN_T_NEON, NN_T_DOTPROD,
 * NN_T_I8MM, and NN_T_NAME, the function's name; the driver (tiles over pixels and 16-channel
 * blocks) is the x86 one's. */
#include <arm_neon.h>
#include <string.h>

#include "kernels/arm/nn_s8_arm.h"

#if defined(NN_T_NEON)
#define MR 1
#define GROUP_BYTES 64 /* weight bytes per group of 4 input channels, 16 outputs */
#elif defined(NN_T_DOTPROD)
#define MR 4
#define GROUP_BYTES 64
#elif defined(NN_T_I8MM)
#define MR 4
#define GROUP_BYTES 128 /* per group of 8 input channels */
#else
#error "define NN_T_NEON, NN_T_DOTPROD or NN_T_I8MM"
#endif

#define INLINE static inline __attribute__((always_inline))

#if defined(NN_T_DOTPROD) && defined(__GNUC__) && !defined(__clang__)
/* gcc 12's default register allocator keeps the 4-pixel tile's 16 accumulators moving: 10 register
 * moves among the 64 sdot of each inner iteration, 39 instead of 34 cycles on llvm-mca's
 * Neoverse N1 (the A76's core); the priority allocator has none (88 instructions, no spills).
 * The 2- and 3-pixel tiles (a row's or a range's remainder, rare here) get some moves instead.
 * docs/PERFORMANCE.md, "Arm predicted by simulation". */
#pragma GCC optimize("ira-algorithm=priority")
#endif

static inline uint32_t load32(const uint8_t *p)
{
    uint32_t v;
    memcpy(&v, p, sizeof v);
    return v;
}

/* pl_requantize of four accumulators (nn_s8_arm.h); nrsh = -e */
INLINE int32x4_t requant(int32x4_t acc, int32x4_t mult, int32x4_t lsh, int32x4_t nrsh)
{
    const int32x4_t h = vqrdmulhq_s32(vqshlq_s32(acc, lsh), mult);
    const int32x4_t fix = vshrq_n_s32(vandq_s32(h, nrsh), 31);
    return vrshlq_s32(vqaddq_s32(h, fix), nrsh);
}

/* Requantises 16 channels of one pixel (r[0..3]: channels 4v..4v+3 of the block, the bias
 * already in) and stores the bytes of channels [cb, ce) at o. */
INLINE void store16(const int32x4_t r[4], const int32_t *qv, int nbp, int16x8_t off, int16x8_t lo,
                    int16x8_t hi, int8x16_t xr, int8_t *o, int cb, int ce)
{
    int16x4_t h[4];
    for (int v = 0; v < 4; v++) {
        const int32_t *q = qv + 4 * v;
        h[v] = vqmovn_s32(requant(r[v], vld1q_s32(q + nbp), vld1q_s32(q + 2 * nbp),
                                  vnegq_s32(vld1q_s32(q + 3 * nbp))));
    }
    int16x8_t s0 = vqaddq_s16(vcombine_s16(h[0], h[1]), off);
    int16x8_t s1 = vqaddq_s16(vcombine_s16(h[2], h[3]), off);
    s0 = vmaxq_s16(vminq_s16(s0, hi), lo);
    s1 = vmaxq_s16(vminq_s16(s1, hi), lo);
    const int8x16_t bytes = veorq_s8(vcombine_s8(vqmovn_s16(s0), vqmovn_s16(s1)), xr);
    if (cb == 0 && ce >= 16) {
        vst1q_s8(o, bytes);
    } else {
        int8_t tmp[16];
        vst1q_s8(tmp, bytes);
        memcpy(o + cb, tmp + cb, (size_t)(ce - cb));
    }
}

/* ---- one tile: mr pixels (A at a0 + m*astep) x the 16 channels of one block ------------------ */
INLINE void tile(const int mr, const pl_s8_conv *c, const uint8_t *a0, size_t astep,
                 const int8_t *wblk, const int32_t *qv, int nbp, int8_t *const *out, int c0, int cb,
                 int ce)
{
    int32x4_t r[MR][4]; /* the 16 channels of each pixel, before requantisation */
    const int8_t *wg = wblk;
#if defined(NN_T_NEON) || defined(NN_T_DOTPROD)
    const uint8x16_t flip = vdupq_n_u8(0x80);
    const int gpt = c->cs / 4;
#if defined(NN_T_NEON)
    int32x4_t lo[MR][4], hi[MR][4]; /* pairs of partial sums: channels 4j, 4j+1 / 4j+2, 4j+3 */
    const int32x4_t zero = vdupq_n_s32(0);
#pragma GCC unroll 6
    for (int m = 0; m < mr; m++)
        for (int j = 0; j < 4; j++)
            lo[m][j] = hi[m][j] = zero;
            /* products of the group of 4 channels in lane `l` of av[m] (lanes hold 4-byte groups)
             */
#define NN_T_GROUP(l)                                                                              \
    do {                                                                                           \
        const int8x16_t w0 = vld1q_s8(wg + 64 * (l)), w1 = vld1q_s8(wg + 64 * (l) + 16),           \
                        w2 = vld1q_s8(wg + 64 * (l) + 32), w3 = vld1q_s8(wg + 64 * (l) + 48);      \
        for (int m = 0; m < mr; m++) {                                                             \
            const int8x16_t ab =                                                                   \
                vreinterpretq_s8_s32(vdupq_laneq_s32(vreinterpretq_s32_s8(av[m]), (l)));           \
            const int8x8_t ab8 = vget_low_s8(ab);                                                  \
            lo[m][0] = vpadalq_s16(lo[m][0], vmull_s8(vget_low_s8(w0), ab8));                      \
            hi[m][0] = vpadalq_s16(hi[m][0], vmull_high_s8(w0, ab));                               \
            lo[m][1] = vpadalq_s16(lo[m][1], vmull_s8(vget_low_s8(w1), ab8));                      \
            hi[m][1] = vpadalq_s16(hi[m][1], vmull_high_s8(w1, ab));                               \
            lo[m][2] = vpadalq_s16(lo[m][2], vmull_s8(vget_low_s8(w2), ab8));                      \
            hi[m][2] = vpadalq_s16(hi[m][2], vmull_high_s8(w2, ab));                               \
            lo[m][3] = vpadalq_s16(lo[m][3], vmull_s8(vget_low_s8(w3), ab8));                      \
            hi[m][3] = vpadalq_s16(hi[m][3], vmull_high_s8(w3, ab));                               \
        }                                                                                          \
    } while (0)
#else
#pragma GCC unroll 6
    for (int m = 0; m < mr; m++)
        for (int j = 0; j < 4; j++)
            r[m][j] = vld1q_s32(qv + 4 * j);
#define NN_T_GROUP(l)                                                                              \
    do {                                                                                           \
        const int8x16_t w0 = vld1q_s8(wg + 64 * (l)), w1 = vld1q_s8(wg + 64 * (l) + 16),           \
                        w2 = vld1q_s8(wg + 64 * (l) + 32), w3 = vld1q_s8(wg + 64 * (l) + 48);      \
        for (int m = 0; m < mr; m++) {                                                             \
            r[m][0] = vdotq_laneq_s32(r[m][0], w0, av[m], (l));                                    \
            r[m][1] = vdotq_laneq_s32(r[m][1], w1, av[m], (l));                                    \
            r[m][2] = vdotq_laneq_s32(r[m][2], w2, av[m], (l));                                    \
            r[m][3] = vdotq_laneq_s32(r[m][3], w3, av[m], (l));                                    \
        }                                                                                          \
    } while (0)
#endif
    for (int ky = 0; ky < c->k_h; ky++)
        for (int kx = 0; kx < c->k_w; kx++) {
            const uint8_t *ap = a0 + ((size_t)ky * (size_t)c->dilation_h * (size_t)c->a_w +
                                      (size_t)kx * (size_t)c->dilation_w) *
                                         (size_t)c->cs;
            int g = 0;
            for (; g + 4 <= gpt; g += 4, wg += 4 * GROUP_BYTES, ap += 16) {
                int8x16_t av[MR];
#pragma GCC unroll 6
                for (int m = 0; m < mr; m++)
                    av[m] = vreinterpretq_s8_u8(veorq_u8(vld1q_u8(ap + (size_t)m * astep), flip));
                NN_T_GROUP(0);
                NN_T_GROUP(1);
                NN_T_GROUP(2);
                NN_T_GROUP(3);
            }
            for (; g < gpt; g++, wg += GROUP_BYTES, ap += 4) {
                int8x16_t av[MR];
#pragma GCC unroll 6
                for (int m = 0; m < mr; m++)
                    av[m] = vreinterpretq_s8_u8(veorq_u8(
                        vreinterpretq_u8_u32(vdupq_n_u32(load32(ap + (size_t)m * astep))), flip));
                NN_T_GROUP(0);
            }
        }
#undef NN_T_GROUP
#if defined(NN_T_NEON)
#pragma GCC unroll 6
    for (int m = 0; m < mr; m++)
        for (int j = 0; j < 4; j++)
            r[m][j] = vaddq_s32(vpaddq_s32(lo[m][j], hi[m][j]), vld1q_s32(qv + 4 * j));
#endif
#else /* NN_T_I8MM */
    enum { NP = (MR + 1) / 2 };
    int32x4_t acc[NP][8]; /* pixel pair q x channel pair j: (2q, 2j) (2q, 2j+1) (2q+1, 2j) ... */
    const int np = (mr + 1) / 2;
    const int32x4_t zero = vdupq_n_s32(0);
#pragma GCC unroll 3
    for (int q = 0; q < np; q++)
        for (int j = 0; j < 8; j++)
            acc[q][j] = zero;
    const int g8 = (c->cs + 7) / 8;
    for (int ky = 0; ky < c->k_h; ky++)
        for (int kx = 0; kx < c->k_w; kx++) {
            const uint8_t *ap = a0 + ((size_t)ky * (size_t)c->dilation_h * (size_t)c->a_w +
                                      (size_t)kx * (size_t)c->dilation_w) *
                                         (size_t)c->cs;
            for (int g = 0; g < g8; g++, wg += GROUP_BYTES, ap += 8) {
                uint8x16_t av[NP];
#pragma GCC unroll 3
                for (int q = 0; q < np; q++) {
                    const int m1 = 2 * q + 1 < mr ? 2 * q + 1 : 2 * q;
                    av[q] = vcombine_u8(vld1_u8(ap + (size_t)(2 * q) * astep),
                                        vld1_u8(ap + (size_t)m1 * astep));
                }
#pragma GCC unroll 8
                for (int j = 0; j < 8; j++) {
                    const int8x16_t w = vld1q_s8(wg + 16 * j);
#pragma GCC unroll 3
                    for (int q = 0; q < np; q++)
                        acc[q][j] = vusmmlaq_s32(acc[q][j], av[q], w);
                }
            }
        }
#pragma GCC unroll 3
    for (int q = 0; q < np; q++)
        for (int v = 0; v < 4; v++) {
            const int64x2_t e = vreinterpretq_s64_s32(acc[q][2 * v]),
                            f = vreinterpretq_s64_s32(acc[q][2 * v + 1]);
            const int32x4_t bias = vld1q_s32(qv + 4 * v);
            r[2 * q][v] = vaddq_s32(vreinterpretq_s32_s64(vzip1q_s64(e, f)), bias);
            if (2 * q + 1 < mr)
                r[2 * q + 1][v] = vaddq_s32(vreinterpretq_s32_s64(vzip2q_s64(e, f)), bias);
        }
#endif

    const int16x8_t off = vdupq_n_s16((int16_t)c->output_offset),
                    lo16 = vdupq_n_s16((int16_t)c->act_min),
                    hi16 = vdupq_n_s16((int16_t)c->act_max);
    const int8x16_t xr = vdupq_n_s8((int8_t)c->out_xor);
    for (int m = 0; m < mr; m++)
        store16(r[m], qv, nbp, off, lo16, hi16, xr, out[m] + c0, cb, ce);
}

/* Dispatches a runtime tile height to the specialised tile. */
#define NN_T_CASE(n)                                                                               \
    case n:                                                                                        \
        tile(n, c, a0, astep, wblk, qv, nbp, out, c0, cb, ce);                                     \
        break;

static void tile_any(int mr, const pl_s8_conv *c, const uint8_t *a0, size_t astep,
                     const int8_t *wblk, const int32_t *qv, int nbp, int8_t *const *out, int c0,
                     int cb, int ce)
{
    switch (mr) {
        NN_T_CASE(1)
#if MR > 1
        NN_T_CASE(2)
        NN_T_CASE(3) NN_T_CASE(4)
#endif
            default : break;
    }
}

void NN_T_NAME(const pl_s8_conv *c, const uint8_t *a, int8_t *out, int out_c_stride, int pix_begin,
               int pix_end, int oc_begin, int oc_end)
{
    const int nb = (c->out_c + PL_S8_OCB - 1) / PL_S8_OCB, nbp = nb * PL_S8_OCB;
#if defined(NN_T_I8MM)
    const size_t wblock_bytes =
        (size_t)c->k_h * (size_t)c->k_w * (size_t)((c->cs + 7) / 8) * GROUP_BYTES;
#else
    const size_t wblock_bytes = (size_t)c->k_h * (size_t)c->k_w * (size_t)(c->cs / 4) * GROUP_BYTES;
#endif
    const int dense = c->k_h == 1 && c->k_w == 1 && c->stride_h == 1 && c->stride_w == 1 &&
                      c->a_h == c->out_h && c->a_w == c->out_w;
    const size_t astep = (size_t)c->stride_w * (size_t)c->cs, ostride = (size_t)out_c_stride;
    const int pitch = c->out_pitch ? c->out_pitch : c->out_w;
    const int blk_begin = oc_begin / PL_S8_OCB, blk_end = (oc_end + PL_S8_OCB - 1) / PL_S8_OCB;
    const int8_t *w = c->w;
    for (int p = pix_begin; p < pix_end;) {
        const int ox = p % c->out_w, row = p / c->out_w, oy = row % c->out_h, b = row / c->out_h;
        int mr = pix_end - p;
        if (!dense && mr > c->out_w - ox) mr = c->out_w - ox;
        if (mr > MR) mr = MR;
        const uint8_t *a0 =
            a + (((size_t)b * (size_t)c->a_h + (size_t)oy * (size_t)c->stride_h) * (size_t)c->a_w +
                 (size_t)ox * (size_t)c->stride_w) *
                    (size_t)c->cs;
        int8_t *o[MR]; /* the tile's output pixels (rows of the output may be apart: out_pitch) */
        for (int m = 0; m < mr; m++) {
            const int q = p + m, qx = q % c->out_w, qrow = q / c->out_w;
            o[m] = out + ((size_t)qrow * (size_t)pitch + (size_t)qx) * ostride;
        }
        for (int blk = blk_begin; blk < blk_end; blk++) {
            const int c0 = blk * PL_S8_OCB;
            const int cb = oc_begin > c0 ? oc_begin - c0 : 0;
            const int ce = oc_end - c0 < PL_S8_OCB ? oc_end - c0 : PL_S8_OCB;
            tile_any(mr, c, a0, astep, w + (size_t)blk * wblock_bytes, c->bias + c0, nbp, o, c0, cb,
                     ce);
        }
        p += mr;
    }
}
