/* Still-image files behind port/image.h: the file is read into memory (precise errno messages,
 * one read), its header is checked against the size limits before anything is decoded (PNG,
 * JPEG, BMP, TIFF, PNM; HDR formats are refused unread), truncation is detected (PNG: chunk lengths
 * and CRCs up to IEND; JPEG: an EOI after the first scan; BMP: all pixel rows present), and only
 * then a decoder runs: libjpeg / libpng directly for JPEG and PNG (port/jpeg_codec.c,
 * port/png_codec.c), OpenCV for the other formats (port/image_io.cpp) when this build has it. See
 * port/image_codec.h and docs/PORTING.md. */
#include "core/file.h"
#include "core/util.h"
#include "port/image.h"
#include "port/image_codec.h"
#include "port/image_jpeg.h"
#include "port/image_mem.h"

#include <ctype.h>
#include <errno.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>
#include <unistd.h>

/* Compressed files larger than this are refused before reading (an uncompressed BMP of the
 * largest accepted image is 768 MiB). */
#define MAX_FILE_BYTES (1LL << 30)

typedef enum kind { KIND_UNKNOWN, KIND_PNG, KIND_JPEG, KIND_BMP, KIND_HDR, KIND_OTHER } kind;

typedef struct header {
    kind kind;
    long long width, height; /* -1: not known from the header */
    size_t jpeg_scan;        /* offset of the first SOS marker (JPEG) */
} header;

static uint32_t be32(const uint8_t *p)
{
    return (uint32_t)p[0] << 24 | (uint32_t)p[1] << 16 | (uint32_t)p[2] << 8 | p[3];
}
static uint32_t be16(const uint8_t *p)
{
    return (uint32_t)p[0] << 8 | p[1];
}
static uint32_t le16(const uint8_t *p)
{
    return (uint32_t)p[1] << 8 | p[0];
}
static uint32_t le32(const uint8_t *p)
{
    return (uint32_t)p[3] << 24 | (uint32_t)p[2] << 16 | (uint32_t)p[1] << 8 | p[0];
}

/* PNG: every chunk complete, its CRC right, IEND reached (trailing junk after IEND allowed). */
static int check_png_chunks(const char *path, const uint8_t *p, size_t n)
{
    static uint32_t table[256];
    static bool have_table = false;
    if (!have_table) { /* benign race: every thread writes the same values */
        for (uint32_t i = 0; i < 256; i++) {
            uint32_t c = i;
            for (int k = 0; k < 8; k++)
                c = c & 1 ? 0xedb88320u ^ (c >> 1) : c >> 1;
            table[i] = c;
        }
        have_table = true;
    }
    size_t pos = 8;
    while (pos + 12 <= n) {
        const uint32_t len = be32(p + pos);
        if (len > 0x7fffffffu || len > n - pos - 12)
            return pl_error(PL_E_FORMAT, "%s: truncated PNG (chunk at byte %zu runs past the end)",
                            path, pos);
        uint32_t c = 0xffffffffu;
        for (size_t i = pos + 4; i < pos + 8 + len; i++)
            c = table[(c ^ p[i]) & 0xff] ^ (c >> 8);
        if ((c ^ 0xffffffffu) != be32(p + pos + 8 + len)) {
            char type[5];
            for (int k = 0; k < 4; k++)
                type[k] = isalpha(p[pos + 4 + k]) ? (char)p[pos + 4 + k] : '?';
            type[4] = '\0';
            return pl_error(PL_E_FORMAT, "%s: corrupt PNG (CRC error in chunk '%s' at byte %zu)",
                            path, type, pos);
        }
        if (memcmp(p + pos + 4, "IEND", 4) == 0) return PL_OK;
        pos += 12 + (size_t)len;
    }
    return pl_error(PL_E_FORMAT, "%s: truncated PNG (no IEND chunk at the end)", path);
}

