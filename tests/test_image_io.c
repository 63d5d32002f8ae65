/* port/image_io: round trips through PNG/BMP/PPM (exact) and JPEG (close), the conversions
 * (gray -> RGB, alpha dropped, 16-bit -> 8-bit rounded, float refused), and bad files made at
 * test time in $PL_TEST_TMP (zero bytes, truncated JPEG/PNG, garbage named .jpg, a text file, a
 * directory, a missing file, headers declaring huge sizes): each must give the expected status and
 * a message naming the file, never a crash. Also buffer reuse and the writer's refusals.
 * needs: opencv (tests/run.sh skips this test in a build without it) */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "core/util.h"
#include "port/image.h"
#include "port/test_helpers.h"
#include "tests/check.h"

static char tmpdir[512];

static const char *tmp(const char *name)
{
    static char buf[4][1024];
    static int k;
    k = (k + 1) & 3;
    snprintf(buf[k], sizeof buf[k], "%s/%s", tmpdir, name);
    return buf[k];
}

static unsigned char *slurp(const char *path, size_t *len)
{
    FILE *f = fopen(path, "rb");
    if (!f) return NULL;
    fseek(f, 0, SEEK_END);
    long n = ftell(f);
    fseek(f, 0, SEEK_SET);
    unsigned char *b = malloc((size_t)n + 1);
    if (b && fread(b, 1, (size_t)n, f) != (size_t)n) {
        free(b);
        b = NULL;
    }
    fclose(f);
    *len = (size_t)n;
    return b;
}

static void spit(const char *path, const void *b, size_t len)
{
    FILE *f = fopen(path, "wb");
    if (!f || fwrite(b, 1, len, f) != len) {
        printf("cannot write %s\n", path);
        exit(1);
    }
    fclose(f);
}


static void random_rgb(pl_image_u8 *img, int w, int h)
{
    if (pl_image_u8_alloc(img, w, h) != PL_OK) {
        printf("alloc failed: %s\n", pl_last_error());
        exit(1);
    }
    for (size_t i = 0; i < img->stride * (size_t)h; i++)
        img->data[i] = (uint8_t)rnd();
}

/* Expects `status` from reading `path`, with the path and `word` in the message. */
static void expect_error(const char *path, int status, const char *word)
{
    pl_image_u8 img;
    int rc = pl_image_read_rgb8(path, &img);
    CHECK(rc == status, "%s: got %s, want %s (%s)", path, pl_status_name(rc),
          pl_status_name(status), pl_last_error());
    CHECK(strstr(pl_last_error(), path) != NULL, "message does not name the path: %s",
          pl_last_error());
    CHECK(!word || strstr(pl_last_error(), word) != NULL, "message lacks '%s': %s", word,
          pl_last_error());
    CHECK(img.data == NULL && img.width == 0, "failed read left an image behind");
    printf("  ok: %s\n", pl_last_error());
}

static void test_round_trips(void)
{
    pl_image_u8 a, b;
    random_rgb(&a, 37, 21);
    const char *exact[] = {"rt.png", "rt.bmp", "rt.ppm", "rt.tif"};
    for (size_t k = 0; k < sizeof exact / sizeof exact[0]; k++) {
        const char *p = tmp(exact[k]);
        CHECK(pl_image_write_rgb8(p, &a) == PL_OK, "write %s: %s", p, pl_last_error());
        int rc = pl_image_read_rgb8(p, &b);
        CHECK(rc == PL_OK, "read %s: %s", p, pl_last_error());
        if (rc == PL_OK) {
            CHECK(b.width == 37 && b.height == 21 && b.stride == 37 * 3, "%s: size %dx%d", p,
                  b.width, b.height);
            CHECK(memcmp(a.data, b.data, 37 * 21 * 3) == 0, "%s: pixels differ", p);
            pl_image_u8_free(&b);
        }
    }
    /* JPEG is lossy: a smooth image must come back close, in RGB order (not BGR). */
    for (int y = 0; y < a.height; y++)
        for (int x = 0; x < a.width; x++) {
            uint8_t *p = a.data + (size_t)y * a.stride + 3 * (size_t)x;
            p[0] = 200;
            p[1] = (uint8_t)(x * 3);
            p[2] = 40;
        }
    const char *jp = tmp("rt.jpg");
    CHECK(pl_image_write_rgb8(jp, &a) == PL_OK, "write jpg: %s", pl_last_error());
    if (pl_image_read_rgb8(jp, &b) == PL_OK) {
        long err = 0;
        for (size_t i = 0; i < 37 * 21 * 3; i++)
            err += labs((long)a.data[i] - (long)b.data[i]);
        CHECK(err / (37 * 21 * 3) < 4, "jpeg mean abs error %ld", err / (37 * 21 * 3));
        CHECK(b.data[0] > 180 && b.data[2] < 60, "jpeg channel order: %d %d %d", b.data[0],
              b.data[1], b.data[2]);
        pl_image_u8_free(&b);
    } else {
        CHECK(0, "read jpg: %s", pl_last_error());
    }
    pl_image_u8_free(&a);
}

