/* port/pixfmt: YCbCr -> RGB against the exact formula for every Y,U,V (BT.601/709, limited/full),
 * anchor values (black, white, grey, primaries), YUYV and NV12 layouts with odd sizes and padded
 * strides (bytes past each row untouched), RGB24 copy, and the size checks. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/util.h"
#include "port/pixfmt.h"
#include "tests/check.h"

/* The formula of port/pixfmt.h in double precision, rounded and clamped. */
static void exact(pl_yuv_matrix m, pl_yuv_range r, int y, int u, int v, double rgb[3])
{
    const double kr = m == PL_YUV_BT709 ? 0.2126 : 0.299, kb = m == PL_YUV_BT709 ? 0.0722 : 0.114;
    const double kg = 1 - kr - kb;
    const double yy = r == PL_YUV_FULL ? y / 255.0 : (y - 16) / 219.0;
    const double cb = (u - 128) / (r == PL_YUV_FULL ? 255.0 : 224.0);
    const double cr = (v - 128) / (r == PL_YUV_FULL ? 255.0 : 224.0);
    const double c[3] = {yy + 2 * (1 - kr) * cr,
                         yy - (2 * kb * (1 - kb) * cb + 2 * kr * (1 - kr) * cr) / kg,
                         yy + 2 * (1 - kb) * cb};
    for (int k = 0; k < 3; k++) {
        double x = c[k] * 255.0;
        rgb[k] = x < 0 ? 0 : x > 255 ? 255 : x;
    }
}

static void test_all_triples(void)
{
    for (int m = 0; m < 2; m++)
        for (int r = 0; r < 2; r++) {
            pl_yuv_coeffs c;
            pl_yuv_coeffs_init(&c, (pl_yuv_matrix)m, (pl_yuv_range)r);
            double worst = 0;
            for (int y = 0; y < 256; y++)
                for (int u = 0; u < 256; u++)
                    for (int v = 0; v < 256; v++) {
                        uint8_t got[3];
                        double want[3];
                        pl_yuv_to_rgb_pixel(&c, y, u, v, got);
                        exact((pl_yuv_matrix)m, (pl_yuv_range)r, y, u, v, want);
                        for (int k = 0; k < 3; k++) {
                            double e = fabs(got[k] - want[k]);
                            if (e > worst) worst = e;
                        }
                    }
            /* One rounding of the exact value is at most 0.5 away; Q16 coefficients add < 0.01. */
            CHECK(worst < 0.52, "matrix %d range %d: worst error %.3f > 0.52", m, r, worst);
            printf("matrix %s %s: worst |fixed - exact| = %.3f over all 2^24 triples\n",
                   m ? "BT.709" : "BT.601", r ? "full" : "limited", worst);
        }
}

static void expect_pixel(pl_yuv_matrix m, pl_yuv_range r, int y, int u, int v, int R, int G, int B)
{
    pl_yuv_coeffs c;
    pl_yuv_coeffs_init(&c, m, r);
    uint8_t got[3];
    pl_yuv_to_rgb_pixel(&c, y, u, v, got);
    CHECK(got[0] == R && got[1] == G && got[2] == B,
          "m%d r%d YUV(%d,%d,%d): got (%d,%d,%d), want (%d,%d,%d)", (int)m, (int)r, y, u, v, got[0],
          got[1], got[2], R, G, B);
}

