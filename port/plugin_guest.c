/* Linked into every plugin (port/plugin.h), never into the library: the core functions the
 * plugins' sources call, defined as calls through the table the loader hands to
 * pl_plugin_bind. A plugin therefore has no undefined pl_* symbol to resolve from whatever
 * loaded it (a static executable, libparlight.so). */
#include <stdarg.h>
#include <stdio.h>

#include "core/status.h"
#include "port/image_mem.h"
#include "port/plugin.h"

static const pl_plugin_host *host;

int pl_plugin_bind(const pl_plugin_host *h);
int pl_plugin_bind(const pl_plugin_host *h)
{
    if (!h || h->abi != PL_PLUGIN_ABI) return PL_E_UNSUPPORTED;
    host = h;
    return PL_OK;
}

int pl_error(int status, const char *fmt, ...)
{
    char msg[512];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    return host->error(status, "%s", msg);
}

int pl_error_prefix(int status, const char *fmt, ...)
{
    char msg[512];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    return host->error_prefix(status, "%s", msg);
}

long long pl_image_max_pixels(void)
{
    return host->image_max_pixels();
}

int pl_image_check_read_size(const char *what, long long width, long long height)
{
    return host->image_check_read_size(what, width, height);
}

int pl_image_u8_reserve(pl_image_u8 *img, size_t *capacity, int width, int height)
{
    return host->image_u8_reserve(img, capacity, width, height);
}

int pl_image_decode_jpeg_rgb8_reuse(const uint8_t *data, size_t n, const char *what,
                                    pl_image_u8 *img, size_t *capacity)
{
    return host->image_decode_jpeg_rgb8_reuse(data, n, what, img, capacity);
}

void pl_yuv_coeffs_init(pl_yuv_coeffs *c, pl_yuv_matrix matrix, pl_yuv_range range)
{
    host->yuv_coeffs_init(c, matrix, range);
}

int pl_pixfmt_min_bytes(pl_pixfmt fmt, int w, int h, size_t stride, size_t *bytes)
{
    return host->pixfmt_min_bytes(fmt, w, h, stride, bytes);
}

const char *pl_pixfmt_name(pl_pixfmt fmt)
{
    return host->pixfmt_name(fmt);
}

void pl_yuyv_to_rgb8(const uint8_t *src, size_t src_stride, int w, int h, const pl_yuv_coeffs *c,
                     uint8_t *dst, size_t dst_stride)
{
    host->yuyv_to_rgb8(src, src_stride, w, h, c, dst, dst_stride);
}

void pl_nv12_to_rgb8(const uint8_t *y_plane, size_t y_stride, const uint8_t *uv_plane,
                     size_t uv_stride, int w, int h, const pl_yuv_coeffs *c, uint8_t *dst,
                     size_t dst_stride)
{
    host->nv12_to_rgb8(y_plane, y_stride, uv_plane, uv_stride, w, h, c, dst, dst_stride);
}

void pl_rgb24_to_rgb8(const uint8_t *src, size_t src_stride, int w, int h, uint8_t *dst,
                      size_t dst_stride)
{
    host->rgb24_to_rgb8(src, src_stride, w, h, dst, dst_stride);
}
