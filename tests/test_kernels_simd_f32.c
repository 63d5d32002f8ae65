/* The fp32 SIMD kernels (kernels/kernels_f32.h) against the reference kernels
 * (kernels/ref/nn_ref.h), on every path this CPU runs (x86: avx2, avxvnni, avx512vnni, amx;
 * Arm: neon, dotprod, i8mm, which share the NEON fp32 kernels; pl_kernels_for; paths it lacks
 * are reported and skipped):
 *  - the packed convolution against nn_conv2d_f32__ref (after nn_bn_relu_f32__ref when the
 *    convolution carries the 1x1 pre-activation): random shapes with k in 1..7, strides 1..3,
 *    every padding, tile remainders (pixels) and panel remainders (odd channel counts), with and
 *    without bias and ReLU, outputs at a channel offset of a wider buffer (values outside the
 *    output channels must stay untouched), K beyond one K block, and the network's own shapes;
 *    the work done in random pieces of tiles and panels, in random order, must equal the whole
 *    bit for bit (the summation order depends on K only);
 *    tolerance per output: |simd - ref| <= 1e-5 * (|bias| + sum |w * x|) + 1e-30;
 *  - bn_relu, maxpool2d (k 1..4, strides, padding; and 3x3/2) and avgpool2d (and 2x2/2): bit
 *    for bit (the same operations in the same order per output);
 *  - fc: the same relative tolerance, n_in with every remainder mod 32 and the network's sizes;
 *  - fc_w8 (a layer the int8 executor keeps float, int8-stored weights): bit for bit, with one
 *    input row and with several (every remainder of the paths' row and output blocks), n_in with
 *    every remainder mod 32, past the reference's 4096-float row buffer, and the shipped
 *    network's kept-float transition3 (12 pooled pixels, 1024 -> 512) and fc;
 *  - Winograd F(2x2, 3x3) and F(4x4, 3x3) (`wino`) against the direct 3x3 convolution summed in
 *    double: random shapes (maps up to 31x37 with partial tiles, every map from 1x1 to 7x9, in_c
 *    1..300, out_c 1..40, more than one chunk of input channels, bias, ReLU, a channel offset)
 *    and the network's 3x3s at 192x256; pieces of blocks and panels in random order must equal
 *    the whole bit for bit. Tolerance per output: the first-order rounding bound of
 *    kernels/kernels_f32.h, gamma(in_c + 16) * (|bias| + sum_ic [|A^T| ((|G||g||G^T|) o
 *    (|B^T||d||B|)) |A|]), computed here from Lavin and Gray's matrices. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/util.h"
#include "kernels/dispatch.h"
#include "kernels/ref/nn_ref.h"
#define CHECK_RNG_SEED 0x2545f4914f6cdd1dULL
#include "tests/check.h"

#define TOL 1e-5

static float rfloat(void) /* [-1, 1) */
{
    return (float)rnd() / 2147483648.0f - 1.0f;
}

static float *xmalloc(size_t n)
{
    float *p = aligned_alloc(64, (n * sizeof(float) + 63) & ~(size_t)63);
    if (!p) {
        printf("out of memory\n");
        exit(1);
    }
    return p;
}

static void fill(float *p, size_t n, float scale)
{
    for (size_t i = 0; i < n; i++) p[i] = scale * rfloat();
}

static const float SENTINEL = -12345.5f;

/* sum |w * x| + |bias| for output (oc, pixel), the scale of its rounding error */
static double magnitude(const nn_conv_params *p, const float *x, const float *w, const float *b,
                        int oc, int pix)
{
    const int oy = pix / p->out_w, ox = pix % p->out_w;
    double s = b ? fabs(b[oc]) : 0.0;
    for (int ic = 0; ic < p->in_c; ic++)
        for (int ky = 0; ky < p->k_h; ky++)
            for (int kx = 0; kx < p->k_w; kx++) {
                const int iy = oy * p->stride - p->pad + ky, ix = ox * p->stride - p->pad + kx;
                if (iy < 0 || iy >= p->in_h || ix < 0 || ix >= p->in_w) continue;
                s += fabs((double)w[((oc * p->in_c + ic) * p->k_h + ky) * p->k_w + kx] *
                          x[((size_t)ic * p->in_h + iy) * p->in_w + ix]);
            }
    return s;
}

/* One convolution: reference vs the packed kernel, whole and in random pieces. `bn` adds the
 * pre-activation (1x1 only). Returns the largest error relative to its magnitude. */
