/* The JPEG and PNG decoders in port/ (libjpeg, libpng directly) against OpenCV's imdecode, pixel
 * for pixel (tolerance 0): the sample and golden frames, whose expected outputs depend on the
 * decoded pixels, and variants made here (EXIF orientations 1..8, grayscale, CMYK and progressive
 * JPEG; gray, gray+alpha, palette with tRNS, interlaced, 16-bit PNG). Also the writers: what
 * they write reads back exactly (PNG) or close (JPEG).
 * Skips (77) when the build lacks libjpeg, libpng or OpenCV: it needs both sides. */
#include "core/util.h"
#include "port/image.h"
#include "port/image_codec.h"
#include "port/test_helpers.h"

#include <dirent.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#if defined(PL_HAVE_LIBJPEG) && defined(PL_HAVE_LIBPNG)
#include <jpeglib.h>
#include <png.h>
#endif

#include "tests/check.h"

static char tmpdir[512];
static int compared;

static const char *tmp(const char *name)
{
    static char buf[4][640];
    static int k;
    k = (k + 1) % 4;
    snprintf(buf[k], sizeof buf[k], "%s/%s", tmpdir, name);
    return buf[k];
}

static unsigned char *slurp(const char *path, size_t *n)
{
    FILE *f = fopen(path, "rb");
    if (!f) return NULL;
    fseek(f, 0, SEEK_END);
    long len = ftell(f);
    fseek(f, 0, SEEK_SET);
    unsigned char *b = len > 0 ? malloc((size_t)len) : NULL;
    if (b && fread(b, 1, (size_t)len, f) != (size_t)len) {
        free(b);
        b = NULL;
    }
    fclose(f);
    *n = (size_t)len;
    return b;
}

static void spit(const char *path, const void *p, size_t n)
{
    FILE *f = fopen(path, "wb");
    if (!f || fwrite(p, 1, n, f) != n) {
        fprintf(stderr, "cannot write %s\n", path);
        exit(1);
    }
    fclose(f);
}

/* pl_image_read_rgb8 (native for JPEG/PNG) against OpenCV's decoder on the same bytes. */
static void same_as_opencv(const char *path, int exif)
{
    size_t n;
    unsigned char *b = slurp(path, &n);
    CHECK(b != NULL, "%s: cannot read", path);
    if (!b) return;
    pl_image_u8 a = {0, 0, 0, NULL}, c = {0, 0, 0, NULL};
    size_t ca = 0, cc = 0;
    int ra = pl_image_read_rgb8_reuse(path, &a, &ca);
    char msg[256];
    snprintf(msg, sizeof msg, "%s", pl_last_error());
    int rb = pl_cv_image_decode_rgb8(b, n, path, (exif ? PL_CV_EXIF : 0) | PL_CV_KNOWN, &c, &cc);
    CHECK(ra == PL_OK, "%s: native: %s", path, msg);
    CHECK(rb == PL_OK, "%s: OpenCV: %s", path, pl_last_error());
    if (ra == PL_OK && rb == PL_OK) {
        CHECK(a.width == c.width && a.height == c.height, "%s: %dx%d native, %dx%d OpenCV", path,
              a.width, a.height, c.width, c.height);
        if (a.width == c.width && a.height == c.height) {
            long diff = 0;
            for (int y = 0; y < a.height; y++)
                for (int x = 0; x < 3 * a.width; x++)
                    diff += a.data[(size_t)y * a.stride + (size_t)x] !=
                            c.data[(size_t)y * c.stride + (size_t)x];
            CHECK(diff == 0, "%s: %ld values differ from OpenCV's", path, diff);
            compared++;
        }
    }
    pl_image_u8_free(&a);
    pl_image_u8_free(&c);
    free(b);
}

static void folder(const char *dir, const char *ext)
{
    DIR *d = opendir(dir);
    CHECK(d != NULL, "cannot open %s", dir);
    if (!d) return;
    struct dirent *e;
    while ((e = readdir(d))) {
        size_t l = strlen(e->d_name);
        if (l < 4 || strcmp(e->d_name + l - 4, ext) != 0) continue;
        char p[1024];
        snprintf(p, sizeof p, "%s/%s", dir, e->d_name);
        same_as_opencv(p, strcmp(ext, ".jpg") == 0);
    }
    closedir(d);
}

