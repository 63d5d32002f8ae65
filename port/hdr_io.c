/* HDR files: format dispatch, Radiance RGBE reader/writer, panorama check (port/hdr_io.h).
 * The OpenEXR side lives in port/exr_io.cpp. */
#include "port/hdr_io.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/file.h"
#include "core/util.h"

/* RGBE files are read into memory in two steps: the header (at most this many bytes), then as
 * many bytes as the declared size can need at most (rgbe_max_bytes), never the whole file: a
 * tiny header on a huge file costs no more than the image it declares. */
#define RGBE_MAX_HEADER_BYTES ((size_t)1 << 16)

static float sanitize(float v)
{
    if (!(v > 0.0f) || isinf(v)) return 0.0f; /* negatives, NaN, +-Inf */
    return v;
}

static int alloc_rgb(pl_image_f32 *img, int w, int h, const char *path)
{
    size_t n;
    if (w <= 0 || h <= 0 || w > PL_IMAGE_MAX_SIDE || h > PL_IMAGE_MAX_SIDE ||
        (size_t)w * (size_t)h > PL_IMAGE_MAX_PIXELS)
        return pl_error(PL_E_FORMAT, "%s: image size %d x %d outside 1..%d per side, %u pixels",
                        path, w, h, PL_IMAGE_MAX_SIDE, PL_IMAGE_MAX_PIXELS);
    if (!pl_mul_size((size_t)w * (size_t)h, 3 * sizeof(float), &n))
        return pl_error(PL_E_NOMEM, "%s: image size %d x %d overflows", path, w, h);
    img->data = malloc(n);
    if (!img->data)
        return pl_error(PL_E_NOMEM, "%s: cannot allocate %zu bytes for %d x %d", path, n, w, h);
    img->width = w;
    img->height = h;
    return PL_OK;
}

/* Reads the first `max` bytes of the file (all of it when shorter) into a malloc'ed buffer. */
static int read_prefix(const char *path, size_t max, unsigned char **buf, size_t *len)
{
    FILE *f;
    int st = pl_file_fopen_regular(path, NULL, &f);
    if (st < 0) return st;
    unsigned char *b = NULL;
    size_t cap = 0, n = 0;
    while (n < max) {
        if (n == cap) {
            size_t ncap = cap ? cap * 2 : 1 << 16;
            if (ncap > max) ncap = max;
            unsigned char *nb = realloc(b, ncap);
            if (!nb) {
                st = pl_error(PL_E_NOMEM, "%s: cannot allocate %zu bytes", path, ncap);
                goto out;
            }
            b = nb;
            cap = ncap;
        }
        size_t got = fread(b + n, 1, cap - n, f);
        n += got;
        if (got == 0) {
            if (ferror(f)) st = pl_error(PL_E_IO, "%s: read error: %s", path, strerror(errno));
            break;
        }
    }
out:
    fclose(f);
    if (st < 0) {
        free(b);
        return st;
    }
    *buf = b;
    *len = n;
    return PL_OK;
}

/* The checks every reader makes on the size its header declares, before allocating: the read
 * limit (core/image.h) and, for a panorama, the 2:1 shape. */
static int check_declared(const char *path, long long w, long long h, int panorama)
{
    if (panorama && w >= 1 && h >= 1 && (h < 2 || w != 2 * h))
        return pl_error(PL_E_FORMAT,
                        "%s: %lld x %lld is not a 2:1 equirectangular panorama (want width = "
                        "2 x height)",
                        path, w, h);
    return pl_image_check_read_size(path, w, h);
}

int pl_hdr_check_declared(const char *path, long long w, long long h, int panorama)
{
    return check_declared(path, w, h, panorama);
}

/* ---- RGBE ------------------------------------------------------------------------------ */

static void rgbe_to_float(const unsigned char *p, float *rgb)
{
    if (p[3] == 0) {
        rgb[0] = rgb[1] = rgb[2] = 0.0f;
        return;
    }
    float f = ldexpf(1.0f, (int)p[3] - 136);
    rgb[0] = ((float)p[0] + 0.5f) * f;
    rgb[1] = ((float)p[1] + 0.5f) * f;
    rgb[2] = ((float)p[2] + 0.5f) * f;
}