static double conv_case(const pl_kernels_f32 *t, const char *isa, const nn_conv_params *p, int bn,
                        int with_bias, int pieces)
{
    const size_t K = (size_t)p->in_c * p->k_h * p->k_w, in_n = (size_t)p->in_c * p->in_h * p->in_w;
    const size_t plane = (size_t)p->out_h * p->out_w;
    const int off = rint_in(0, 3), extra = rint_in(0, 2), total_c = off + p->out_c + extra;
    float *x = xmalloc(in_n), *xa = xmalloc(in_n), *w = xmalloc(K * p->out_c + 1);
    float *b = xmalloc((size_t)p->out_c + 1), *sc = xmalloc((size_t)p->in_c + 1),
          *sh = xmalloc((size_t)p->in_c + 1);
    float *ref = xmalloc((size_t)total_c * plane), *got = xmalloc((size_t)total_c * plane),
          *got2 = xmalloc((size_t)total_c * plane);
    float *wp = xmalloc(pl_f32_packed_weights_floats(p));
    float *scratch = xmalloc(pl_f32_conv_scratch_floats(p));
    fill(x, in_n, 2.0f);
    fill(w, K * p->out_c, 1.0f / sqrtf((float)K));
    fill(b, (size_t)p->out_c, 0.5f);
    fill(sc, (size_t)p->in_c, 1.5f);
    fill(sh, (size_t)p->in_c, 1.0f);
    for (size_t i = 0; i < (size_t)total_c * plane; i++) ref[i] = got[i] = got2[i] = SENTINEL;

    if (bn)
        nn_bn_relu_f32__ref(x, sc, sh, p->in_h * p->in_w, xa, 0, p->in_c);
    else
        memcpy(xa, x, in_n * sizeof(float));
    nn_conv2d_f32__ref(p, xa, w, with_bias ? b : NULL, ref + (size_t)off * plane, 0, p->out_c);

    pl_f32_pack_weights(p, w, wp);
    const pl_f32_conv c = {*p, wp, with_bias ? b : NULL, bn ? sc : NULL, bn ? sh : NULL, 0};
    const int tiles = pl_f32_conv_tiles(p), panels = pl_f32_conv_panels(p);
    t->conv(&c, x, got + (size_t)off * plane, scratch, 0, tiles, 0, panels);

    /* pieces: a grid of tile and panel cuts, visited in a random order */
    int tc[6] = {0}, pc[6] = {0}, nt = 1, np = 1;
    tc[0] = pc[0] = 0;
    for (int i = 0; i < pieces && nt < 4; i++) {
        const int cut = rint_in(tc[nt - 1], tiles);
        if (cut > tc[nt - 1] && cut < tiles) tc[nt++] = cut;
    }
    tc[nt] = tiles;
    for (int i = 0; i < pieces && np < 4; i++) {
        const int cut = rint_in(pc[np - 1], panels);
        if (cut > pc[np - 1] && cut < panels) pc[np++] = cut;
    }
    pc[np] = panels;
    int order[16], n = nt * np;
    for (int i = 0; i < n; i++) order[i] = i;
    for (int i = n - 1; i > 0; i--) {
        const int j = rint_in(0, i), tmp = order[i];
        order[i] = order[j];
        order[j] = tmp;
    }
    for (int i = 0; i < n; i++) {
        const int ti = order[i] / np, pi = order[i] % np;
        t->conv(&c, x, got2 + (size_t)off * plane, scratch, tc[ti], tc[ti + 1], pc[pi],
                pc[pi + 1]);
    }

    double worst = 0.0;
    int reported = 0;
    for (int ch = 0; ch < total_c; ch++) {
        const int inside = ch >= off && ch < off + p->out_c;
        for (size_t i = 0; i < plane; i++) {
            const size_t at = (size_t)ch * plane + i;
            if (!inside) {
                if (!(got[at] == SENTINEL && got2[at] == SENTINEL) && !reported++)
                    CHECK(0, "%s conv: channel %d outside the output (offset %d, out_c %d) written",
                          isa, ch, off, p->out_c);
                continue;
            }
            const int oc = ch - off;
            if (memcmp(&got[at], &got2[at], sizeof(float)) && !reported++)
                CHECK(0, "%s conv: pieces differ from the whole at oc %d pixel %zu: %g vs %g", isa,
                      oc, i, (double)got2[at], (double)got[at]);
            const double mag = magnitude(p, xa, w, with_bias ? b : NULL, oc, (int)i);
            const double err = fabs((double)got[at] - (double)ref[at]);
            const double rel = err / (mag + 1e-30);
            if (rel > worst) worst = rel;
            if (!(err <= TOL * mag + 1e-30) && !reported++)
                CHECK(0,
                      "%s conv in %dx%dx%d out %dx%dx%d k %dx%d s %d p %d relu %d bn %d: oc %d "
                      "pixel %zu: %.9g vs ref %.9g (magnitude %g)",
                      isa, p->in_c, p->in_h, p->in_w, p->out_c, p->out_h, p->out_w, p->k_h,
                      p->k_w, p->stride, p->pad, p->relu, bn, oc, i, (double)got[at],
                      (double)ref[at], mag);
        }
    }
    free(x);
    free(xa);
    free(w);
    free(b);
    free(sc);
    free(sh);
    free(ref);
    free(got);
    free(got2);
    free(wp);
    free(scratch);
    return worst;
}

