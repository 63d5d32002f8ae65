/* PNG through libpng directly (port/image_codec.h), with the transformations OpenCV 4.6's
 * IMREAD_UNCHANGED decoder asks for, then parlight's 16->8-bit rule and RGB output; the writer
 * uses OpenCV's default settings. libpng errors longjmp back here; warnings are not printed. */
#include "core/util.h"
#include "port/image_codec.h"

#include <string.h>

#ifdef PL_HAVE_LIBPNG

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>

#include <png.h>
#include <zlib.h>

int pl_codec_have_png(void)
{
    return 1;
}

typedef struct pngio {
    const uint8_t *p;
    size_t n, pos;
    char msg[160];
    uint8_t *rows;   /* a 16-bit image, before scaling to 8 bits */
    png_bytep *rowp; /* row pointers handed to libpng */
} pngio;

static void on_error(png_structp png, png_const_charp msg)
{
    pngio *s = png_get_error_ptr(png);
    snprintf(s->msg, sizeof s->msg, "%s", msg ? msg : "error");
    png_longjmp(png, 1);
}

static void on_warning(png_structp png, png_const_charp msg)
{
    (void)png, (void)msg;
}

static void on_read(png_structp png, png_bytep out, size_t len)
{
    pngio *s = png_get_io_ptr(png);
    if (len > s->n - s->pos) png_error(png, "read past the end of the data");
    memcpy(out, s->p + s->pos, len);
    s->pos += len;
}

static int decode(png_structp png, png_infop info, pngio *s, const char *what, pl_image_u8 *img,
                  size_t *cap)
{
    png_set_read_fn(png, s, on_read);
    png_read_info(png, info);
    const png_uint_32 w = png_get_image_width(png, info), h = png_get_image_height(png, info);
    const int depth = png_get_bit_depth(png, info);
    int rc = pl_image_check_read_size(what, w, h);
    if (rc < 0) return rc;
    png_set_expand(png);      /* palette -> RGB, gray < 8 bits -> 8, tRNS -> alpha */
    png_set_strip_alpha(png); /* alpha dropped, colours kept as they are */
    png_set_gray_to_rgb(png);
    png_set_interlace_handling(png);
    png_read_update_info(png, info);
    const size_t bpp = depth == 16 ? 6 : 3;
    if (png_get_rowbytes(png, info) != bpp * w)
        return pl_error(PL_E_INTERNAL, "%s: PNG rows of %zu bytes, expected %zu", what,
                        (size_t)png_get_rowbytes(png, info), bpp * w);
    rc = pl_image_u8_reserve(img, cap, (int)w, (int)h);
    if (rc < 0) return pl_error_prefix(rc, "%s", what);
    if (depth == 16) {
        size_t bytes;
        if (!pl_mul_size(bpp * w, h, &bytes) || !(s->rows = malloc(bytes)))
            return pl_error(PL_E_NOMEM, "%s: out of memory decoding a %ux%u PNG", what, (unsigned)w,
                            (unsigned)h);
    }
    if (!(s->rowp = malloc(sizeof *s->rowp * h)))
        return pl_error(PL_E_NOMEM, "%s: out of memory", what);
    for (png_uint_32 y = 0; y < h; y++)
        s->rowp[y] =
            depth == 16 ? s->rows + (size_t)y * bpp * w : img->data + (size_t)y * img->stride;
    png_read_image(png, s->rowp);
    if (depth == 16) {
        for (png_uint_32 y = 0; y < h; y++) {
            const uint8_t *q = s->rows + (size_t)y * bpp * w;
            uint8_t *d = img->data + (size_t)y * img->stride;
            for (size_t x = 0; x < 3 * (size_t)w; x++, q += 2)
                d[x] = (uint8_t)((((uint32_t)q[0] << 8 | q[1]) * 255u + 32767u) / 65535u);
        }
    }
    png_read_end(png, NULL);
    return PL_OK;
}

