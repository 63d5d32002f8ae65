/* port/resize: the area resize against a brute-force double-precision area average (random
 * images, odd sizes, windows, padded strides), identity exactness, the bilinear path (enlarging,
 * and mixed shrink/enlarge per axis) against a brute-force bilinear, the centre-crop geometry
 * (odd remainders), argument checks, and the cost of 1920x1080 -> 4:3 -> 256x192. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/image.h"
#include "core/util.h"
#include "model/resize.h"
#include "tests/check.h"

/* Weight of source pixel j (width 1) for output i along an axis, brute force in doubles. */
static double area_w(int src, int dst, int i, int j)
{
    double s = (double)src / dst, lo = i * s, hi = (i + 1) * s;
    double a = lo > j ? lo : j, b = hi < j + 1 ? hi : j + 1;
    return b > a ? (b - a) / s : 0.0;
}
static double bilin_w(int src, int dst, int i, int j)
{
    double x = (i + 0.5) * src / dst - 0.5;
    if (x < 0) x = 0;
    if (x > src - 1) x = src - 1;
    int x0 = (int)floor(x);
    double f = x - x0;
    if (j == x0) return 1.0 - f;
    if (j == x0 + 1) return f;
    return 0.0;
}
static double axis_w(int src, int dst, int i, int j)
{
    return src >= dst ? area_w(src, dst, i, j) : bilin_w(src, dst, i, j);
}

/* Compares the resize of a random w x h image's window to the brute force; returns max error. */
static double compare(int w, int h, int pad, int x0, int y0, int cw, int ch, int dw, int dh)
{
    size_t stride = (size_t)w * 3 + (size_t)pad;
    uint8_t *src = malloc(stride * (size_t)h);
    float *dst = malloc(sizeof(float) * 3 * (size_t)dw * (size_t)dh);
    for (size_t i = 0; i < stride * (size_t)h; i++)
        src[i] = (uint8_t)rnd();
    CHECK(pl_resize_check(w, h, stride, x0, y0, cw, ch, dw, dh) == PL_OK, "check: %s",
          pl_last_error());
    pl_resize_area_rgb8_to_chw(src, stride, x0, y0, cw, ch, dst, dw, dh);
    double maxerr = 0;
    double *wx = malloc(sizeof(double) * (size_t)cw), *wy = malloc(sizeof(double) * (size_t)ch);
    for (int oy = 0; oy < dh; oy++) {
        for (int j = 0; j < ch; j++)
            wy[j] = axis_w(ch, dh, oy, j);
        for (int ox = 0; ox < dw; ox++) {
            for (int j = 0; j < cw; j++)
                wx[j] = axis_w(cw, dw, ox, j);
            for (int c = 0; c < 3; c++) {
                double s = 0;
                for (int y = 0; y < ch; y++) {
                    if (wy[y] == 0) continue;
                    const uint8_t *row = src + (size_t)(y0 + y) * stride + 3 * (size_t)x0;
                    for (int x = 0; x < cw; x++)
                        s += wy[y] * wx[x] * row[3 * x + c];
                }
                double e = fabs(s - dst[(size_t)c * dw * dh + (size_t)oy * dw + ox]);
                if (e > maxerr) maxerr = e;
            }
        }
    }
    free(wx);
    free(wy);
    free(src);
    free(dst);
    return maxerr;
}

static void test_random_area(void)
{
    for (int t = 0; t < 60; t++) {
        int w = 1 + (int)(rnd() % 97), h = 1 + (int)(rnd() % 83);
        int cw = 1 + (int)(rnd() % (unsigned)w), ch = 1 + (int)(rnd() % (unsigned)h);
        int x0 = (int)(rnd() % (unsigned)(w - cw + 1)), y0 = (int)(rnd() % (unsigned)(h - ch + 1));
        int dw = 1 + (int)(rnd() % (unsigned)cw), dh = 1 + (int)(rnd() % (unsigned)ch);
        int pad = (int)(rnd() % 5);
        double e = compare(w, h, pad, x0, y0, cw, ch, dw, dh);
        CHECK(e < 1e-4, "area %dx%d win %dx%d@(%d,%d) -> %dx%d: max error %g", w, h, cw, ch, x0, y0,
              dw, dh, e);
    }
    /* Wider than one 256-column chunk, and extreme ratios. */
    double e = compare(700, 9, 3, 5, 1, 690, 7, 300, 3);
    CHECK(e < 1e-4, "chunked 690 -> 300: max error %g", e);
    e = compare(1000, 3, 0, 0, 0, 1000, 3, 1, 1);
    CHECK(e < 1e-4, "1000x3 -> 1x1: max error %g", e);
    e = compare(257, 257, 1, 0, 0, 257, 257, 256, 2);
    CHECK(e < 1e-4, "257 -> 256: max error %g", e);
}