/* A JPEG with an EXIF orientation tag (6: rotate 90 degrees clockwise to display) comes back
 * rotated: a 16x8 picture, left half red, reads as 8x16 with red on top. */
static void test_exif_orientation(void)
{
    pl_image_u8 a, b;
    if (pl_image_u8_alloc(&a, 16, 8) != PL_OK) exit(1);
    for (int y = 0; y < 8; y++)
        for (int x = 0; x < 16; x++) {
            uint8_t *p = a.data + (size_t)y * a.stride + 3 * (size_t)x;
            p[0] = x < 8 ? 250 : 0;
            p[1] = 0;
            p[2] = x < 8 ? 0 : 250;
        }
    CHECK(pl_image_write_rgb8(tmp("plain.jpg"), &a) == PL_OK, "%s", pl_last_error());
    pl_image_u8_free(&a);
    size_t n;
    unsigned char *j = slurp(tmp("plain.jpg"), &n);
    if (!j) exit(1);
    static const unsigned char app1[] = {
        0xff, 0xe1, 0x00, 0x22, 'E',  'x',  'i',  'f',  0,    0, /* APP1, length 34 */
        'I',  'I',  0x2a, 0x00, 0x08, 0x00, 0x00, 0x00,          /* TIFF header, IFD at 8 */
        0x01, 0x00,                                              /* one entry */
        0x12, 0x01, 0x03, 0x00, 0x01, 0x00, 0x00, 0x00, 0x06, 0x00, 0x00, 0x00, /* orientation 6 */
        0x00, 0x00, 0x00, 0x00};                                                /* no next IFD */
    unsigned char *o = malloc(n + sizeof app1);
    memcpy(o, j, 2);
    memcpy(o + 2, app1, sizeof app1);
    memcpy(o + 2 + sizeof app1, j + 2, n - 2);
    spit(tmp("rotated.jpg"), o, n + sizeof app1);
    free(o);
    free(j);
    if (pl_image_read_rgb8(tmp("rotated.jpg"), &b) == PL_OK) {
        CHECK(b.width == 8 && b.height == 16, "EXIF orientation 6: %dx%d, want 8x16", b.width,
              b.height);
        if (b.width == 8 && b.height == 16) {
            const uint8_t *top = b.data + 2 * b.stride + 3 * 4,
                          *bottom = b.data + 13 * b.stride + 3 * 4;
            CHECK(top[0] > 200 && top[2] < 50 && bottom[0] < 50 && bottom[2] > 200,
                  "rotation direction: top %d,%d bottom %d,%d", top[0], top[2], bottom[0],
                  bottom[2]);
        }
        pl_image_u8_free(&b);
    } else {
        CHECK(0, "rotated.jpg: %s", pl_last_error());
    }
}

