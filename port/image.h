/* Images as they travel inside parlight.
 *
 * pl_image_u8: 8-bit RGB, interleaved R,G,B, rows `stride` bytes apart (stride >= 3*width).
 * pl_image_f32: linear float RGB, interleaved, rows packed (3*width floats per row); used for
 * HDR panoramas, environment maps and renders.
 * Both own their pixels when created by the functions here; free with the matching _free. */
#ifndef PL_PORT_IMAGE_H
#define PL_PORT_IMAGE_H

#include <stddef.h>
#include <stdint.h>

typedef struct pl_image_u8 {
    int width, height;
    size_t stride;
    uint8_t *data;
} pl_image_u8;

typedef struct pl_image_f32 {
    int width, height;
    float *data;
} pl_image_f32;

/* Largest image any reader accepts, per side and in pixels: bigger declared sizes are rejected
 * before any allocation (a guard against hostile headers). */
#define PL_IMAGE_MAX_SIDE 32768
#define PL_IMAGE_MAX_PIXELS (256u * 1024u * 1024u)

int pl_image_u8_alloc(pl_image_u8 *img, int width, int height);
void pl_image_u8_free(pl_image_u8 *img);
int pl_image_f32_alloc(pl_image_f32 *img, int width, int height);
void pl_image_f32_free(pl_image_f32 *img);

/* ---- files through OpenCV (port/image_io.cpp) ---------------------------------------------- */

/* Reads a still image (JPEG, PNG, BMP, TIFF, ...) as 8-bit RGB. Grayscale is expanded to RGB,
 * alpha is dropped (composited on nothing: the colour channels are kept), 16-bit is scaled to
 * 8-bit (v * 255 / 65535, rounded). Unreadable, corrupt or empty files give PL_E_IO/PL_E_FORMAT
 * with the path in the message. */
int pl_image_read_rgb8(const char *path, pl_image_u8 *out);
/* Writes 8-bit RGB to PNG (or any format OpenCV knows from the extension). */
int pl_image_write_rgb8(const char *path, const pl_image_u8 *img);

/* ---- geometry ------------------------------------------------------------------------------- */

/* Centre crop of a w x h image to the aspect aw:ah: the largest such window, centred (odd
 * remainders leave the extra column/row on the right/bottom). */
void pl_crop_to_aspect(int w, int h, int aw, int ah, int *x0, int *y0, int *cw, int *ch);

/* Area-filter resize of the window (x0, y0, cw, ch) of `src` to dst_w x dst_h, output as float
 * planes CHW (3 x dst_h x dst_w) with values in [0, 255]. Each output pixel is the exact
 * area-weighted mean of the source pixels it covers (OpenCV's INTER_AREA when shrinking); when
 * enlarging it falls back to bilinear interpolation with half-pixel centres. */
void pl_resize_area_rgb8_to_chw(const uint8_t *src, size_t stride, int x0, int y0, int cw, int ch,
                                float *dst, int dst_w, int dst_h);

#endif