static nn_conv_params shape(int in_c, int in_h, int in_w, int out_c, int k, int s, int pad,
                            int relu)
{
    nn_conv_params p = {in_c, in_h, in_w, out_c, (in_h + 2 * pad - k) / s + 1,
                        (in_w + 2 * pad - k) / s + 1, k, k, s, pad, relu};
    return p;
}

static double random_conv(const pl_kernels_f32 *t, const char *isa)
{
    const int kind = rint_in(0, 3);
    int k = 1, s = 1, pad = 0;
    if (kind == 1) { /* stride 1 "same": the shifted-copy packer */
        k = 2 * rint_in(0, 3) + 1;
        pad = k / 2;
    } else if (kind == 2) { /* anything */
        k = rint_in(1, 7);
        s = rint_in(1, 3);
        pad = rint_in(0, k - 1);
    } else if (kind == 3) { /* stride 1, other paddings (in_w != out_w) */
        k = rint_in(2, 5);
        pad = rint_in(0, k - 1);
    }
    const int in_h = rint_in(k - 2 * pad > 1 ? k - 2 * pad : 1, 23), in_w = rint_in(k, 29);
    const nn_conv_params p = shape(rint_in(1, kind == 0 ? 300 : 40), in_h, in_w, rint_in(1, 41),
                                   k, s, pad, rint_in(0, 1));
    const int bn = kind == 0 && rint_in(0, 2) > 0;
    return conv_case(t, isa, &p, bn, rint_in(0, 3) > 0, rint_in(0, 4));
}

static double fc_case(const pl_kernels_f32 *t, const char *isa, int n_in, int n_out, int relu)
{
    float *x = xmalloc((size_t)n_in), *w = xmalloc((size_t)n_in * n_out), *b = xmalloc((size_t)n_out);
    float *ref = xmalloc((size_t)n_out + 2), *got = xmalloc((size_t)n_out + 2);
    fill(x, (size_t)n_in, 2.0f);
    fill(w, (size_t)n_in * n_out, 1.0f / sqrtf((float)n_in));
    fill(b, (size_t)n_out, 0.5f);
    const int with_bias = rint_in(0, 3) > 0;
    for (int i = 0; i < n_out + 2; i++) ref[i] = got[i] = SENTINEL;
    const int o0 = rint_in(0, n_out - 1), o1 = rint_in(o0 + 1, n_out);
    nn_fc_f32__ref(x, n_in, w, with_bias ? b : NULL, relu, ref, o0, o1);
    t->fc(x, n_in, w, with_bias ? b : NULL, relu, got, o0, o1);
    double worst = 0.0;
    for (int o = 0; o < n_out + 2; o++) {
        if (o < o0 || o >= o1) {
            CHECK(got[o] == SENTINEL, "%s fc: output %d outside [%d, %d) written", isa, o, o0, o1);
            continue;
        }
        double mag = with_bias ? fabs(b[o]) : 0.0;
        for (int i = 0; i < n_in; i++) mag += fabs((double)w[(size_t)o * n_in + i] * x[i]);
        const double err = fabs((double)got[o] - (double)ref[o]);
        if (err / (mag + 1e-30) > worst) worst = err / (mag + 1e-30);
        CHECK(err <= TOL * mag + 1e-30, "%s fc %d -> %d: output %d: %.9g vs ref %.9g", isa, n_in,
              n_out, o, (double)got[o], (double)ref[o]);
    }
    free(x);
    free(w);
    free(b);
    free(ref);
    free(got);
    return worst;
}

/* fc_w8 against its reference, bit for bit: rows x n_in -> outputs [o0, o1) of n_out, written
 * at a row stride wider than n_out (the columns outside [o0, o1) must stay untouched). */
