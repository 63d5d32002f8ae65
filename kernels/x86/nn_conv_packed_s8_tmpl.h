/* The packed int8 convolution (kernels/kernels_s8.h), written once for three x86 paths. The
 * including file defines one of
 *   NN_T_AVX512VNNI  zmm, vpdpbusd; a tile is up to 14 pixels x 2 blocks of 16 channels
 *   NN_T_AVXVNNI     ymm, VEX vpdpbusd; 6 pixels x 1 block (2 ymm)
 *   NN_T_AVX2        ymm, u8 widened to s16 and vpmaddwd; 4 pixels x 1 block (2 ymm)
 *   NN_T_AMX         AMX tiles (tdpbusd) accumulate, zmm requantise; 16 pixels x 2 blocks; with
 *                    NN_T_AMX_EMU the tile operations are emulated in C (below)
 * and NN_T_NAME, the function's name.
 *
 * Each tile keeps MR x 2 int32 accumulators in registers, starting from the folded bias, and
 * walks the taps and the groups of 4 input channels: per group it loads the two weight vectors
 * once and broadcasts 4 bytes of A per pixel. Then it requantises exactly as pl_requantize_s8
 * (kernels/requant.h), lane by lane:
 *   x    = acc << lsh, saturated to int32 when the shift overflows
 *   high = (x * mult + 2^30) >> 31          (64-bit products of the even and odd lanes; the low
 *                                            32 bits of the shifted sum are the same for a
 *                                            logical and an arithmetic shift)
 *   res  = (high >> rsh) + (remainder > (mask >> 1) + (high < 0))     rounding half away
 * clamps res to [-1024, 1024] (which changes no final value, as |output_offset| <= 128 and the
 * activation range is inside [-128, 127]), adds the output offset, clamps to the activation
 * range, narrows to bytes and stores the channels asked for. AVX-512 does the same in fewer
 * operations: it clamps res to [act_min - offset, act_max - offset] (inside [-256, 255], so the
 * [-1024, 1024] clamp has nothing to do) before adding the offset, and an out_xor of 0x80 is
 * the offset + 128 (x ^ 0x80 = x + 128 mod 256 on a byte), so vpmovdb's truncation writes it. */
#include <immintrin.h>
#include <string.h>

#include "kernels/x86/nn_s8_x86.h"

#if defined(NN_T_AVX512VNNI) || defined(NN_T_AMX)
#define NN_T_ZMM 1 /* requantisation on AVX-512 */
typedef __m512i vec;
#if defined(NN_T_AMX)
#define MR 16 /* the rows of a tile */
#else
#define MR 14 /* 28 accumulators + 2 weight vectors + the broadcast: 31 of the 32 zmm */
#endif
#define NBLK 2 /* blocks per tile */
#define GROUP_BYTES 64
#elif defined(NN_T_AVXVNNI) || defined(NN_T_AVX2)
typedef __m256i vec;
#define NBLK 1
#if defined(NN_T_AVX2)
#define MR 4 /* 8 accumulators + 4 weight vectors + temporaries: no spills in 16 ymm */
#define GROUP_BYTES 128
#else
#define MR 6
#define GROUP_BYTES 64
#endif
#else
#error "define NN_T_AVX512VNNI, NN_T_AMX, NN_T_AVXVNNI or NN_T_AVX2"
#endif

#define INLINE static inline __attribute__((always_inline))

static inline int32_t load32(const uint8_t *p)
{
    int32_t v;
    memcpy(&v, p, sizeof v);
    return v;
}

/* ---- requantisation of one vector of accumulators ------------------------------------------ */

#if defined(NN_T_ZMM)
INLINE __m512i requant(const int left, __m512i acc, __m512i mult, __m512i lsh, __m512i rsh,
                       __m512i mask, __m512i half, __m512i off, __m512i lo, __m512i hi)
{
    __m512i x = acc;
    if (left) {
        const __m512i x0 = _mm512_sllv_epi32(acc, lsh);
        const __mmask16 ovf = _mm512_cmpneq_epi32_mask(_mm512_srav_epi32(x0, lsh), acc);
        const __m512i sat =
            _mm512_xor_si512(_mm512_srai_epi32(acc, 31), _mm512_set1_epi32(INT32_MAX));
        x = _mm512_mask_blend_epi32(ovf, x0, sat);
    }
    const __m512i nudge = _mm512_set1_epi64((int64_t)1 << 30);
    const __m512i ev = _mm512_add_epi64(_mm512_mul_epi32(x, mult), nudge);
    const __m512i od = _mm512_add_epi64(
        _mm512_mul_epi32(_mm512_srli_epi64(x, 32), _mm512_srli_epi64(mult, 32)), nudge);
    const __m512i high =
        _mm512_mask_blend_epi32(0xAAAA, _mm512_srli_epi64(ev, 31), _mm512_slli_epi64(od, 1));
    const __m512i one = _mm512_set1_epi32(1);
    const __m512i rem = _mm512_and_si512(high, mask);
    const __m512i thr = _mm512_sub_epi32(half, _mm512_srai_epi32(high, 31));
    __m512i res = _mm512_srav_epi32(high, rsh);
    res = _mm512_mask_add_epi32(res, _mm512_cmpgt_epi32_mask(rem, thr), res, one);
    /* lo, hi: the activation range minus the offset; off: the offset (+ 128 for out_xor 0x80) */
    return _mm512_add_epi32(_mm512_max_epi32(_mm512_min_epi32(res, hi), lo), off);
}

