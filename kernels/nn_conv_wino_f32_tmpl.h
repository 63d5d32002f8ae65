/* Winograd F(m x m, 3x3) for the packed fp32 paths (kernels/kernels_f32.h describes the layout and
 * the error bound), one source for x86 and Arm. Included at the end of a path's packed-GEMM file
 * (kernels/x86/nn_conv_gemm_f32_*.c, kernels/arm/nn_conv_gemm_f32_*.c), after
 * kernels/nn_conv_gemm_f32_tmpl.h, so it multiplies with that file's micro-kernel `ukr`; the
 * including file defines CONV_WINO_FN, the kernel's name.
 *
 * Per block of NR tiles and chunk of input channels: each patch row of a run of tiles (tiles of
 * one tile row) is copied once into a zero-padded segment and transformed with B^T from there,
 * 8 tiles at a time with the patch columns deinterleaved by vector shuffles (single tiles for
 * the rest of a run); then B^T down the columns across the NR tiles (GNU C vectors of 16 lanes)
 * writes row `ic` of the T*T B blocks; then T*T x panels micro-kernel calls; after the last
 * chunk, A^T . A per output channel across the NR tiles, and the m x m pixels of each tile
 * stored where they lie inside the map (8 tiles' rows interleaved by shuffles into one store
 * where they fit). GNU C vector extensions (vector_size, __builtin_shufflevector) need gcc >= 12
 * or clang; each path's compiler lowers them to its own registers (zmm/ymm, NEON q).
 *
 * The transforms are Lavin and Gray's (B^T, A^T for points 0, -1, 1 and, for m = 4, 2, -2),
 * written out so that each output is a short sum (no multiply by 0 or 1); the error bound in
 * kernels_f32.h counts their roundings. */
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "kernels/kernels_f32.h"

#define WNR PL_F32_NR

/* Tiles [j0, j1) of a block lie in tile row ty, from tile column tx0. */
struct wino_run {
    int j0, j1, ty, tx0;
};

static int wino_runs(int tiles_x, int n_tiles, int block, struct wino_run *runs)
{
    int n = 0;
    const int t0 = block * WNR, t1 = t0 + WNR < n_tiles ? t0 + WNR : n_tiles;
    for (int t = t0; t < t1;) {
        const int ty = t / tiles_x, tx = t % tiles_x;
        const int len = tiles_x - tx < t1 - t ? tiles_x - tx : t1 - t;
        runs[n++] = (struct wino_run){t - t0, t - t0 + len, ty, tx};
        t += len;
    }
    return n;
}

/* The transforms run on 16 tiles at a time in GNU C vectors (one zmm, two ymm or four NEON
 * registers), loaded and stored with memcpy: plain loops over rows at run-time strides are not
 * vectorised by gcc, which cannot rule out that the rows overlap. */
typedef float wino_v __attribute__((vector_size(64)));

/* macros, not functions: a function returning a 64-byte vector changes the ABI without AVX-512 */
#define WINO_LD(v, p) memcpy(&(v), (p), sizeof(wino_v))
#define WINO_ST(p, v)                                                                              \
    do {                                                                                           \
        const wino_v wino_tmp_ = (v);                                                              \
        memcpy((p), &wino_tmp_, sizeof(wino_v));                                                   \
    } while (0)

typedef float wino_v8 __attribute__((vector_size(32)));
#define WINO_LD8(v, p) memcpy(&(v), (p), sizeof(wino_v8))
#define WINO_ST8(p, v)                                                                             \
    do {                                                                                           \
        const wino_v8 wino_tmp8_ = (v);                                                            \
        memcpy((p), &wino_tmp8_, sizeof(wino_v8));                                                 \
    } while (0)

/* *v = columns [a, a + 8) of the row xr (w columns), zeros outside it. */
static inline __attribute__((always_inline)) void wino_cols8(wino_v8 *v, const float *xr, int a,
                                                             int w)
{
    if (a >= 0 && a + 8 <= w) {
        WINO_LD8(*v, xr + a);
    } else if (a + 8 <= 0 || a >= w) {
        *v = (wino_v8){0};
    } else {
        float t[8];
        for (int i = 0; i < 8; i++)
            t[i] = a + i >= 0 && a + i < w ? xr[a + i] : 0.0f;
        memcpy(v, t, sizeof t);
    }
}

