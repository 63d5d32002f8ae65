/* JPEG through libjpeg(-turbo) directly (port/image_codec.h): decode with OpenCV 4.6's settings
 * (default IDCT, fancy upsampling, RGB output, EXIF orientation), encode as OpenCV's imwrite.
 * libjpeg reports errors through error_exit: it longjmps back here, nothing is printed. */
#include "core/util.h"
#include "port/image_codec.h"

#include <string.h>

#ifdef PL_HAVE_LIBJPEG

#include <errno.h>
#include <setjmp.h>
#include <stdio.h>
#include <stdlib.h>

#include <jpeglib.h>

int pl_codec_have_jpeg(void)
{
    return 1;
}

typedef struct jerr {
    struct jpeg_error_mgr pub;
    jmp_buf jump;
    char msg[JMSG_LENGTH_MAX];
} jerr;

static void on_error(j_common_ptr c)
{
    jerr *e = (jerr *)c->err;
    e->pub.format_message(c, e->msg);
    longjmp(e->jump, 1);
}

static void on_message(j_common_ptr c)
{
    (void)c; /* warnings (e.g. "Corrupt JPEG data: premature end of data segment"): silent */
}

static void init_err(jerr *e)
{
    memset(e, 0, sizeof *e);
    jpeg_std_error(&e->pub);
    e->pub.error_exit = on_error;
    e->pub.output_message = on_message;
}

/* EXIF orientation 1..8 from the saved APP1 markers; 1 when absent or not understood (as
 * OpenCV's ExifReader: IFD0 tag 0x0112, type SHORT). */
static int exif_orientation(j_decompress_ptr c)
{
    for (jpeg_saved_marker_ptr m = c->marker_list; m; m = m->next) {
        if (m->marker != JPEG_APP0 + 1 || m->data_length < 14) continue;
        const uint8_t *d = m->data;
        if (memcmp(d, "Exif\0\0", 6) != 0) continue;
        const uint8_t *t = d + 6;
        const size_t n = m->data_length - 6;
        int le;
        if (t[0] == 'I' && t[1] == 'I')
            le = 1;
        else if (t[0] == 'M' && t[1] == 'M')
            le = 0;
        else
            return 1;
#define RD16(q) (le ? (uint32_t)(q)[0] | (uint32_t)(q)[1] << 8 : (uint32_t)(q)[0] << 8 | (q)[1])
#define RD32(q) (le ? RD16(q) | RD16((q) + 2) << 16 : RD16(q) << 16 | RD16((q) + 2))
        if (RD16(t + 2) != 42) return 1;
        const uint32_t ifd = RD32(t + 4);
        if (ifd > n || n - ifd < 2) return 1;
        const uint32_t count = RD16(t + ifd);
        for (uint32_t k = 0; k < count; k++) {
            const size_t e = (size_t)ifd + 2 + 12 * (size_t)k;
            if (e + 12 > n) return 1;
            if (RD16(t + e) == 0x0112) {
                const uint32_t v = RD16(t + e + 8);
                return RD16(t + e + 2) == 3 && v >= 1 && v <= 8 ? (int)v : 1;
            }
        }
#undef RD16
#undef RD32
        return 1;
    }
    return 1;
}

/* out (ow x oh, packed) from src (w x h, packed) under EXIF orientation o (OpenCV's
 * ApplyExifOrientation: flips and transposes, no resampling). */
static void orient(const uint8_t *src, int w, int h, int o, pl_image_u8 *out)
{
    const int ow = out->width, oh = out->height;
    for (int y = 0; y < oh; y++) {
        uint8_t *d = out->data + (size_t)y * out->stride;
        for (int x = 0; x < ow; x++, d += 3) {
            int sx, sy;
            switch (o) {
            case 2:
                sx = w - 1 - x, sy = y;
                break;
            case 3:
                sx = w - 1 - x, sy = h - 1 - y;
                break;
            case 4:
                sx = x, sy = h - 1 - y;
                break;
            case 5:
                sx = y, sy = x;
                break;
            case 6:
                sx = y, sy = h - 1 - x;
                break;
            case 7:
                sx = w - 1 - y, sy = h - 1 - x;
                break;
            case 8:
                sx = w - 1 - y, sy = x;
                break;
            default:
                sx = x, sy = y;
                break;
            }
            memcpy(d, src + ((size_t)sy * (size_t)w + (size_t)sx) * 3, 3);
        }
    }
}

/* State that must survive a longjmp lives here, not in locals. */
typedef struct dec {
    struct jpeg_decompress_struct c;
    jerr err;
    uint8_t *tmp; /* the unrotated image when an orientation applies, or CMYK rows */
} dec;

