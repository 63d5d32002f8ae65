/* port/source: a directory of mixed files (name order differs from creation order, hidden files,
 * a sub-directory, text and zero-byte files as bad frames), empty and all-bad directories, a still
 * image, a small MJPG video written at test time with cv::VideoWriter, and bad paths. Fixtures
 * live in $PL_TEST_TMP.
 * needs: opencv (tests/run.sh skips this test in a build without it) */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "core/util.h"
#include "port/image.h"
#include "port/source.h"
#include "port/test_helpers.h"
#include "tests/check.h"

static char tmpdir[512];

static const char *tmp(const char *name)
{
    static char buf[8][1024];
    static int k;
    k = (k + 1) & 7;
    snprintf(buf[k], sizeof buf[k], "%s/%s", tmpdir, name);
    return buf[k];
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

/* Writes a uniform w x h image of colour (r, g, b). */
static void write_uniform(const char *path, int w, int h, int r, int g, int b)
{
    pl_image_u8 img;
    if (pl_image_u8_alloc(&img, w, h) != PL_OK) exit(1);
    for (int i = 0; i < w * h; i++) {
        img.data[3 * i] = (uint8_t)r;
        img.data[3 * i + 1] = (uint8_t)g;
        img.data[3 * i + 2] = (uint8_t)b;
    }
    if (pl_image_write_rgb8(path, &img) != PL_OK) {
        printf("fixture %s: %s\n", path, pl_last_error());
        exit(1);
    }
    pl_image_u8_free(&img);
}

static int near(int a, int b, int tol)
{
    return a - b <= tol && b - a <= tol;
}

static void test_directory(void)
{
    const char *d = tmp("frames");
    mkdir(d, 0755);
    char p[1100];
    /* Created in an order unlike the name order; sizes vary so the buffer grows and shrinks. */
#define F(name) (snprintf(p, sizeof p, "%s/%s", d, name), p)
    write_uniform(F("e.bmp"), 8, 6, 50, 60, 70);
    spit(F("c.txt"), "hello\n", 6);
    write_uniform(F("b.png"), 40, 30, 10, 20, 30);
    write_uniform(F("A.png"), 16, 12, 200, 100, 0);
    spit(F("d.png"), "", 0);
    write_uniform(F("a.jpg"), 32, 24, 0, 128, 255);
    write_uniform(F(".hidden.png"), 4, 4, 1, 2, 3);
    mkdir(F("sub"), 0755);
    write_uniform(F("sub/x.png"), 4, 4, 1, 2, 3);
#undef F
    pl_source *s;
    int rc = pl_source_open_path(d, &s);
    CHECK(rc == PL_OK, "open dir: %s", pl_last_error());
    if (rc != PL_OK) return;
    char want_desc[1100];
    snprintf(want_desc, sizeof want_desc, "dir:%s", d);
    CHECK(strcmp(pl_source_describe(s), want_desc) == 0, "describe: %s", pl_source_describe(s));
    double fps;
    CHECK(pl_source_fps(s, &fps) == PL_E_UNSUPPORTED, "a directory has no fps");

    struct {
        const char *name;
        int rc, w, h, r, g, b;
    } want[] = {
        {"A.png", PL_OK, 16, 12, 200, 100, 0}, {"a.jpg", PL_OK, 32, 24, 0, 128, 255},
        {"b.png", PL_OK, 40, 30, 10, 20, 30},  {"c.txt", PL_E_FORMAT, 0, 0, 0, 0, 0},
        {"d.png", PL_E_FORMAT, 0, 0, 0, 0, 0}, {"e.bmp", PL_OK, 8, 6, 50, 60, 70},
    };
    for (int i = 0; i < 6; i++) {
        pl_frame f;
        memset(&f, 0, sizeof f);
        rc = pl_source_read(s, &f);
        CHECK(rc == want[i].rc, "frame %d (%s): %s, want %s (%s)", i, want[i].name,
              pl_status_name(rc), pl_status_name(want[i].rc), pl_last_error());
        if (rc < 0) {
            CHECK(strstr(pl_last_error(), want[i].name) != NULL,
                  "bad frame message lacks the name: %s", pl_last_error());
            printf("  bad frame ok: %s\n", pl_last_error());
            continue;
        }
        if (rc != PL_OK) continue;
        CHECK(f.index == i && f.name && strcmp(f.name, want[i].name) == 0,
              "frame %d: index %lld name %s", i, (long long)f.index, f.name ? f.name : "(null)");
        CHECK(f.image.width == want[i].w && f.image.height == want[i].h, "%s: %dx%d", want[i].name,
              f.image.width, f.image.height);
        const uint8_t *c = f.image.data + f.image.stride * (size_t)(f.image.height / 2) +
                           3 * (size_t)(f.image.width / 2);
        CHECK(near(c[0], want[i].r, 4) && near(c[1], want[i].g, 4) && near(c[2], want[i].b, 4),
              "%s: colour %d %d %d", want[i].name, c[0], c[1], c[2]);
        struct stat st;
        char path[1100];
        snprintf(path, sizeof path, "%s/%s", d, want[i].name);
        stat(path, &st);
        CHECK(f.t_ns == (int64_t)st.st_mtim.tv_sec * 1000000000LL + st.st_mtim.tv_nsec,
              "%s: t_ns %lld", want[i].name, (long long)f.t_ns);
    }
    pl_frame f;
    CHECK(pl_source_read(s, &f) == PL_E_EOF, "EOF after the last file");
    CHECK(strstr(pl_last_error(), "4 good, 2 bad") != NULL, "EOF summary: %s", pl_last_error());
    CHECK(pl_source_read(s, &f) == PL_E_EOF, "EOF again");
    int64_t good, bad;
    pl_source_counts(s, &good, &bad);
    CHECK(good == 4 && bad == 2, "counts %lld good %lld bad", (long long)good, (long long)bad);
    pl_source_close(s);

    /* A trailing slash gives the same source. */
    char slash[1100];
    snprintf(slash, sizeof slash, "%s/", d);
    CHECK(pl_source_open_path(slash, &s) == PL_OK, "%s", pl_last_error());
    CHECK(strcmp(pl_source_describe(s), want_desc) == 0, "describe with slash: %s",
          pl_source_describe(s));
    pl_source_close(s);
}

static void test_bad_directories(void)
{
    pl_source *s = (pl_source *)1;
    const char *empty = tmp("empty");
    mkdir(empty, 0755);
    CHECK(pl_source_open_path(empty, &s) == PL_E_FORMAT && s == NULL, "empty dir: %s",
          pl_last_error());
    CHECK(strstr(pl_last_error(), "no frame files") && strstr(pl_last_error(), empty), "%s",
          pl_last_error());
    printf("  empty dir ok: %s\n", pl_last_error());
    const char *hidden = tmp("hidden");
    mkdir(hidden, 0755);
    char p[1100];
    snprintf(p, sizeof p, "%s/.x.png", hidden);
    write_uniform(p, 4, 4, 1, 1, 1);
    CHECK(pl_source_open_path(hidden, &s) == PL_E_FORMAT, "only hidden files: %s", pl_last_error());

    const char *allbad = tmp("allbad");
    mkdir(allbad, 0755);
    snprintf(p, sizeof p, "%s/1.jpg", allbad);
    spit(p, "not a jpeg", 10);
    snprintf(p, sizeof p, "%s/2.png", allbad);
    spit(p, "", 0);
    CHECK(pl_source_open_path(allbad, &s) == PL_OK, "all-bad dir opens: %s", pl_last_error());
    pl_frame f;
    int errors = 0, rc;
    for (int i = 0; i < 10 && (rc = pl_source_read(s, &f)) != PL_E_EOF; i++)
        errors += rc < 0;
    int64_t good, bad;
    pl_source_counts(s, &good, &bad);
    CHECK(errors == 2 && good == 0 && bad == 2, "all-bad: %d errors, %lld good", errors,
          (long long)good);
    pl_source_close(s);
}

static void test_still(void)
{
    const char *p = tmp("still.png");
    write_uniform(p, 20, 10, 9, 8, 7);
    pl_source *s;
    CHECK(pl_source_open_path(p, &s) == PL_OK, "%s", pl_last_error());
    if (!s) return;
    char want[1100];
    snprintf(want, sizeof want, "file:%s", p);
    CHECK(strcmp(pl_source_describe(s), want) == 0, "describe: %s", pl_source_describe(s));
    pl_frame f;
    CHECK(pl_source_read(s, &f) == PL_OK, "%s", pl_last_error());
    CHECK(f.index == 0 && f.image.width == 20 && f.image.height == 10 && f.image.data[0] == 9 &&
              f.image.data[2] == 7 && strcmp(f.name, p) == 0,
          "still frame");
    struct stat st;
    stat(p, &st);
    CHECK(f.t_ns == (int64_t)st.st_mtim.tv_sec * 1000000000LL + st.st_mtim.tv_nsec, "still t_ns");
    CHECK(pl_source_read(s, &f) == PL_E_EOF, "one frame only");
    double fps;
    CHECK(pl_source_fps(s, &fps) == PL_E_UNSUPPORTED, "still has no fps");
    pl_source_close(s);

    /* Bad stills fail at open with the path in the message. */
    spit(tmp("bad.jpg"), "garbage!", 8);
    s = (pl_source *)1;
    CHECK(pl_source_open_path(tmp("bad.jpg"), &s) == PL_E_FORMAT && s == NULL, "bad still: %s",
          pl_last_error());
    CHECK(pl_source_open_path(tmp("nope.png"), &s) == PL_E_IO, "missing: %s", pl_last_error());
    CHECK(strstr(pl_last_error(), "nope.png") != NULL, "%s", pl_last_error());
    CHECK(pl_source_open_path("/dev/null", &s) == PL_E_IO, "device: %s", pl_last_error());
    CHECK(pl_source_open_path("", &s) == PL_E_ARG, "empty path");
    CHECK(pl_source_open_path(NULL, &s) == PL_E_ARG, "NULL path");
    CHECK(pl_source_open_path(p, NULL) == PL_E_ARG, "NULL out");
    CHECK(pl_source_read(NULL, &f) == PL_E_ARG, "NULL source");
    pl_source_close(NULL);
}

static void test_video(void)
{
    enum { W = 64, H = 48, N = 5 };
    static uint8_t frames[N * W * H * 3];
    const int colours[N][3] = {
        {250, 0, 0}, {0, 250, 0}, {0, 0, 250}, {128, 128, 128}, {250, 250, 0}};
    for (int k = 0; k < N; k++)
        for (int i = 0; i < W * H; i++)
            for (int c = 0; c < 3; c++)
                frames[(k * W * H + i) * 3 + c] = (uint8_t)colours[k][c];
    const char *p = tmp("clip.avi");
    int rc = pl_test_write_video(p, "MJPG", 10.0, W, H, N, frames);
    CHECK(rc == PL_OK, "write video: %s", pl_last_error());
    if (rc != PL_OK) return;
    pl_source *s;
    rc = pl_source_open_path(p, &s);
    CHECK(rc == PL_OK, "open video: %s", pl_last_error());
    if (rc != PL_OK) return;
    char want[1100];
    snprintf(want, sizeof want, "video:%s", p);
    CHECK(strcmp(pl_source_describe(s), want) == 0, "describe: %s", pl_source_describe(s));
    double fps = 0;
    CHECK(pl_source_fps(s, &fps) == PL_OK && fps > 9.99 && fps < 10.01, "fps %g: %s", fps,
          pl_last_error());
    pl_frame f;
    int n = 0;
    const uint8_t *buf = NULL;
    int64_t last_t = -1;
    while ((rc = pl_source_read(s, &f)) == PL_OK) {
        CHECK(n < N, "too many frames");
        if (n >= N) break;
        CHECK(f.index == n && f.image.width == W && f.image.height == H,
              "frame %d: index %lld %dx%d", n, (long long)f.index, f.image.width, f.image.height);
        const uint8_t *c = f.image.data + f.image.stride * (H / 2) + 3 * (W / 2);
        CHECK(near(c[0], colours[n][0], 12) && near(c[1], colours[n][1], 12) &&
                  near(c[2], colours[n][2], 12),
              "frame %d colour %d %d %d, want %d %d %d", n, c[0], c[1], c[2], colours[n][0],
              colours[n][1], colours[n][2]);
        CHECK(near((int)(f.t_ns / 1000000), n * 100, 2), "frame %d t_ns %lld, want ~%d ms", n,
              (long long)f.t_ns, n * 100);
        CHECK(f.t_ns > last_t, "time goes forward");
        last_t = f.t_ns;
        if (buf) CHECK(f.image.data == buf, "frame %d: buffer not reused", n);
        buf = f.image.data;
        n++;
    }
    CHECK(rc == PL_E_EOF && n == N, "video ended with %s after %d frames: %s", pl_status_name(rc),
          n, pl_last_error());
    pl_source_close(s);

    /* A video-named file that is nothing: both reasons, the path, PL_E_FORMAT. */
    static unsigned char junk[3000];
    for (size_t i = 0; i < sizeof junk; i++)
        junk[i] = (unsigned char)(i * 7919u >> 3);
    spit(tmp("junk.mp4"), junk, sizeof junk);
    s = (pl_source *)1;
    rc = pl_source_open_path(tmp("junk.mp4"), &s);
    CHECK(rc == PL_E_FORMAT && s == NULL, "junk video: %s (%s)", pl_status_name(rc),
          pl_last_error());
    CHECK(strstr(pl_last_error(), "video") && strstr(pl_last_error(), "image") &&
              strstr(pl_last_error(), "junk.mp4"),
          "junk video message: %s", pl_last_error());
    printf("  junk video ok: %s\n", pl_last_error());
    /* A header-only video (cut after 200 bytes): no decodable frame. */
    FILE *in = fopen(p, "rb");
    unsigned char head[200];
    size_t got = in ? fread(head, 1, sizeof head, in) : 0;
    if (in) fclose(in);
    spit(tmp("cut.avi"), head, got);
    rc = pl_source_open_path(tmp("cut.avi"), &s);
    CHECK(rc == PL_E_FORMAT, "cut video: %s (%s)", pl_status_name(rc), pl_last_error());
    printf("  cut video ok: %s\n", pl_last_error());
    /* A still photo with a video name is still read (as a still or a one-frame video). */
    write_uniform(tmp("photo.png"), 8, 8, 90, 90, 90);
    rename(tmp("photo.png"), tmp("photo.mov"));
    rc = pl_source_open_path(tmp("photo.mov"), &s);
    CHECK(rc == PL_OK, "photo named .mov: %s", pl_last_error());
    if (rc == PL_OK) {
        CHECK(pl_source_read(s, &f) == PL_OK && f.image.width == 8 && near(f.image.data[0], 90, 3),
              "photo named .mov: frame");
        printf("  photo.mov opened as %s\n", pl_source_describe(s));
        pl_source_close(s);
    }
}

int main(void)
{
    const char *t = getenv("PL_TEST_TMP");
    snprintf(tmpdir, sizeof tmpdir, "%s/source", t && t[0] ? t : "/tmp");
    mkdir(tmpdir, 0755);
    test_directory();
    test_bad_directories();
    test_still();
    test_video();
    if (failures) {
        printf("%d failures\n", failures);
        return 1;
    }
    printf("all source tests passed\n");
    return 0;
}