/* 1-D input transform B^T s of T rows of NR (at stride ss) into T rows (at stride os). */
static inline __attribute__((always_inline)) void wino_bt(int m, const float *s, size_t ss,
                                                          float *o, size_t os)
{
    for (int j = 0; j < WNR; j += 16) {
        wino_v s0, s1, s2, s3, s4, s5;
        WINO_LD(s0, s + j);
        WINO_LD(s1, s + ss + j);
        WINO_LD(s2, s + 2 * ss + j);
        WINO_LD(s3, s + 3 * ss + j);
        if (m == 2) {
            WINO_ST(o + j, s0 - s2);
            WINO_ST(o + os + j, s1 + s2);
            WINO_ST(o + 2 * os + j, s2 - s1);
            WINO_ST(o + 3 * os + j, s1 - s3);
        } else {
            WINO_LD(s4, s + 4 * ss + j);
            WINO_LD(s5, s + 5 * ss + j);
            WINO_ST(o + j, 4.0f * s0 - 5.0f * s2 + s4);
            WINO_ST(o + os + j, s3 + s4 - 4.0f * (s1 + s2));
            WINO_ST(o + 2 * os + j, 4.0f * (s1 - s2) + (s4 - s3));
            WINO_ST(o + 3 * os + j, 2.0f * (s3 - s1) + (s4 - s2));
            WINO_ST(o + 4 * os + j, 2.0f * (s1 - s3) + (s4 - s2));
            WINO_ST(o + 5 * os + j, 4.0f * s1 - 5.0f * s3 + s5);
        }
    }
}

/* 1-D output transform A^T s: T rows of NR (at stride ss) into m rows (at stride os). */
static inline __attribute__((always_inline)) void wino_at(int m, const float *s, size_t ss,
                                                          float *o, size_t os)
{
    for (int j = 0; j < WNR; j += 16) {
        wino_v s0, s1, s2, s3, s4, s5;
        WINO_LD(s0, s + j);
        WINO_LD(s1, s + ss + j);
        WINO_LD(s2, s + 2 * ss + j);
        WINO_LD(s3, s + 3 * ss + j);
        if (m == 2) {
            WINO_ST(o + j, s0 + s1 + s2);
            WINO_ST(o + os + j, s1 - s2 - s3);
        } else {
            WINO_LD(s4, s + 4 * ss + j);
            WINO_LD(s5, s + 5 * ss + j);
            const wino_v a = s1 + s2, b = s1 - s2, c = s3 + s4, d = s3 - s4;
            WINO_ST(o + j, s0 + a + c);
            WINO_ST(o + os + j, b + 2.0f * d);
            WINO_ST(o + 2 * os + j, a + 4.0f * c);
            WINO_ST(o + 3 * os + j, b + 8.0f * d + s5);
        }
    }
}

/* V rows for one input channel plane x: v[xi * vs + j] = (B^T d_j B)[xi] for the block's tiles;
 * `t1` (T*T x NR) and `seg` (m*NR + 8 floats) are work space. */