static void test_conversions(void)
{
    enum { W = 5, H = 3 };
    /* Gray 8-bit PNG: r = g = b = v. */
    uint8_t gray[W * H];
    for (int i = 0; i < W * H; i++)
        gray[i] = (uint8_t)(i * 17);
    CHECK(pl_test_write_image(tmp("gray.png"), W, H, 1, 8, gray) == PL_OK, "%s", pl_last_error());
    pl_image_u8 img;
    if (pl_image_read_rgb8(tmp("gray.png"), &img) == PL_OK) {
        int bad = 0;
        for (int i = 0; i < W * H; i++)
            bad += img.data[3 * i] != gray[i] || img.data[3 * i + 1] != gray[i] ||
                   img.data[3 * i + 2] != gray[i];
        CHECK(bad == 0 && img.width == W && img.height == H, "gray: %d pixels wrong", bad);
        pl_image_u8_free(&img);
    } else {
        CHECK(0, "gray: %s", pl_last_error());
    }
    /* BGRA PNG: colour kept, alpha dropped (not composited). */
    uint8_t bgra[W * H * 4];
    for (int i = 0; i < W * H; i++) {
        bgra[4 * i] = (uint8_t)i;             /* B */
        bgra[4 * i + 1] = (uint8_t)(100 + i); /* G */
        bgra[4 * i + 2] = (uint8_t)(200 + i); /* R */
        bgra[4 * i + 3] = (uint8_t)(i * 10);  /* A, 0 for the first pixel */
    }
    CHECK(pl_test_write_image(tmp("rgba.png"), W, H, 4, 8, bgra) == PL_OK, "%s", pl_last_error());
    if (pl_image_read_rgb8(tmp("rgba.png"), &img) == PL_OK) {
        int bad = 0;
        for (int i = 0; i < W * H; i++)
            bad += img.data[3 * i] != 200 + i || img.data[3 * i + 1] != 100 + i ||
                   img.data[3 * i + 2] != i;
        CHECK(bad == 0, "rgba: %d pixels wrong", bad);
        pl_image_u8_free(&img);
    } else {
        CHECK(0, "rgba: %s", pl_last_error());
    }
    /* 16-bit: v*255/65535 rounded to nearest, including values just around the .5 boundaries. */
    uint16_t v16[W * H * 3];
    const uint16_t probes[] = {0,   1,     128,   129,   256,   257,   385,
                               386, 32767, 32768, 65406, 65407, 65534, 65535};
    for (int i = 0; i < W * H * 3; i++)
        v16[i] = i < 14 ? probes[i] : (uint16_t)rnd();
    CHECK(pl_test_write_image(tmp("deep.png"), W, H, 3, 16, v16) == PL_OK, "%s", pl_last_error());
    if (pl_image_read_rgb8(tmp("deep.png"), &img) == PL_OK) {
        int bad = 0;
        for (int i = 0; i < W * H; i++)
            for (int c = 0; c < 3; c++) {
                uint32_t v = v16[3 * i + (2 - c)]; /* file is BGR */
                uint8_t want = (uint8_t)((v * 255 + 32767) / 65535);
                double exact = v * 255.0 / 65535.0;
                if (img.data[3 * i + c] != want || (double)want - exact > 0.5 ||
                    exact - (double)want > 0.5) {
                    if (bad++ < 5)
                        printf("  16-bit %u -> %u, want %u\n", v, img.data[3 * i + c], want);
                }
            }
        CHECK(bad == 0, "16-bit: %d values wrong", bad);
        pl_image_u8_free(&img);
    } else {
        CHECK(0, "16-bit: %s", pl_last_error());
    }
    /* 16-bit gray. */
    uint16_t g16[W * H];
    for (int i = 0; i < W * H; i++)
        g16[i] = (uint16_t)(i * 4000);
    CHECK(pl_test_write_image(tmp("gray16.png"), W, H, 1, 16, g16) == PL_OK, "%s", pl_last_error());
    if (pl_image_read_rgb8(tmp("gray16.png"), &img) == PL_OK) {
        int bad = 0;
        for (int i = 0; i < W * H; i++) {
            uint8_t want = (uint8_t)(((uint32_t)g16[i] * 255 + 32767) / 65535);
            bad += img.data[3 * i] != want || img.data[3 * i + 2] != want;
        }
        CHECK(bad == 0, "16-bit gray: %d pixels wrong", bad);
        pl_image_u8_free(&img);
    } else {
        CHECK(0, "16-bit gray: %s", pl_last_error());
    }
    /* Float (Radiance .hdr): refused, not tone-mapped. */
    float f[W * H * 3];
    for (int i = 0; i < W * H * 3; i++)
        f[i] = 0.5f * (float)i;
    CHECK(pl_test_write_image(tmp("float.hdr"), W, H, 3, 32, f) == PL_OK, "%s", pl_last_error());
    expect_error(tmp("float.hdr"), PL_E_UNSUPPORTED, "float");
}

