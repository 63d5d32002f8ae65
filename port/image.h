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

#ifdef __cplusplus
extern "C" {
#endif

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

/* Allocates width x height pixels (rows packed: stride = 3*width for u8). Sizes must be in
 * 1..PL_IMAGE_MAX_SIDE with width*height <= PL_IMAGE_MAX_PIXELS, else PL_E_ARG; PL_E_NOMEM when
 * the allocation fails. On failure *img is zeroed. Pixels are not initialised. */
int pl_image_u8_alloc(pl_image_u8 *img, int width, int height);
/* Frees the pixels and zeroes *img; NULL or an already-freed (zeroed) image is fine. */
void pl_image_u8_free(pl_image_u8 *img);
int pl_image_f32_alloc(pl_image_f32 *img, int width, int height);
void pl_image_f32_free(pl_image_f32 *img);

/* Reuses img's buffer for a width x height packed image when *capacity (bytes held by img->data)
 * is enough, else reallocates it (the old pixels are lost) and updates *capacity. For sources
 * that hand out one buffer per frame: no allocation once sizes settle. img and *capacity start
 * zeroed; free with pl_image_u8_free. Same size checks as pl_image_u8_alloc; on failure img
 * keeps its old buffer and capacity. */
int pl_image_u8_reserve(pl_image_u8 *img, size_t *capacity, int width, int height);

/* Checks a size against the limits above; PL_E_FORMAT naming `what` (a path) when out of range. */
int pl_image_check_size(const char *what, long long width, long long height);

/* ---- files through OpenCV (port/image_io.cpp) ---------------------------------------------- */

/* Reads a still image (JPEG, PNG, BMP, TIFF, WebP, PNM, ... whatever this OpenCV decodes; the
 * format is found from the file's content, not its name) as 8-bit RGB into a new image that the
 * caller frees with pl_image_u8_free.
 *  - Grayscale is expanded to RGB; alpha is dropped (the colour channels are kept as they are,
 *    not composited); 16-bit is scaled to 8-bit as (v * 255 + 32767) / 65535 (v*255/65535
 *    rounded to nearest); 8-bit JPEGs get their EXIF orientation applied.
 *  - Floating-point images (Radiance .hdr, float TIFF, EXR) are refused with PL_E_UNSUPPORTED:
 *    they are HDR and need the HDR path, not a silent tone map. Signed 16-bit also unsupported.
 *  - Guard against decompression bombs: for PNG, JPEG and BMP the declared size is read from the
 *    header and checked against PL_IMAGE_MAX_SIDE / PL_IMAGE_MAX_PIXELS BEFORE decoding; for
 *    other formats OpenCV's own limits apply (OPENCV_IO_MAX_IMAGE_PIXELS, default 2^30, read by
 *    OpenCV at load time) and the decoded size is checked afterwards. Files over 1 GiB are
 *    refused unread.
 *  - Checked before decoding, so that the decoders neither return half images nor print: PNG
 *    chunk lengths and CRCs up to IEND; JPEG markers up to the first scan and an end-of-image
 *    marker after it (libjpeg would pad a truncated file with grey); BMP compression and, when
 *    uncompressed, that all pixel rows are present. Damage inside a JPEG scan is still decoded
 *    (as libjpeg does) and libjpeg prints "Corrupt JPEG data ..." to stderr: not ours to stop.
 * Errors, each naming the path: PL_E_IO (missing, not a regular file, unreadable), PL_E_FORMAT
 * (zero bytes, not an image OpenCV recognises, corrupt or truncated data, too large),
 * PL_E_UNSUPPORTED (float/signed data, odd channel count). Never throws. */
int pl_image_read_rgb8(const char *path, pl_image_u8 *out);
/* Same, decoding into img's buffer (see pl_image_u8_reserve) instead of a new image. */
int pl_image_read_rgb8_reuse(const char *path, pl_image_u8 *img, size_t *capacity);
/* Writes 8-bit RGB to a file whose format OpenCV knows from the extension (.png, .jpg, .bmp,
 * .tif, .ppm, ...). An unknown or missing extension is PL_E_ARG and nothing is written. An
 * existing file is overwritten: deciding whether that is wanted is the caller's job. PL_E_IO
 * when the file cannot be written. */
int pl_image_write_rgb8(const char *path, const pl_image_u8 *img);

/* ---- geometry (port/resize.c) ------------------------------------------------------------- */

/* Centre crop of a w x h image to the aspect aw:ah: the largest such window, centred (odd
 * remainders leave the extra column/row on the right/bottom). The window's other side is
 * rounded down (floor(h*aw/ah) or floor(w*ah/aw)) and is at least 1. With w or h < 1 or
 * aw or ah < 1 the window is the whole image (0, 0, w, h). */
void pl_crop_to_aspect(int w, int h, int aw, int ah, int *x0, int *y0, int *cw, int *ch);

/* Area-filter resize of the window (x0, y0, cw, ch) of `src` to dst_w x dst_h, output as float
 * planes CHW (3 x dst_h x dst_w) with values in [0, 255]. Each output pixel is the exact
 * area-weighted mean of the source pixels it covers (OpenCV's INTER_AREA when shrinking); when
 * enlarging it falls back to bilinear interpolation with half-pixel centres.
 *
 * The choice is made per axis (shrink or same size: area; enlarge: bilinear, edge pixels
 * clamped), and both are separable, so a frame shrunk in x and enlarged in y is handled. All
 * weights are exact integers (area: overlaps in units of 1/dst source pixel; bilinear: in units
 * of 1/(2*dst)), sums are exact in int64, and each output is rounded once to float: an identity
 * resize (cw == dst_w, ch == dst_h) returns the source values exactly.
 *
 * No allocation: a fixed ~10 KiB of stack, whatever the sizes (output columns are processed in
 * chunks of 256). Cost is about (cw/dst_w + 1) * (ch/dst_h + 1) * dst_w * dst_h * 3 multiply-adds
 * (1920x1080 cropped to 1440x1080 -> 256x192: 1.6 ms here, printed by tests/test_resize).
 *
 * Preconditions (programmer errors, asserted; callers validate frames where they enter, e.g.
 * with pl_resize_check): src non-NULL, stride >= 3*(x0+cw), 0 <= x0, 0 <= y0, 1 <= cw, ch,
 * dst_w, dst_h <= PL_IMAGE_MAX_SIDE, dst holds 3*dst_w*dst_h floats and does not overlap src. */
void pl_resize_area_rgb8_to_chw(const uint8_t *src, size_t stride, int x0, int y0, int cw, int ch,
                                float *dst, int dst_w, int dst_h);
/* The same for output rows [row_begin, row_end) only, 0 <= row_begin <= row_end <= dst_h (the
 * other rows of dst are not touched): every output row is computed the same way whatever the
 * range, so a frame split over threads equals the whole call bit for bit. */
void pl_resize_area_rgb8_to_chw_rows(const uint8_t *src, size_t stride, int x0, int y0, int cw,
                                     int ch, float *dst, int dst_w, int dst_h, int row_begin,
                                     int row_end);

/* That call's arguments, for splitting it over port/threads.h's pl_pool_for:
 * pl_pool_for(pool, dst_h, pl_resize_job_rows, &job). */
typedef struct pl_resize_job {
    const uint8_t *src;
    size_t stride;
    int x0, y0, cw, ch;
    float *dst;
    int dst_w, dst_h;
} pl_resize_job;
void pl_resize_job_rows(void *job, int row_begin, int row_end);

/* Checks the arguments above for a source image of src_w x src_h (PL_E_ARG with a message). */
int pl_resize_check(int src_w, int src_h, size_t stride, int x0, int y0, int cw, int ch, int dst_w,
                    int dst_h);

#ifdef __cplusplus
}
#endif
#endif
