/* Prints, for an int8 (or float) model, one line per observed layer (model/observer.h) with a
 * 64-bit FNV-1a hash of its activations, for one synthetic 320x240 frame (a deterministic
 * pattern). Used by tests/test_isa_exact.sh to check that the int8 executor's observer — the
 * per-layer values behind `parlight qcheck` and calibration — sees the same activations on every
 * PARLIGHT_ISA path and thread count. Not a test on its own.
 *
 *   observe_dump MODEL.plm [THREADS] */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "model/observer.h"
#include "parlight.h"

static void observe(void *ctx, const char *layer, const float *chw, int c, int h, int w,
                    const float *floor)
{
    (void)ctx;
    (void)floor;
    uint64_t hash = 0xcbf29ce484222325ULL;
    const size_t n = (size_t)c * (size_t)h * (size_t)w;
    const unsigned char *b = (const unsigned char *)chw;
    for (size_t i = 0; i < n * sizeof(float); i++)
        hash = (hash ^ b[i]) * 0x100000001b3ULL;
    printf("%s %d %d %d %016llx\n", layer, c, h, w, (unsigned long long)hash);
}

int main(int argc, char **argv)
{
    if (argc < 2 || argc > 3) {
        fprintf(stderr, "usage: observe_dump MODEL.plm [THREADS]\n");
        return 2;
    }
    pl_model *m;
    if (pl_model_load(argv[1], &m) < 0) {
        fprintf(stderr, "observe_dump: %s\n", pl_last_error());
        return 1;
    }
    const int threads = argc > 2 ? atoi(argv[2]) : 1;
    if (pl_model_set_threads(m, threads) < 0 || pl_model_set_observer(m, observe, NULL) < 0) {
        fprintf(stderr, "observe_dump: %s\n", pl_last_error());
        pl_model_free(m);
        return 1;
    }
    enum { W = 320, H = 240 };
    static uint8_t rgb[W * H * 3];
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            uint8_t *p = rgb + ((size_t)y * W + (size_t)x) * 3;
            p[0] = (uint8_t)(x * 255 / W);
            p[1] = (uint8_t)(y * 255 / H);
            p[2] = (uint8_t)((x * 7 + y * 13) & 255);
        }
    pl_lighting L;
    const int rc = pl_estimate_rgb8(m, rgb, W, H, (size_t)W * 3, &L, NULL);
    if (rc < 0) fprintf(stderr, "observe_dump: %s\n", pl_last_error());
    pl_model_free(m);
    return rc < 0 ? 1 : 0;
}