/* JPEG markers up to the first scan (declared size from the SOF), then an EOI after it. */
static int check_jpeg(const char *path, const uint8_t *p, size_t n, header *h)
{
    size_t i = 2;
    for (int guard = 0; guard < 100000; guard++) {
        while (i < n && p[i] == 0xff && i + 1 < n && p[i + 1] == 0xff)
            i++; /* fill bytes */
        if (i + 4 > n) break;
        if (p[i] != 0xff)
            return pl_error(PL_E_FORMAT, "%s: corrupt JPEG (no marker at byte %zu)", path, i);
        const uint8_t m = p[i + 1];
        if (m == 0xd8 || m == 0x01 || (m >= 0xd0 && m <= 0xd7)) { /* no length */
            i += 2;
            continue;
        }
        if (m == 0xd9) break; /* EOI before any scan */
        const size_t len = be16(p + i + 2);
        if (len < 2)
            return pl_error(PL_E_FORMAT, "%s: corrupt JPEG (segment length %zu at byte %zu)", path,
                            len, i);
        if (m >= 0xc0 && m <= 0xcf && m != 0xc4 && m != 0xc8 && m != 0xcc) {
            if (i + 9 > n) break;
            h->height = be16(p + i + 5);
            h->width = be16(p + i + 7);
        }
        if (m == 0xda) {
            h->jpeg_scan = i;
            break;
        }
        i += 2 + len;
    }
    if (h->jpeg_scan == 0)
        return pl_error(PL_E_FORMAT, "%s: truncated or corrupt JPEG (no image scan found)", path);
    /* FF D9 cannot occur inside entropy-coded data (FF is stuffed as FF 00). */
    bool eoi = false;
    for (size_t k = h->jpeg_scan; k + 1 < n; k++)
        if (p[k] == 0xff && p[k + 1] == 0xd9) {
            eoi = true;
            break;
        }
    if (!eoi) return pl_error(PL_E_FORMAT, "%s: truncated JPEG (no end-of-image marker)", path);
    if (h->width <= 0 || h->height <= 0)
        return pl_error(PL_E_FORMAT, "%s: JPEG declares a %lldx%lld image", path, h->width,
                        h->height);
    return PL_OK;
}

static int check_bmp(const char *path, const uint8_t *p, size_t n, header *h)
{
    const uint32_t dib = le32(p + 14);
    const uint32_t offset = le32(p + 10);
    uint32_t bpp = 0, compression = 0;
    if (dib == 12) {
        h->kind = KIND_BMP;
        h->width = le16(p + 18);
        h->height = le16(p + 20);
        bpp = le16(p + 24);
    } else if (dib >= 40) {
        if (n < 34) return pl_error(PL_E_FORMAT, "%s: truncated BMP header", path);
        h->kind = KIND_BMP;
        h->width = (int32_t)le32(p + 18);
        const long long hh = (int32_t)le32(p + 22);
        h->height = hh < 0 ? -hh : hh; /* negative: top-down rows */
        bpp = le16(p + 28);
        compression = le32(p + 30);
        /* 0 RGB, 1 RLE8, 2 RLE4, 3 BITFIELDS: what OpenCV decodes (it asserts on the rest). */
        if (compression > 3)
            return pl_error(PL_E_UNSUPPORTED, "%s: BMP compression %u not supported", path,
                            compression);
    }
    /* Uncompressed pixel data must all be there (OpenCV would throw, and print, on the way). */
    if (h->kind == KIND_BMP && (compression == 0 || compression == 3) && h->width >= 1 &&
        h->height >= 1 && h->width <= PL_IMAGE_MAX_SIDE && h->height <= PL_IMAGE_MAX_SIDE &&
        (bpp == 1 || bpp == 4 || bpp == 8 || bpp == 16 || bpp == 24 || bpp == 32)) {
        const unsigned long long row = ((unsigned long long)h->width * bpp + 31) / 32 * 4;
        const unsigned long long need =
            (unsigned long long)offset + row * (unsigned long long)h->height;
        if (need > n)
            return pl_error(PL_E_FORMAT,
                            "%s: truncated BMP (pixel data needs %llu bytes, file has %zu)", path,
                            need, n);
    }
    return PL_OK;
}

/* TIFF: the size of the first image (IFD 0: ImageWidth 256, ImageLength 257), the one OpenCV
 * decodes. OpenCV 4.6 has no way to read a header without decoding (cv::ImageCollection came
 * in 4.7) and its own limit is 2^30 pixels: a 9 KB TIFF whose strips all point at one deflated
 * block reaches 2.7 GB inside imdecode. So the size is read here, and checked before decoding.
 * Leaves h->width/height at -1 when the directory cannot be read (OpenCV then says why). */