static void test_bad_files(void)
{
    pl_image_u8 a;
    random_rgb(&a, 64, 48);
    CHECK(pl_image_write_rgb8(tmp("good.jpg"), &a) == PL_OK, "%s", pl_last_error());
    CHECK(pl_image_write_rgb8(tmp("good.png"), &a) == PL_OK, "%s", pl_last_error());
    CHECK(pl_image_write_rgb8(tmp("good.bmp"), &a) == PL_OK, "%s", pl_last_error());
    pl_image_u8_free(&a);
    size_t jn, pn, bn;
    unsigned char *jpg = slurp(tmp("good.jpg"), &jn), *png = slurp(tmp("good.png"), &pn),
                  *bmp = slurp(tmp("good.bmp"), &bn);
    if (!jpg || !png || !bmp) {
        printf("cannot read back fixtures\n");
        exit(1);
    }

    spit(tmp("trunc.jpg"), jpg, jn / 2);
    expect_error(tmp("trunc.jpg"), PL_E_FORMAT, "truncated");
    spit(tmp("trunc-head.jpg"), jpg, 20);
    expect_error(tmp("trunc-head.jpg"), PL_E_FORMAT, "JPEG");
    spit(tmp("trunc.png"), png, pn * 2 / 3);
    expect_error(tmp("trunc.png"), PL_E_FORMAT, "truncated");
    spit(tmp("trunc-head.png"), png, 20);
    expect_error(tmp("trunc-head.png"), PL_E_FORMAT, "IHDR");
    unsigned char *q = malloc(pn);
    memcpy(q, png, pn);
    q[pn / 2] ^= 0x55; /* inside the pixel data: the chunk CRC no longer matches */
    spit(tmp("crc.png"), q, pn);
    expect_error(tmp("crc.png"), PL_E_FORMAT, "CRC");
    free(q);
    q = malloc(bn);
    memcpy(q, bmp, bn);
    q[30] = 9; /* compression 9: not a BMP compression OpenCV knows */
    spit(tmp("comp.bmp"), q, bn);
    expect_error(tmp("comp.bmp"), PL_E_UNSUPPORTED, "compression");
    free(q);
    spit(tmp("trunc.bmp"), bmp, bn / 2);
    expect_error(tmp("trunc.bmp"), PL_E_FORMAT, "truncated BMP");
    spit(tmp("zero.png"), "", 0);
    expect_error(tmp("zero.png"), PL_E_FORMAT, "empty");
    unsigned char junk[4096];
    for (size_t i = 0; i < sizeof junk; i++)
        junk[i] = (unsigned char)rnd();
    junk[0] = 0x42; /* not a JPEG/PNG signature by chance */
    spit(tmp("garbage.jpg"), junk, sizeof junk);
    expect_error(tmp("garbage.jpg"), PL_E_FORMAT, "not an image");
    const char *text = "this is a text file, not a picture\n";
    spit(tmp("notes.png"), text, strlen(text));
    expect_error(tmp("notes.png"), PL_E_FORMAT, "not an image");
    expect_error(tmp("missing.png"), PL_E_IO, "No such file");
    expect_error(tmpdir, PL_E_IO, "directory");

    /* Decompression bombs: headers declaring huge sizes are refused before decoding. */
    unsigned char *p = malloc(pn);
    memcpy(p, png, pn);
    p[16] = 0;
    p[17] = 0x01;
    p[18] = 0x86;
    p[19] = 0xa0; /* width 100000 */
    spit(tmp("bomb.png"), p, pn);
    expect_error(tmp("bomb.png"), PL_E_FORMAT, "100000x48");
    memcpy(p, png, pn);
    p[16] = 0;
    p[17] = 0;
    p[18] = 0x7f;
    p[19] = 0xff; /* 32767 x 32767: each side fine, too many pixels */
    p[20] = 0;
    p[21] = 0;
    p[22] = 0x7f;
    p[23] = 0xff;
    spit(tmp("bomb2.png"), p, pn);
    expect_error(tmp("bomb2.png"), PL_E_FORMAT, "pixels");
    free(p);
    p = malloc(jn);
    memcpy(p, jpg, jn);
    int patched = 0;
    for (size_t i = 2; i + 9 < jn; i++)
        if (p[i] == 0xff && (p[i + 1] == 0xc0 || p[i + 1] == 0xc2)) {
            p[i + 5] = 0xff;
            p[i + 6] = 0xff;
            p[i + 7] = 0xff;
            p[i + 8] = 0xff; /* 65535 x 65535 */
            patched = 1;
            break;
        }
    CHECK(patched, "no SOF marker found in the JPEG fixture");
    spit(tmp("bomb.jpg"), p, jn);
    expect_error(tmp("bomb.jpg"), PL_E_FORMAT, "65535x65535");
    free(p);
    p = malloc(bn);
    memcpy(p, bmp, bn);
    p[18] = 0x40;
    p[19] = 0x9c;
    p[20] = 0;
    p[21] = 0; /* width 40000 */
    spit(tmp("bomb.bmp"), p, bn);
    expect_error(tmp("bomb.bmp"), PL_E_FORMAT, "40000");
    free(p);

    /* Unreadable file (root reads anything: skip that part). */
    if (geteuid() != 0) {
        spit(tmp("locked.png"), png, pn);
        chmod(tmp("locked.png"), 0);
        expect_error(tmp("locked.png"), PL_E_IO, "Permission denied");
    }
    free(jpg);
    free(png);
    free(bmp);
}