static void fc_w8_case(const pl_kernels_f32 *t, const char *isa, int rows, int n_in, int n_out)
{
    const int stride = n_out + 3;
    const size_t n_o = (size_t)rows * (size_t)stride;
    float *x = xmalloc((size_t)rows * n_in), *ws = xmalloc((size_t)n_out), *b = xmalloc((size_t)n_out);
    float *ref = xmalloc(n_o), *got = xmalloc(n_o);
    int8_t *w = malloc((size_t)n_in * (size_t)n_out);
    if (!w) {
        printf("out of memory\n");
        exit(1);
    }
    fill(x, (size_t)rows * n_in, 2.0f);
    for (size_t i = 0; i < (size_t)n_in * n_out; i++) w[i] = (int8_t)rint_in(-128, 127);
    for (int o = 0; o < n_out; o++) ws[o] = (0.5f + 0.5f * rfloat()) / (127.0f * sqrtf((float)n_in));
    fill(b, (size_t)n_out, 0.5f);
    const int with_bias = rint_in(0, 3) > 0, relu = rint_in(0, 1);
    const int o0 = rint_in(0, n_out - 1), o1 = rint_in(o0 + 1, n_out);
    for (size_t i = 0; i < n_o; i++) ref[i] = got[i] = SENTINEL;
    nn_fc_w8_f32__ref(x, rows, n_in, w, ws, with_bias ? b : NULL, relu, ref, stride, o0, o1);
    t->fc_w8(x, rows, n_in, w, ws, with_bias ? b : NULL, relu, got, stride, o0, o1);
    CHECK(!memcmp(ref, got, n_o * sizeof(float)),
          "%s fc_w8 %d rows x %d -> outputs [%d, %d) of %d (bias %d, relu %d): differs from the "
          "reference",
          isa, rows, n_in, o0, o1, n_out, with_bias, relu);
    free(x);
    free(ws);
    free(b);
    free(ref);
    free(got);
    free(w);
}

/* Lavin and Gray's transforms, for the error bound (the kernels carry their own copies) */
static const double BT2[4][4] = {{1, 0, -1, 0}, {0, 1, 1, 0}, {0, -1, 1, 0}, {0, 1, 0, -1}};
static const double G2[4][3] = {{1, 0, 0}, {0.5, 0.5, 0.5}, {0.5, -0.5, 0.5}, {0, 0, 1}};
static const double AT2[2][4] = {{1, 1, 1, 0}, {0, 1, -1, -1}};
static const double BT4[6][6] = {{4, 0, -5, 0, 1, 0},  {0, -4, -4, 1, 1, 0}, {0, 4, -4, -1, 1, 0},
                                 {0, -2, -1, 2, 1, 0}, {0, 2, -1, -2, 1, 0}, {0, 4, 0, -5, 0, 1}};
static const double G4[6][3] = {{1.0 / 4, 0, 0},
                                {-1.0 / 6, -1.0 / 6, -1.0 / 6},
                                {-1.0 / 6, 1.0 / 6, -1.0 / 6},
                                {1.0 / 24, 1.0 / 12, 1.0 / 6},
                                {1.0 / 24, -1.0 / 12, 1.0 / 6},
                                {0, 0, 1}};
static const double AT4[4][6] = {
    {1, 1, 1, 1, 1, 0}, {0, 1, -1, 2, -2, 0}, {0, 1, 1, 4, 4, 0}, {0, 1, -1, 8, -8, 1}};

static double *dmalloc(size_t n)
{
    double *p = malloc((n ? n : 1) * sizeof(double));
    if (!p) {
        printf("out of memory\n");
        exit(1);
    }
    return p;
}

/* worst err / bound and worst err / sum |w x| of the Winograd cases, per m */
static double wino_worst_bound[5], wino_worst_direct[5];

/* One Winograd convolution (3x3, stride 1, pad 1) with F(m x m, 3x3): the whole and random pieces
 * against the direct convolution in double, within the bound (kernels_f32.h). */