static void tiff_size(const uint8_t *p, size_t n, header *h)
{
    const bool le = p[0] == 'I';
    uint32_t (*u16)(const uint8_t *) = le ? le16 : be16;
    uint32_t (*u32)(const uint8_t *) = le ? le32 : be32;
    if (n < 8) return;
    const uint32_t ifd = u32(p + 4);
    if (ifd < 8 || ifd > n - 2) return;
    const uint32_t count = u16(p + ifd);
    for (uint32_t i = 0; i < count && ifd + 2 + 12 * (size_t)(i + 1) <= n; i++) {
        const uint8_t *e = p + ifd + 2 + 12 * (size_t)i;
        const uint32_t tag = u16(e), type = u16(e + 2);
        const long long v = type == 3   ? (long long)u16(e + 8)
                            : type == 4 ? (long long)u32(e + 8)
                                        : -1;
        if (tag == 256) h->width = v;
        if (tag == 257) h->height = v;
    }
    if (h->width < 0 || h->height < 0) h->width = h->height = -1;
}

/* Decimal digits at p[i..n) after optional blanks, at most 11 of them (no strtoll: the buffer is
 * the file's bytes, not a string, and may end inside the number); -1 when there are none. */
static long long pnm_number(const uint8_t *p, size_t n, size_t i)
{
    while (i < n && (p[i] == ' ' || p[i] == '\t'))
        i++;
    long long x = 0;
    size_t d = 0;
    for (; i < n && isdigit(p[i]) && d < 12; i++, d++)
        x = x * 10 + (p[i] - '0');
    return d == 0 || d == 12 ? -1 : x;
}

/* PNM/PAM: "P<n>" then width and height as decimal text (PAM: WIDTH and HEIGHT lines). */
static void pnm_size(const uint8_t *p, size_t n, header *h)
{
    long long v[2] = {-1, -1};
    size_t i = 2;
    if (p[1] == '7') { /* PAM */
        for (; i + 7 < n && i < 4096; i++) {
            if (p[i - 1] != '\n') continue;
            if (memcmp(p + i, "WIDTH ", 6) == 0) v[0] = pnm_number(p, n, i + 6);
            if (memcmp(p + i, "HEIGHT ", 7) == 0) v[1] = pnm_number(p, n, i + 7);
            if (memcmp(p + i, "ENDHDR", 6) == 0) break;
        }
    } else {
        for (int k = 0; k < 2; k++) {
            while (i < n && (isspace(p[i]) || p[i] == '#')) {
                if (p[i] == '#')
                    while (i < n && p[i] != '\n')
                        i++;
                else
                    i++;
            }
            long long x = 0;
            size_t d = 0;
            for (; i < n && isdigit(p[i]) && d < 12; i++, d++)
                x = x * 10 + (p[i] - '0');
            if (d == 0 || d == 12) return;
            v[k] = x;
        }
    }
    if (v[0] >= 0 && v[1] >= 0) {
        h->width = v[0];
        h->height = v[1];
    }
}

/* Formats OpenCV may decode that we recognise by their first bytes, so that a build without
 * OpenCV can say "unsupported here" instead of "not an image". */
static bool other_image_magic(const uint8_t *p, size_t n)
{
    if (n >= 4 && (memcmp(p, "II*\0", 4) == 0 || memcmp(p, "MM\0*", 4) == 0))
        return true; /* TIFF */
    if (n >= 12 && memcmp(p, "RIFF", 4) == 0 && memcmp(p + 8, "WEBP", 4) == 0) return true;
    if (n >= 2 && p[0] == 'P' && p[1] >= '1' && p[1] <= '7') return true; /* PNM, PAM */
    if (n >= 4 && memcmp(p, "\x76\x2f\x31\x01", 4) == 0) return true;     /* EXR */
    if (n >= 10 && memcmp(p, "#?RADIANCE", 10) == 0) return true;         /* HDR */
    if (n >= 6 && memcmp(p, "#?RGBE", 6) == 0) return true;
    if (n >= 4 && memcmp(p, "\x59\xa6\x6a\x95", 4) == 0) return true; /* Sun raster */
    if (n >= 12 && memcmp(p, "\0\0\0\x0cjP  ", 8) == 0) return true;  /* JPEG 2000 */
    return false;
}

/* Reads what the header declares: PL_OK, or PL_E_FORMAT (with a message) for a header that is
 * recognisably this format but broken or truncated. */
