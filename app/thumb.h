/* `parlight estimate --thumb W`: a small JPEG of each frame, as a data: URL for the JSON line's
 * "thumb" field (docs/OUTPUT.md), which the live viewer shows (docs/VIEWER.md). */
#ifndef PL_APP_THUMB_H
#define PL_APP_THUMB_H

#include <stddef.h>

#include "core/image.h"

#define APP_THUMB_MIN_WIDTH 16
#define APP_THUMB_MAX_WIDTH 320
#define APP_THUMB_QUALITY 70

/* Buffers kept from frame to frame (the small image, the URL); zero it before the first use. */
typedef struct app_thumb {
    pl_image_u8 small;
    size_t small_cap;
    char *url;
    size_t url_cap;
} app_thumb;

/* The frame box-filtered to `width` pixels wide (height in proportion, at least 1; never wider
 * than the frame), JPEG quality APP_THUMB_QUALITY, base64: *url = "data:image/jpeg;base64,...",
 * valid until the next call. Negative status with pl_last_error() on failure. */
int app_thumb_make(app_thumb *t, const pl_image_u8 *frame, int width, const char **url);

void app_thumb_free(app_thumb *t);

#endif
