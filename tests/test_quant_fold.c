/* DenseNet folding (quant/fold.h, docs/QUANT.md "DenseNet folding") on random tensors:
 *  1. nn_conv1x1_clamp_s8__ref equals nn_conv1x1_s8__ref on a pre-clamped copy of the input,
 *     bit for bit (random shapes, pixel strides, channel pieces), and nn_clamp_s8__ref clamps
 *     exactly the channels asked for;
 *  2. clamp semantics of pl_fold_preact for both signs of the BN scale (and 0): for every int8 q,
 *     A*clamp(q) + B equals relu(a*x(q) + b) within |A|/4 (a quarter input step: the integer
 *     threshold), exactly when the channel never clips; a negative scale clamps from above, a
 *     positive one from below;
 *  3. a folded int8 1x1 layer on a block buffer with three segments of different scales and zero
 *     points, BN scales of both signs and some zero, equals the float layer (relu(bn(x)) then
 *     conv, x the dequantised input) within the quantisation error bound computed per output
 *     (output rounding, threshold rounding, weight and bias rounding);
 *  4. a folded 3x3 conv with padding on a plain quantised input (input offset = -zero point)
 *     equals the float conv within the same kind of bound;
 *  5. pl_qparams_clipped's grid holds its whole range: the first level at or below lo (so a
 *     block channel clipped at its consumers' clamp point t never reads as a value above t,
 *     which every consumer would pass on: the rounded zero point did that), the last at or above
 *     hi, with at most one step of slack in all (unless the zero point's bound coarsens the
 *     step). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/util.h"
#include "kernels/ref/nn_ref_s8.h"
#include "kernels/ref/nn_ref_s8_clamp.h"
#include "kernels/requant.h"
#include "quant/fold.h"
#include "tests/check.h"

static double urand(double lo, double hi)
{
    return lo + (hi - lo) * (rnd() / 4294967296.0);
}
static void *xmalloc(size_t n)
{
    void *p = calloc(1, n ? n : 1);
    if (!p) {
        printf("out of memory\n");
        exit(1);
    }
    return p;
}

static void test_clamp_kernel(void)
{
    for (int it = 0; it < 300; it++) {
        const int h = rint_in(1, 5), w = rint_in(1, 5), c = rint_in(1, 40), oc = rint_in(1, 20);
        const int in_stride = c + rint_in(0, 5), out_stride = oc + rint_in(0, 5);
        const nn_dims in = {1, h, w, c}, filt = {oc, 1, 1, c}, out = {1, h, w, oc};
        const size_t n_in = (size_t)h * w * in_stride, n_out = (size_t)h * w * out_stride;
        int8_t *x = xmalloc(n_in), *xc = xmalloc(n_in), *wt = xmalloc((size_t)oc * c);
        int8_t *lo = xmalloc((size_t)c), *hi = xmalloc((size_t)c);
        int8_t *o1 = xmalloc(n_out), *o2 = xmalloc(n_out);
        int32_t *bias = xmalloc((size_t)oc * 4), *mult = xmalloc((size_t)oc * 4),
                *shift = xmalloc((size_t)oc * 4);
        for (size_t i = 0; i < n_in; i++)
            x[i] = (int8_t)rnd();
        for (int i = 0; i < oc * c; i++)
            wt[i] = (int8_t)rnd();
        for (int i = 0; i < c; i++) {
            int a = rint_in(-128, 127), b = rint_in(-128, 127);
            if (rnd() % 3 == 0) a = -128;
            if (rnd() % 3 == 0) b = 127;
            lo[i] = (int8_t)(a < b ? a : b);
            hi[i] = (int8_t)(a < b ? b : a);
        }
        for (int i = 0; i < oc; i++) {
            bias[i] = (int32_t)rint_in(-100000, 100000);
            mult[i] = (int32_t)((1u << 30) + (rnd() & 0x3fffffff));
            shift[i] = rint_in(-12, -6);
        }
        const nn_conv_s8_params p = {
            rint_in(-127, 128), rint_in(-128, 127), 1, 1, 0, 0, 1, 1, -128, 127};
        const nn_per_channel_quant q = {mult, shift};
        CHECK(nn_conv1x1_s8_check(&p, &in, in_stride, &filt, &out, out_stride) == PL_OK, "check");
        memcpy(xc, x, n_in);
        nn_clamp_s8__ref(&in, xc, in_stride, lo, hi, 0, c);
        for (size_t i = 0; i < n_in; i++) {
            const int ch = (int)(i % (size_t)in_stride);
            const int8_t want = ch >= c         ? x[i]
                                : x[i] < lo[ch] ? lo[ch]
                                : x[i] > hi[ch] ? hi[ch]
                                                : x[i];
            CHECK(xc[i] == want, "clamp element %zu: %d, want %d", i, xc[i], want);
        }
        memset(o1, 0x5a, n_out);
        memset(o2, 0x5a, n_out);
        nn_conv1x1_s8__ref(&p, &q, &in, xc, in_stride, &filt, wt, bias, &out, o1, out_stride, 0,
                           oc);
        const int cut = rint_in(0, oc);
        nn_conv1x1_clamp_s8__ref(&p, &q, &in, x, in_stride, lo, hi, &filt, wt, bias, &out, o2,
                                 out_stride, cut, oc);
        nn_conv1x1_clamp_s8__ref(&p, &q, &in, x, in_stride, lo, hi, &filt, wt, bias, &out, o2,
                                 out_stride, 0, cut);
        CHECK(!memcmp(o1, o2, n_out), "conv1x1_clamp != conv1x1 on clamped input (it %d)", it);
        free(x), free(xc), free(wt), free(lo), free(hi), free(o1), free(o2), free(bias);
        free(mult), free(shift);
    }
}

static double relu(double v)
{
    return v > 0 ? v : 0;
}

static void test_preact_semantics(void)
{
    for (int it = 0; it < 2000; it++) {
        pl_qparams in = {(float)urand(0.001, 2.0), rint_in(-128, 127)};
        double a = urand(-3, 3), b = urand(-300, 300) * in.scale * fabs(a);
        if (it % 10 == 0) a = 0;
        pl_preact f;
        pl_fold_preact(a, b, in, &f);
        CHECK(f.lo <= f.hi, "lo %d > hi %d", f.lo, f.hi);
        if (f.active && a > 0) CHECK(f.hi == 127, "positive scale clamps from below only");
        if (f.active && a < 0) CHECK(f.lo == -128, "negative scale clamps from above only");
        const double A = fabs(a) * in.scale;
        const double t = a != 0 ? -(b - a * in.scale * in.zero_point) / (a * in.scale) : 0;
        for (int qv = -128; qv <= 127; qv++) {
            const double x = (double)in.scale * (qv - in.zero_point);
            const double want = relu(a * x + b), got = pl_preact_value(&f, qv);
            const double tol = 1e-9 * (1 + fabs(want)) + 1e-9 * A * 256;
            CHECK(fabs(got - want) <= A / 4 + tol, "a %g b %g q %d: %g, want %g +- A/4", a, b, qv,
                  got, want);
            if (f.active && (a > 0 ? t <= -128 : t >= 127))
                CHECK(fabs(got - want) <= tol, "unclamped channel must be exact");
        }
    }
}

/* float dequantised input x[c][pixel], segments with their own qparams; layer with BN of both
 * signs; compares with the int8 kernels. */