static int parse_header(const char *path, const uint8_t *p, size_t n, header *h)
{
    static const uint8_t png_sig[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
    h->kind = KIND_UNKNOWN;
    h->width = h->height = -1;
    h->jpeg_scan = 0;
    if (n >= 8 && memcmp(p, png_sig, 8) == 0) {
        h->kind = KIND_PNG;
        if (n < 33 || memcmp(p + 12, "IHDR", 4) != 0)
            return pl_error(PL_E_FORMAT, "%s: truncated PNG (no complete IHDR chunk)", path);
        h->width = be32(p + 16);
        h->height = be32(p + 20);
        int rc =
            pl_image_check_read_size(path, h->width, h->height); /* a bomb's CRCs may be right */
        if (rc < 0) return rc;
        return check_png_chunks(path, p, n);
    }
    if (n >= 3 && p[0] == 0xff && p[1] == 0xd8 && p[2] == 0xff) {
        h->kind = KIND_JPEG;
        return check_jpeg(path, p, n, h);
    }
    if (n >= 26 && p[0] == 'B' && p[1] == 'M') return check_bmp(path, p, n, h);
    if ((n >= 4 && memcmp(p, "\x76\x2f\x31\x01", 4) == 0) ||
        (n >= 2 && p[0] == '#' && p[1] == '?')) {
        h->kind = KIND_HDR;
        return PL_OK;
    }
    if (other_image_magic(p, n)) h->kind = KIND_OTHER;
    if (n >= 8 && (memcmp(p, "II*\0", 4) == 0 || memcmp(p, "MM\0*", 4) == 0)) tiff_size(p, n, h);
    if (n >= 3 && p[0] == 'P' && p[1] >= '1' && p[1] <= '7') pnm_size(p, n, h);
    return PL_OK;
}

/* Reads the whole regular file at `path`, with a message for each way that can fail. */
static int read_file(const char *path, uint8_t **out, size_t *size)
{
    *out = NULL;
    *size = 0;
    int fd;
    int64_t bytes;
    int rc = pl_file_open_regular(path, "image", &fd, &bytes);
    if (rc < 0) return rc;
    if (bytes == 0 || bytes > MAX_FILE_BYTES) {
        close(fd);
        if (bytes == 0)
            return pl_error(PL_E_FORMAT, "%s: empty file (0 bytes), not an image", path);
        return pl_error(PL_E_FORMAT,
                        "%s: file of %lld bytes is larger than the %lld accepted for an image",
                        path, (long long)bytes, MAX_FILE_BYTES);
    }
    FILE *f = fdopen(fd, "rb");
    if (!f) {
        int err = errno;
        close(fd);
        return pl_error(PL_E_IO, "%s: cannot open image: %s", path, strerror(err));
    }
    uint8_t *buf = malloc((size_t)bytes);
    if (!buf) {
        fclose(f);
        return pl_error(PL_E_NOMEM, "%s: cannot allocate %lld bytes to read it", path,
                        (long long)bytes);
    }
    const size_t got = fread(buf, 1, (size_t)bytes, f);
    const int err = ferror(f) ? errno : 0;
    fclose(f);
    if (err) {
        free(buf);
        return pl_error(PL_E_IO, "%s: read error: %s", path, strerror(err));
    }
    if (got == 0) {
        free(buf);
        return pl_error(PL_E_FORMAT, "%s: empty file (0 bytes), not an image", path);
    }
    *out = buf;
    *size = got; /* the file may have shrunk since stat */
    return PL_OK;
}

static int decode(const char *path, const uint8_t *p, size_t n, const header *h, pl_image_u8 *img,
                  size_t *cap)
{
    const bool cv = pl_codec_have_opencv();
    switch (h->kind) {
    case KIND_JPEG:
        if (pl_codec_have_jpeg()) return pl_jpeg_decode_rgb8(p, n, path, img, cap);
        if (cv) return pl_cv_image_decode_rgb8(p, n, path, PL_CV_EXIF | PL_CV_KNOWN, img, cap);
        return pl_error(PL_E_UNSUPPORTED,
                        "%s: this build has neither libjpeg nor OpenCV: cannot decode JPEG", path);
    case KIND_PNG:
        if (pl_codec_have_png()) return pl_png_decode_rgb8(p, n, path, img, cap);
        if (cv) return pl_cv_image_decode_rgb8(p, n, path, PL_CV_KNOWN, img, cap);
        return pl_error(PL_E_UNSUPPORTED,
                        "%s: this build has neither libpng nor OpenCV: cannot decode PNG", path);
    case KIND_HDR:
        /* Refused unread: OpenCV would decode the whole float image first (a 98 KB RGBE file
         * declares 32768 x 8192, 3 GB), only for mat_to_rgb8 to refuse it. */
        return pl_error(PL_E_UNSUPPORTED,
                        "%s: an HDR image (OpenEXR or Radiance): not read as 8-bit RGB; use the "
                        "HDR reader",
                        path);
    case KIND_BMP:
    case KIND_OTHER:
        if (cv) return pl_cv_image_decode_rgb8(p, n, path, PL_CV_KNOWN, img, cap);
        return pl_error(PL_E_UNSUPPORTED,
                        "%s: this build has no OpenCV: only JPEG and PNG images can be read", path);
    default:
        if (cv) return pl_cv_image_decode_rgb8(p, n, path, 0, img, cap);
        return pl_error(PL_E_FORMAT,
                        "%s: not an image (content matches no format this build "
                        "decodes: JPEG, PNG)",
                        path);
    }
}

int pl_image_read_rgb8_reuse(const char *path, pl_image_u8 *img, size_t *capacity)
{
    if (!path || !img || !capacity) return pl_error(PL_E_ARG, "pl_image_read_rgb8: NULL argument");
    uint8_t *buf;
    size_t n;
    int rc = read_file(path, &buf, &n);
    if (rc < 0) return rc;
    header h;
    rc = parse_header(path, buf, n, &h);
    if (rc == PL_OK && h.width >= 0 && h.height >= 0)
        rc = pl_image_check_read_size(path, h.width, h.height);
    if (rc == PL_OK) rc = decode(path, buf, n, &h, img, capacity);
    free(buf);
    return rc;
}

int pl_image_read_rgb8(const char *path, pl_image_u8 *out)
{
    if (!out) return pl_error(PL_E_ARG, "pl_image_read_rgb8: out is NULL");
    pl_image_u8 img = {0, 0, 0, NULL};
    size_t cap = 0;
    int rc = pl_image_read_rgb8_reuse(path, &img, &cap);
    if (rc < 0) {
        pl_image_u8_free(&img);
        memset(out, 0, sizeof *out);
        return rc;
    }
    *out = img;
    return PL_OK;
}

static const char *extension(const char *path)
{
    const char *slash = strrchr(path, '/');
    const char *dot = strrchr(path, '.');
    return dot && (!slash || dot > slash) && dot[1] ? dot + 1 : NULL;
}

/* Checks common to the writers: the target is not a non-regular file and its folder is
 * writable (so that the error names the real problem). */
static int check_target(const char *path)
{
    struct stat st;
    if (stat(path, &st) == 0 && !S_ISREG(st.st_mode))
        return pl_error(PL_E_IO, "%s: exists and is not a regular file", path);
    char dir[4096];
    const char *slash = strrchr(path, '/');
    if (!slash)
        snprintf(dir, sizeof dir, ".");
    else if (slash == path)
        snprintf(dir, sizeof dir, "/");
    else
        snprintf(dir, sizeof dir, "%.*s", (int)(slash - path), path);
    if (access(dir, W_OK | X_OK) != 0)
        return pl_error(PL_E_IO, "%s: cannot write into %s: %s", path, dir, strerror(errno));
    return PL_OK;
}

int pl_image_write_rgb8(const char *path, const pl_image_u8 *img)
{
    if (!path || !img || !img->data)
        return pl_error(PL_E_ARG, "pl_image_write_rgb8: NULL argument");
    if (pl_image_check_size(path, img->width, img->height) < 0)
        return pl_error(PL_E_ARG, "%s: cannot write a %dx%d image", path, img->width, img->height);
    if (img->stride < (size_t)img->width * 3)
        return pl_error(PL_E_ARG, "%s: stride %zu < 3 * width %d", path, img->stride, img->width);
    const char *ext = extension(path);
    const bool png = ext && strcasecmp(ext, "png") == 0;
    const bool jpg = ext && (strcasecmp(ext, "jpg") == 0 || strcasecmp(ext, "jpeg") == 0 ||
                             strcasecmp(ext, "jpe") == 0);
    if ((png && pl_codec_have_png()) || (jpg && pl_codec_have_jpeg())) {
        int rc = check_target(path);
        if (rc < 0) return rc;
        return png ? pl_png_write_rgb8(path, img) : pl_jpeg_write_rgb8(path, img, 95);
    }
    if (pl_codec_have_opencv()) {
        if (!pl_cv_has_writer(path))
            return pl_error(PL_E_ARG,
                            "%s: unknown image extension (use .png, .jpg, .bmp, .tif, .ppm, ...)",
                            path);
        int rc = check_target(path);
        if (rc < 0) return rc;
        return pl_cv_image_write_rgb8(path, img);
    }
    if (png || jpg)
        return pl_error(PL_E_UNSUPPORTED, "%s: this build has no lib%s: cannot write it", path,
                        png ? "png" : "jpeg");
    return pl_error(PL_E_ARG, "%s: unknown image extension (this build writes .png and .jpg)",
                    path);
}

int pl_image_write_jpeg(const char *path, const pl_image_u8 *img, int quality)
{
    if (!path || !img || !img->data || img->width < 1 || img->height < 1 ||
        img->stride < (size_t)img->width * 3)
        return pl_error(PL_E_ARG, "pl_image_write_jpeg: invalid image or path");
    if (quality < 1 || quality > 100)
        return pl_error(PL_E_ARG, "%s: JPEG quality %d, expected 1..100", path, quality);
    return pl_jpeg_write_rgb8(path, img, quality);
}

int pl_image_decode_jpeg_rgb8_reuse(const uint8_t *data, size_t n, const char *what,
                                    pl_image_u8 *img, size_t *capacity)
{
    if (!what) what = "JPEG frame";
    if (!data || !img || !capacity)
        return pl_error(PL_E_ARG, "pl_image_decode_jpeg_rgb8_reuse: NULL argument");
    if (n < 4 || data[0] != 0xff || data[1] != 0xd8)
        return pl_error(PL_E_FORMAT, "%s: not a JPEG frame (%zu bytes, no start-of-image marker)",
                        what, n);
    size_t end = n;
    while (end > 2 && data[end - 1] == 0)
        end--;
    bool eoi = false;
    for (size_t k = end; k >= 4 && k + 16 >= end; k--) /* EOI at the end, maybe after padding */
        if (data[k - 2] == 0xff && data[k - 1] == 0xd9) {
            eoi = true;
            break;
        }
    if (!eoi)
        return pl_error(PL_E_FORMAT, "%s: truncated JPEG frame (%zu bytes, no end-of-image marker)",
                        what, n);
    /* Width and height from the first SOF before the first scan. */
    long long w = -1, h = -1;
    size_t i = 2;
    for (int guard = 0; guard < 10000 && i + 4 <= n; guard++) {
        if (data[i] != 0xff) break;
        const uint8_t m = data[i + 1];
        if (m == 0xff) {
            i++;
            continue;
        }
        if (m == 0xd8 || m == 0x01 || (m >= 0xd0 && m <= 0xd7)) {
            i += 2;
            continue;
        }
        if (m == 0xd9 || m == 0xda) break;
        const size_t len = be16(data + i + 2);
        if (len < 2) break;
        if (m >= 0xc0 && m <= 0xcf && m != 0xc4 && m != 0xc8 && m != 0xcc) {
            if (i + 9 <= n) {
                h = be16(data + i + 5);
                w = be16(data + i + 7);
            }
            break;
        }
        i += 2 + len;
    }
    if (w < 0) return pl_error(PL_E_FORMAT, "%s: JPEG frame without a frame header (SOF)", what);
    if (pl_image_check_read_size(what, w, h) < 0) return PL_E_FORMAT;
    if (n > (size_t)INT32_MAX) return pl_error(PL_E_FORMAT, "%s: JPEG frame too large", what);
    if (pl_codec_have_jpeg()) return pl_jpeg_decode_rgb8(data, n, what, img, capacity);
    if (pl_codec_have_opencv())
        return pl_cv_image_decode_rgb8(data, n, what, PL_CV_EXIF | PL_CV_KNOWN, img, capacity);
    return pl_error(PL_E_UNSUPPORTED,
                    "%s: this build has neither libjpeg nor OpenCV: cannot decode MJPEG", what);
}
