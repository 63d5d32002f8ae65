/* Centre crop and the area/bilinear resize to the network's CHW float input.
 *
 * Each axis is described by integer taps: output i reads source pixels first..last, with weight
 * w_first on `first`, w_last on `last` and w_mid on every pixel between; the weights of one
 * output sum to the axis denominator D. Area (src >= dst): source pixel j spans [j*dst, (j+1)*dst)
 * and output i spans [i*src, (i+1)*src) in units of 1/dst source pixel, weights are the overlaps,
 * D = src. Bilinear (src < dst): the sample sits at ((2i+1)*src - dst) / (2*dst) source pixels
 * from pixel 0's centre, weights in units of 1/(2*dst), D = 2*dst, clamped at the edges. */
#include "model/resize.h"

#include <assert.h>
#include <stdbool.h>

#include "core/image.h"
#include "core/util.h"

void pl_crop_to_aspect(int w, int h, int aw, int ah, int *x0, int *y0, int *cw, int *ch)
{
    int ow = w, oh = h;
    if (w >= 1 && h >= 1 && aw >= 1 && ah >= 1) {
        if ((int64_t)w * ah > (int64_t)h * aw) /* too wide: keep the height */
            ow = (int)((int64_t)h * aw / ah);
        else
            oh = (int)((int64_t)w * ah / aw);
        if (ow < 1) ow = 1;
        if (oh < 1) oh = 1;
    }
    *cw = ow;
    *ch = oh;
    *x0 = w > ow ? (w - ow) / 2 : 0;
    *y0 = h > oh ? (h - oh) / 2 : 0;
}

int pl_resize_check(int src_w, int src_h, size_t stride, int x0, int y0, int cw, int ch, int dst_w,
                    int dst_h)
{
    if (src_w < 1 || src_h < 1 || src_w > PL_IMAGE_MAX_SIDE || src_h > PL_IMAGE_MAX_SIDE)
        return pl_error(PL_E_ARG, "resize: source size %dx%d out of range (1..%d)", src_w, src_h,
                        PL_IMAGE_MAX_SIDE);
    if (stride < (size_t)src_w * 3)
        return pl_error(PL_E_ARG, "resize: stride %zu < 3 * width %d", stride, src_w);
    if (x0 < 0 || y0 < 0 || cw < 1 || ch < 1 || (int64_t)x0 + cw > src_w ||
        (int64_t)y0 + ch > src_h)
        return pl_error(PL_E_ARG, "resize: window %dx%d at (%d,%d) not inside the %dx%d source", cw,
                        ch, x0, y0, src_w, src_h);
    if (dst_w < 1 || dst_h < 1 || dst_w > PL_IMAGE_MAX_SIDE || dst_h > PL_IMAGE_MAX_SIDE)
        return pl_error(PL_E_ARG, "resize: output size %dx%d out of range (1..%d)", dst_w, dst_h,
                        PL_IMAGE_MAX_SIDE);
    return PL_OK;
}

typedef struct tap {
    int first, last;            /* source index range, inclusive, relative to the window */
    int w_first, w_mid, w_last; /* weights; when first == last only w_first counts */
} tap;

/* Denominator of an axis: every output's weights sum to it. */
static int64_t axis_denominator(int src, int dst)
{
    return src >= dst ? src : 2 * (int64_t)dst;
}

static tap axis_tap(int src, int dst, int i)
{
    tap t = {0, 0, 0, 0, 0};
    if (src >= dst) {
        int64_t lo = (int64_t)i * src, hi = lo + src;
        t.first = (int)(lo / dst);
        t.last = (int)((hi - 1) / dst);
        if (t.first == t.last) {
            t.w_first = src;
        } else {
            t.w_first = (int)((int64_t)(t.first + 1) * dst - lo);
            t.w_mid = dst;
            t.w_last = (int)(hi - (int64_t)t.last * dst);
        }
    } else {
        int64_t d = 2 * (int64_t)dst, num = (int64_t)(2 * i + 1) * src - dst;
        int64_t j = num <= 0 ? 0 : num / d, f = num <= 0 ? 0 : num % d;
        if (j >= src - 1) {
            j = src - 1;
            f = 0;
        }
        t.first = (int)j;
        if (f == 0) {
            t.last = (int)j;
            t.w_first = (int)d;
        } else {
            t.last = (int)j + 1;
            t.w_first = (int)(d - f);
            t.w_last = (int)f;
        }
    }
    return t;
}