static void wino_case(const pl_kernels_f32 *t, const char *isa, int in_c, int h, int w, int out_c,
                      int m, int with_bias, int relu, int pieces)
{
    const nn_conv_params p = shape(in_c, h, w, out_c, 3, 1, 1, relu);
    const int T = m + 2, tiles_y = (h + m - 1) / m, tiles_x = (w + m - 1) / m;
    const int n_tiles = tiles_y * tiles_x, TT = T * T;
    const size_t in_n = (size_t)in_c * h * w, plane = (size_t)h * w, K = (size_t)in_c * 9;
    const int off = rint_in(0, 3), extra = rint_in(0, 2), total_c = off + out_c + extra;
    float *x = xmalloc(in_n), *wt = xmalloc(K * out_c), *b = xmalloc((size_t)out_c);
    float *got = xmalloc((size_t)total_c * plane), *got2 = xmalloc((size_t)total_c * plane);
    float *wp = xmalloc(pl_f32_wino_weights_floats(&p, m));
    float *scratch = xmalloc(pl_f32_wino_scratch_floats(&p, m));
    double *vabs = dmalloc((size_t)n_tiles * in_c * TT), *uabs = dmalloc((size_t)out_c * in_c * TT);
    const double(*BT)[6] = NULL, (*G)[3] = m == 4 ? G4 : G2;
    double bt[6][6] = {{0}}, at[4][6] = {{0}};
    for (int i = 0; i < T; i++)
        for (int j = 0; j < T; j++)
            bt[i][j] = fabs(m == 4 ? BT4[i][j] : BT2[i][j]);
    for (int i = 0; i < m; i++)
        for (int j = 0; j < T; j++)
            at[i][j] = fabs(m == 4 ? AT4[i][j] : AT2[i][j]);
    (void)BT;
    fill(x, in_n, 2.0f);
    fill(wt, K * out_c, 1.0f / sqrtf((float)K));
    fill(b, (size_t)out_c, 0.5f);
    for (size_t i = 0; i < (size_t)total_c * plane; i++)
        got[i] = got2[i] = SENTINEL;

    /* |B^T||d||B| per (tile, ic) and |G||g||G^T| per (oc, ic) */
    for (int tile = 0; tile < n_tiles; tile++) {
        const int y0 = tile / tiles_x * m - 1, x0 = tile % tiles_x * m - 1;
        for (int ic = 0; ic < in_c; ic++) {
            double d[6][6], e[6][6];
            for (int r = 0; r < T; r++)
                for (int c = 0; c < T; c++) {
                    const int iy = y0 + r, ix = x0 + c;
                    d[r][c] = iy >= 0 && iy < h && ix >= 0 && ix < w
                                  ? fabs((double)x[(size_t)ic * plane + (size_t)iy * w + ix])
                                  : 0.0;
                }
            for (int i = 0; i < T; i++)
                for (int c = 0; c < T; c++) {
                    e[i][c] = 0.0;
                    for (int r = 0; r < T; r++)
                        e[i][c] += bt[i][r] * d[r][c];
                }
            for (int i = 0; i < T; i++)
                for (int k = 0; k < T; k++) {
                    double s = 0.0;
                    for (int c = 0; c < T; c++)
                        s += e[i][c] * bt[k][c];
                    vabs[((size_t)tile * in_c + ic) * TT + i * T + k] = s;
                }
        }
    }
    for (int oc = 0; oc < out_c; oc++)
        for (int ic = 0; ic < in_c; ic++) {
            const float *g = wt + ((size_t)oc * in_c + ic) * 9;
            double e[6][3];
            for (int i = 0; i < T; i++)
                for (int k = 0; k < 3; k++) {
                    e[i][k] = 0.0;
                    for (int r = 0; r < 3; r++)
                        e[i][k] += fabs(G[i][r]) * fabs((double)g[r * 3 + k]);
                }
            for (int i = 0; i < T; i++)
                for (int j = 0; j < T; j++) {
                    double s = 0.0;
                    for (int k = 0; k < 3; k++)
                        s += e[i][k] * fabs(G[j][k]);
                    uabs[((size_t)oc * in_c + ic) * TT + i * T + j] = s;
                }
        }

    pl_f32_wino_pack_weights(&p, m, wt, wp);
    pl_f32_conv c = {p, wp, with_bias ? b : NULL, NULL, NULL, m};
    const int blocks = pl_f32_wino_blocks(&p, m), panels = pl_f32_conv_panels(&p);
    t->wino(&c, x, got + (size_t)off * plane, scratch, 0, blocks, 0, panels);
    /* pieces: block and panel cuts, visited in a random order */
    int bc[6] = {0}, pc[6] = {0}, nb = 1, np = 1;
    for (int i = 0; i < pieces && nb < 4; i++) {
        const int cut = rint_in(bc[nb - 1], blocks);
        if (cut > bc[nb - 1] && cut < blocks) bc[nb++] = cut;
    }
    bc[nb] = blocks;
    for (int i = 0; i < pieces && np < 4; i++) {
        const int cut = rint_in(pc[np - 1], panels);
        if (cut > pc[np - 1] && cut < panels) pc[np++] = cut;
    }
    pc[np] = panels;
    int order[16], n = nb * np;
    for (int i = 0; i < n; i++)
        order[i] = i;
    for (int i = n - 1; i > 0; i--) {
        const int j = rint_in(0, i), tmp = order[i];
        order[i] = order[j];
        order[j] = tmp;
    }
    for (int i = 0; i < n; i++) {
        const int bi = order[i] / np, pi = order[i] % np;
        t->wino(&c, x, got2 + (size_t)off * plane, scratch, bc[bi], bc[bi + 1], pc[pi], pc[pi + 1]);
    }

    const double u = 1.0 / 16777216.0, nu = (double)(in_c + 16) * u, gamma = nu / (1.0 - nu);
    int reported = 0;
    double *sum = dmalloc((size_t)TT);
    for (int ch = 0; ch < total_c; ch++) {
        const int inside = ch >= off && ch < off + out_c, oc = ch - off;
        for (int tile = 0; inside && tile < n_tiles; tile++) {
            for (int e = 0; e < TT; e++)
                sum[e] = 0.0;
            for (int ic = 0; ic < in_c; ic++) {
                const double *va = vabs + ((size_t)tile * in_c + ic) * TT,
                             *ua = uabs + ((size_t)oc * in_c + ic) * TT;
                for (int e = 0; e < TT; e++)
                    sum[e] += ua[e] * va[e];
            }
            for (int yy = 0; yy < m; yy++)
                for (int xx = 0; xx < m; xx++) {
                    const int oy = tile / tiles_x * m + yy, ox = tile % tiles_x * m + xx;
                    if (oy >= h || ox >= w) continue;
                    double bound = with_bias ? fabs((double)b[oc]) : 0.0, ref = 0.0, direct = 0.0;
                    for (int i = 0; i < T; i++)
                        for (int k = 0; k < T; k++)
                            bound += at[yy][i] * sum[i * T + k] * at[xx][k];
                    bound *= gamma;
                    for (int ic = 0; ic < in_c; ic++)
                        for (int ky = 0; ky < 3; ky++)
                            for (int kx = 0; kx < 3; kx++) {
                                const int iy = oy - 1 + ky, ix = ox - 1 + kx;
                                if (iy < 0 || iy >= h || ix < 0 || ix >= w) continue;
                                const double pr =
                                    (double)wt[((size_t)oc * in_c + ic) * 9 + ky * 3 + kx] *
                                    x[(size_t)ic * plane + (size_t)iy * w + ix];
                                ref += pr;
                                direct += fabs(pr);
                            }
                    if (with_bias) {
                        ref += b[oc];
                        direct += fabs((double)b[oc]);
                    }
                    if (relu && ref < 0.0) ref = 0.0;
                    const size_t at_ = (size_t)ch * plane + (size_t)oy * w + ox;
                    const double err = fabs((double)got[at_] - ref);
                    if (err / (bound + 1e-300) > wino_worst_bound[m])
                        wino_worst_bound[m] = err / (bound + 1e-300);
                    if (err / (direct + 1e-300) > wino_worst_direct[m])
                        wino_worst_direct[m] = err / (direct + 1e-300);
                    if (!(err <= bound + 1e-30) && !reported++)
                        CHECK(0,
                              "%s wino F(%dx%d) in %dx%dx%d out_c %d bias %d relu %d: oc %d (%d, "
                              "%d): "
                              "%.9g vs %.9g, error %.3g > bound %.3g",
                              isa, m, m, in_c, h, w, out_c, with_bias, relu, oc, oy, ox,
                              (double)got[at_], ref, err, bound);
                    if (memcmp(&got[at_], &got2[at_], sizeof(float)) && !reported++)
                        CHECK(0,
                              "%s wino F(%dx%d) in %dx%dx%d out_c %d: pieces differ at oc %d (%d, "
                              "%d)",
                              isa, m, m, in_c, h, w, out_c, oc, oy, ox);
                }
        }
        for (size_t i = 0; !inside && i < plane; i++) {
            const size_t at_ = (size_t)ch * plane + i;
            if (!(got[at_] == SENTINEL && got2[at_] == SENTINEL) && !reported++)
                CHECK(0, "%s wino: channel %d outside the output (offset %d, out_c %d) written",
                      isa, ch, off, out_c);
        }
    }
    free(sum);
    free(x);
    free(wt);
    free(b);
    free(got);
    free(got2);
    free(wp);
    free(scratch);
    free(vabs);
    free(uabs);
}