/* The shorter requantisation (pl_s8_conv.short_requant: no left shift, |acc| < 2^30, the
 * activation range all of [-128, 127]), in fewer operations on the shift and shuffle pipes:
 * - high = floor((acc*mult + 2^30) / 2^31) = floor((2acc*mult + 2^31) / 2^32) is the high dword
 *   of each 64-bit product of 2acc (no overflow: |acc| < 2^30), so one masked vpshufd gathers
 *   the even lanes' next to the odd lanes';
 * - the rounding divide by 2^e, (high >> e) + (rem > (mask >> 1) + (high < 0)), is
 *   floor((high + 2^(e-1) - (high < 0)) / 2^e) for e >= 1 (high = (high >> e) * 2^e + rem;
 *   |high| <= |acc| < 2^30 and 2^(e-1) <= 2^30, so the sum fits); e = 0 lanes have hp = 0 and
 *   no kpos bit, so res = high.
 * The caller narrows with saturation. */
INLINE __m512i requant_short(__m512i acc, __m512i mult, __m512i mult_odd, __m512i rsh,
                             __m512i hp, __mmask16 kpos)
{
    const __m512i nudge = _mm512_set1_epi64((int64_t)1 << 31);
    const __m512i x2 = _mm512_add_epi32(acc, acc);
    const __m512i ev = _mm512_add_epi64(_mm512_mul_epi32(x2, mult), nudge);
    const __m512i od =
        _mm512_add_epi64(_mm512_mul_epi32(_mm512_shuffle_epi32(x2, _MM_PERM_DDBB), mult_odd),
                         nudge);
    const __m512i high = _mm512_mask_shuffle_epi32(od, 0x5555, ev, _MM_PERM_DDBB);
    const __mmask16 kneg = _mm512_mask_cmplt_epi32_mask(kpos, high, _mm512_setzero_si512());
    __m512i t = _mm512_add_epi32(high, hp);
    t = _mm512_mask_sub_epi32(t, kneg, t, _mm512_set1_epi32(1));
    return _mm512_srav_epi32(t, rsh);
}
#else
INLINE __m256i requant(const int left, __m256i acc, __m256i mult, __m256i lsh, __m256i rsh,
                       __m256i mask, __m256i half, __m256i off, __m256i lo, __m256i hi)
{
    __m256i x = acc;
    if (left) {
        const __m256i x0 = _mm256_sllv_epi32(acc, lsh);
        const __m256i same = _mm256_cmpeq_epi32(_mm256_srav_epi32(x0, lsh), acc);
        const __m256i sat =
            _mm256_xor_si256(_mm256_srai_epi32(acc, 31), _mm256_set1_epi32(INT32_MAX));
        x = _mm256_blendv_epi8(sat, x0, same);
    }
    const __m256i nudge = _mm256_set1_epi64x((int64_t)1 << 30);
    const __m256i ev = _mm256_add_epi64(_mm256_mul_epi32(x, mult), nudge);
    const __m256i od = _mm256_add_epi64(
        _mm256_mul_epi32(_mm256_srli_epi64(x, 32), _mm256_srli_epi64(mult, 32)), nudge);
    const __m256i high =
        _mm256_blend_epi32(_mm256_srli_epi64(ev, 31), _mm256_slli_epi64(od, 1), 0xAA);
    const __m256i rem = _mm256_and_si256(high, mask);
    const __m256i thr = _mm256_sub_epi32(half, _mm256_srai_epi32(high, 31));
    __m256i res = _mm256_srav_epi32(high, rsh);
    res = _mm256_sub_epi32(res, _mm256_cmpgt_epi32(rem, thr)); /* true is -1 */
    res = _mm256_max_epi32(_mm256_min_epi32(res, _mm256_set1_epi32(1024)),
                           _mm256_set1_epi32(-1024));
    res = _mm256_add_epi32(res, off);
    return _mm256_max_epi32(_mm256_min_epi32(res, hi), lo);
}
#endif

#if defined(NN_T_AMX)
/* ---- AMX: five tile operations ---------------------------------------------------------------
 * The tile kernel is written against LDTILECFG, TILEZERO, TILELOADD, TILESTORED and TDPBUSD
 * (palette 1: 8 tiles of up to 16 rows x 64 bytes). Without NN_T_AMX_EMU they are the
 * intrinsics; with it, C that follows the Intel SDM's pseudocode of each instruction, so that
 * the packing, the tile configuration, the accumulation and the requantisation run bit for bit
 * on any AVX-512 VNNI machine (nn_conv_packed_s8_16x32c4_amxemu__avx512vnni, tested against the
 * reference kernels by tests/test_kernels_simd_s8.c) and only the instructions themselves wait
 * for AMX hardware.
 * Tiles: 0, 1 the accumulators (mr pixels x 16 channels of int32, one per block); 2 A (mr pixels
 * x 64 bytes of K), 3, 4 the blocks' weights (16 groups of 4 K x 16 channels: 1024 contiguous
 * bytes of the VNNI packing, [K/4][16][4], rows 64 bytes apart); 5, 6, 7 the same for the tail
 * of a tap when cs is not a multiple of 64. Without a tail, full 16-pixel tiles go in pairs
 * (tile_pair): 5, 6 are the second pixel tile's accumulators and 7 its A, so each weight tile
 * loaded serves two tdpbusd instead of one (the loads of the weight tiles were most of the
 * kernel's time). */