/* A w x h test picture with structure in both axes and every channel. */
static uint8_t *picture(int w, int h)
{
    uint8_t *p = malloc((size_t)w * (size_t)h * 4 * 2);
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            uint8_t *q = p + ((size_t)y * (size_t)w + (size_t)x) * 3;
            q[0] = (uint8_t)(x * 255 / (w - 1));
            q[1] = (uint8_t)(y * 255 / (h - 1));
            q[2] = (uint8_t)((x + y) * 255 / (w + h - 2));
        }
    return p;
}

#if defined(PL_HAVE_LIBJPEG) && defined(PL_HAVE_LIBPNG)
/* JPEG with libjpeg: components 1 (gray), 3 (RGB) or 4 (CMYK, Adobe marker), progressive. */
static void write_jpeg(const char *path, int w, int h, int comps, int progressive)
{
    struct jpeg_compress_struct c;
    struct jpeg_error_mgr e;
    c.err = jpeg_std_error(&e);
    jpeg_create_compress(&c);
    FILE *f = fopen(path, "wb");
    if (!f) exit(1);
    jpeg_stdio_dest(&c, f);
    c.image_width = (JDIMENSION)w;
    c.image_height = (JDIMENSION)h;
    c.input_components = comps;
    c.in_color_space = comps == 1 ? JCS_GRAYSCALE : comps == 3 ? JCS_RGB : JCS_CMYK;
    jpeg_set_defaults(&c);
    jpeg_set_quality(&c, 90, TRUE);
    if (progressive) jpeg_simple_progression(&c);
    jpeg_start_compress(&c, TRUE);
    uint8_t *rgb = picture(w, h), *row = malloc((size_t)w * 4);
    while (c.next_scanline < c.image_height) {
        const uint8_t *s = rgb + (size_t)c.next_scanline * (size_t)w * 3;
        for (int x = 0; x < w; x++)
            for (int k = 0; k < comps; k++)
                row[x * comps + k] = comps == 4 && k == 3 ? (uint8_t)(255 - x) : s[3 * x + k % 3];
        JSAMPROW r = row;
        jpeg_write_scanlines(&c, &r, 1);
    }
    jpeg_finish_compress(&c);
    jpeg_destroy_compress(&c);
    fclose(f);
    free(rgb);
    free(row);
}

/* PNG with libpng: any colour type and depth, optional tRNS and Adam7 interlacing. */
static void write_png(const char *path, int w, int h, int type, int depth, int trns, int adam7)
{
    png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, NULL, NULL, NULL);
    png_infop info = png_create_info_struct(png);
    FILE *f = fopen(path, "wb");
    if (!f || setjmp(png_jmpbuf(png))) exit(1);
    png_init_io(png, f);
    png_set_IHDR(png, info, (png_uint_32)w, (png_uint_32)h, depth, type,
                 adam7 ? PNG_INTERLACE_ADAM7 : PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT,
                 PNG_FILTER_TYPE_DEFAULT);
    png_color pal[256];
    png_byte alpha[256];
    const int entries = 1 << depth;
    for (int i = 0; i < 256; i++) {
        pal[i].red = (png_byte)(i * 17), pal[i].green = (png_byte)(255 - i * 17);
        pal[i].blue = (png_byte)(i * 5);
        alpha[i] = (png_byte)(i * 16);
    }
    if (type == PNG_COLOR_TYPE_PALETTE) png_set_PLTE(png, info, pal, entries);
    png_color_16 tv = {0, 3, 3, 3, 3};
    if (trns) png_set_tRNS(png, info, alpha, type == PNG_COLOR_TYPE_PALETTE ? entries : 0, &tv);
    png_write_info(png, info);
    const int ch = (type & PNG_COLOR_MASK_COLOR ? 3 : 1) + (type & PNG_COLOR_MASK_ALPHA ? 1 : 0);
    const int samples = type == PNG_COLOR_TYPE_PALETTE ? 1 : ch;
    const size_t rowbytes = ((size_t)w * (size_t)samples * (size_t)depth + 7) / 8;
    png_bytep img = calloc((size_t)h, rowbytes);
    png_bytep *rows = malloc(sizeof *rows * (size_t)h);
    for (int y = 0; y < h; y++) {
        rows[y] = img + (size_t)y * rowbytes;
        for (size_t i = 0; i < rowbytes; i++)
            rows[y][i] = (png_byte)(type == PNG_COLOR_TYPE_PALETTE ? (i * 3 + (size_t)y * 5) * 17
                                                                   : i * 37 + (size_t)y * 11);
    }
    png_write_image(png, rows);
    png_write_end(png, info);
    png_destroy_write_struct(&png, &info);
    fclose(f);
    free(rows);
    free(img);
}
#endif