/* Mutated and truncated copies of valid files: any status but a crash, and a message when it fails.
 * Run under ASan/valgrind this is a small fuzzer for the header checks in front of OpenCV. */
static void test_mutations(void)
{
    const char *names[] = {"good.jpg", "good.png", "good.bmp"};
    const char *outs[] = {"mut.jpg", "mut.png", "mut.bmp"};
    pl_image_u8 img = {0, 0, 0, NULL};
    size_t cap = 0;
    int ok = 0, failed = 0;
    for (int k = 0; k < 3; k++) {
        size_t n;
        unsigned char *orig = slurp(tmp(names[k]), &n);
        unsigned char *b = malloc(n);
        if (!orig || !b) exit(1);
        for (int it = 0; it < 100; it++) {
            memcpy(b, orig, n);
            size_t len = n;
            if (it % 4 == 3) {
                len = rnd() % n;
            } else {
                int flips = 1 + (int)(rnd() % 8);
                for (int f = 0; f < flips; f++) {
                    /* Mostly the first 200 bytes, where the headers are. */
                    size_t at = (rnd() & 1) ? rnd() % (n < 200 ? n : 200) : rnd() % n;
                    b[at] = (unsigned char)rnd();
                }
            }
            spit(tmp(outs[k]), b, len);
            int rc = pl_image_read_rgb8_reuse(tmp(outs[k]), &img, &cap);
            if (rc == PL_OK) {
                ok++;
                CHECK(img.width >= 1 && img.height >= 1 && img.width <= PL_IMAGE_MAX_SIDE,
                      "mutant size");
            } else {
                failed++;
                CHECK(rc == PL_E_FORMAT || rc == PL_E_UNSUPPORTED, "mutant %s #%d: %s", outs[k], it,
                      pl_status_name(rc));
                CHECK(strstr(pl_last_error(), outs[k]) != NULL, "mutant message: %s",
                      pl_last_error());
            }
        }
        free(orig);
        free(b);
    }
    printf("  mutants: %d decoded, %d refused\n", ok, failed);
    pl_image_u8_free(&img);
}