static int decode(dec *s, const uint8_t *p, size_t n, const char *what, pl_image_u8 *img,
                  size_t *cap)
{
    j_decompress_ptr c = &s->c;
    jpeg_create_decompress(c);
    jpeg_mem_src(c, p, (unsigned long)n);
    jpeg_save_markers(c, JPEG_APP0 + 1, 0xffff);
    jpeg_read_header(c, TRUE);
    const int cmyk = c->num_components == 4;
    c->out_color_space = cmyk ? JCS_CMYK : JCS_RGB;
    jpeg_start_decompress(c);
    const int w = (int)c->output_width, h = (int)c->output_height;
    int rc = pl_image_check_read_size(what, w, h);
    if (rc < 0) return rc;
    const int o = exif_orientation(c);
    const int swap = o >= 5;
    rc = pl_image_u8_reserve(img, cap, swap ? h : w, swap ? w : h);
    if (rc < 0) return pl_error_prefix(rc, "%s", what);
    /* Rows go straight into img unless they must be rotated or converted from CMYK: then tmp
     * holds one CMYK row (w * 4 bytes) and/or the whole unrotated image (w * h * 3). */
    const size_t row = (size_t)w * 3;
    const size_t cmyk_bytes = cmyk ? (size_t)w * 4 : 0;
    uint8_t *rgb = NULL;
    if (o != 1 || cmyk) {
        size_t bytes = 0;
        if ((o != 1 && !pl_mul_size(row, (size_t)h, &bytes)) || bytes > SIZE_MAX - cmyk_bytes ||
            !(s->tmp = malloc(bytes + cmyk_bytes)))
            return pl_error(PL_E_NOMEM, "%s: out of memory decoding a %dx%d JPEG", what, w, h);
        if (o != 1) rgb = s->tmp + cmyk_bytes;
    }
    while (c->output_scanline < c->output_height) {
        const size_t y = c->output_scanline;
        uint8_t *dst = o != 1 ? rgb + y * row : img->data + y * img->stride;
        JSAMPROW r = cmyk ? s->tmp : dst;
        if (jpeg_read_scanlines(c, &r, 1) != 1)
            return pl_error(PL_E_FORMAT, "%s: JPEG decoder stopped at row %zu", what, y);
        if (cmyk) {
            /* OpenCV's icvCvt_CMYK2BGR_8u_C4C3R (Adobe's inverted CMYK as libjpeg gives it). */
            const uint8_t *q = s->tmp;
            for (int x = 0; x < w; x++, q += 4) {
                const int k = q[3];
                dst[3 * x + 0] = (uint8_t)(k - ((255 - q[0]) * k >> 8));
                dst[3 * x + 1] = (uint8_t)(k - ((255 - q[1]) * k >> 8));
                dst[3 * x + 2] = (uint8_t)(k - ((255 - q[2]) * k >> 8));
            }
        }
    }
    jpeg_finish_decompress(c);
    if (o != 1) orient(rgb, w, h, o, img);
    return PL_OK;
}

int pl_jpeg_decode_rgb8(const uint8_t *p, size_t n, const char *what, pl_image_u8 *img, size_t *cap)
{
    if (!p || !what || !img || !cap)
        return pl_error(PL_E_ARG, "pl_jpeg_decode_rgb8: NULL argument");
    if (n == 0 || n > (size_t)0x7fffffff)
        return pl_error(PL_E_FORMAT, "%s: JPEG of %zu bytes", what, n);
    dec *s = calloc(1, sizeof *s);
    if (!s) return pl_error(PL_E_NOMEM, "%s: out of memory", what);
    init_err(&s->err);
    s->c.err = &s->err.pub;
    int rc;
    if (setjmp(s->err.jump))
        rc = pl_error(PL_E_FORMAT, "%s: corrupt JPEG (libjpeg: %s)", what, s->err.msg);
    else
        rc = decode(s, p, n, what, img, cap);
    jpeg_destroy_decompress(&s->c);
    free(s->tmp);
    free(s);
    return rc;
}

typedef struct enc {
    struct jpeg_compress_struct c;
    jerr err;
    FILE *f;
    unsigned char *mem; /* jpeg_mem_dest's buffer */
    unsigned long mem_n;
} enc;

static void compress_rows(j_compress_ptr c, const pl_image_u8 *img, int quality)
{
    c->image_width = (JDIMENSION)img->width;
    c->image_height = (JDIMENSION)img->height;
    c->input_components = 3;
    c->in_color_space = JCS_RGB;
    jpeg_set_defaults(c);
    jpeg_set_quality(c, quality, TRUE);
    jpeg_start_compress(c, TRUE);
    while (c->next_scanline < c->image_height) {
        JSAMPROW r = img->data + (size_t)c->next_scanline * img->stride;
        jpeg_write_scanlines(c, &r, 1);
    }
    jpeg_finish_compress(c);
}