/* Parses the header: fills *w, *h, *flip_y and *pos (offset of the first scanline byte). */
static int rgbe_header(const char *path, const unsigned char *b, size_t len, int panorama, int *w,
                       int *h, int *flip_y, size_t *pos)
{
    size_t p = 0;
    if (!(len >= 2 && b[0] == '#' && b[1] == '?'))
        return pl_error(PL_E_FORMAT, "%s: not a Radiance file (no '#?' magic)", path);
    int format_ok = 0, saw_blank = 0;
    char line[512];
    while (p < len) {
        size_t e = p;
        while (e < len && b[e] != '\n')
            e++;
        if (e == len) break;
        size_t n = e - p;
        if (n >= sizeof line) n = sizeof line - 1;
        memcpy(line, b + p, n);
        line[n] = '\0';
        if (n > 0 && line[n - 1] == '\r') line[--n] = '\0';
        p = e + 1;
        if (n == 0) {
            saw_blank = 1;
            break;
        }
        if (!strncmp(line, "FORMAT=", 7)) {
            if (!strcmp(line + 7, "32-bit_rle_rgbe"))
                format_ok = 1;
            else if (!strcmp(line + 7, "32-bit_rle_xyze"))
                return pl_error(PL_E_UNSUPPORTED, "%s: XYZE Radiance files are not supported",
                                path);
            else
                return pl_error(PL_E_FORMAT, "%s: unknown FORMAT '%s'", path, line + 7);
        }
    }
    if (!saw_blank)
        return pl_error(PL_E_FORMAT, "%s: truncated header (no blank line in its first %zu bytes)",
                        path, len);
    if (!format_ok) format_ok = 1; /* FORMAT is optional; RGBE is the default */
    size_t e = p;
    while (e < len && b[e] != '\n')
        e++;
    if (e == len) return pl_error(PL_E_FORMAT, "%s: truncated header (no resolution line)", path);
    size_t n = e - p;
    if (n >= sizeof line) return pl_error(PL_E_FORMAT, "%s: resolution line too long", path);
    memcpy(line, b + p, n);
    line[n] = '\0';
    char ys, xs, yc, xc;
    long hh, ww;
    char extra;
    if (sscanf(line, " %c%c %ld %c%c %ld %c", &ys, &yc, &hh, &xs, &xc, &ww, &extra) != 6)
        return pl_error(PL_E_FORMAT, "%s: bad resolution line '%s'", path, line);
    if (yc != 'Y' || xc != 'X' || (ys != '-' && ys != '+') || xs != '+')
        return pl_error(PL_E_UNSUPPORTED, "%s: orientation '%s' not supported (want -Y H +X W)",
                        path, line);
    int st = check_declared(path, ww, hh, panorama);
    if (st < 0) return st;
    *w = (int)ww;
    *h = (int)hh;
    *flip_y = ys == '+';
    *pos = e + 1;
    return PL_OK;
}

