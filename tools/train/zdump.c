/* zdump: the latent z (the layer the fc and the lighting heads read: norm5 + ReLU, band pooled)
 * that the C executor computes for each frame of a list and for its mirror image, as float32.
 *
 *   zdump MODEL.plm LIST OUT [THREADS]
 *
 * LIST: one image path per line (any image `parlight estimate --input` reads). OUT gets, for each
 * line in order, z of the image then z of the image mirrored left-right: 2 x lines x D float32
 * values in this machine's byte order, D = 1024 x bands; nothing else. An existing OUT is not
 * replaced. tools/train/heads.py --int8 runs it on an int8 model to train the heads on the int8
 * encoder's own latents (docs/TRAINING.md, 6b): PyTorch has no int8 executor that matches this
 * one bit for bit, and the observer behind `parlight qcheck` (model/observer.h) already yields z
 * dequantised. Errors name the line and the file; exit status 1 on any of them. */
#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "model/observer.h"
#include "parlight.h"

typedef struct {
    float *z; /* the last z observed */
    size_t n; /* its length; 0 before the first */
    size_t cap;
} zbuf;

static void observe(void *ctx, const char *layer, const float *chw, int c, int h, int w,
                    const float *floor)
{
    (void)floor;
    zbuf *b = ctx;
    if (strcmp(layer, "z") != 0) return;
    const size_t n = (size_t)c * (size_t)h * (size_t)w;
    if (n > b->cap) {
        float *p = realloc(b->z, n * sizeof *p);
        if (!p) {
            b->n = 0;
            return;
        }
        b->z = p;
        b->cap = n;
    }
    memcpy(b->z, chw, n * sizeof *b->z);
    b->n = n;
}

/* z of one RGB frame into b; 0 or -1 with the reason printed. */
static int latent(pl_model *m, const uint8_t *rgb, int w, int h, zbuf *b, const char *what)
{
    pl_lighting L;
    b->n = 0;
    if (pl_estimate_rgb8(m, rgb, w, h, (size_t)w * 3, &L, NULL) < 0) {
        fprintf(stderr, "zdump: %s: %s\n", what, pl_last_error());
        return -1;
    }
    if (b->n == 0) {
        fprintf(stderr, "zdump: %s: the model reported no layer z (out of memory?)\n", what);
        return -1;
    }
    return 0;
}

int main(int argc, char **argv)
{
    if (argc < 4 || argc > 5) {
        fprintf(stderr, "usage: zdump MODEL.plm LIST OUT [THREADS]\n");
        return 2;
    }
    const int threads = argc > 4 ? atoi(argv[4]) : 1;
    if (threads < 1 || threads > 256) {
        fprintf(stderr, "zdump: THREADS %s: expected 1..256\n", argv[4]);
        return 2;
    }
    FILE *list = fopen(argv[2], "r");
    if (!list) {
        fprintf(stderr, "zdump: %s: %s\n", argv[2], strerror(errno));
        return 1;
    }
    pl_model *m = NULL;
    zbuf b = {0};
    if (pl_model_load(argv[1], &m) < 0 || pl_model_set_threads(m, threads) < 0 ||
        pl_model_set_observer(m, observe, &b) < 0) {
        fprintf(stderr, "zdump: %s: %s\n", argv[1], pl_last_error());
        fclose(list);
        pl_model_free(m);
        return 1;
    }
    const int fd = open(argv[3], O_WRONLY | O_CREAT | O_EXCL, 0644);
    FILE *out = fd < 0 ? NULL : fdopen(fd, "wb");
    if (!out) {
        fprintf(stderr, "zdump: %s: %s%s\n", argv[3], strerror(errno),
                errno == EEXIST ? " (not replacing it)" : "");
        if (fd >= 0) close(fd);
        fclose(list);
        pl_model_free(m);
        return 1;
    }
    char line[4096];
    size_t d = 0;
    long lines = 0;
    int rc = 0;
    while (rc == 0 && fgets(line, sizeof line, list)) {
        lines++;
        line[strcspn(line, "\r\n")] = 0;
        if (!line[0]) {
            fprintf(stderr, "zdump: %s line %ld: empty\n", argv[2], lines);
            rc = 1;
            break;
        }
        uint8_t *rgb = NULL;
        int w, h;
        if (pl_image_load_rgb8(line, &rgb, &w, &h) < 0) {
            fprintf(stderr, "zdump: %s line %ld: %s\n", argv[2], lines, pl_last_error());
            rc = 1;
            break;
        }
        for (int flip = 0; flip < 2 && rc == 0; flip++) {
            if (flip) /* mirror in place: each row's pixels in reverse order */
                for (int y = 0; y < h; y++) {
                    uint8_t *row = rgb + (size_t)y * (size_t)w * 3;
                    for (int x = 0, r = w - 1; x < r; x++, r--)
                        for (int k = 0; k < 3; k++) {
                            const uint8_t t = row[x * 3 + k];
                            row[x * 3 + k] = row[r * 3 + k];
                            row[r * 3 + k] = t;
                        }
                }
            if (latent(m, rgb, w, h, &b, line) < 0) {
                rc = 1;
            } else if (d && b.n != d) {
                fprintf(stderr, "zdump: %s: z has %zu values, earlier frames %zu\n", line, b.n, d);
                rc = 1;
            } else if (fwrite(b.z, sizeof *b.z, b.n, out) != b.n) {
                fprintf(stderr, "zdump: %s: %s\n", argv[3], strerror(errno));
                rc = 1;
            }
            d = b.n;
        }
        pl_free(rgb);
    }
    if (rc == 0 && ferror(list)) {
        fprintf(stderr, "zdump: %s: read error\n", argv[2]);
        rc = 1;
    }
    if (rc == 0 && lines == 0) {
        fprintf(stderr, "zdump: %s: no lines\n", argv[2]);
        rc = 1;
    }
    if (fclose(out) != 0 && rc == 0) {
        fprintf(stderr, "zdump: %s: %s\n", argv[3], strerror(errno));
        rc = 1;
    }
    if (rc != 0) unlink(argv[3]); /* never leave a partial file that looks whole */
    fclose(list);
    free(b.z);
    pl_model_free(m);
    return rc;
}