typedef struct amx_cfg {
    uint8_t palette, start_row, reserved[14];
    uint16_t colsb[16];
    uint8_t rows[16];
} amx_cfg; /* LDTILECFG's 64-byte operand */
_Static_assert(sizeof(amx_cfg) == 64, "the tile configuration is 64 bytes");

static void amx_config(amx_cfg *cfg, int mr, int tail)
{
    memset(cfg, 0, sizeof *cfg);
    cfg->palette = 1;
    for (int t = 0; t < 5; t++) {
        cfg->rows[t] = (uint8_t)(t == 3 || t == 4 ? 16 : mr);
        cfg->colsb[t] = 64;
    }
    if (!tail && mr == MR) { /* tile_pair's: 5, 6 accumulators, 7 A, all 16 x 64 bytes */
        for (int t = 5; t < 8; t++) {
            cfg->rows[t] = MR;
            cfg->colsb[t] = 64;
        }
    } else if (tail) {
        cfg->rows[5] = (uint8_t)mr;
        cfg->colsb[5] = (uint16_t)tail;
        cfg->rows[6] = cfg->rows[7] = (uint8_t)(tail / 4);
        cfg->colsb[6] = cfg->colsb[7] = 64;
    }
}

#if defined(NN_T_AMX_EMU)
#include <assert.h>
static _Thread_local struct {
    uint8_t rows[8];
    uint16_t colsb[8];
    uint8_t t[8][16][64];
} emu;

/* LDTILECFG: the shapes, and every tile zeroed */
static void emu_config(const amx_cfg *cfg)
{
    memset(&emu, 0, sizeof emu);
    for (int i = 0; i < 8; i++) {
        emu.rows[i] = cfg->rows[i];
        emu.colsb[i] = cfg->colsb[i];
    }
}

static void emu_zero(int t)
{
    memset(emu.t[t], 0, sizeof emu.t[t]);
}

/* TILELOADD: rows x colsb bytes, row r from base + r*stride; the rest of the tile zeroed */
static void emu_load(int t, const void *base, size_t stride)
{
    emu_zero(t);
    for (int r = 0; r < emu.rows[t]; r++)
        memcpy(emu.t[t][r], (const uint8_t *)base + (size_t)r * stride, emu.colsb[t]);
}

static void emu_store(int t, void *base, size_t stride)
{
    for (int r = 0; r < emu.rows[t]; r++)
        memcpy((uint8_t *)base + (size_t)r * stride, emu.t[t][r], emu.colsb[t]);
}

/* TDPBUSD: C[m][n] += sum over k of the 4 products u8 A[m][4k+i] x s8 B[k][4n+i], in 32 bits
 * with wrap-around (not saturating) */
static void emu_dpbusd(int tc, int ta, int tb)
{
    const int M = emu.rows[tc], N = emu.colsb[tc] / 4, K = emu.colsb[ta] / 4;
    assert(emu.rows[ta] == M && emu.rows[tb] == K && emu.colsb[tb] == emu.colsb[tc]);
    for (int m = 0; m < M; m++)
        for (int n = 0; n < N; n++) {
            uint32_t acc;
            memcpy(&acc, &emu.t[tc][m][4 * n], 4);
            for (int k = 0; k < K; k++) {
                int32_t d = 0;
                for (int i = 0; i < 4; i++)
                    d +=
                        (int32_t)emu.t[ta][m][4 * k + i] * (int32_t)(int8_t)emu.t[tb][k][4 * n + i];
                acc += (uint32_t)d;
            }
            memcpy(&emu.t[tc][m][4 * n], &acc, 4);
        }
}
#define T_CONFIG(cfg) emu_config(cfg)
#define T_ZERO(t) emu_zero(t)
#define T_LOAD(t, p, stride) emu_load(t, p, stride)
#define T_STORE(t, p, stride) emu_store(t, p, stride)
#define T_DPBUSD(c, a, b) emu_dpbusd(c, a, b)
#define T_RELEASE() ((void)0)
#else
#define T_CONFIG(cfg) _tile_loadconfig(cfg)
#define T_ZERO(t) _tile_zero(t)
#define T_LOAD(t, p, stride) _tile_loadd(t, p, (long)(stride))
#define T_STORE(t, p, stride) _tile_stored(t, p, (long)(stride))
#define T_DPBUSD(c, a, b) _tile_dpbusd(c, a, b)
#define T_RELEASE() _tile_release()
#endif

/* The tile's sums over all taps and K in tiles 0 and 1, then into zmm with the folded bias
 * added (mod 2^32, as the reference adds it). The caller has loaded the configuration for mr. */