static void wino_cases(const pl_kernels_f32 *t, const char *isa)
{
    for (int m = 2; m <= 4; m += 2) {
        for (int h = 1; h <= 7; h++) /* every small map: one tile, partial tiles */
            for (int w = 1; w <= 9; w++)
                wino_case(t, isa, rint_in(1, 40), h, w, rint_in(1, 40), m, rint_in(0, 1),
                          rint_in(0, 1), 2);
        for (int iter = 0; iter < 40; iter++) /* random maps, several blocks, chunks of in_c */
            wino_case(t, isa, rint_in(1, 300), rint_in(1, 31), rint_in(1, 37), rint_in(1, 40), m,
                      rint_in(0, 3) > 0, rint_in(0, 1), rint_in(0, 4));
        /* the network's 3x3s at 192x256 (128 -> 32, no bias, no ReLU) */
        wino_case(t, isa, 128, 48, 64, 32, m, 0, 0, 3);
        wino_case(t, isa, 128, 24, 32, 32, m, 0, 0, 3);
        wino_case(t, isa, 128, 12, 16, 32, m, 0, 0, 3);
        wino_case(t, isa, 128, 6, 8, 32, m, 0, 0, 3);
    }
}

static void bn_relu_case(const pl_kernels_f32 *t, const char *isa)
{
    const int c = rint_in(1, 40), hw = rint_in(1, 200);
    const int c0 = rint_in(0, c - 1), c1 = rint_in(c0 + 1, c);
    float *x = xmalloc((size_t)c * hw), *sc = xmalloc((size_t)c), *sh = xmalloc((size_t)c);
    float *ref = xmalloc((size_t)c * hw), *got = xmalloc((size_t)c * hw);
    fill(x, (size_t)c * hw, 3.0f);
    fill(sc, (size_t)c, 2.0f);
    fill(sh, (size_t)c, 1.0f);
    for (size_t i = 0; i < (size_t)c * hw; i++) ref[i] = got[i] = SENTINEL;
    nn_bn_relu_f32__ref(x, sc, sh, hw, ref, c0, c1);
    t->bn_relu(x, sc, sh, hw, got, c0, c1);
    CHECK(!memcmp(ref, got, (size_t)c * hw * sizeof(float)),
          "%s bn_relu %d x %d channels [%d, %d): differs from the reference", isa, c, hw, c0, c1);
    free(x);
    free(sc);
    free(sh);
    free(ref);
    free(got);
}