/* Decodes one scanline of `w` pixels into `out` (4 bytes per pixel); advances *pos. */
static int rgbe_scanline(const char *path, int y, const unsigned char *b, size_t len, size_t *pos,
                         int w, unsigned char *out)
{
    size_t p = *pos;
    if (len - p < 4) return pl_error(PL_E_FORMAT, "%s: truncated at scanline %d", path, y);
    if (w >= 8 && w < 32768 && b[p] == 2 && b[p + 1] == 2 && !(b[p + 2] & 0x80)) {
        int lw = (b[p + 2] << 8) | b[p + 3];
        if (lw != w)
            return pl_error(PL_E_FORMAT, "%s: scanline %d declares width %d, expected %d", path, y,
                            lw, w);
        p += 4;
        for (int c = 0; c < 4; c++) {
            int x = 0;
            while (x < w) {
                if (p >= len) return pl_error(PL_E_FORMAT, "%s: truncated at scanline %d", path, y);
                int count = b[p++];
                if (count > 128) {
                    count -= 128;
                    if (count > w - x || p >= len)
                        return pl_error(PL_E_FORMAT, "%s: bad run (length %d) at scanline %d", path,
                                        count, y);
                    unsigned char v = b[p++];
                    for (int i = 0; i < count; i++)
                        out[4 * (x++) + c] = v;
                } else {
                    if (count == 0 || count > w - x || (size_t)count > len - p)
                        return pl_error(PL_E_FORMAT, "%s: bad literal (length %d) at scanline %d",
                                        path, count, y);
                    for (int i = 0; i < count; i++)
                        out[4 * (x++) + c] = b[p++];
                }
            }
        }
        *pos = p;
        return PL_OK;
    }
    /* flat pixels, with old-style runs (1,1,1,n): repeat the previous pixel n << shift times */
    int x = 0, shift = 0;
    while (x < w) {
        if (len - p < 4) return pl_error(PL_E_FORMAT, "%s: truncated at scanline %d", path, y);
        const unsigned char *q = b + p;
        p += 4;
        if (q[0] == 1 && q[1] == 1 && q[2] == 1) {
            if (x == 0 || shift > 16)
                return pl_error(PL_E_FORMAT, "%s: bad old-style run at scanline %d", path, y);
            long count = (long)q[3] << shift;
            if (count > w - x)
                return pl_error(PL_E_FORMAT, "%s: old-style run past the end of scanline %d", path,
                                y);
            for (long i = 0; i < count; i++, x++)
                memcpy(out + 4 * x, out + 4 * (x - 1), 4);
            shift += 8;
        } else {
            memcpy(out + 4 * x, q, 4);
            x++;
            shift = 0;
        }
    }
    *pos = p;
    return PL_OK;
}

/* The most bytes a w x h RGBE image can take after its header: a new-style RLE scanline of only
 * literals (4 + 4 x (w + one count per 128)), or a flat one (4 x w). */
static size_t rgbe_max_bytes(int w, int h)
{
    unsigned long long rle = 4 + 4 * ((unsigned long long)w + ((unsigned long long)w + 127) / 128);
    unsigned long long flat = 4 * (unsigned long long)w;
    unsigned long long n = (rle > flat ? rle : flat) * (unsigned long long)h;
    return n > SIZE_MAX ? SIZE_MAX : (size_t)n;
}

static int rgbe_read(const char *path, const unsigned char *b, size_t len, int panorama,
                     pl_image_f32 *out)
{
    int w, h, flip, st;
    size_t pos;
    if ((st = rgbe_header(path, b, len, panorama, &w, &h, &flip, &pos)) < 0) return st;
    /* Refuse sizes the file cannot hold before allocating. A new-style RLE scanline takes at
     * least 4 + 4 * 2 bytes per 128 pixels; a flat one a literal pixel and then one old-style run
     * code per byte of the run length (w - 1 = 0x7fff takes two: 12 bytes for 32768 pixels). */
    size_t min_line = 4;
    for (size_t rest = (size_t)w - 1; rest > 0; rest >>= 8)
        min_line += 4;
    if (w >= 8 && w < 32768 && len - pos >= 4 && b[pos] == 2 && b[pos + 1] == 2)
        min_line = 4 + 8 * (((size_t)w + 127) / 128);
    if ((len - pos) / min_line < (size_t)h)
        return pl_error(PL_E_FORMAT, "%s: truncated: %zu bytes of pixel data cannot hold %d x %d",
                        path, len - pos, w, h);
    unsigned char *line = malloc((size_t)w * 4);
    if (!line) return pl_error(PL_E_NOMEM, "%s: cannot allocate a scanline", path);
    pl_image_f32 img;
    if ((st = alloc_rgb(&img, w, h, path)) < 0) {
        free(line);
        return st;
    }
    for (int y = 0; y < h; y++) {
        if ((st = rgbe_scanline(path, y, b, len, &pos, w, line)) < 0) {
            free(line);
            free(img.data);
            return st;
        }
        float *row = img.data + (size_t)(flip ? h - 1 - y : y) * (size_t)w * 3;
        for (int x = 0; x < w; x++)
            rgbe_to_float(line + 4 * x, row + 3 * x);
    }
    free(line);
    *out = img;
    return PL_OK;
}