INLINE void amx_accumulate(const int mr, const int nv, const pl_s8_conv *c, const uint8_t *a0,
                           size_t astep, const uint8_t *wblk, size_t wblock_bytes,
                           const int32_t *qv, __m512i acc[MR][2])
{
    int32_t ct[2][16][16] __attribute__((aligned(64)));
    const int nfull = c->cs / 64, tail = c->cs % 64;
    const uint8_t *wg = wblk;
    T_ZERO(0);
    T_ZERO(1);
    for (int ky = 0; ky < c->k_h; ky++)
        for (int kx = 0; kx < c->k_w; kx++) {
            const uint8_t *ap = a0 + ((size_t)ky * (size_t)c->dilation_h * (size_t)c->a_w +
                                      (size_t)kx * (size_t)c->dilation_w) *
                                         (size_t)c->cs;
            for (int k = 0; k < nfull; k++, ap += 64, wg += 16 * GROUP_BYTES) {
                T_LOAD(2, ap, astep);
                T_LOAD(3, wg, GROUP_BYTES);
                T_DPBUSD(0, 2, 3);
                if (nv > 1) {
                    T_LOAD(4, wg + wblock_bytes, GROUP_BYTES);
                    T_DPBUSD(1, 2, 4);
                }
            }
            if (tail) {
                T_LOAD(5, ap, astep);
                T_LOAD(6, wg, GROUP_BYTES);
                T_DPBUSD(0, 5, 6);
                if (nv > 1) {
                    T_LOAD(7, wg + wblock_bytes, GROUP_BYTES);
                    T_DPBUSD(1, 5, 7);
                }
                wg += (size_t)(tail / 4) * GROUP_BYTES;
            }
        }
    T_STORE(0, ct[0], 64);
    if (nv > 1) T_STORE(1, ct[1], 64);
    const __m512i b0 = _mm512_loadu_si512(qv), b1 = _mm512_loadu_si512(qv + (nv > 1 ? 16 : 0));
#pragma GCC unroll 16
    for (int m = 0; m < mr; m++) {
        acc[m][0] = _mm512_add_epi32(_mm512_load_si512(ct[0][m]), b0);
        acc[m][1] = nv > 1 ? _mm512_add_epi32(_mm512_load_si512(ct[1][m]), b1) : acc[m][0];
    }
}
#endif

/* ---- one tile --------------------------------------------------------------------------------
 * mr pixels (A at a0 + m*astep) x nv vectors of channels starting at block `blk`; writes the
 * bytes of channels [cb, ce) (relative to the tile's first channel) of pixel m at out[m] + c0. */
INLINE void requant_store(const int mr, const int nv, const pl_s8_conv *c, const int32_t *qv,
                          int nbp, vec acc[MR][2], int8_t *const *out, int c0, int cb, int ce);

INLINE void tile(const int mr, const int nv, const pl_s8_conv *c, const uint8_t *a0, size_t astep,
                 const uint8_t *wblk, size_t wblock_bytes, const int32_t *qv, int nbp,
                 int8_t *const *out, int c0, int cb, int ce)
{
    vec acc[MR][2];
#if defined(NN_T_AMX)
    amx_accumulate(mr, nv, c, a0, astep, wblk, wblock_bytes, qv, acc);
#else
#if defined(NN_T_AVX512VNNI)
    const __m512i b0 = _mm512_loadu_si512(qv), b1 = _mm512_loadu_si512(qv + (nv > 1 ? 16 : 0));
#pragma GCC unroll 14
    for (int m = 0; m < mr; m++) {
        acc[m][0] = b0;
        acc[m][1] = b1;
    }
#else
    const __m256i b0 = _mm256_loadu_si256((const __m256i *)(const void *)qv),
                  b1 = _mm256_loadu_si256((const __m256i *)(const void *)(qv + 8));
#pragma GCC unroll 14
    for (int m = 0; m < mr; m++) {
        acc[m][0] = b0;
        acc[m][1] = b1;
    }
#endif
    const int gpt = c->cs / 4;
    const uint8_t *wg = wblk;
    for (int ky = 0; ky < c->k_h; ky++)
        for (int kx = 0; kx < c->k_w; kx++) {
            const uint8_t *ap =
                a0 + ((size_t)ky * (size_t)c->dilation_h * (size_t)c->a_w +
                      (size_t)kx * (size_t)c->dilation_w) * (size_t)c->cs;
#pragma GCC unroll 2
            for (int g = 0; g < gpt; g++, wg += GROUP_BYTES, ap += 4) {
#if defined(NN_T_AVX512VNNI)
                const __m512i w0 = _mm512_loadu_si512(wg);
                const __m512i w1 = nv > 1 ? _mm512_loadu_si512(wg + wblock_bytes) : w0;
#pragma GCC unroll 14
                for (int m = 0; m < mr; m++) {
                    const __m512i av = _mm512_set1_epi32(load32(ap + (size_t)m * astep));
                    acc[m][0] = _mm512_dpbusd_epi32(acc[m][0], av, w0);
                    if (nv > 1) acc[m][1] = _mm512_dpbusd_epi32(acc[m][1], av, w1);
                }
#elif defined(NN_T_AVXVNNI)
                (void)wblock_bytes;
                const __m256i w0 = _mm256_loadu_si256((const __m256i *)(const void *)wg);
                const __m256i w1 = _mm256_loadu_si256((const __m256i *)(const void *)(wg + 32));
#pragma GCC unroll 14
                for (int m = 0; m < mr; m++) {
                    const __m256i av = _mm256_set1_epi32(load32(ap + (size_t)m * astep));
                    acc[m][0] = _mm256_dpbusd_avx_epi32(acc[m][0], av, w0);
                    acc[m][1] = _mm256_dpbusd_avx_epi32(acc[m][1], av, w1);
                }
#else
                (void)wblock_bytes;
                const __m256i w01a = _mm256_loadu_si256((const __m256i *)(const void *)wg);
                const __m256i w01b = _mm256_loadu_si256((const __m256i *)(const void *)(wg + 32));
                const __m256i w23a = _mm256_loadu_si256((const __m256i *)(const void *)(wg + 64));
                const __m256i w23b = _mm256_loadu_si256((const __m256i *)(const void *)(wg + 96));
#pragma GCC unroll 14
                for (int m = 0; m < mr; m++) {
                    const __m256i u = _mm256_unpacklo_epi8(
                        _mm256_set1_epi32(load32(ap + (size_t)m * astep)), _mm256_setzero_si256());
                    const __m256i a01 = _mm256_shuffle_epi32(u, 0x00);
                    const __m256i a23 = _mm256_shuffle_epi32(u, 0x55);
                    acc[m][0] = _mm256_add_epi32(
                        acc[m][0], _mm256_add_epi32(_mm256_madd_epi16(a01, w01a),
                                                    _mm256_madd_epi16(a23, w23a)));
                    acc[m][1] = _mm256_add_epi32(
                        acc[m][1], _mm256_add_epi32(_mm256_madd_epi16(a01, w01b),
                                                    _mm256_madd_epi16(a23, w23b)));
                }
#endif
            }
        }
#endif /* NN_T_AMX */
    requant_store(mr, nv, c, qv, nbp, acc, out, c0, cb, ce);
}