static void exif_variants(void)
{
    pl_image_u8 a;
    if (pl_image_u8_alloc(&a, 24, 10) != PL_OK) exit(1);
    uint8_t *p = picture(24, 10);
    for (int y = 0; y < 10; y++)
        memcpy(a.data + (size_t)y * a.stride, p + (size_t)y * 72, 72);
    free(p);
    CHECK(pl_image_write_rgb8(tmp("plain.jpg"), &a) == PL_OK, "%s", pl_last_error());
    pl_image_u8_free(&a);
    size_t n;
    unsigned char *j = slurp(tmp("plain.jpg"), &n);
    if (!j) exit(1);
    for (int o = 0; o <= 9; o++) { /* 0 and 9: invalid values, ignored */
        for (int be = 0; be < 2; be++) {
            unsigned char app1[] = {
                0xff, 0xe1, 0x00, 0x22, 'E', 'x', 'i', 'f', 0, 0, 'I', 'I', 0x2a, 0x00, 0x08, 0x00,
                0x00, 0x00, 0x01, 0x00, 0x12, 0x01, 0x03, 0x00, 0x01, 0x00, 0x00, 0x00,
                (unsigned char)o, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00};
            if (be) { /* the same in Motorola byte order */
                static const unsigned char mm[] = {'M', 'M', 0x00, 0x2a, 0x00, 0x00, 0x00, 0x08,
                                                   0x00, 0x01, 0x01, 0x12, 0x00, 0x03, 0x00, 0x00,
                                                   0x00, 0x01, 0x00, 0x00, 0x00, 0x00};
                memcpy(app1 + 10, mm, sizeof mm);
                app1[10 + 18] = 0, app1[10 + 19] = (unsigned char)o;
            }
            unsigned char *o2 = malloc(n + sizeof app1);
            memcpy(o2, j, 2);
            memcpy(o2 + 2, app1, sizeof app1);
            memcpy(o2 + 2 + sizeof app1, j + 2, n - 2);
            char name[64];
            snprintf(name, sizeof name, "exif%d%s.jpg", o, be ? "mm" : "ii");
            spit(tmp(name), o2, n + sizeof app1);
            free(o2);
            same_as_opencv(tmp(name), 1);
        }
    }
    free(j);
}

