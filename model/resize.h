/* Preprocessing geometry: the centre crop to the model's aspect and the area-filter resize to its
 * input, from 8-bit RGB (core/image.h) to float CHW planes (model/resize.c). */
#ifndef PL_MODEL_RESIZE_H
#define PL_MODEL_RESIZE_H

#include <stddef.h>
#include <stdint.h>

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

/* That call's arguments, for splitting it over core/threads.h's pl_pool_for:
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

#endif