static void test_anchors(void)
{
    /* limited range: 16 is black, 235 white, values beyond clip */
    expect_pixel(PL_YUV_BT601, PL_YUV_LIMITED, 16, 128, 128, 0, 0, 0);
    expect_pixel(PL_YUV_BT601, PL_YUV_LIMITED, 235, 128, 128, 255, 255, 255);
    expect_pixel(PL_YUV_BT601, PL_YUV_LIMITED, 0, 128, 128, 0, 0, 0);
    expect_pixel(PL_YUV_BT601, PL_YUV_LIMITED, 255, 128, 128, 255, 255, 255);
    expect_pixel(PL_YUV_BT601, PL_YUV_LIMITED, 126, 128, 128, 128, 128, 128); /* 110*255/219 */
    /* full range: 0 black, 255 white, grey unchanged */
    expect_pixel(PL_YUV_BT601, PL_YUV_FULL, 0, 128, 128, 0, 0, 0);
    expect_pixel(PL_YUV_BT601, PL_YUV_FULL, 255, 128, 128, 255, 255, 255);
    expect_pixel(PL_YUV_BT601, PL_YUV_FULL, 77, 128, 128, 77, 77, 77);
    /* BT.601 full-range red as JPEG encodes it: Y 76, Cb 85, Cr 255 -> (254, 0, 0)
     * (76 + 1.402 * 127 = 254.05; G = 76 + 0.344 * 43 - 0.714 * 127 < 0; B = 76 - 1.772 * 43 < 0)
     */
    expect_pixel(PL_YUV_BT601, PL_YUV_FULL, 76, 85, 255, 254, 0, 0);
    /* BT.601 limited 100% colour bars (ITU-R BT.801 / the test pattern vivid draws):
     * red Y 81 Cb 90 Cr 240, green 145 54 34, blue 41 240 110; red comes back as 254 because
     * its Y (81.48) was rounded down when encoded: (65/219 + 1.402 * 0.5) * 255 = 254.4 */
    expect_pixel(PL_YUV_BT601, PL_YUV_LIMITED, 81, 90, 240, 254, 0, 0);
    expect_pixel(PL_YUV_BT601, PL_YUV_LIMITED, 145, 54, 34, 0, 255, 1);
    expect_pixel(PL_YUV_BT601, PL_YUV_LIMITED, 41, 240, 110, 0, 0, 255);
    /* BT.709 limited red: Y 63 Cb 102 Cr 240 (Y rounded up from 62.56: G = 0.6 -> 1) */
    expect_pixel(PL_YUV_BT709, PL_YUV_LIMITED, 63, 102, 240, 255, 1, 0);
    /* the same bytes read with the wrong range differ: full-range 16 is not black */
    expect_pixel(PL_YUV_BT601, PL_YUV_FULL, 16, 128, 128, 16, 16, 16);
}

/* Fills a YUYV frame whose pixels encode their position, converts it and compares pixel by pixel
 * with pl_yuv_to_rgb_pixel on the bytes each pixel should use. */
static void test_yuyv(int w, int h, size_t stride_pad)
{
    pl_yuv_coeffs c;
    pl_yuv_coeffs_init(&c, PL_YUV_BT601, PL_YUV_LIMITED);
    const size_t stride = (size_t)(w + 1) / 2 * 4 + stride_pad;
    size_t need;
    CHECK(pl_pixfmt_min_bytes(PL_PIX_YUYV, w, h, stride, &need) == PL_OK, "%s", pl_last_error());
    CHECK(need == stride * (size_t)h, "YUYV %dx%d: min bytes %zu", w, h, need);
    uint8_t *src = malloc(need);
    const size_t dstride = (size_t)w * 3 + 5;
    uint8_t *dst = malloc(dstride * (size_t)h);
    for (size_t i = 0; i < need; i++)
        src[i] = (uint8_t)(i * 37 + (i >> 8) * 11 + 3);
    memset(dst, 0xA5, dstride * (size_t)h);
    pl_yuyv_to_rgb8(src, stride, w, h, &c, dst, dstride);
    int bad = 0;
    for (int y = 0; y < h; y++) {
        for (int x = 0; x < w; x++) {
            const uint8_t *mp = src + (size_t)y * stride + (size_t)(x / 2) * 4;
            uint8_t want[3];
            pl_yuv_to_rgb_pixel(&c, mp[(x & 1) * 2], mp[1], mp[3], want);
            if (memcmp(dst + (size_t)y * dstride + (size_t)x * 3, want, 3) != 0) bad++;
        }
        for (size_t k = (size_t)w * 3; k < dstride; k++)
            if (dst[(size_t)y * dstride + k] != 0xA5) bad++;
    }
    CHECK(bad == 0, "YUYV %dx%d pad %zu: %d wrong bytes", w, h, stride_pad, bad);
    free(src);
    free(dst);
}

static void test_nv12(int w, int h, size_t stride_pad)
{
    pl_yuv_coeffs c;
    pl_yuv_coeffs_init(&c, PL_YUV_BT709, PL_YUV_FULL);
    const size_t stride = (size_t)(w + 1) / 2 * 2 + stride_pad;
    size_t need;
    CHECK(pl_pixfmt_min_bytes(PL_PIX_NV12, w, h, stride, &need) == PL_OK, "%s", pl_last_error());
    CHECK(need == stride * ((size_t)h + (size_t)(h + 1) / 2), "NV12 %dx%d: min bytes %zu", w, h,
          need);
    uint8_t *src = malloc(need);
    const size_t dstride = (size_t)w * 3;
    uint8_t *dst = malloc(dstride * (size_t)h);
    for (size_t i = 0; i < need; i++)
        src[i] = (uint8_t)(i * 53 + (i >> 7) + 1);
    const uint8_t *uv = src + stride * (size_t)h;
    pl_nv12_to_rgb8(src, stride, uv, stride, w, h, &c, dst, dstride);
    int bad = 0;
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            const uint8_t *p = uv + (size_t)(y / 2) * stride + (size_t)(x / 2) * 2;
            uint8_t want[3];
            pl_yuv_to_rgb_pixel(&c, src[(size_t)y * stride + (size_t)x], p[0], p[1], want);
            if (memcmp(dst + (size_t)y * dstride + (size_t)x * 3, want, 3) != 0) bad++;
        }
    CHECK(bad == 0, "NV12 %dx%d pad %zu: %d wrong pixels", w, h, stride_pad, bad);
    free(src);
    free(dst);
}

