/* The public API's frame entry points (include/parlight.h): estimates from YUYV and NV12 camera
 * frames through the sources' conversion (port/pixfmt.h) into the model's RGB buffer
 * (model/model.h), and image files read as `parlight estimate --input` reads them
 * (port/image.h). */
#include <stdlib.h>
#include <string.h>

#include "core/status.h"
#include "core/util.h"
#include "model/model.h"
#include "port/image.h"
#include "port/pixfmt.h"

static int coeffs_of(pl_ycbcr enc, pl_yuv_coeffs *c)
{
    switch (enc) {
    case PL_YCBCR_BT601_LIMITED:
        pl_yuv_coeffs_init(c, PL_YUV_BT601, PL_YUV_LIMITED);
        return PL_OK;
    case PL_YCBCR_BT601_FULL:
        pl_yuv_coeffs_init(c, PL_YUV_BT601, PL_YUV_FULL);
        return PL_OK;
    case PL_YCBCR_BT709_LIMITED:
        pl_yuv_coeffs_init(c, PL_YUV_BT709, PL_YUV_LIMITED);
        return PL_OK;
    case PL_YCBCR_BT709_FULL:
        pl_yuv_coeffs_init(c, PL_YUV_BT709, PL_YUV_FULL);
        return PL_OK;
    }
    return pl_error(PL_E_ARG,
                    "YCbCr encoding %d: expected PL_YCBCR_BT601_LIMITED (0) .. "
                    "PL_YCBCR_BT709_FULL (3)",
                    (int)enc);
}

/* Checks a YUV frame's size and returns the model's RGB buffer for it (rows 3 x width). */
static int check_yuv(pl_model *m, const char *fmt, int width, int height, int even_height,
                     pl_ycbcr enc, pl_yuv_coeffs *c, uint8_t **rgb)
{
    if (width < 8 || height < 8 || width > PL_IMAGE_MAX_SIDE || height > PL_IMAGE_MAX_SIDE)
        return pl_error(PL_E_ARG, "%s frame %dx%d: each side must be in 8..%d", fmt, width, height,
                        PL_IMAGE_MAX_SIDE);
    if (width % 2 || (even_height && height % 2))
        return pl_error(PL_E_ARG, "%s frame %dx%d: %s must be even (chroma is shared by %s)", fmt,
                        width, height, even_height ? "width and height" : "the width",
                        even_height ? "2x2 pixels" : "pixel pairs");
    int rc = coeffs_of(enc, c);
    if (rc < 0) return rc;
    *rgb = pl_model_frame_rgb(m, (size_t)width * 3 * (size_t)height);
    return *rgb ? PL_OK : PL_E_NOMEM;
}

int pl_estimate_yuyv(pl_model *m, const uint8_t *yuyv, int width, int height, size_t stride,
                     pl_ycbcr enc, pl_lighting *out, pl_timing *timing)
{
    if (!m || !yuyv || !out) return pl_error(PL_E_ARG, "pl_estimate_yuyv: NULL argument");
    pl_yuv_coeffs c;
    uint8_t *rgb;
    int rc = check_yuv(m, "YUYV", width, height, 0, enc, &c, &rgb);
    if (rc < 0) return rc;
    if (stride < (size_t)width * 2)
        return pl_error(PL_E_ARG, "YUYV frame %dx%d: stride %zu smaller than 2 x width (%d)", width,
                        height, stride, width * 2);
    const int64_t t0 = pl_now_ns();
    pl_yuyv_to_rgb8(yuyv, stride, width, height, &c, rgb, (size_t)width * 3);
    const double convert_ms = (double)(pl_now_ns() - t0) / 1e6;
    rc = pl_estimate_rgb8(m, rgb, width, height, (size_t)width * 3, out, timing);
    if (rc == PL_OK && timing) timing->preprocess_ms += convert_ms;
    return rc;
}

int pl_estimate_nv12(pl_model *m, const uint8_t *y, size_t y_stride, const uint8_t *uv,
                     size_t uv_stride, int width, int height, pl_ycbcr enc, pl_lighting *out,
                     pl_timing *timing)
{
    if (!m || !y || !uv || !out) return pl_error(PL_E_ARG, "pl_estimate_nv12: NULL argument");
    pl_yuv_coeffs c;
    uint8_t *rgb;
    int rc = check_yuv(m, "NV12", width, height, 1, enc, &c, &rgb);
    if (rc < 0) return rc;
    if (y_stride < (size_t)width || uv_stride < (size_t)width)
        return pl_error(PL_E_ARG,
                        "NV12 frame %dx%d: y_stride %zu and uv_stride %zu must be >= width", width,
                        height, y_stride, uv_stride);
    const int64_t t0 = pl_now_ns();
    pl_nv12_to_rgb8(y, y_stride, uv, uv_stride, width, height, &c, rgb, (size_t)width * 3);
    const double convert_ms = (double)(pl_now_ns() - t0) / 1e6;
    rc = pl_estimate_rgb8(m, rgb, width, height, (size_t)width * 3, out, timing);
    if (rc == PL_OK && timing) timing->preprocess_ms += convert_ms;
    return rc;
}

int pl_image_load_rgb8(const char *path, uint8_t **rgb, int *width, int *height)
{
    if (rgb) *rgb = NULL;
    if (!path || !rgb || !width || !height)
        return pl_error(PL_E_ARG, "pl_image_load_rgb8: NULL argument");
    pl_image_u8 img;
    int rc = pl_image_read_rgb8(path, &img);
    if (rc < 0) return rc;
    const size_t row = (size_t)img.width * 3;
    if (img.stride != row) /* rows packed, as the header promises */
        for (int r = 1; r < img.height; r++)
            memmove(img.data + (size_t)r * row, img.data + (size_t)r * img.stride, row);
    *rgb = img.data;
    *width = img.width;
    *height = img.height;
    return PL_OK;
}

void pl_free(void *p)
{
    free(p);
}