static void float_to_rgbe(const float *rgb, unsigned char *p)
{
    float r = sanitize(rgb[0]), g = sanitize(rgb[1]), bl = sanitize(rgb[2]);
    float m = r > g ? r : g;
    if (bl > m) m = bl;
    if (m < 1e-32f) {
        p[0] = p[1] = p[2] = p[3] = 0;
        return;
    }
    int e;
    float f = frexpf(m, &e) * 256.0f / m;
    if (e > 127) { /* beyond RGBE's range: saturate */
        p[0] = p[1] = p[2] = 255;
        p[3] = 255;
        return;
    }
    float vr = r * f, vg = g * f, vb = bl * f;
    p[0] = (unsigned char)(vr >= 255.0f ? 255 : (int)vr);
    p[1] = (unsigned char)(vg >= 255.0f ? 255 : (int)vg);
    p[2] = (unsigned char)(vb >= 255.0f ? 255 : (int)vb);
    p[3] = (unsigned char)(e + 128);
}

/* New-style RLE of one channel (stride 4) of n bytes. */
static void rle_channel(FILE *f, const unsigned char *d, int n)
{
    int x = 0;
    while (x < n) {
        int run = 1;
        while (x + run < n && run < 127 && d[4 * (x + run)] == d[4 * x])
            run++;
        if (run >= 3) {
            fputc(128 + run, f);
            fputc(d[4 * x], f);
            x += run;
            continue;
        }
        int start = x, cnt = 0;
        while (x < n && cnt < 128) {
            int r = 1;
            while (x + r < n && r < 3 && d[4 * (x + r)] == d[4 * x])
                r++;
            if (r >= 3) break;
            x++;
            cnt++;
        }
        fputc(cnt, f);
        for (int i = 0; i < cnt; i++)
            fputc(d[4 * (start + i)], f);
    }
}

int pl_hdr_write_rgbe(const char *path, const pl_image_f32 *img)
{
    if (!path || !img || !img->data || img->width <= 0 || img->height <= 0)
        return pl_error(PL_E_ARG, "pl_hdr_write_rgbe: invalid image or path");
    int w = img->width, h = img->height;
    unsigned char *line = malloc((size_t)w * 4);
    if (!line) return pl_error(PL_E_NOMEM, "%s: cannot allocate a scanline", path);
    FILE *f = fopen(path, "wb");
    if (!f) {
        free(line);
        return pl_error(PL_E_IO, "%s: cannot create: %s", path, strerror(errno));
    }
    fprintf(f, "#?RADIANCE\n# written by parlight\nFORMAT=32-bit_rle_rgbe\n\n-Y %d +X %d\n", h, w);
    int rle = w >= 8 && w < 32768;
    for (int y = 0; y < h; y++) {
        const float *row = img->data + (size_t)y * (size_t)w * 3;
        for (int x = 0; x < w; x++)
            float_to_rgbe(row + 3 * x, line + 4 * x);
        if (rle) {
            unsigned char hd[4] = {2, 2, (unsigned char)(w >> 8), (unsigned char)(w & 255)};
            fwrite(hd, 1, 4, f);
            for (int c = 0; c < 4; c++)
                rle_channel(f, line + c, w);
        } else {
            fwrite(line, 4, (size_t)w, f);
        }
    }
    free(line);
    int bad = ferror(f);
    if (fclose(f) != 0 || bad)
        return pl_error(PL_E_IO, "%s: write failed: %s", path, strerror(errno));
    return PL_OK;
}

/* ---- dispatch ------------------------------------------------------------------------------ */

static void sanitize_image(pl_image_f32 *img)
{
    size_t n = (size_t)img->width * (size_t)img->height * 3;
    for (size_t i = 0; i < n; i++)
        img->data[i] = sanitize(img->data[i]);
}