int pl_jpeg_encode_rgb8(const pl_image_u8 *img, int quality, unsigned char **out, size_t *n)
{
    if (!out || !n) return pl_error(PL_E_ARG, "pl_jpeg_encode_rgb8: NULL output");
    *out = NULL;
    *n = 0;
    if (!img || !img->data || img->width < 1 || img->height < 1 ||
        img->stride < (size_t)img->width * 3)
        return pl_error(PL_E_ARG, "pl_jpeg_encode_rgb8: invalid image");
    if (quality < 1 || quality > 100)
        return pl_error(PL_E_ARG, "JPEG quality %d, expected 1..100", quality);
    if (img->width > 65500 || img->height > 65500)
        return pl_error(PL_E_ARG, "%dx%d is too large for JPEG", img->width, img->height);
    enc *s = calloc(1, sizeof *s);
    if (!s) return pl_error(PL_E_NOMEM, "JPEG encoder: out of memory");
    init_err(&s->err);
    s->c.err = &s->err.pub;
    int rc = PL_OK;
    if (setjmp(s->err.jump)) {
        rc = pl_error(PL_E_NOMEM, "JPEG encoder failed (libjpeg: %s)", s->err.msg);
    } else {
        jpeg_create_compress(&s->c);
        jpeg_mem_dest(&s->c, &s->mem, &s->mem_n);
        compress_rows(&s->c, img, quality);
    }
    jpeg_destroy_compress(&s->c);
    if (rc == PL_OK) {
        *out = s->mem;
        *n = (size_t)s->mem_n;
    } else {
        free(s->mem);
    }
    free(s);
    return rc;
}

int pl_jpeg_write_rgb8(const char *path, const pl_image_u8 *img, int quality)
{
    if (!path || !img || !img->data || img->width < 1 || img->height < 1 ||
        img->stride < (size_t)img->width * 3)
        return pl_error(PL_E_ARG, "pl_jpeg_write_rgb8: invalid image or path");
    if (quality < 1 || quality > 100)
        return pl_error(PL_E_ARG, "%s: JPEG quality %d, expected 1..100", path, quality);
    if (img->width > 65500 || img->height > 65500)
        return pl_error(PL_E_ARG, "%s: %dx%d is too large for JPEG", path, img->width, img->height);
    enc *s = calloc(1, sizeof *s);
    if (!s) return pl_error(PL_E_NOMEM, "%s: out of memory", path);
    init_err(&s->err);
    s->c.err = &s->err.pub;
    int rc = PL_OK;
    s->f = fopen(path, "wb");
    if (!s->f) {
        rc = pl_error(PL_E_IO, "%s: cannot write: %s", path, strerror(errno));
        free(s);
        return rc;
    }
    if (setjmp(s->err.jump)) {
        rc = pl_error(PL_E_IO, "%s: JPEG encoder failed (libjpeg: %s)", path, s->err.msg);
    } else {
        jpeg_create_compress(&s->c);
        jpeg_stdio_dest(&s->c, s->f);
        compress_rows(&s->c, img, quality);
    }
    jpeg_destroy_compress(&s->c);
    if (fclose(s->f) != 0 && rc == PL_OK)
        rc = pl_error(PL_E_IO, "%s: write error: %s", path, strerror(errno));
    if (rc < 0) remove(path);
    free(s);
    return rc;
}

#else /* !PL_HAVE_LIBJPEG */

int pl_codec_have_jpeg(void)
{
    return 0;
}

int pl_jpeg_decode_rgb8(const uint8_t *p, size_t n, const char *what, pl_image_u8 *img, size_t *cap)
{
    (void)p, (void)n, (void)img, (void)cap;
    return pl_error(PL_E_UNSUPPORTED, "%s: this build has no libjpeg: cannot decode JPEG",
                    what ? what : "JPEG");
}

int pl_jpeg_encode_rgb8(const pl_image_u8 *img, int quality, unsigned char **out, size_t *n)
{
    (void)img, (void)quality;
    if (out) *out = NULL;
    if (n) *n = 0;
    return pl_error(PL_E_UNSUPPORTED, "this build has no libjpeg: cannot encode JPEG");
}

int pl_jpeg_write_rgb8(const char *path, const pl_image_u8 *img, int quality)
{
    (void)img, (void)quality;
    return pl_error(PL_E_UNSUPPORTED, "%s: this build has no libjpeg: cannot write JPEG",
                    path ? path : "JPEG");
}

#endif