static void test_known_frame(void)
{
    /* 3x1 YUYV (odd width): white, black | red from the colour bars; the 4th Y is ignored */
    const uint8_t yuyv[8] = {235, 128, 16, 128, 81, 90, 200, 240};
    uint8_t rgb[9];
    pl_yuv_coeffs c;
    pl_yuv_coeffs_init(&c, PL_YUV_BT601, PL_YUV_LIMITED);
    pl_yuyv_to_rgb8(yuyv, 8, 3, 1, &c, rgb, 9);
    const uint8_t want[9] = {255, 255, 255, 0, 0, 0, 254, 0, 0};
    CHECK(memcmp(rgb, want, 9) == 0, "YUYV 3x1: got %d,%d,%d %d,%d,%d %d,%d,%d", rgb[0], rgb[1],
          rgb[2], rgb[3], rgb[4], rgb[5], rgb[6], rgb[7], rgb[8]);
    /* 3x3 NV12 full range, grey chroma: RGB = Y */
    uint8_t nv[4 * 3 + 4 * 2];
    for (int i = 0; i < 12; i++)
        nv[i] = (uint8_t)(i * 20);
    memset(nv + 12, 128, 8);
    uint8_t out[27];
    pl_yuv_coeffs_init(&c, PL_YUV_BT601, PL_YUV_FULL);
    pl_nv12_to_rgb8(nv, 4, nv + 12, 4, 3, 3, &c, out, 9);
    int bad = 0;
    for (int y = 0; y < 3; y++)
        for (int x = 0; x < 3; x++)
            for (int k = 0; k < 3; k++)
                if (out[y * 9 + x * 3 + k] != nv[y * 4 + x]) bad++;
    CHECK(bad == 0, "NV12 3x3 grey: %d wrong", bad);
}

static void test_rgb24_and_sizes(void)
{
    uint8_t src[2 * 8], dst[2 * 6];
    for (int i = 0; i < 16; i++)
        src[i] = (uint8_t)i;
    pl_rgb24_to_rgb8(src, 8, 2, 2, dst, 6);
    const uint8_t want[12] = {0, 1, 2, 3, 4, 5, 8, 9, 10, 11, 12, 13};
    CHECK(memcmp(dst, want, 12) == 0, "RGB24 copy with stride");
    size_t n;
    CHECK(pl_pixfmt_min_bytes(PL_PIX_YUYV, 641, 480, 1280, &n) == PL_E_FORMAT,
          "YUYV 641 wide needs 1284 bytes a row, 1280 accepted");
    CHECK(pl_pixfmt_min_bytes(PL_PIX_RGB24, 640, 480, 1919, &n) == PL_E_FORMAT, "RGB24 stride");
    CHECK(pl_pixfmt_min_bytes(PL_PIX_NV12, 0, 480, 640, &n) == PL_E_FORMAT, "zero width");
    CHECK(pl_pixfmt_min_bytes(PL_PIX_NV12, 640, 480, SIZE_MAX / 2, &n) == PL_E_NOMEM,
          "overflow not caught");
    CHECK(pl_pixfmt_min_bytes(PL_PIX_NV12, 640, 480, 640, &n) == PL_OK && n == 640 * 720,
          "NV12 640x480: %zu", n);
}

int main(void)
{
    test_anchors();
    test_known_frame();
    const int sizes[][2] = {{1, 1}, {2, 2}, {3, 5}, {7, 3}, {640, 480}, {33, 17}};
    for (size_t i = 0; i < sizeof sizes / sizeof sizes[0]; i++)
        for (size_t pad = 0; pad < 9; pad += 8) {
            test_yuyv(sizes[i][0], sizes[i][1], pad);
            test_nv12(sizes[i][0], sizes[i][1], pad);
        }
    test_rgb24_and_sizes();
    test_all_triples();
    if (failures) {
        printf("%d failure(s)\n", failures);
        return 1;
    }
    printf("pixfmt: all checks passed\n");
    return 0;
}