static inline __attribute__((always_inline)) void wino_input(int m, const float *x, int h, int w,
                                                             const struct wino_run *runs,
                                                             int n_runs, int cols, float *t1,
                                                             float *seg, float *v, size_t vs)
{
    const int T = m + 2;
    for (int r = 0; r < T; r++) {
        for (int q = 0; q < n_runs; q++) {
            const struct wino_run *R = &runs[q];
            const int n = R->j1 - R->j0, iy = R->ty * m - 1 + r;
            if (iy < 0 || iy >= h) {
                for (int k = 0; k < T; k++)
                    memset(t1 + ((size_t)k * T + (size_t)r) * WNR + R->j0, 0,
                           (size_t)n * sizeof(float));
                continue;
            }
            /* the run's input columns [ix0, ix0 + m n + 2) into seg, zeros outside the map, so
             * that the strided reads below need no bounds; written as whole 8-float vectors,
             * seg[8c .. 8c + 8) = (u_{c-1}[7], u_c[0..6]) with u_c the columns from
             * ix0 + 1 + 8c: each 8-lane load below then reads back exactly one earlier store
             * (store-to-load forwarding; memcpy's stores, placed otherwise, made them wait) */
            const int ix0 = R->tx0 * m - 1, len = m * n + 2;
            const float *xr = x + (size_t)iy * (size_t)w;
            wino_v8 up, uc;
            wino_cols8(&up, xr, ix0 + 1 - 8, w);
            for (int c = 0; 8 * c < len; c++) {
                wino_cols8(&uc, xr, ix0 + 1 + 8 * c, w);
                WINO_ST8(seg + 8 * c,
                         __builtin_shufflevector(up, uc, 7, 8, 9, 10, 11, 12, 13, 14));
                up = uc;
            }
            /* B^T along the row, tile by tile, straight from seg: t1[k][r] */
            float *restrict o = t1 + (size_t)r * WNR + R->j0;
            const size_t os = (size_t)T * WNR;
            int k0 = 0;
            /* 8 tiles at a time: the patch columns as 8-lane vectors, deinterleaved from the
             * segment by shuffles (vector_size vectors and __builtin_shufflevector: gcc >= 12,
             * clang), then the same sums as the scalar loop below */
            for (; k0 + 8 <= n; k0 += 8) {
                const float *sg = seg + m * k0;
                wino_v8 a0, a1, a2, a3, c0, c1, c2, c3, c4, c5;
                WINO_LD8(a0, sg);
                WINO_LD8(a1, sg + 8);
                WINO_LD8(a2, sg + 16);
                if (m == 2) { /* columns 2k + c: c0, c1 deinterleaved, c2, c3 one tile on */
                    c0 = __builtin_shufflevector(a0, a1, 0, 2, 4, 6, 8, 10, 12, 14);
                    c1 = __builtin_shufflevector(a0, a1, 1, 3, 5, 7, 9, 11, 13, 15);
                    c2 = __builtin_shufflevector(c0, a2, 1, 2, 3, 4, 5, 6, 7, 8);
                    c3 = __builtin_shufflevector(c1, a2, 1, 2, 3, 4, 5, 6, 7, 9);
                    WINO_ST8(o + k0, c0 - c2);
                    WINO_ST8(o + os + k0, c1 + c2);
                    WINO_ST8(o + 2 * os + k0, c2 - c1);
                    WINO_ST8(o + 3 * os + k0, c1 - c3);
                } else { /* columns 4k + c: c0..c3 deinterleaved, c4, c5 one tile on */
                    wino_v8 a4;
                    WINO_LD8(a3, sg + 24);
                    WINO_LD8(a4, sg + 32);
#define WINO_DEAL(c)                                                                               \
    __builtin_shufflevector(__builtin_shufflevector(a0, a1, c, c + 4, c + 8, c + 12),              \
                            __builtin_shufflevector(a2, a3, c, c + 4, c + 8, c + 12), 0, 1, 2, 3,  \
                            4, 5, 6, 7)
                    c0 = WINO_DEAL(0);
                    c1 = WINO_DEAL(1);
                    c2 = WINO_DEAL(2);
                    c3 = WINO_DEAL(3);
#undef WINO_DEAL
                    c4 = __builtin_shufflevector(c0, a4, 1, 2, 3, 4, 5, 6, 7, 8);
                    c5 = __builtin_shufflevector(c1, a4, 1, 2, 3, 4, 5, 6, 7, 9);
                    WINO_ST8(o + k0, 4.0f * c0 - 5.0f * c2 + c4);
                    WINO_ST8(o + os + k0, c3 + c4 - 4.0f * (c1 + c2));
                    WINO_ST8(o + 2 * os + k0, 4.0f * (c1 - c2) + (c4 - c3));
                    WINO_ST8(o + 3 * os + k0, 2.0f * (c3 - c1) + (c4 - c2));
                    WINO_ST8(o + 4 * os + k0, 2.0f * (c1 - c3) + (c4 - c2));
                    WINO_ST8(o + 5 * os + k0, 4.0f * c1 - 5.0f * c3 + c5);
                }
            }
            if (m == 2) {
                for (int k = k0; k < n; k++) {
                    const float *sk = seg + 2 * k;
                    o[k] = sk[0] - sk[2];
                    o[os + k] = sk[1] + sk[2];
                    o[2 * os + k] = sk[2] - sk[1];
                    o[3 * os + k] = sk[1] - sk[3];
                }
            } else {
                for (int k = k0; k < n; k++) {
                    const float *sk = seg + 4 * k;
                    const float s0 = sk[0], s1 = sk[1], s2 = sk[2], s3 = sk[3], s4 = sk[4],
                                s5 = sk[5];
                    o[k] = 4.0f * s0 - 5.0f * s2 + s4;
                    o[os + k] = s3 + s4 - 4.0f * (s1 + s2);
                    o[2 * os + k] = 4.0f * (s1 - s2) + (s4 - s3);
                    o[3 * os + k] = 2.0f * (s3 - s1) + (s4 - s2);
                    o[4 * os + k] = 2.0f * (s1 - s3) + (s4 - s2);
                    o[5 * os + k] = 4.0f * s1 - 5.0f * s3 + s5;
                }
            }
        }
        for (int k = 0; k < T; k++)
            for (int j = cols; j < WNR; j++)
                t1[((size_t)k * T + (size_t)r) * WNR + (size_t)j] = 0.0f;
    }
    for (int k = 0; k < T; k++) /* down the columns: v[i*T + k] */
        wino_bt(m, t1 + (size_t)k * T * WNR, WNR, v + (size_t)k * vs, (size_t)T * vs);
}