enum { CHUNK = 256 };

void pl_resize_area_rgb8_to_chw(const uint8_t *src, size_t stride, int x0, int y0, int cw, int ch,
                                float *dst, int dst_w, int dst_h)
{
    pl_resize_area_rgb8_to_chw_rows(src, stride, x0, y0, cw, ch, dst, dst_w, dst_h, 0, dst_h);
}

void pl_resize_area_rgb8_to_chw_rows(const uint8_t *src, size_t stride, int x0, int y0, int cw,
                                     int ch, float *dst, int dst_w, int dst_h, int row_begin,
                                     int row_end)
{
    assert(src && dst);
    assert(0 <= row_begin && row_begin <= row_end && row_end <= dst_h);
    assert(x0 >= 0 && y0 >= 0 && cw >= 1 && ch >= 1 && dst_w >= 1 && dst_h >= 1);
    assert(cw <= PL_IMAGE_MAX_SIDE && ch <= PL_IMAGE_MAX_SIDE);
    assert(dst_w <= PL_IMAGE_MAX_SIDE && dst_h <= PL_IMAGE_MAX_SIDE);
    assert(stride >= 3 * ((size_t)x0 + (size_t)cw));

    /* Divide (not multiply by a reciprocal): correctly rounded, so exact multiples stay exact. */
    const double den = (double)axis_denominator(cw, dst_w) * (double)axis_denominator(ch, dst_h);
    const size_t plane = (size_t)dst_w * (size_t)dst_h;
    const uint8_t *base = src + (size_t)y0 * stride + 3 * (size_t)x0;
    tap xt[CHUNK];
    int64_t acc[3 * CHUNK];

    for (int c0 = 0; c0 < dst_w; c0 += CHUNK) {
        const int n = dst_w - c0 < CHUNK ? dst_w - c0 : CHUNK;
        for (int i = 0; i < n; i++)
            xt[i] = axis_tap(cw, dst_w, c0 + i);
        for (int oy = row_begin; oy < row_end; oy++) {
            const tap yt = axis_tap(ch, dst_h, oy);
            for (int i = 0; i < 3 * n; i++)
                acc[i] = 0;
            for (int sy = yt.first; sy <= yt.last; sy++) {
                const int64_t wy = sy == yt.first  ? yt.w_first
                                   : sy == yt.last ? yt.w_last
                                                   : yt.w_mid;
                const uint8_t *row = base + (size_t)sy * stride;
                for (int i = 0; i < n; i++) {
                    const tap t = xt[i];
                    const uint8_t *p = row + 3 * (size_t)t.first;
                    int32_t r = t.w_first * p[0], g = t.w_first * p[1], b = t.w_first * p[2];
                    if (t.last > t.first) {
                        int32_t mr = 0, mg = 0, mb = 0;
                        for (int sx = t.first + 1; sx < t.last; sx++) {
                            p += 3;
                            mr += p[0];
                            mg += p[1];
                            mb += p[2];
                        }
                        p += 3;
                        r += t.w_mid * mr + t.w_last * p[0];
                        g += t.w_mid * mg + t.w_last * p[1];
                        b += t.w_mid * mb + t.w_last * p[2];
                    }
                    acc[3 * i + 0] += wy * r;
                    acc[3 * i + 1] += wy * g;
                    acc[3 * i + 2] += wy * b;
                }
            }
            float *o = dst + (size_t)oy * (size_t)dst_w + (size_t)c0;
            for (int i = 0; i < n; i++) {
                o[i] = (float)((double)acc[3 * i + 0] / den);
                o[plane + i] = (float)((double)acc[3 * i + 1] / den);
                o[2 * plane + i] = (float)((double)acc[3 * i + 2] / den);
            }
        }
    }
}

void pl_resize_job_rows(void *job, int row_begin, int row_end)
{
    const pl_resize_job *j = job;
    pl_resize_area_rgb8_to_chw_rows(j->src, j->stride, j->x0, j->y0, j->cw, j->ch, j->dst, j->dst_w,
                                    j->dst_h, row_begin, row_end);
}
