/* A small application of the installed library, built by tests/test_install.sh with
 * `pkg-config --cflags --libs parlight` (shared) and `pkg-config --static ...` (static), using
 * only <parlight.h>. Usage:
 *   install_app MODEL.plm IMAGE...
 * Loads MODEL from memory (pl_model_load_memory: the app reads the file itself), then for each
 * IMAGE (pl_image_load_rgb8: JPEG/PNG by the library, BMP & co. through the OpenCV plugin)
 * prints the JSON line `parlight estimate` prints for it (frame numbers from 0, source
 * "file:IMAGE"), and checks that the same frame as NV12 (converted here, BT.601 full range)
 * gives sane lights through pl_estimate_nv12. An image that does not load prints its error on
 * stderr and makes the exit status 1; the other images still run. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <parlight.h>

static unsigned char *read_file(const char *path, size_t *n)
{
    FILE *f = fopen(path, "rb");
    if (!f) return NULL;
    unsigned char *buf = NULL;
    size_t cap = 0, len = 0, got;
    do {
        if (len == cap) {
            unsigned char *p = realloc(buf, cap = cap ? cap * 2 : 1 << 20);
            if (!p) break;
            buf = p;
        }
        got = fread(buf + len, 1, cap - len, f);
        len += got;
    } while (got > 0);
    fclose(f);
    *n = len;
    return buf;
}

static unsigned char clamp8(double v)
{
    return (unsigned char)(v < 0 ? 0 : v > 255 ? 255 : v + 0.5);
}

/* RGB -> NV12, BT.601 full range, chroma averaged over each 2x2 block (width, height even). */
static void to_nv12(const unsigned char *rgb, int w, int h, unsigned char *y, unsigned char *uv)
{
    for (int r = 0; r < h; r++)
        for (int c = 0; c < w; c++) {
            const unsigned char *p = rgb + ((size_t)r * w + c) * 3;
            y[(size_t)r * w + c] = clamp8(0.299 * p[0] + 0.587 * p[1] + 0.114 * p[2]);
        }
    for (int r = 0; r < h; r += 2)
        for (int c = 0; c < w; c += 2) {
            double cb = 0, cr = 0;
            for (int k = 0; k < 4; k++) {
                const unsigned char *p = rgb + ((size_t)(r + k / 2) * w + c + k % 2) * 3;
                cb += -0.168736 * p[0] - 0.331264 * p[1] + 0.5 * p[2];
                cr += 0.5 * p[0] - 0.418688 * p[1] - 0.081312 * p[2];
            }
            uv[(size_t)(r / 2) * w + c] = clamp8(128 + cb / 4);
            uv[(size_t)(r / 2) * w + c + 1] = clamp8(128 + cr / 4);
        }
}

static int sane(const pl_lighting *L)
{
    if (L->n_lights < 1) return 0;
    for (int i = 0; i < L->n_lights; i++) {
        const float *d = L->lights[i].dir;
        if (!(fabs(sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]) - 1) < 1e-3)) return 0;
    }
    return 1;
}

int main(int argc, char **argv)
{
    if (argc < 3) {
        fprintf(stderr, "usage: install_app MODEL.plm IMAGE...\n");
        return 2;
    }
    size_t n = 0;
    unsigned char *bytes = read_file(argv[1], &n);
    pl_model *m = NULL;
    if (pl_model_load_memory(bytes, n, &m) < 0) {
        fprintf(stderr, "install_app: %s\n", pl_last_error());
        free(bytes);
        return 1;
    }
    free(bytes); /* the model has its own copy */
    fprintf(stderr, "install_app: parlight %s (built against %s)\n", pl_version(),
            PARLIGHT_VERSION);
    int status = 0;
    for (int i = 2; i < argc; i++) {
        unsigned char *rgb = NULL;
        int w, h;
        if (pl_image_load_rgb8(argv[i], &rgb, &w, &h) < 0) {
            fprintf(stderr, "install_app: %s\n", pl_last_error());
            status = 1;
            continue;
        }
        pl_lighting L;
        pl_timing t;
        char source[4200], line[16384];
        snprintf(source, sizeof source, "file:%s", argv[i]);
        pl_frame_meta meta = {i - 2, 0, source, NULL, {0, 0}, 0, -1, 0};
        if (pl_estimate_rgb8(m, rgb, w, h, (size_t)w * 3, &L, &t) < 0 ||
            pl_frame_format_json(&meta, &L, line, sizeof line) < 0) {
            fprintf(stderr, "install_app: %s: %s\n", argv[i], pl_last_error());
            status = 1;
        } else {
            fputs(line, stdout);
        }
        const int we = w & ~1, he = h & ~1;
        unsigned char *packed = malloc((size_t)we * he * 3), *y = malloc((size_t)we * he * 3 / 2);
        for (int r = 0; r < he && packed; r++)
            memcpy(packed + (size_t)r * we * 3, rgb + (size_t)r * w * 3, (size_t)we * 3);
        if (packed && y) {
            to_nv12(packed, we, he, y, y + (size_t)we * he);
            pl_lighting N;
            memset(&N, 0, sizeof N);
            if (pl_estimate_nv12(m, y, (size_t)we, y + (size_t)we * he, (size_t)we, we, he,
                                 PL_YCBCR_BT601_FULL, &N, NULL) < 0 ||
                !sane(&N)) {
                fprintf(stderr, "install_app: %s as NV12: %s\n", argv[i],
                        sane(&N) ? pl_last_error() : "lights not sane");
                status = 1;
            }
        }
        free(packed);
        free(y);
        pl_free(rgb);
    }
    pl_model_free(m);
    return status;
}
