/* Image buffers: checked sizes, one allocation per image, reuse for per-frame buffers. */
#include "core/image.h"

#include <stdlib.h>
#include <string.h>

#include "core/util.h"

int pl_image_check_size(const char *what, long long width, long long height)
{
    if (width < 1 || height < 1 || width > PL_IMAGE_MAX_SIDE || height > PL_IMAGE_MAX_SIDE)
        return pl_error(PL_E_FORMAT, "%s: image size %lldx%lld out of range (1..%d per side)", what,
                        width, height, PL_IMAGE_MAX_SIDE);
    if ((unsigned long long)width * (unsigned long long)height > PL_IMAGE_MAX_PIXELS)
        return pl_error(PL_E_FORMAT, "%s: image size %lldx%lld has more than %u pixels", what,
                        width, height, PL_IMAGE_MAX_PIXELS);
    return PL_OK;
}

static _Atomic long long read_limit = PL_IMAGE_DEFAULT_MAX_PIXELS;
static const char *_Atomic read_limit_how;

int pl_image_set_max_pixels(long long max_pixels, const char *how_to_raise)
{
    if (max_pixels < 1 || max_pixels > (long long)PL_IMAGE_MAX_PIXELS)
        return pl_error(PL_E_ARG, "read limit %lld pixels outside 1..%u", max_pixels,
                        PL_IMAGE_MAX_PIXELS);
    read_limit = max_pixels;
    read_limit_how = how_to_raise;
    return PL_OK;
}

long long pl_image_max_pixels(void)
{
    return read_limit;
}

int pl_image_check_read_size(const char *what, long long width, long long height)
{
    int rc = pl_image_check_size(what, width, height);
    if (rc < 0) return rc;
    const long long limit = read_limit;
    if (width * height <= limit) return PL_OK;
    const char *how = read_limit_how;
    if (how)
        return pl_error(PL_E_FORMAT,
                        "%s: image size %lldx%lld (%lld pixels) is over the limit of %lld pixels; "
                        "%s N raises it (up to %u)",
                        what, width, height, width * height, limit, how, PL_IMAGE_MAX_PIXELS);
    return pl_error(PL_E_FORMAT,
                    "%s: image size %lldx%lld (%lld pixels) is over the limit of %lld pixels", what,
                    width, height, width * height, limit);
}

static int image_bytes(int width, int height, size_t channel_bytes, size_t *bytes)
{
    if (pl_image_check_size("image", width, height) < 0) return PL_E_ARG;
    size_t n;
    if (!pl_mul_size((size_t)width, (size_t)height, &n) || !pl_mul_size(n, 3, &n) ||
        !pl_mul_size(n, channel_bytes, &n))
        return pl_error(PL_E_NOMEM, "image %dx%d: size overflows", width, height);
    *bytes = n;
    return PL_OK;
}

int pl_image_u8_alloc(pl_image_u8 *img, int width, int height)
{
    if (!img) return pl_error(PL_E_ARG, "pl_image_u8_alloc: img is NULL");
    memset(img, 0, sizeof *img);
    size_t bytes;
    int rc = image_bytes(width, height, 1, &bytes);
    if (rc < 0) return rc;
    uint8_t *p = malloc(bytes);
    if (!p)
        return pl_error(PL_E_NOMEM, "image %dx%d: cannot allocate %zu bytes", width, height, bytes);
    img->width = width;
    img->height = height;
    img->stride = (size_t)width * 3;
    img->data = p;
    return PL_OK;
}

void pl_image_u8_free(pl_image_u8 *img)
{
    if (!img) return;
    free(img->data);
    memset(img, 0, sizeof *img);
}

int pl_image_f32_alloc(pl_image_f32 *img, int width, int height)
{
    if (!img) return pl_error(PL_E_ARG, "pl_image_f32_alloc: img is NULL");
    memset(img, 0, sizeof *img);
    size_t bytes;
    int rc = image_bytes(width, height, sizeof(float), &bytes);
    if (rc < 0) return rc;
    float *p = malloc(bytes);
    if (!p)
        return pl_error(PL_E_NOMEM, "image %dx%d: cannot allocate %zu bytes", width, height, bytes);
    img->width = width;
    img->height = height;
    img->data = p;
    return PL_OK;
}

void pl_image_f32_free(pl_image_f32 *img)
{
    if (!img) return;
    free(img->data);
    memset(img, 0, sizeof *img);
}

int pl_image_u8_reserve(pl_image_u8 *img, size_t *capacity, int width, int height)
{
    if (!img || !capacity) return pl_error(PL_E_ARG, "pl_image_u8_reserve: NULL argument");
    size_t bytes;
    int rc = image_bytes(width, height, 1, &bytes);
    if (rc < 0) return rc;
    if (!img->data || *capacity < bytes) {
        uint8_t *p = realloc(img->data, bytes);
        if (!p)
            return pl_error(PL_E_NOMEM, "image %dx%d: cannot allocate %zu bytes", width, height,
                            bytes);
        img->data = p;
        *capacity = bytes;
    }
    img->width = width;
    img->height = height;
    img->stride = (size_t)width * 3;
    return PL_OK;
}