/* Requantises the tile's mr x nv vectors of int32 sums and stores the bytes of channels [cb, ce)
 * of pixel m at out[m] + c0. */
INLINE void requant_store(const int mr, const int nv, const pl_s8_conv *c, const int32_t *qv,
                          int nbp, vec acc[MR][2], int8_t *const *out, int c0, int cb, int ce)
{
#if defined(NN_T_ZMM)
    const __m512i off = _mm512_set1_epi32(c->output_offset + (c->out_xor & 0x80 ? 128 : 0)),
                  lo = _mm512_set1_epi32(c->act_min - c->output_offset),
                  hi = _mm512_set1_epi32(c->act_max - c->output_offset);
    const __m128i xr = _mm_set1_epi8((char)(c->out_xor & 0x7f));
    const int any_xor = (c->out_xor & 0x7f) != 0;
    if (nv == 2 && c->short_requant && !any_xor) {
        /* two pixels x 32 channels at a time: requant_short, then vpackssdw (saturating to
         * s16), the offset added with s16 saturation, vpacksswb / vpackuswb (u8 out: the offset
         * + 128) and one vpermd to put each pixel's 32 bytes in order. The saturations clamp to
         * [-128, 127] (or [0, 255]) exactly as the activation range does: |offset| <= 255, so a
         * value saturated to s16 stays out of the byte range on the same side. */
        const __m512i one = _mm512_set1_epi32(1), zero = _mm512_setzero_si512();
        const __m512i mult0 = _mm512_loadu_si512(qv + nbp),
                      mult1 = _mm512_loadu_si512(qv + 16 + nbp);
        const __m512i mo0 = _mm512_shuffle_epi32(mult0, _MM_PERM_DDBB),
                      mo1 = _mm512_shuffle_epi32(mult1, _MM_PERM_DDBB);
        const __m512i rsh0 = _mm512_loadu_si512(qv + 3 * nbp),
                      rsh1 = _mm512_loadu_si512(qv + 16 + 3 * nbp);
        const __mmask16 kp0 = _mm512_cmpgt_epi32_mask(rsh0, zero),
                        kp1 = _mm512_cmpgt_epi32_mask(rsh1, zero);
        const __m512i hp0 = _mm512_maskz_add_epi32(kp0, _mm512_loadu_si512(qv + 5 * nbp), one),
                      hp1 = _mm512_maskz_add_epi32(kp1, _mm512_loadu_si512(qv + 16 + 5 * nbp),
                                                   one);
        const int u8out = c->out_xor != 0;
        const __m512i off16 =
            _mm512_set1_epi16((short)(c->output_offset + (u8out ? 128 : 0)));
        const __m512i perm =
            _mm512_setr_epi32(0, 4, 8, 12, 1, 5, 9, 13, 2, 6, 10, 14, 3, 7, 11, 15);
        const __mmask32 km = (__mmask32)((ce >= 32 ? ~0u : (1u << ce) - 1u) & ~((1u << cb) - 1u));
#pragma GCC unroll 7
        for (int m = 0; m < mr; m += 2) {
            const int m1 = m + 1 < mr ? m + 1 : m;
            const __m512i p0 = _mm512_adds_epi16(
                _mm512_packs_epi32(requant_short(acc[m][0], mult0, mo0, rsh0, hp0, kp0),
                                   requant_short(acc[m][1], mult1, mo1, rsh1, hp1, kp1)),
                off16);
            const __m512i p1 = _mm512_adds_epi16(
                _mm512_packs_epi32(requant_short(acc[m1][0], mult0, mo0, rsh0, hp0, kp0),
                                   requant_short(acc[m1][1], mult1, mo1, rsh1, hp1, kp1)),
                off16);
            const __m512i b = _mm512_permutexvar_epi32(
                perm, u8out ? _mm512_packus_epi16(p0, p1) : _mm512_packs_epi16(p0, p1));
            _mm256_mask_storeu_epi8(out[m] + c0, km, _mm512_castsi512_si256(b));
            if (m + 1 < mr)
                _mm256_mask_storeu_epi8(out[m1] + c0, km, _mm512_extracti64x4_epi64(b, 1));
        }
        return;
    }
    for (int v = 0; v < nv; v++) {
        const int32_t *q = qv + 16 * v;
        const __m512i mult = _mm512_loadu_si512(q + nbp), lsh = _mm512_loadu_si512(q + 2 * nbp),
                      rsh = _mm512_loadu_si512(q + 3 * nbp), mask = _mm512_loadu_si512(q + 4 * nbp),
                      half = _mm512_loadu_si512(q + 5 * nbp);
        const int vb = cb - 16 * v < 0 ? 0 : cb - 16 * v;
        const int ve = ce - 16 * v > 16 ? 16 : ce - 16 * v;
        if (ve <= vb) continue;
        const __mmask16 km = (__mmask16)(((1u << ve) - 1u) & ~((1u << vb) - 1u));
        if (c->any_left_shift) {
#pragma GCC unroll 14
            for (int m = 0; m < mr; m++) {
                const __m512i r = requant(1, acc[m][v], mult, lsh, rsh, mask, half, off, lo, hi);
                __m128i bytes = _mm512_cvtepi32_epi8(r);
                if (any_xor) bytes = _mm_xor_si128(bytes, xr);
                _mm_mask_storeu_epi8(out[m] + c0 + 16 * v, km, bytes);
            }
        } else {
#pragma GCC unroll 14
            for (int m = 0; m < mr; m++) {
                const __m512i r = requant(0, acc[m][v], mult, lsh, rsh, mask, half, off, lo, hi);
                __m128i bytes = _mm512_cvtepi32_epi8(r);
                if (any_xor) bytes = _mm_xor_si128(bytes, xr);
                _mm_mask_storeu_epi8(out[m] + c0 + 16 * v, km, bytes);
            }
        }
    }
#else
    const __m256i off = _mm256_set1_epi32(c->output_offset), lo = _mm256_set1_epi32(c->act_min),
                  hi = _mm256_set1_epi32(c->act_max);
    const __m128i xr = _mm_set1_epi8((char)c->out_xor);
    const __m256i m0 = _mm256_loadu_si256((const __m256i *)(const void *)(qv + nbp)),
                  m1 = _mm256_loadu_si256((const __m256i *)(const void *)(qv + nbp + 8)),
                  l0 = _mm256_loadu_si256((const __m256i *)(const void *)(qv + 2 * nbp)),
                  l1 = _mm256_loadu_si256((const __m256i *)(const void *)(qv + 2 * nbp + 8)),
                  r0 = _mm256_loadu_si256((const __m256i *)(const void *)(qv + 3 * nbp)),
                  r1 = _mm256_loadu_si256((const __m256i *)(const void *)(qv + 3 * nbp + 8)),
                  k0 = _mm256_loadu_si256((const __m256i *)(const void *)(qv + 4 * nbp)),
                  k1 = _mm256_loadu_si256((const __m256i *)(const void *)(qv + 4 * nbp + 8)),
                  h0 = _mm256_loadu_si256((const __m256i *)(const void *)(qv + 5 * nbp)),
                  h1 = _mm256_loadu_si256((const __m256i *)(const void *)(qv + 5 * nbp + 8));
    const int left = c->any_left_shift;
    (void)nv;
#pragma GCC unroll 14
    for (int m = 0; m < mr; m++) {
        const __m256i q0 = left ? requant(1, acc[m][0], m0, l0, r0, k0, h0, off, lo, hi)
                                : requant(0, acc[m][0], m0, l0, r0, k0, h0, off, lo, hi);
        const __m256i q1 = left ? requant(1, acc[m][1], m1, l1, r1, k1, h1, off, lo, hi)
                                : requant(0, acc[m][1], m1, l1, r1, k1, h1, off, lo, hi);
        const __m256i w16 = _mm256_permute4x64_epi64(_mm256_packs_epi32(q0, q1), 0xD8);
        const __m128i bytes = _mm_xor_si128(
            _mm_packs_epi16(_mm256_castsi256_si128(w16), _mm256_extracti128_si256(w16, 1)), xr);
        int8_t *o = out[m] + c0;
        if (cb == 0 && ce >= 16) {
            _mm_storeu_si128((__m128i *)(void *)o, bytes);
        } else {
            int8_t tmp[16];
            _mm_storeu_si128((__m128i *)(void *)tmp, bytes);
            memcpy(o + cb, tmp + cb, (size_t)(ce - cb));
        }
    }
#endif
}

