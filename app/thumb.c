#include "app/thumb.h"

#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "core/util.h"
#include "port/image_codec.h"

/* Area average of the source rectangle under each output pixel (integer bounds, every source
 * pixel counted once). */
static void box_downscale(const pl_image_u8 *src, pl_image_u8 *dst)
{
    for (int y = 0; y < dst->height; y++) {
        int y0 = (int)((int64_t)y * src->height / dst->height);
        int y1 = (int)((int64_t)(y + 1) * src->height / dst->height);
        if (y1 <= y0) y1 = y0 + 1;
        for (int x = 0; x < dst->width; x++) {
            int x0 = (int)((int64_t)x * src->width / dst->width);
            int x1 = (int)((int64_t)(x + 1) * src->width / dst->width);
            if (x1 <= x0) x1 = x0 + 1;
            uint64_t acc[3] = {0, 0, 0};
            for (int yy = y0; yy < y1; yy++) {
                const uint8_t *p = src->data + (size_t)yy * src->stride + (size_t)x0 * 3;
                for (int xx = x0; xx < x1; xx++, p += 3) {
                    acc[0] += p[0];
                    acc[1] += p[1];
                    acc[2] += p[2];
                }
            }
            const uint64_t n = (uint64_t)(y1 - y0) * (uint64_t)(x1 - x0);
            uint8_t *o = dst->data + (size_t)y * dst->stride + (size_t)x * 3;
            for (int k = 0; k < 3; k++)
                o[k] = (uint8_t)((acc[k] + n / 2) / n);
        }
    }
}

static const char PREFIX[] = "data:image/jpeg;base64,";

int app_thumb_make(app_thumb *t, const pl_image_u8 *frame, int width, const char **url)
{
    *url = NULL;
    if (width < APP_THUMB_MIN_WIDTH || width > APP_THUMB_MAX_WIDTH)
        return pl_error(PL_E_ARG, "thumbnail width %d: expected %d..%d", width, APP_THUMB_MIN_WIDTH,
                        APP_THUMB_MAX_WIDTH);
    int w = width < frame->width ? width : frame->width;
    int h = (int)(((int64_t)frame->height * w + frame->width / 2) / frame->width);
    if (h < 1) h = 1;
    int rc = pl_image_u8_reserve(&t->small, &t->small_cap, w, h);
    if (rc < 0) return rc;
    box_downscale(frame, &t->small);
    unsigned char *jpg;
    size_t n;
    if ((rc = pl_jpeg_encode_rgb8(&t->small, APP_THUMB_QUALITY, &jpg, &n)) < 0) return rc;
    const size_t need = sizeof PREFIX + 4 * ((n + 2) / 3);
    if (need > t->url_cap) {
        char *u = realloc(t->url, need);
        if (!u) {
            free(jpg);
            return pl_error(PL_E_NOMEM, "thumbnail: out of memory");
        }
        t->url = u;
        t->url_cap = need;
    }
    static const char b64[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    char *o = t->url + sizeof PREFIX - 1;
    memcpy(t->url, PREFIX, sizeof PREFIX - 1);
    for (size_t i = 0; i < n; i += 3) {
        uint32_t v = (uint32_t)jpg[i] << 16;
        if (i + 1 < n) v |= (uint32_t)jpg[i + 1] << 8;
        if (i + 2 < n) v |= jpg[i + 2];
        *o++ = b64[v >> 18];
        *o++ = b64[(v >> 12) & 63];
        *o++ = i + 1 < n ? b64[(v >> 6) & 63] : '=';
        *o++ = i + 2 < n ? b64[v & 63] : '=';
    }
    *o = '\0';
    free(jpg);
    *url = t->url;
    return 0;
}

void app_thumb_free(app_thumb *t)
{
    pl_image_u8_free(&t->small);
    free(t->url);
    memset(t, 0, sizeof *t);
}