/* k, stride: 0 picks at random (the fast paths: 3x3/2 max, 2x2/2 average) */
static void pool_case(const pl_kernels_f32 *t, const char *isa, int avg, int k, int stride)
{
    nn_pool_params p;
    p.c = rint_in(1, 9);
    p.k = k ? k : rint_in(1, 4);
    p.stride = stride ? stride : rint_in(1, 3);
    p.pad = avg ? 0 : rint_in(0, p.k / 2); /* PyTorch's limit */
    p.in_h = rint_in(p.k, 30);
    p.in_w = rint_in(p.k, 70);
    p.out_h = (p.in_h + 2 * p.pad - p.k) / p.stride + 1;
    p.out_w = (p.in_w + 2 * p.pad - p.k) / p.stride + 1;
    const size_t n_in = (size_t)p.c * p.in_h * p.in_w, n_out = (size_t)p.c * p.out_h * p.out_w;
    float *x = xmalloc(n_in), *ref = xmalloc(n_out), *got = xmalloc(n_out);
    fill(x, n_in, 4.0f);
    for (size_t i = 0; i < n_in; i += 7) x[i] = (i & 8) ? 0.0f : -0.0f; /* signed-zero ties */
    for (size_t i = 0; i < n_out; i++) ref[i] = got[i] = SENTINEL;
    const int c0 = rint_in(0, p.c - 1), c1 = rint_in(c0 + 1, p.c);
    (avg ? nn_avgpool2d_f32__ref : nn_maxpool2d_f32__ref)(&p, x, ref, c0, c1);
    (avg ? t->avgpool : t->maxpool)(&p, x, got, c0, c1);
    CHECK(!memcmp(ref, got, n_out * sizeof(float)),
          "%s %s k %d s %d pad %d on %dx%dx%d, channels [%d, %d): differs from the reference", isa,
          avg ? "avgpool2d" : "maxpool2d", p.k, p.stride, p.pad, p.c, p.in_h, p.in_w, c0, c1);
    free(x);
    free(ref);
    free(got);
}

/* The float network's convolutions at 192x256 (block 4 and the stem at full size; the others
 * with their real depth on their real planes) and its fully connected layers. */
static double network_shapes(const pl_kernels_f32 *t, const char *isa)
{
    double worst = 0.0, e;
    const nn_conv_params convs[] = {
        shape(3, 192, 256, 64, 7, 2, 3, 1),   /* conv0 */
        shape(224, 48, 64, 128, 1, 1, 0, 1),  /* block 1, last bottleneck */
        shape(128, 48, 64, 32, 3, 1, 1, 0),   /* block 1, 3x3 */
        shape(256, 24, 32, 128, 1, 1, 0, 0),  /* transition 1 (after the pool) */
        shape(480, 24, 32, 128, 1, 1, 0, 1),  /* block 2 */
        shape(128, 12, 16, 32, 3, 1, 1, 0),   /* block 3, 3x3 */
        shape(992, 6, 8, 128, 1, 1, 0, 1),    /* block 4, last bottleneck */
        shape(128, 6, 8, 32, 3, 1, 1, 0),     /* block 4, 3x3 */
    };
    for (size_t i = 0; i < sizeof convs / sizeof convs[0]; i++) {
        const int bn = convs[i].k_h == 1 && convs[i].relu;
        if ((e = conv_case(t, isa, &convs[i], bn, convs[i].relu, 3)) > worst) worst = e;
    }
    if ((e = fc_case(t, isa, 3072, 512, 1)) > worst) worst = e;
    if ((e = fc_case(t, isa, 3072 + 9, 64, 1)) > worst) worst = e;
    if ((e = fc_case(t, isa, 512, 9, 0)) > worst) worst = e;
    return worst;
}