static void test_folded_1x1(void)
{
    for (int it = 0; it < 60; it++) {
        const int npx = rint_in(1, 30), c = rint_in(3, 60), oc = rint_in(1, 24);
        const int s1 = rint_in(1, c - 2), s2 = rint_in(s1 + 1, c - 1);
        pl_qparams seg[3];
        for (int k = 0; k < 3; k++) {
            seg[k].scale = (float)urand(0.005, 0.5);
            seg[k].zero_point = k == 0 ? -128 : rint_in(-60, 60);
        }
        int8_t *q = xmalloc((size_t)npx * c), *wq = xmalloc((size_t)oc * c);
        int8_t *lo = xmalloc((size_t)c), *hi = xmalloc((size_t)c), *out = xmalloc((size_t)npx * oc);
        float *w = xmalloc((size_t)oc * c * 4), *bias = xmalloc((size_t)oc * 4),
              *wscale = xmalloc((size_t)oc * 4);
        double *a = xmalloc((size_t)c * 8), *b = xmalloc((size_t)c * 8);
        double *yf = xmalloc((size_t)npx * oc * 8);
        int32_t *bq = xmalloc((size_t)oc * 4), *mult = xmalloc((size_t)oc * 4),
                *shift = xmalloc((size_t)oc * 4);
        pl_preact *fold = xmalloc((size_t)c * sizeof *fold);
        for (int i = 0; i < c; i++) {
            const pl_qparams sq = seg[i < s1 ? 0 : i < s2 ? 1 : 2];
            a[i] = urand(-2, 2);
            if (i % 7 == 3) a[i] = 0;
            b[i] = urand(-1, 1);
            pl_fold_preact(a[i], b[i], sq, &fold[i]);
            lo[i] = fold[i].lo;
            hi[i] = fold[i].hi;
        }
        for (size_t i = 0; i < (size_t)npx * c; i++)
            q[i] = (int8_t)rnd();
        for (int i = 0; i < oc * c; i++)
            w[i] = (float)urand(-1, 1);
        for (int o = 0; o < oc; o++)
            bias[o] = (float)urand(-1, 1);
        /* float reference and output range */
        double ymax = 1e-6, ymin = -1e-6;
        for (int p = 0; p < npx; p++)
            for (int o = 0; o < oc; o++) {
                double y = bias[o];
                for (int i = 0; i < c; i++) {
                    const pl_qparams sq = seg[i < s1 ? 0 : i < s2 ? 1 : 2];
                    const double x = (double)sq.scale * (q[(size_t)p * c + i] - sq.zero_point);
                    y += w[(size_t)o * c + i] * relu(a[i] * x + b[i]);
                }
                yf[(size_t)p * oc + o] = y;
                ymax = fmax(ymax, y);
                ymin = fmin(ymin, y);
            }
        pl_qparams oq;
        CHECK(pl_qparams_from_range(ymin, ymax, 0, &oq) == PL_OK, "range");
        CHECK(pl_quantize_layer("t", w, bias, oc, c, fold, 1, c, 0, wq, bq, wscale) == PL_OK,
              "quantize_layer: %s", pl_last_error());
        for (int o = 0; o < oc; o++)
            CHECK(pl_quantize_multiplier((double)wscale[o] / oq.scale, &mult[o], &shift[o]) ==
                      PL_OK,
                  "multiplier");
        const nn_conv_s8_params p = {0, oq.zero_point, 1, 1, 0, 0, 1, 1, -128, 127};
        const nn_per_channel_quant qq = {mult, shift};
        const nn_dims ind = {1, 1, npx, c}, fd = {oc, 1, 1, c}, od = {1, 1, npx, oc};
        nn_conv1x1_clamp_s8__ref(&p, &qq, &ind, q, c, lo, hi, &fd, wq, bq, &od, out, oc, 0, oc);
        for (int px = 0; px < npx; px++)
            for (int o = 0; o < oc; o++) {
                double bound = oq.scale * 0.5 + 1e-6 + wscale[o] * 0.5; /* output, bias rounding */
                for (int i = 0; i < c; i++) {
                    const int qi = q[(size_t)px * c + i];
                    const int cl = qi < lo[i] ? lo[i] : qi > hi[i] ? hi[i] : qi;
                    bound += fabs(w[(size_t)o * c + i]) * fabs(fold[i].A) * 0.25; /* threshold */
                    bound += wscale[o] * 0.5 * abs(cl - fold[i].center);          /* weights */
                }
                const double got = oq.scale * (out[(size_t)px * oc + o] - oq.zero_point);
                const double want = yf[(size_t)px * oc + o];
                CHECK(fabs(got - want) <= bound * 1.001 + oq.scale,
                      "folded 1x1 it %d px %d oc %d: %g, want %g (bound %g)", it, px, o, got, want,
                      bound);
            }
        free(q), free(wq), free(lo), free(hi), free(out), free(w), free(bias), free(wscale);
        free(a), free(b), free(yf), free(bq), free(mult), free(shift), free(fold);
    }
}