/* One output channel: mo[xi * ms + j] (the T*T products) -> A^T . A, + bias, ReLU, into the
 * plane `y` (out_h x out_w), pixels outside the map skipped. */
static inline __attribute__((always_inline)) void
wino_output(int m, const float *mo, size_t ms, float bias, int relu, const struct wino_run *runs,
            int n_runs, int oh, int ow, float *t1, float *yt, float *y)
{
    const int T = m + 2;
    for (int k = 0; k < T; k++) /* down the columns: t1[i][k], i < m */
        wino_at(m, mo + (size_t)k * ms, (size_t)T * ms, t1 + (size_t)k * WNR, (size_t)T * WNR);
    for (int i = 0; i < m; i++) /* along the rows: yt[i][c] */
        wino_at(m, t1 + (size_t)i * T * WNR, WNR, yt + (size_t)i * m * WNR, WNR);
    for (int e = 0; e < m * m; e++) {
        float *restrict o = yt + (size_t)e * WNR;
        for (int j = 0; j < WNR; j++) {
            const float v = o[j] + bias;
            o[j] = relu && v < 0.0f ? 0.0f : v;
        }
    }
    for (int q = 0; q < n_runs; q++) {
        const struct wino_run *R = &runs[q];
        for (int i = 0; i < m; i++) {
            const int oy = R->ty * m + i;
            if (oy >= oh) break;
            float *yr = y + (size_t)oy * (size_t)ow;
            const float *src = yt + (size_t)i * m * WNR;
            int k0 = 0;
            /* 8 tiles at a time where their 8 m pixels lie inside the row: the m columns
             * interleaved by shuffles into one contiguous store */
            for (; k0 + 8 <= R->j1 - R->j0 && (R->tx0 + k0 + 8) * m <= ow; k0 += 8) {
                const float *s0 = src + R->j0 + k0;
                float *d = yr + (size_t)(R->tx0 + k0) * (size_t)m;
                wino_v8 y0, y1;
                WINO_LD8(y0, s0);
                WINO_LD8(y1, s0 + WNR);
                const wino_v8 p01a = __builtin_shufflevector(y0, y1, 0, 8, 1, 9, 2, 10, 3, 11);
                const wino_v8 p01b = __builtin_shufflevector(y0, y1, 4, 12, 5, 13, 6, 14, 7, 15);
                if (m == 2) {
                    WINO_ST8(d, p01a);
                    WINO_ST8(d + 8, p01b);
                } else {
                    wino_v8 y2, y3;
                    WINO_LD8(y2, s0 + 2 * WNR);
                    WINO_LD8(y3, s0 + 3 * WNR);
                    const wino_v8 p23a = __builtin_shufflevector(y2, y3, 0, 8, 1, 9, 2, 10, 3, 11);
                    const wino_v8 p23b =
                        __builtin_shufflevector(y2, y3, 4, 12, 5, 13, 6, 14, 7, 15);
                    WINO_ST8(d, __builtin_shufflevector(p01a, p23a, 0, 1, 8, 9, 2, 3, 10, 11));
                    WINO_ST8(d + 8,
                             __builtin_shufflevector(p01a, p23a, 4, 5, 12, 13, 6, 7, 14, 15));
                    WINO_ST8(d + 16, __builtin_shufflevector(p01b, p23b, 0, 1, 8, 9, 2, 3, 10, 11));
                    WINO_ST8(d + 24,
                             __builtin_shufflevector(p01b, p23b, 4, 5, 12, 13, 6, 7, 14, 15));
                }
            }
            for (int c = 0; c < m; c++) {
                const float *sc = src + (size_t)c * WNR;
                for (int j = R->j0 + k0; j < R->j1; j++) {
                    const int ox = (R->tx0 + j - R->j0) * m + c;
                    if (ox < ow) yr[ox] = sc[j];
                }
            }
        }
    }
}