static int hdr_read(const char *path, int panorama, pl_image_f32 *out)
{
    if (!path || !out) return pl_error(PL_E_ARG, "pl_hdr_read: NULL argument");
    unsigned char magic[4] = {0};
    FILE *f; /* refuses a FIFO before OpenEXR could open it (blocking) by name */
    int st = pl_file_fopen_regular(path, NULL, &f);
    if (st < 0) return st;
    size_t got = fread(magic, 1, 4, f);
    fclose(f);
    if (got == 4 && magic[0] == 0x76 && magic[1] == 0x2f && magic[2] == 0x31 && magic[3] == 0x01) {
        st = pl_exr_read_file(path, panorama, out);
    } else if (got >= 2 && magic[0] == '#' && magic[1] == '?') {
        unsigned char *buf = NULL;
        size_t len = 0, pos;
        int w, h, flip;
        if ((st = read_prefix(path, RGBE_MAX_HEADER_BYTES, &buf, &len)) < 0) return st;
        st = rgbe_header(path, buf, len, panorama, &w, &h, &flip, &pos);
        free(buf);
        if (st < 0) return st;
        size_t need;
        if (!pl_add_size(pos, rgbe_max_bytes(w, h), &need)) need = SIZE_MAX;
        if ((st = read_prefix(path, need, &buf, &len)) < 0) return st;
        st = rgbe_read(path, buf, len, panorama, out);
        free(buf);
    } else {
        return pl_error(PL_E_FORMAT,
                        "%s: not an HDR image (%zu-byte magic %02x %02x %02x %02x: "
                        "want OpenEXR 76 2f 31 01 or Radiance '#?')",
                        path, got, magic[0], magic[1], magic[2], magic[3]);
    }
    if (st < 0) return st;
    sanitize_image(out);
    return PL_OK;
}

int pl_hdr_read(const char *path, pl_image_f32 *out)
{
    return hdr_read(path, 0, out);
}

int pl_hdr_read_panorama(const char *path, pl_image_f32 *out)
{
    pl_image_f32 img;
    int st = hdr_read(path, 1, &img);
    if (st < 0) return st;
    if (img.height < 2 || img.width != 2 * img.height) {
        int w = img.width, h = img.height;
        free(img.data);
        return pl_error(PL_E_FORMAT,
                        "%s: %d x %d is not a 2:1 equirectangular panorama (want width = "
                        "2 x height)",
                        path, w, h);
    }
    *out = img;
    return PL_OK;
}

static int has_ext(const char *path, const char *ext)
{
    size_t n = strlen(path), e = strlen(ext);
    if (n < e) return 0;
    for (size_t i = 0; i < e; i++) {
        char c = path[n - e + i];
        if (c >= 'A' && c <= 'Z') c = (char)(c - 'A' + 'a');
        if (c != ext[i]) return 0;
    }
    return 1;
}

int pl_hdr_write_exr(const char *path, const pl_image_f32 *img, pl_exr_type type)
{
    if (!path || !img || !img->data || img->width <= 0 || img->height <= 0)
        return pl_error(PL_E_ARG, "pl_hdr_write_exr: invalid image or path");
    if (type != PL_EXR_FLOAT && type != PL_EXR_HALF)
        return pl_error(PL_E_ARG, "pl_hdr_write_exr: unknown type %d", (int)type);
    return pl_exr_write_file(path, img, type);
}

int pl_hdr_write(const char *path, const pl_image_f32 *img)
{
    if (!path) return pl_error(PL_E_ARG, "pl_hdr_write: NULL path");
    if (has_ext(path, ".exr")) return pl_hdr_write_exr(path, img, PL_EXR_FLOAT);
    if (has_ext(path, ".hdr") || has_ext(path, ".pic")) return pl_hdr_write_rgbe(path, img);
    return pl_error(PL_E_ARG, "%s: unknown HDR extension (want .exr or .hdr)", path);
}