static void test_folded_3x3(void)
{
    for (int it = 0; it < 30; it++) {
        const int h = rint_in(1, 6), wd = rint_in(1, 6), c = rint_in(1, 20), oc = rint_in(1, 10);
        pl_qparams in = {(float)urand(0.01, 0.2), rint_in(-128, 50)};
        const size_t nw = (size_t)oc * 9 * c;
        int8_t *q = xmalloc((size_t)h * wd * c), *wq = xmalloc(nw),
               *out = xmalloc((size_t)h * wd * oc);
        float *w = xmalloc(nw * 4), *wscale = xmalloc((size_t)oc * 4);
        double *yf = xmalloc((size_t)h * wd * oc * 8);
        int32_t *bq = xmalloc((size_t)oc * 4), *mult = xmalloc((size_t)oc * 4),
                *shift = xmalloc((size_t)oc * 4);
        pl_preact *fold = xmalloc((size_t)c * sizeof *fold);
        for (int i = 0; i < c; i++)
            pl_fold_plain(in, &fold[i]);
        for (int i = 0; i < h * wd * c; i++)
            q[i] = (int8_t)rint_in(in.zero_point, 127);
        for (size_t i = 0; i < nw; i++)
            w[i] = (float)urand(-1, 1);
        double ymin = -1e-6, ymax = 1e-6;
        for (int y = 0; y < h; y++)
            for (int x = 0; x < wd; x++)
                for (int o = 0; o < oc; o++) {
                    double s = 0;
                    for (int ky = 0; ky < 3; ky++)
                        for (int kx = 0; kx < 3; kx++) {
                            const int iy = y + ky - 1, ix = x + kx - 1;
                            if (iy < 0 || iy >= h || ix < 0 || ix >= wd) continue; /* zero pad */
                            for (int i = 0; i < c; i++)
                                s += w[(((size_t)o * 3 + ky) * 3 + kx) * c + i] * in.scale *
                                     (q[((size_t)iy * wd + ix) * c + i] - in.zero_point);
                        }
                    yf[((size_t)y * wd + x) * oc + o] = s;
                    ymin = fmin(ymin, s);
                    ymax = fmax(ymax, s);
                }
        pl_qparams oq;
        pl_qparams_from_range(ymin, ymax, 0, &oq);
        CHECK(pl_quantize_layer("t3", w, NULL, oc, 9 * c, fold, 1, c, -in.zero_point, wq, bq,
                                wscale) == PL_OK,
              "quantize 3x3");
        for (int o = 0; o < oc; o++) {
            CHECK(bq[o] == 0, "plain fold with input offset -zp needs no bias (got %d)", bq[o]);
            pl_quantize_multiplier((double)wscale[o] / oq.scale, &mult[o], &shift[o]);
        }
        const nn_conv_s8_params p = {-in.zero_point, oq.zero_point, 1, 1, 1, 1, 1, 1, -128, 127};
        const nn_per_channel_quant qq = {mult, shift};
        const nn_dims ind = {1, h, wd, c}, fd = {oc, 3, 3, c}, od = {1, h, wd, oc};
        CHECK(nn_conv2d_s8_check(&p, &ind, c, &fd, &od, oc) == PL_OK, "conv check");
        nn_conv2d_s8__ref(&p, &qq, &ind, q, c, &fd, wq, bq, &od, out, oc, 0, oc);
        for (int i = 0; i < h * wd; i++)
            for (int o = 0; o < oc; o++) {
                double bound = oq.scale * 0.5 + 1e-6;
                for (int k = 0; k < 9 * c; k++)
                    bound += wscale[o] * 0.5 * 255; /* |q - zp| */
                const double got = oq.scale * (out[(size_t)i * oc + o] - oq.zero_point);
                CHECK(fabs(got - yf[(size_t)i * oc + o]) <= bound + oq.scale,
                      "folded 3x3: %g want %g", got, yf[(size_t)i * oc + o]);
            }
        free(q), free(wq), free(out), free(w), free(wscale), free(yf), free(bq), free(mult);
        free(shift), free(fold);
    }
}