static void test_bilinear_and_mixed(void)
{
    for (int t = 0; t < 30; t++) {
        int cw = 1 + (int)(rnd() % 20), ch = 1 + (int)(rnd() % 20);
        int dw = 1 + (int)(rnd() % 60), dh = 1 + (int)(rnd() % 60);
        double e = compare(cw + 2, ch + 1, 2, 1, 1, cw, ch, dw, dh);
        CHECK(e < 1e-4, "%dx%d -> %dx%d: max error %g", cw, ch, dw, dh, e);
    }
    /* A horizontal ramp enlarged 4x stays a ramp inside and clamps at the edges. */
    enum { W = 8, H = 2, DW = 32 };
    uint8_t src[W * H * 3];
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++)
            for (int c = 0; c < 3; c++)
                src[(y * W + x) * 3 + c] = (uint8_t)(x * 10);
    float dst[3 * DW * H];
    pl_resize_area_rgb8_to_chw(src, W * 3, 0, 0, W, H, dst, DW, H);
    CHECK(dst[0] == 0.0f && dst[1] == 0.0f, "left edge clamps: %g %g", dst[0], dst[1]);
    CHECK(dst[DW - 1] == 70.0f, "right edge clamps: %g", dst[DW - 1]);
    for (int i = 2; i < DW - 2; i++) {
        double want = ((i + 0.5) / 4.0 - 0.5) * 10.0;
        CHECK(fabs(dst[i] - want) < 1e-5, "ramp at %d: %g, want %g", i, dst[i], want);
    }
}

static void test_identity_exact(void)
{
    int sizes[][2] = {{1, 1}, {3, 7}, {37, 23}, {256, 192}, {300, 5}};
    for (size_t k = 0; k < sizeof sizes / sizeof sizes[0]; k++) {
        int cw = sizes[k][0], ch = sizes[k][1], w = cw + 3, h = ch + 2;
        size_t stride = (size_t)w * 3 + 1;
        uint8_t *src = malloc(stride * (size_t)h);
        float *dst = malloc(sizeof(float) * 3 * (size_t)cw * (size_t)ch);
        for (size_t i = 0; i < stride * (size_t)h; i++)
            src[i] = (uint8_t)rnd();
        pl_resize_area_rgb8_to_chw(src, stride, 2, 1, cw, ch, dst, cw, ch);
        int bad = 0;
        for (int y = 0; y < ch; y++)
            for (int x = 0; x < cw; x++)
                for (int c = 0; c < 3; c++)
                    bad += dst[(size_t)c * cw * ch + (size_t)y * cw + x] !=
                           (float)src[(size_t)(y + 1) * stride + 3 * (size_t)(x + 2) + (size_t)c];
        CHECK(bad == 0, "identity %dx%d: %d values differ", cw, ch, bad);
        free(src);
        free(dst);
    }
    /* Exact 2x2 block means. */
    const uint8_t s[2 * 4 * 3] = {0, 0, 0, 1, 1, 1, 10, 20, 30, 10, 20, 30,
                                  2, 2, 2, 3, 3, 3, 10, 20, 30, 14, 24, 34};
    float d[3 * 2];
    pl_resize_area_rgb8_to_chw(s, 12, 0, 0, 4, 2, d, 2, 1);
    CHECK(d[0] == 1.5f && d[1] == 11.0f && d[2] == 1.5f && d[3] == 21.0f && d[4] == 1.5f &&
              d[5] == 31.0f,
          "2x2 means: %g %g | %g %g | %g %g", d[0], d[1], d[2], d[3], d[4], d[5]);
}

/* Output rows in pieces (as threads split a frame) equal the whole call bit for bit, and rows
 * outside the range are left alone. */
static void test_rows(void)
{
    const int sizes[][4] = {
        {1440, 1080, 256, 192}, {37, 23, 128, 96}, {64, 48, 64, 48}, {9, 700, 5, 3}};
    for (size_t k = 0; k < sizeof sizes / sizeof sizes[0]; k++) {
        const int cw = sizes[k][0], ch = sizes[k][1], dw = sizes[k][2], dh = sizes[k][3];
        const size_t stride = (size_t)cw * 3 + 5, n = 3 * (size_t)dw * dh;
        uint8_t *src = malloc(stride * (size_t)ch);
        float *whole = malloc(sizeof(float) * n), *parts = malloc(sizeof(float) * n);
        for (size_t i = 0; i < stride * (size_t)ch; i++)
            src[i] = (uint8_t)rnd();
        pl_resize_area_rgb8_to_chw(src, stride, 0, 0, cw, ch, whole, dw, dh);
        for (size_t i = 0; i < n; i++)
            parts[i] = -1.0f;
        int r0 = 0, untouched = 1;
        while (r0 < dh) {
            const int step = 1 + (int)(rnd() % 7), r1 = r0 + step > dh ? dh : r0 + step;
            pl_resize_area_rgb8_to_chw_rows(src, stride, 0, 0, cw, ch, parts, dw, dh, r0, r1);
            for (int c = 0; c < 3; c++) /* the next row is still untouched */
                for (int x = 0; r1 < dh && x < dw; x++)
                    untouched &= parts[(size_t)c * dw * dh + (size_t)r1 * dw + x] == -1.0f;
            r0 = r1;
        }
        pl_resize_area_rgb8_to_chw_rows(src, stride, 0, 0, cw, ch, parts, dw, dh, 1, 1);
        CHECK(untouched, "%dx%d -> %dx%d: a row range wrote outside itself", cw, ch, dw, dh);
        CHECK(memcmp(whole, parts, sizeof(float) * n) == 0,
              "%dx%d -> %dx%d: rows in pieces differ from the whole", cw, ch, dw, dh);
        free(src);
        free(whole);
        free(parts);
    }
}