int pl_png_decode_rgb8(const uint8_t *p, size_t n, const char *what, pl_image_u8 *img, size_t *cap)
{
    if (!p || !what || !img || !cap) return pl_error(PL_E_ARG, "pl_png_decode_rgb8: NULL argument");
    pngio *s = calloc(1, sizeof *s);
    if (!s) return pl_error(PL_E_NOMEM, "%s: out of memory", what);
    s->p = p;
    s->n = n;
    int rc;
    png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, s, on_error, on_warning);
    png_infop info = png ? png_create_info_struct(png) : NULL;
    if (!png || !info) {
        rc = pl_error(PL_E_NOMEM, "%s: out of memory starting libpng", what);
    } else if (setjmp(png_jmpbuf(png))) {
        rc = pl_error(PL_E_FORMAT, "%s: corrupt PNG (libpng: %s)", what, s->msg);
    } else {
        /* libpng refuses what we would refuse anyway, before it allocates. */
        png_set_user_limits(png, PL_IMAGE_MAX_SIDE, PL_IMAGE_MAX_SIDE);
        rc = decode(png, info, s, what, img, cap);
    }
    png_destroy_read_struct(png ? &png : NULL, info ? &info : NULL, NULL);
    free(s->rowp);
    free(s->rows);
    free(s);
    return rc;
}

typedef struct pngw {
    FILE *f;
    char msg[160];
} pngw;

int pl_png_write_rgb8(const char *path, const pl_image_u8 *img)
{
    if (!path || !img || !img->data || img->width < 1 || img->height < 1 ||
        img->stride < (size_t)img->width * 3)
        return pl_error(PL_E_ARG, "pl_png_write_rgb8: invalid image or path");
    pngw *s = calloc(1, sizeof *s);
    if (!s) return pl_error(PL_E_NOMEM, "%s: out of memory", path);
    int rc = PL_OK;
    s->f = fopen(path, "wb");
    if (!s->f) {
        rc = pl_error(PL_E_IO, "%s: cannot write: %s", path, strerror(errno));
        free(s);
        return rc;
    }
    png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, s, on_error, on_warning);
    png_infop info = png ? png_create_info_struct(png) : NULL;
    if (!png || !info) {
        rc = pl_error(PL_E_NOMEM, "%s: out of memory starting libpng", path);
    } else if (setjmp(png_jmpbuf(png))) {
        rc = pl_error(PL_E_IO, "%s: PNG encoder failed (libpng: %s)", path, s->msg);
    } else {
        png_init_io(png, s->f);
        png_set_IHDR(png, info, (png_uint_32)img->width, (png_uint_32)img->height, 8,
                     PNG_COLOR_TYPE_RGB, PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT,
                     PNG_FILTER_TYPE_DEFAULT);
        png_set_filter(png, PNG_FILTER_TYPE_BASE, PNG_FILTER_SUB);
        png_set_compression_level(png, Z_BEST_SPEED);
        png_set_compression_strategy(png, Z_RLE);
        png_write_info(png, info);
        for (int y = 0; y < img->height; y++)
            png_write_row(png, img->data + (size_t)y * img->stride);
        png_write_end(png, info);
    }
    png_destroy_write_struct(png ? &png : NULL, info ? &info : NULL);
    if (fclose(s->f) != 0 && rc == PL_OK)
        rc = pl_error(PL_E_IO, "%s: write error: %s", path, strerror(errno));
    if (rc < 0) remove(path);
    free(s);
    return rc;
}

#else /* !PL_HAVE_LIBPNG */

int pl_codec_have_png(void)
{
    return 0;
}

int pl_png_decode_rgb8(const uint8_t *p, size_t n, const char *what, pl_image_u8 *img, size_t *cap)
{
    (void)p, (void)n, (void)img, (void)cap;
    return pl_error(PL_E_UNSUPPORTED, "%s: this build has no libpng: cannot decode PNG",
                    what ? what : "PNG");
}

int pl_png_write_rgb8(const char *path, const pl_image_u8 *img)
{
    (void)img;
    return pl_error(PL_E_UNSUPPORTED, "%s: this build has no libpng: cannot write PNG",
                    path ? path : "PNG");
}

#endif
