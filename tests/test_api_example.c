/* The example at the top of include/parlight.h, as a program: loads the shipped int8 model (or
 * argv[1]), estimates a synthetic frame (a bright window in the top left of a grey room) and
 * prints the lights. The lines between the BEGIN/END markers are the header's example, word for
 * word (tests/test_header_example.sh compares them); the rest only makes it a program and checks
 * what it printed is sane and that the version macros match the library. Skips (77) without the
 * model. */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "parlight.h"

static int example(const char *path, const uint8_t *rgb, int width, int height, pl_lighting *out)
{
    /* BEGIN header example */
    pl_model *m = NULL;
    if (pl_model_load(path, &m) < 0) {
        fprintf(stderr, "%s\n", pl_last_error());
        return 1;
    }
    pl_lighting L;
    pl_timing t;
    if (pl_estimate_rgb8(m, rgb, width, height, (size_t)width * 3, &L, &t) < 0) {
        fprintf(stderr, "%s\n", pl_last_error());
        pl_model_free(m);
        return 1;
    }
    for (int i = 0; i < L.n_lights; i++)
        printf("light %d: dir %.3f %.3f %.3f, %.3f sr\n", i, L.lights[i].dir[0],
               L.lights[i].dir[1], L.lights[i].dir[2], L.lights[i].solid_angle_sr);
    printf("ambient %.3f %.3f %.3f (%.1f ms)\n", L.ambient[0], L.ambient[1], L.ambient[2],
           t.preprocess_ms + t.infer_ms);
    pl_model_free(m);
    /* END header example */
    *out = L;
    return 0;
}

int main(int argc, char **argv)
{
    const char *path = argc > 1 ? argv[1] : "models/parlight-n3-int8.plm";
    FILE *f = fopen(path, "rb");
    if (!f) {
        printf("skip: no %s\n", path);
        return 77;
    }
    fclose(f);
    int failures = 0;
    char v[32];
    snprintf(v, sizeof v, "%d.%d.%d", PARLIGHT_VERSION_MAJOR, PARLIGHT_VERSION_MINOR,
             PARLIGHT_VERSION_PATCH);
    if (strcmp(v, PARLIGHT_VERSION) || strcmp(pl_version(), PARLIGHT_VERSION)) {
        printf("FAIL: version macros %s / %s and pl_version() %s disagree\n", v, PARLIGHT_VERSION,
               pl_version());
        failures++;
    }
    const int w = 320, h = 240;
    uint8_t *rgb = malloc((size_t)w * h * 3);
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            int window = x < 100 && y < 80;
            for (int c = 0; c < 3; c++)
                rgb[((size_t)y * w + x) * 3 + c] = (uint8_t)(window ? 250 : 90 + c * 10);
        }
    pl_lighting L;
    memset(&L, 0, sizeof L);
    if (example(path, rgb, w, h, &L) != 0) failures++;
    for (int i = 0; i < L.n_lights; i++) {
        const pl_light *l = &L.lights[i];
        double n = sqrt((double)l->dir[0] * l->dir[0] + (double)l->dir[1] * l->dir[1] +
                        (double)l->dir[2] * l->dir[2]);
        if (!(fabs(n - 1) < 1e-4) || !(l->solid_angle_sr > 0) || !(l->distance_m > 0)) {
            printf("FAIL: light %d is not sane\n", i);
            failures++;
        }
    }
    if (L.n_lights < 1) {
        printf("FAIL: no lights\n");
        failures++;
    }
    free(rgb);
    printf(failures ? "%d failure(s)\n" : "api example: all passed\n", failures);
    return failures ? 1 : 0;
}