/* Dispatches a runtime tile height and width to the specialised tile. */
#define NN_T_CASE(n, v)                                                                           \
    case n: tile(n, v, c, a0, astep, wblk, wblock_bytes, qv, nbp, out, c0, cb, ce); break;

static void tile_any(int mr, int nv, const pl_s8_conv *c, const uint8_t *a0, size_t astep,
                     const uint8_t *wblk, size_t wblock_bytes, const int32_t *qv, int nbp,
                     int8_t *const *out, int c0, int cb, int ce)
{
    if (nv == 2) {
        switch (mr) {
            NN_T_CASE(1, 2)
            NN_T_CASE(2, 2) NN_T_CASE(3, 2) NN_T_CASE(4, 2)
#if MR > 4
                NN_T_CASE(5, 2) NN_T_CASE(6, 2)
#endif
#if MR > 6
                    NN_T_CASE(7, 2) NN_T_CASE(8, 2) NN_T_CASE(9, 2) NN_T_CASE(10, 2)
                        NN_T_CASE(11, 2) NN_T_CASE(12, 2) NN_T_CASE(13, 2) NN_T_CASE(14, 2)
#endif
#if MR > 14
                            NN_T_CASE(15, 2) NN_T_CASE(16, 2)
#endif
                                default : break;
        }
    } else {
#if NBLK > 1
        switch (mr) {
            NN_T_CASE(1, 1)
            NN_T_CASE(2, 1) NN_T_CASE(3, 1) NN_T_CASE(4, 1) NN_T_CASE(5, 1) NN_T_CASE(6, 1)
                NN_T_CASE(7, 1) NN_T_CASE(8, 1) NN_T_CASE(9, 1) NN_T_CASE(10, 1) NN_T_CASE(11, 1)
                    NN_T_CASE(12, 1) NN_T_CASE(13, 1) NN_T_CASE(14, 1)
#if MR > 14
                        NN_T_CASE(15, 1) NN_T_CASE(16, 1)
#endif
                            default : break;
        }
#endif
    }
}