int main(void)
{
    if (!pl_codec_have_jpeg() || !pl_codec_have_png() || !pl_codec_have_opencv()) {
        printf("skip: this build lacks %s (needs libjpeg, libpng and OpenCV to compare them)\n",
               !pl_codec_have_jpeg() ? "libjpeg" : !pl_codec_have_png() ? "libpng" : "OpenCV");
        return 77;
    }
    const char *base = getenv("PL_TEST_TMP");
    snprintf(tmpdir, sizeof tmpdir, "%s/image_codec.XXXXXX", base ? base : "/tmp");
    if (!mkdtemp(tmpdir)) {
        perror("mkdtemp");
        return 1;
    }
    folder("tests/data/frames", ".jpg");
    folder("tests/data/golden-frames", ".png");
    exif_variants();
#if defined(PL_HAVE_LIBJPEG) && defined(PL_HAVE_LIBPNG)
    write_jpeg(tmp("gray.jpg"), 33, 17, 1, 0);
    write_jpeg(tmp("cmyk.jpg"), 33, 17, 4, 0);
    write_jpeg(tmp("prog.jpg"), 65, 31, 3, 1);
    same_as_opencv(tmp("gray.jpg"), 1);
    same_as_opencv(tmp("cmyk.jpg"), 1);
    same_as_opencv(tmp("prog.jpg"), 1);
    static const struct {
        const char *name;
        int type, depth, trns, adam7;
    } pngs[] = {
        {"g1.png", PNG_COLOR_TYPE_GRAY, 1, 0, 0},       {"g4t.png", PNG_COLOR_TYPE_GRAY, 4, 1, 0},
        {"g8.png", PNG_COLOR_TYPE_GRAY, 8, 0, 1},       {"g16t.png", PNG_COLOR_TYPE_GRAY, 16, 1, 0},
        {"ga8.png", PNG_COLOR_TYPE_GRAY_ALPHA, 8, 0, 1}, {"ga16.png", PNG_COLOR_TYPE_GRAY_ALPHA, 16, 0, 0},
        {"p4t.png", PNG_COLOR_TYPE_PALETTE, 4, 1, 0},   {"p8.png", PNG_COLOR_TYPE_PALETTE, 8, 0, 1},
        {"rgb8t.png", PNG_COLOR_TYPE_RGB, 8, 1, 0},     {"rgb16.png", PNG_COLOR_TYPE_RGB, 16, 0, 1},
        {"rgba8.png", PNG_COLOR_TYPE_RGBA, 8, 0, 0},    {"rgba16.png", PNG_COLOR_TYPE_RGBA, 16, 0, 1},
    };
    for (size_t i = 0; i < sizeof pngs / sizeof pngs[0]; i++) {
        write_png(tmp(pngs[i].name), 19, 7, pngs[i].type, pngs[i].depth, pngs[i].trns,
                  pngs[i].adam7);
        same_as_opencv(tmp(pngs[i].name), 0);
    }
#endif
    /* Writers: PNG is lossless; JPEG round-trips closely, with the channels in order. */
    pl_image_u8 a, b;
    if (pl_image_u8_alloc(&a, 41, 23) != PL_OK) return 1;
    uint8_t *p = picture(41, 23);
    memcpy(a.data, p, 41 * 23 * 3);
    free(p);
    CHECK(pl_png_write_rgb8(tmp("w.png"), &a) == PL_OK, "%s", pl_last_error());
    CHECK(pl_image_read_rgb8(tmp("w.png"), &b) == PL_OK, "%s", pl_last_error());
    CHECK(b.data && memcmp(a.data, b.data, 41 * 23 * 3) == 0, "PNG round trip differs");
    pl_image_u8_free(&b);
    same_as_opencv(tmp("w.png"), 0);
    CHECK(pl_jpeg_write_rgb8(tmp("w.jpg"), &a, 95) == PL_OK, "%s", pl_last_error());
    CHECK(pl_image_read_rgb8(tmp("w.jpg"), &b) == PL_OK, "%s", pl_last_error());
    long err = 0;
    for (size_t i = 0; b.data && i < 41 * 23 * 3; i++)
        err += labs((long)a.data[i] - (long)b.data[i]);
    CHECK(b.data && err / (41 * 23 * 3) < 4, "JPEG round trip: mean abs error %ld",
          err / (41 * 23 * 3));
    pl_image_u8_free(&b);
    same_as_opencv(tmp("w.jpg"), 1);
    CHECK(pl_jpeg_write_rgb8(tmp("q0.jpg"), &a, 0) == PL_E_ARG, "quality 0 accepted");
    CHECK(pl_png_write_rgb8(tmp("no/such/dir.png"), &a) == PL_E_IO, "missing folder: %s",
          pl_last_error());
    pl_image_u8_free(&a);
    printf("%d images identical to OpenCV's decoding\n", compared);
    if (failures) fprintf(stderr, "%d checks failed\n", failures);
    return failures ? 1 : 0;
}