static inline __attribute__((always_inline)) void
wino_run_m(int m, const pl_f32_conv *c, const float *in, float *out, float *scratch,
           int block_begin, int block_end, int panel_begin, int panel_end)
{
    const nn_conv_params *p = &c->p;
    const int T = m + 2, TT = T * T, in_c = p->in_c, panels = pl_f32_conv_panels(p);
    const int kcmax = in_c < PL_F32_WINO_KC ? in_c : PL_F32_WINO_KC;
    const int tiles_x = (p->out_w + m - 1) / m, n_tiles = tiles_x * ((p->out_h + m - 1) / m);
    const size_t plane = (size_t)p->in_h * (size_t)p->in_w, oplane = (size_t)p->out_h * p->out_w;
    const size_t vs = (size_t)kcmax * WNR, ms = (size_t)panels * PL_F32_MR * WNR;
    float *v = scratch, *mm = v + (size_t)TT * vs;
    float *t1 = mm + (size_t)TT * ms, *yt = t1 + (size_t)TT * WNR, *seg = yt + (size_t)m * m * WNR;
    struct wino_run runs[WNR];
    const int oc_end = panel_end * PL_F32_MR < p->out_c ? panel_end * PL_F32_MR : p->out_c;

    for (int blk = block_begin; blk < block_end; blk++) {
        const int n_runs = wino_runs(tiles_x, n_tiles, blk, runs);
        const int cols = runs[n_runs - 1].j1;
        for (int k0 = 0; k0 < in_c; k0 += kcmax) {
            const int kc = in_c - k0 < kcmax ? in_c - k0 : kcmax;
            for (int ic = k0; ic < k0 + kc; ic++)
                wino_input(m, in + (size_t)ic * plane, p->in_h, p->in_w, runs, n_runs, cols, t1,
                           seg, v + (size_t)(ic - k0) * WNR, vs);
            for (int xi = 0; xi < TT; xi++) {
                for (int pn = panel_begin; pn < panel_end; pn++) {
                    const int oc0 = pn * PL_F32_MR;
                    const int rows = p->out_c - oc0 < PL_F32_MR ? p->out_c - oc0 : PL_F32_MR;
                    ukr(kc,
                        c->w + (((size_t)xi * panels + (size_t)pn) * in_c + (size_t)k0) * PL_F32_MR,
                        v + (size_t)xi * vs, mm + (size_t)xi * ms + (size_t)oc0 * WNR, WNR, rows,
                        cols, NULL, k0 > 0, 0);
                }
            }
        }
        for (int oc = panel_begin * PL_F32_MR; oc < oc_end; oc++)
            wino_output(m, mm + (size_t)oc * WNR, ms, c->bias ? c->bias[oc] : 0.0f, p->relu, runs,
                        n_runs, p->out_h, p->out_w, t1, yt, out + (size_t)oc * oplane);
    }
}

void CONV_WINO_FN(const pl_f32_conv *c, const float *in, float *out, float *scratch,
                  int block_begin, int block_end, int panel_begin, int panel_end)
{
    if (c->wino == 4)
        wino_run_m(4, c, in, out, scratch, block_begin, block_end, panel_begin, panel_end);
    else
        wino_run_m(2, c, in, out, scratch, block_begin, block_end, panel_begin, panel_end);
}

#undef WINO_LD
#undef WINO_ST
#undef WINO_LD8
#undef WINO_ST8
#undef WNR