static void test_clipped_grid(void)
{
    int worst_lo = 0, worst_hi = 0;
    for (int it = 0; it < 20000; it++) {
        const double mag = pow(10.0, urand(-3, 3.5));
        double lo = urand(-mag, mag), hi = urand(-mag, mag);
        if (lo > hi) {
            const double t = lo;
            lo = hi;
            hi = t;
        }
        if (it % 7 == 0) lo = hi - mag * 1e-3; /* narrow ranges */
        pl_qparams q;
        CHECK(pl_qparams_clipped(lo, hi, &q) == PL_OK, "clipped [%g, %g]", lo, hi);
        const double s = q.scale, first = s * (-128.0 - q.zero_point),
                     last = s * (127.0 - q.zero_point),
                     tol = 1e-6 * s + 2e-7 * fmax(fabs(lo), fabs(hi)); /* the f32 scale */
        if (!(first <= lo + tol)) worst_lo++;
        if (!(last >= hi - tol)) worst_hi++;
        /* unless the zero point's bound (|z| <= 32767) made the step coarser */
        if ((hi - lo) / 254.0 > fmax(fabs(lo), fabs(hi)) / 32000.0)
            CHECK(last - first <= (hi - lo) * (1 + 1e-6) + s + tol,
                  "[%g, %g]: grid [%g, %g] wider than a step of slack", lo, hi, first, last);
    }
    CHECK(worst_lo == 0, "%d ranges whose first level lies above lo", worst_lo);
    CHECK(worst_hi == 0, "%d ranges whose last level lies below hi", worst_hi);
}

int main(void)
{
    test_clipped_grid();
    test_clamp_kernel();
    test_preact_semantics();
    test_folded_1x1();
    test_folded_3x3();
    if (failures) {
        printf("%d failures\n", failures);
        return 1;
    }
    printf("quant fold: clipped grids hold their ranges, clamp kernel exact, clamp semantics (both "
           "BN signs), folded 1x1 and 3x3 within bounds\n");
    return 0;
}