static void test_crop(void)
{
    struct {
        int w, h, aw, ah, x0, y0, cw, ch;
    } c[] = {
        {1920, 1080, 4, 3, 240, 0, 1440, 1080},
        {1000, 1000, 4, 3, 0, 125, 1000, 750},
        {1001, 750, 4, 3, 0, 0, 1000, 750}, /* remainder 1: extra column on the right */
        {1003, 750, 4, 3, 1, 0, 1000, 750}, /* remainder 3: 1 left, 2 right */
        {640, 481, 4, 3, 0, 0, 640, 480},   /* extra row at the bottom */
        {640, 483, 4, 3, 0, 1, 640, 480},
        {5, 3, 4, 3, 0, 0, 4, 3},
        {7, 5, 4, 3, 0, 0, 6, 5},      /* too wide: cw = floor(5*4/3) = 6, extra column right */
        {1, 1000, 4, 3, 0, 499, 1, 1}, /* degenerate: at least 1 */
        {256, 192, 4, 3, 0, 0, 256, 192},
        {640, 480, 0, 3, 0, 0, 640, 480}, /* invalid aspect: whole image */
    };
    for (size_t k = 0; k < sizeof c / sizeof c[0]; k++) {
        int x0, y0, cw, ch;
        pl_crop_to_aspect(c[k].w, c[k].h, c[k].aw, c[k].ah, &x0, &y0, &cw, &ch);
        CHECK(x0 == c[k].x0 && y0 == c[k].y0 && cw == c[k].cw && ch == c[k].ch,
              "crop %dx%d to %d:%d: got %dx%d@(%d,%d), want %dx%d@(%d,%d)", c[k].w, c[k].h, c[k].aw,
              c[k].ah, cw, ch, x0, y0, c[k].cw, c[k].ch, c[k].x0, c[k].y0);
    }
}

static void test_check(void)
{
    CHECK(pl_resize_check(100, 50, 300, 0, 0, 100, 50, 10, 10) == PL_OK, "valid");
    CHECK(pl_resize_check(100, 50, 299, 0, 0, 100, 50, 10, 10) == PL_E_ARG, "short stride");
    CHECK(pl_resize_check(100, 50, 300, 1, 0, 100, 50, 10, 10) == PL_E_ARG, "window past right");
    CHECK(strstr(pl_last_error(), "window") != NULL, "message names the window: %s",
          pl_last_error());
    CHECK(pl_resize_check(100, 50, 300, 0, -1, 10, 10, 10, 10) == PL_E_ARG, "negative y0");
    CHECK(pl_resize_check(100, 50, 300, 0, 0, 100, 50, 0, 10) == PL_E_ARG, "zero output");
    CHECK(pl_resize_check(0, 50, 300, 0, 0, 1, 1, 1, 1) == PL_E_ARG, "zero source");
    CHECK(pl_resize_check(100, 50, 300, 0, 0, 100, 50, 40000, 10) == PL_E_ARG, "huge output");
}

static void test_speed(void)
{
    const int w = 1920, h = 1080, dw = 256, dh = 192;
    uint8_t *src = malloc((size_t)w * h * 3);
    float *dst = malloc(sizeof(float) * 3 * dw * dh);
    for (size_t i = 0; i < (size_t)w * h * 3; i++)
        src[i] = (uint8_t)rnd();
    int x0, y0, cw, ch;
    pl_crop_to_aspect(w, h, 4, 3, &x0, &y0, &cw, &ch);
    double best = 1e9;
    for (int r = 0; r < 20; r++) {
        int64_t t0 = pl_now_ns();
        pl_resize_area_rgb8_to_chw(src, (size_t)w * 3, x0, y0, cw, ch, dst, dw, dh);
        double ms = (double)(pl_now_ns() - t0) / 1e6;
        if (ms < best) best = ms;
    }
    printf("1920x1080 -> crop %dx%d -> %dx%d: best of 20 %.2f ms\n", cw, ch, dw, dh, best);
    CHECK(best < 50.0, "resize too slow: %.2f ms", best);
    free(src);
    free(dst);
}

int main(void)
{
    test_random_area();
    test_bilinear_and_mixed();
    test_identity_exact();
    test_rows();
    test_crop();
    test_check();
    test_speed();
    if (failures) {
        printf("%d failures\n", failures);
        return 1;
    }
    printf("all resize tests passed\n");
    return 0;
}
