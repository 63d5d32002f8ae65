/* YUYV / NV12 / RGB24 to RGB8: the formulas and layouts are in port/pixfmt.h. */
#include "port/pixfmt.h"

#include <math.h>
#include <string.h>

#include "core/image.h"
#include "core/util.h"

void pl_yuv_coeffs_init(pl_yuv_coeffs *c, pl_yuv_matrix matrix, pl_yuv_range range)
{
    const double kr = matrix == PL_YUV_BT709 ? 0.2126 : 0.299;
    const double kb = matrix == PL_YUV_BT709 ? 0.0722 : 0.114;
    const double kg = 1.0 - kr - kb;
    const double ys = range == PL_YUV_FULL ? 1.0 : 255.0 / 219.0;
    const double cs = range == PL_YUV_FULL ? 1.0 : 255.0 / 224.0;
    const double q = 65536.0;
    c->y_off = range == PL_YUV_FULL ? 0 : 16;
    c->y_mul = (int32_t)lround(q * ys);
    c->r_v = (int32_t)lround(q * cs * 2.0 * (1.0 - kr));
    c->b_u = (int32_t)lround(q * cs * 2.0 * (1.0 - kb));
    c->g_u = (int32_t)lround(q * cs * 2.0 * kb * (1.0 - kb) / kg);
    c->g_v = (int32_t)lround(q * cs * 2.0 * kr * (1.0 - kr) / kg);
}

static inline uint8_t clamp_q16(int32_t t)
{
    /* t includes the rounding half; negative before the shift would be implementation-defined. */
    if (t <= 0) return 0;
    t >>= 16;
    return (uint8_t)(t > 255 ? 255 : t);
}

/* Writes R,G,B for luma y given the chroma terms already multiplied out. */
static inline void put_rgb(uint8_t *d, int32_t yv, int32_t rc, int32_t gc, int32_t bc)
{
    d[0] = clamp_q16(yv + rc);
    d[1] = clamp_q16(yv - gc);
    d[2] = clamp_q16(yv + bc);
}

void pl_yuv_to_rgb_pixel(const pl_yuv_coeffs *c, int y, int u, int v, uint8_t rgb[3])
{
    const int32_t yv = c->y_mul * (y - c->y_off) + 32768;
    put_rgb(rgb, yv, c->r_v * (v - 128), c->g_u * (u - 128) + c->g_v * (v - 128),
            c->b_u * (u - 128));
}

const char *pl_pixfmt_name(pl_pixfmt fmt)
{
    switch (fmt) {
    case PL_PIX_YUYV:
        return "YUYV";
    case PL_PIX_NV12:
        return "NV12";
    case PL_PIX_RGB24:
        return "RGB24";
    }
    return "unknown";
}

int pl_pixfmt_min_bytes(pl_pixfmt fmt, int w, int h, size_t stride, size_t *bytes)
{
    if (pl_image_check_size(pl_pixfmt_name(fmt), w, h) < 0) return PL_E_FORMAT;
    const size_t half_w = ((size_t)w + 1) / 2, half_h = ((size_t)h + 1) / 2;
    size_t row, rows;
    switch (fmt) {
    case PL_PIX_YUYV:
        row = 4 * half_w;
        rows = (size_t)h;
        break;
    case PL_PIX_NV12:
        row = 2 * half_w;
        rows = (size_t)h + half_h;
        break;
    case PL_PIX_RGB24:
        row = 3 * (size_t)w;
        rows = (size_t)h;
        break;
    default:
        return pl_error(PL_E_FORMAT, "pixel format %d unknown", (int)fmt);
    }
    if (stride < row)
        return pl_error(PL_E_FORMAT, "%s %dx%d: row stride %zu bytes < the %zu a row needs",
                        pl_pixfmt_name(fmt), w, h, stride, row);
    size_t n;
    if (!pl_mul_size(stride, rows, &n))
        return pl_error(PL_E_NOMEM, "%s %dx%d stride %zu: size overflows", pl_pixfmt_name(fmt), w,
                        h, stride);
    *bytes = n;
    return PL_OK;
}

void pl_yuyv_to_rgb8(const uint8_t *src, size_t src_stride, int w, int h, const pl_yuv_coeffs *c,
                     uint8_t *dst, size_t dst_stride)
{
    for (int row = 0; row < h; row++) {
        const uint8_t *s = src + (size_t)row * src_stride;
        uint8_t *d = dst + (size_t)row * dst_stride;
        for (int x = 0; x < w; x += 2, s += 4, d += 6) {
            const int u = s[1] - 128, v = s[3] - 128;
            const int32_t rc = c->r_v * v, gc = c->g_u * u + c->g_v * v, bc = c->b_u * u;
            put_rgb(d, c->y_mul * (s[0] - c->y_off) + 32768, rc, gc, bc);
            if (x + 1 < w) put_rgb(d + 3, c->y_mul * (s[2] - c->y_off) + 32768, rc, gc, bc);
        }
    }
}

void pl_nv12_to_rgb8(const uint8_t *y_plane, size_t y_stride, const uint8_t *uv_plane,
                     size_t uv_stride, int w, int h, const pl_yuv_coeffs *c, uint8_t *dst,
                     size_t dst_stride)
{
    for (int row = 0; row < h; row++) {
        const uint8_t *yp = y_plane + (size_t)row * y_stride;
        const uint8_t *uv = uv_plane + (size_t)(row / 2) * uv_stride;
        uint8_t *d = dst + (size_t)row * dst_stride;
        for (int x = 0; x < w; x += 2, uv += 2, d += 6) {
            const int u = uv[0] - 128, v = uv[1] - 128;
            const int32_t rc = c->r_v * v, gc = c->g_u * u + c->g_v * v, bc = c->b_u * u;
            put_rgb(d, c->y_mul * (yp[x] - c->y_off) + 32768, rc, gc, bc);
            if (x + 1 < w) put_rgb(d + 3, c->y_mul * (yp[x + 1] - c->y_off) + 32768, rc, gc, bc);
        }
    }
}

void pl_rgb24_to_rgb8(const uint8_t *src, size_t src_stride, int w, int h, uint8_t *dst,
                      size_t dst_stride)
{
    for (int row = 0; row < h; row++)
        memcpy(dst + (size_t)row * dst_stride, src + (size_t)row * src_stride, (size_t)w * 3);
}
