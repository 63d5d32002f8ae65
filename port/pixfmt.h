/* Camera pixel formats to 8-bit RGB (the layout of pl_image_u8: interleaved R,G,B).
 *
 * Packed/planar layouts, as V4L2 defines them (single-planar API):
 *  - YUYV (V4L2_PIX_FMT_YUYV, "YUV 4:2:2"): per row, macropixels of 4 bytes Y0 U Y1 V covering
 *    two pixels that share U and V. A row holds ceil(w/2) macropixels; with an odd width the last
 *    macropixel's Y1 is ignored. Row stride >= 4 * ceil(w/2) bytes.
 *  - NV12 (V4L2_PIX_FMT_NV12, "Y/CbCr 4:2:0"): a Y plane (h rows of w bytes, `y_stride` apart)
 *    then a CbCr plane of ceil(h/2) rows, each ceil(w/2) pairs U V, `uv_stride` apart; a chroma
 *    pair covers a 2x2 block of pixels (the last column/row alone when w/h is odd). In V4L2's
 *    single-planar NV12 the CbCr plane starts at y_stride * h and uv_stride == y_stride.
 *  - RGB24 (V4L2_PIX_FMT_RGB24): R,G,B bytes per pixel, row stride >= 3w: copied as is.
 * Chroma is not interpolated: every pixel takes the U,V of the macropixel / 2x2 block it is in
 * (nearest, no filter). The network area-filters the frame down to 256x192 anyway.
 *
 * YCbCr -> RGB (ITU-R BT.601 or BT.709 matrix, Kr/Kb = 0.299/0.114 or 0.2126/0.0722):
 *   limited ("video") range: Y' = (Y - 16) / 219, Cb' = (U - 128) / 224, Cr' = (V - 128) / 224
 *   full ("JPEG") range:      Y' = Y / 255,        Cb' = (U - 128) / 255, Cr' = (V - 128) / 255
 *   R = Y' + 2(1-Kr) Cr',  B = Y' + 2(1-Kb) Cb',  G = Y' - (2Kb(1-Kb) Cb' + 2Kr(1-Kr) Cr') / Kg
 * scaled by 255, rounded to nearest and clamped to 0..255 (limited-range values outside 16..235
 * / 16..240 therefore clip). Fixed point: Q16 coefficients, one rounding per channel; the result
 * is within 1 of the exact formula (tests/test_pixfmt.c checks every Y,U,V triple). The RGB is
 * the camera's gamma-encoded R'G'B', which is what the network was trained on (sRGB-ish LDR).
 *
 * These functions trust their arguments (sizes validated by pl_pixfmt_min_bytes where a frame
 * enters); they never allocate. */
#ifndef PL_PORT_PIXFMT_H
#define PL_PORT_PIXFMT_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef enum pl_pixfmt { PL_PIX_YUYV = 1, PL_PIX_NV12, PL_PIX_RGB24 } pl_pixfmt;

typedef enum pl_yuv_matrix { PL_YUV_BT601 = 0, PL_YUV_BT709 = 1 } pl_yuv_matrix;
typedef enum pl_yuv_range { PL_YUV_LIMITED = 0, PL_YUV_FULL = 1 } pl_yuv_range;

/* Precomputed Q16 coefficients of one (matrix, range) pair; fill with pl_yuv_coeffs_init. */
typedef struct pl_yuv_coeffs {
    int32_t y_off;              /* 16 (limited) or 0 (full) */
    int32_t y_mul;              /* 255/219 or 1, Q16 */
    int32_t r_v, g_u, g_v, b_u; /* chroma terms, Q16, applied to (U-128), (V-128) */
} pl_yuv_coeffs;

void pl_yuv_coeffs_init(pl_yuv_coeffs *c, pl_yuv_matrix matrix, pl_yuv_range range);

/* One pixel (for tests and single values): Y,U,V bytes to R,G,B bytes. */
void pl_yuv_to_rgb_pixel(const pl_yuv_coeffs *c, int y, int u, int v, uint8_t rgb[3]);

/* Smallest byte count a frame of this format needs with the given row stride (for NV12: the
 * single-planar layout, CbCr at stride*h with the same stride); checks that stride is at least
 * the row length. PL_OK with *bytes, else PL_E_FORMAT (stride too small, size out of range) or
 * PL_E_NOMEM (overflow); messages name the format and sizes. */
int pl_pixfmt_min_bytes(pl_pixfmt fmt, int w, int h, size_t stride, size_t *bytes);

/* Short name: "YUYV", "NV12", "RGB24". */
const char *pl_pixfmt_name(pl_pixfmt fmt);

/* Conversions into dst (w x h RGB, rows dst_stride >= 3w bytes apart; bytes past 3w in each row
 * are left untouched). w, h >= 1. */
void pl_yuyv_to_rgb8(const uint8_t *src, size_t src_stride, int w, int h, const pl_yuv_coeffs *c,
                     uint8_t *dst, size_t dst_stride);
void pl_nv12_to_rgb8(const uint8_t *y_plane, size_t y_stride, const uint8_t *uv_plane,
                     size_t uv_stride, int w, int h, const pl_yuv_coeffs *c, uint8_t *dst,
                     size_t dst_stride);
void pl_rgb24_to_rgb8(const uint8_t *src, size_t src_stride, int w, int h, uint8_t *dst,
                      size_t dst_stride);

#ifdef __cplusplus
}
#endif
#endif