static void test_reuse_and_args(void)
{
    pl_image_u8 a, img = {0, 0, 0, NULL};
    size_t cap = 0;
    random_rgb(&a, 40, 30);
    CHECK(pl_image_write_rgb8(tmp("big.png"), &a) == PL_OK, "%s", pl_last_error());
    pl_image_u8_free(&a);
    random_rgb(&a, 10, 10);
    CHECK(pl_image_write_rgb8(tmp("small.png"), &a) == PL_OK, "%s", pl_last_error());
    CHECK(pl_image_read_rgb8_reuse(tmp("big.png"), &img, &cap) == PL_OK, "%s", pl_last_error());
    uint8_t *first = img.data;
    CHECK(cap == 40 * 30 * 3, "capacity %zu", cap);
    CHECK(pl_image_read_rgb8_reuse(tmp("small.png"), &img, &cap) == PL_OK, "%s", pl_last_error());
    CHECK(img.data == first && cap == 40 * 30 * 3 && img.width == 10 && img.stride == 30,
          "smaller image did not reuse the buffer");
    CHECK(memcmp(img.data, a.data, 300) == 0, "reused buffer holds wrong pixels");
    CHECK(pl_image_read_rgb8_reuse(tmp("zero.png"), &img, &cap) == PL_E_FORMAT,
          "bad file in reuse");
    pl_image_u8_free(&img);

    /* Writer refusals: unknown extension (nothing written), missing directory, bad image. */
    CHECK(pl_image_write_rgb8(tmp("out.xyz"), &a) == PL_E_ARG, "unknown extension: %s",
          pl_last_error());
    CHECK(strstr(pl_last_error(), "extension") != NULL, "%s", pl_last_error());
    CHECK(access(tmp("out.xyz"), F_OK) != 0, "a file was written for an unknown extension");
    CHECK(pl_image_write_rgb8(tmp("noext"), &a) == PL_E_ARG, "no extension: %s", pl_last_error());
    CHECK(pl_image_write_rgb8(tmp("no/such/dir/x.png"), &a) == PL_E_IO, "missing dir: %s",
          pl_last_error());
    CHECK(pl_image_write_rgb8(tmpdir, &a) == PL_E_ARG, "directory as output: %s", pl_last_error());
    pl_image_u8 bad = a;
    bad.stride = 5;
    CHECK(pl_image_write_rgb8(tmp("bad.png"), &bad) == PL_E_ARG, "short stride");
    pl_image_u8_free(&a);
    CHECK(pl_image_read_rgb8(NULL, &img) == PL_E_ARG, "NULL path");
    CHECK(pl_image_read_rgb8(tmp("small.png"), NULL) == PL_E_ARG, "NULL out");

    /* Allocation limits. */
    CHECK(pl_image_u8_alloc(&img, 0, 10) == PL_E_ARG && img.data == NULL, "zero width");
    CHECK(pl_image_u8_alloc(&img, PL_IMAGE_MAX_SIDE + 1, 1) == PL_E_ARG, "too wide");
    CHECK(pl_image_u8_alloc(&img, PL_IMAGE_MAX_SIDE, PL_IMAGE_MAX_SIDE) == PL_E_ARG,
          "too many pixels");
    pl_image_f32 f;
    CHECK(pl_image_f32_alloc(&f, 3, 2) == PL_OK && f.data != NULL, "f32 alloc");
    pl_image_f32_free(&f);
    CHECK(f.data == NULL, "f32 free zeroes");
    pl_image_f32_free(&f);
    CHECK(pl_image_f32_alloc(&f, -1, 2) == PL_E_ARG, "f32 negative");
}

int main(void)
{
    const char *t = getenv("PL_TEST_TMP");
    snprintf(tmpdir, sizeof tmpdir, "%s/image_io", t && t[0] ? t : "/tmp");
    mkdir(tmpdir, 0755);
    test_round_trips();
    test_conversions();
    test_exif_orientation();
    test_bad_files();
    test_mutations();
    test_reuse_and_args();
    if (failures) {
        printf("%d failures\n", failures);
        return 1;
    }
    printf("all image_io tests passed\n");
    return 0;
}