int main(void)
{
    const pl_isa paths[] = {PL_ISA_AVX2, PL_ISA_AVXVNNI, PL_ISA_AVX512F, PL_ISA_AVX512VNNI,
                            PL_ISA_AMX,  PL_ISA_NEON,    PL_ISA_DOTPROD, PL_ISA_I8MM};
    int ran = 0;
    for (size_t pi = 0; pi < sizeof paths / sizeof paths[0]; pi++) {
        const char *isa = pl_isa_name(paths[pi]);
        pl_kernels k;
        if (pl_kernels_for(paths[pi], &k) < 0) {
            printf("path %s: not available here (%s), skipped\n", isa, pl_last_error());
            continue;
        }
        if (!k.f32.packed) {
            printf("path %s: no packed fp32 kernels in this build, skipped\n", isa);
            continue;
        }
        /* a path whose fp32 kernels are all those of a path tested above (the Arm paths share
         * NEON's, avxvnni has avx2's, avx512vnni avx512f's) is not tested twice */
        int same = -1;
        for (size_t qi = 0; qi < pi && same < 0; qi++) {
            pl_kernels q;
            if (pl_kernels_for(paths[qi], &q) == 0 && q.f32.packed && q.f32.conv == k.f32.conv &&
                q.f32.wino == k.f32.wino && q.f32.fc == k.f32.fc && q.f32.fc_w8 == k.f32.fc_w8 &&
                q.f32.bn_relu == k.f32.bn_relu &&
                q.f32.maxpool == k.f32.maxpool && q.f32.avgpool == k.f32.avgpool)
                same = (int)qi;
        }
        if (same >= 0) {
            printf("path %s: the fp32 kernels of %s (%s), tested above\n", isa,
                   pl_isa_name(paths[same]), k.f32.conv_name);
            ran++;
            continue;
        }
        const int before = failures;
        double worst = 0.0, e;
        for (int iter = 0; iter < 400; iter++)
            if ((e = random_conv(&k.f32, isa)) > worst) worst = e;
        for (int n_in = 1; n_in <= 70; n_in++)
            if ((e = fc_case(&k.f32, isa, n_in, rint_in(1, 13), rint_in(0, 1))) > worst) worst = e;
        for (int n_in = 1; n_in <= 70; n_in++)
            fc_w8_case(&k.f32, isa, rint_in(1, 9), n_in, rint_in(1, 9));
        for (int iter = 0; iter < 20; iter++)
            fc_w8_case(&k.f32, isa, rint_in(1, 13), rint_in(1, 300), rint_in(1, 40));
        fc_w8_case(&k.f32, isa, 1, 4096 + 33, 5); /* past the reference's row buffer */
        fc_w8_case(&k.f32, isa, 3, 4096 + 33, 5);
        fc_w8_case(&k.f32, isa, 12, 1024, 512);   /* the shipped network's transition3 */
        fc_w8_case(&k.f32, isa, 1, 3072, 512);   /* and its fc (z: 1024 channels x 3 bands) */
        for (int iter = 0; iter < 100; iter++) {
            bn_relu_case(&k.f32, isa);
            pool_case(&k.f32, isa, 0, 0, 0);
            pool_case(&k.f32, isa, 1, 0, 0);
            pool_case(&k.f32, isa, 0, 3, 2);
            pool_case(&k.f32, isa, 1, 2, 2);
        }
        if ((e = network_shapes(&k.f32, isa)) > worst) worst = e;
        wino_cases(&k.f32, isa);
        printf("path %s: %s (%s, %s, %s, %s, %s, %s, %s); largest error / magnitude %.2e (limit %.0e); "
               "Winograd largest error / bound: F(2x2) %.2e, F(4x4) %.2e (limit 1), "
               "error / sum |w x|: F(2x2) %.2e, F(4x4) %.2e\n",
               isa, failures == before ? "ok" : "FAILED", k.f32.conv_name, k.f32.wino_name,
               k.f32.fc_name, k.f32.fc_w8_name, k.f32.bn_relu_name, k.f32.maxpool_name, k.f32.avgpool_name, worst,
               TOL, wino_worst_bound[2], wino_worst_bound[4], wino_worst_direct[2],
               wino_worst_direct[4]);
        for (int mi = 0; mi < 5; mi++)
            wino_worst_bound[mi] = wino_worst_direct[mi] = 0.0;
        ran++;
    }
    if (failures) {
        printf("%d failures\n", failures);
        return 1;
    }
    if (!ran) {
        printf("no SIMD fp32 path available on this CPU or build\n");
        return 77;
    }
    return 0;
}