#if defined(NN_T_AMX)
/* Two full tiles of 16 pixels (A at a0 and a1) x 2 blocks, when cs is a multiple of 64: four
 * accumulator tiles, each weight tile loaded once for both pixel tiles. The sums are the same
 * int32 values as two calls of tile() (wrap-around addition in another order), so the bytes
 * are too. The caller has loaded amx_config(.., MR, 0). */
static void tile_pair(const pl_s8_conv *c, const uint8_t *a0, const uint8_t *a1, size_t astep,
                      const uint8_t *wblk, size_t wblock_bytes, const int32_t *qv, int nbp,
                      int8_t *const *out0, int8_t *const *out1, int c0, int cb, int ce)
{
    int32_t ct[4][16][16] __attribute__((aligned(64)));
    const int nk = c->cs / 64;
    const size_t tap = (size_t)c->cs;
    const uint8_t *wg = wblk;
    T_ZERO(0);
    T_ZERO(1);
    T_ZERO(5);
    T_ZERO(6);
    for (int ky = 0; ky < c->k_h; ky++)
        for (int kx = 0; kx < c->k_w; kx++) {
            const size_t off = ((size_t)ky * (size_t)c->dilation_h * (size_t)c->a_w +
                                (size_t)kx * (size_t)c->dilation_w) * tap;
            const uint8_t *ap = a0 + off, *bp = a1 + off;
            for (int k = 0; k < nk; k++, ap += 64, bp += 64, wg += 16 * GROUP_BYTES) {
                T_LOAD(2, ap, astep);
                T_LOAD(7, bp, astep);
                T_LOAD(3, wg, GROUP_BYTES);
                T_DPBUSD(0, 2, 3);
                T_DPBUSD(5, 7, 3);
                T_LOAD(4, wg + wblock_bytes, GROUP_BYTES);
                T_DPBUSD(1, 2, 4);
                T_DPBUSD(6, 7, 4);
            }
        }
    T_STORE(0, ct[0], 64);
    T_STORE(1, ct[1], 64);
    T_STORE(5, ct[2], 64);
    T_STORE(6, ct[3], 64);
    const __m512i b0 = _mm512_loadu_si512(qv), b1 = _mm512_loadu_si512(qv + 16);
    for (int t = 0; t < 2; t++) {
        __m512i acc[MR][2];
#pragma GCC unroll 16
        for (int m = 0; m < MR; m++) {
            acc[m][0] = _mm512_add_epi32(_mm512_load_si512(ct[2 * t][m]), b0);
            acc[m][1] = _mm512_add_epi32(_mm512_load_si512(ct[2 * t + 1][m]), b1);
        }
        requant_store(MR, 2, c, qv, nbp, acc, t ? out1 : out0, c0, cb, ce);
    }
}
#endif

/* The tile of pixels from p (at most MR, within one output row unless the convolution is
 * dense, and before pix_end): its height, its A (*a0) and its output pixels (o). */
INLINE int locate(const pl_s8_conv *c, const uint8_t *a, int8_t *out, size_t ostride, int pitch,
                  int dense, int p, int pix_end, const uint8_t **a0, int8_t **o)
{
    const int ox = p % c->out_w, row = p / c->out_w, oy = row % c->out_h, b = row / c->out_h;
    int mr = pix_end - p;
    if (!dense && mr > c->out_w - ox) mr = c->out_w - ox; /* a k x k tile stays in its row */
    if (mr > MR) mr = MR;
    *a0 = a + (((size_t)b * (size_t)c->a_h + (size_t)oy * (size_t)c->stride_h) * (size_t)c->a_w +
               (size_t)ox * (size_t)c->stride_w) *
                  (size_t)c->cs;
    for (int m = 0, qx = ox, qrow = row; m < mr; m++) { /* pixel p + m, without dividing */
        o[m] = out + ((size_t)qrow * (size_t)pitch + (size_t)qx) * ostride;
        if (++qx == c->out_w) {
            qx = 0;
            qrow++;
        }
    }
    return mr;
}

void NN_T_NAME(const pl_s8_conv *c, const uint8_t *a, int8_t *out, int out_c_stride,
               int pix_begin, int pix_end, int oc_begin, int oc_end)
{
    const int nb = (c->out_c + PL_S8_OCB - 1) / PL_S8_OCB, nbp = nb * PL_S8_OCB;
    const size_t wblock_bytes = (size_t)c->k_h * (size_t)c->k_w * (size_t)(c->cs / 4) *
                                GROUP_BYTES;
    const int dense = c->k_h == 1 && c->k_w == 1 && c->stride_h == 1 && c->stride_w == 1 &&
                      c->a_h == c->out_h && c->a_w == c->out_w;
    const size_t astep = (size_t)c->stride_w * (size_t)c->cs, ostride = (size_t)out_c_stride;
    const int pitch = c->out_pitch ? c->out_pitch : c->out_w;
    const int blk_begin = oc_begin / PL_S8_OCB, blk_end = (oc_end + PL_S8_OCB - 1) / PL_S8_OCB;
    const uint8_t *w = c->w;
#if defined(NN_T_AMX)
    amx_cfg cfg;
    int cfg_mr = -1; /* the tile height the loaded configuration is for */
#endif
    for (int p = pix_begin; p < pix_end;) {
        const uint8_t *a0;
        int8_t *o[MR]; /* the tile's output pixels (rows of the output may be apart: out_pitch) */
        const int mr = locate(c, a, out, ostride, pitch, dense, p, pix_end, &a0, o);
#if defined(NN_T_AMX)
        if (mr != cfg_mr) {
            amx_config(&cfg, mr, c->cs % 64);
            T_CONFIG(&cfg);
            cfg_mr = mr;
        }
        if (mr == MR && c->cs % 64 == 0 && p + MR < pix_end) {
            const uint8_t *a1;
            int8_t *o1[MR];
            if (locate(c, a, out, ostride, pitch, dense, p + MR, pix_end, &a1, o1) == MR) {
                for (int blk = blk_begin; blk < blk_end; blk += NBLK) {
                    const int c0 = blk * PL_S8_OCB;
                    const int cb = oc_begin > c0 ? oc_begin - c0 : 0;
                    const uint8_t *wb = w + (size_t)blk * wblock_bytes;
                    if (blk + 2 <= blk_end) {
                        const int ce = oc_end - c0 < 2 * PL_S8_OCB ? oc_end - c0 : 2 * PL_S8_OCB;
                        tile_pair(c, a0, a1, astep, wb, wblock_bytes, c->bias + c0, nbp, o, o1,
                                  c0, cb, ce);
                    } else {
                        const int ce = oc_end - c0 < PL_S8_OCB ? oc_end - c0 : PL_S8_OCB;
                        tile_any(MR, 1, c, a0, astep, wb, wblock_bytes, c->bias + c0, nbp, o, c0,
                                 cb, ce);
                        tile_any(MR, 1, c, a1, astep, wb, wblock_bytes, c->bias + c0, nbp, o1, c0,
                                 cb, ce);
                    }
                }
                p += 2 * MR;
                continue;
            }
        }
#endif
        for (int blk = blk_begin; blk < blk_end; blk += NBLK) {
            const int nblk = blk + NBLK <= blk_end ? NBLK : blk_end - blk;
#if NBLK > 1
            const int nv = nblk;
#else
            const int nv = 2;
#endif
            const int c0 = blk * PL_S8_OCB;
            const int cb = oc_begin > c0 ? oc_begin - c0 : 0;
            const int ce = oc_end - c0 < nblk * PL_S8_OCB ? oc_end - c0 : nblk * PL_S8_OCB;
            tile_any(mr, nv, c, a0, astep, w + (size_t)blk * wblock_bytes, wblock_bytes,
                     c->bias + c0, nbp, o, c0, cb, ce);
        }
        p += mr;
    }
#if defined(NN_T_AMX)
    if (cfg_mr >= 0) T_RELEASE();
#endif
}
