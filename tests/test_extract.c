/* light/extract: synthetic lights -> map (pl_envmap_from_lights) -> extract recovers every light
 * within 2 degrees and 5% energy (energy = luminance(c) * pl_sg_integral(s), the SG convention),
 * on several random scenes and map sizes; plus the room-distance rule, the 10% rule, parameter
 * checks, degenerate panoramas and timing of a 1024 x 512 extraction. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/util.h"
#include "light/extract.h"
#include "light/light.h"
#include "tests/check.h"

static unsigned rng = 2024;
static double frand(void)
{
    rng = rng * 1664525u + 1013904223u;
    return (double)(rng >> 8) / 16777216.0;
}

static double lum3(const float *c)
{
    return 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2];
}

static double energy(const pl_light *l)
{
    return lum3(l->rgb) * pl_sg_integral(l->solid_angle_sr);
}

static double angle_deg(const float *a, const float *b)
{
    double d = (double)a[0] * b[0] + (double)a[1] * b[1] + (double)a[2] * b[2];
    double na = sqrt((double)a[0] * a[0] + (double)a[1] * a[1] + (double)a[2] * a[2]);
    double nb = sqrt((double)b[0] * b[0] + (double)b[1] * b[1] + (double)b[2] * b[2]);
    d /= na * nb;
    return acos(fmax(-1.0, fmin(1.0, d))) * 180.0 / M_PI;
}

/* n lights at least 40 degrees apart, |elevation| <= 70, sizes 0.02..0.3 sr, energies within 4x. */
static void random_scene(pl_lighting *L, int n)
{
    memset(L, 0, sizeof *L);
    L->n_lights = n;
    for (int i = 0; i < n; i++) {
        pl_light *l = &L->lights[i];
        for (;;) {
            double el = (frand() * 140 - 70) * M_PI / 180, az = (frand() * 360 - 180) * M_PI / 180;
            l->dir[0] = (float)(sin(az) * cos(el));
            l->dir[1] = (float)sin(el);
            l->dir[2] = (float)(-cos(az) * cos(el));
            int ok = 1;
            for (int j = 0; j < i; j++)
                ok &= angle_deg(l->dir, L->lights[j].dir) > 40;
            if (ok) break;
        }
        l->solid_angle_sr = (float)(0.02 + 0.28 * frand());
        l->distance_m = 2.0f;
        double e = 1.0 + 3.0 * frand(); /* target energy */
        float col[3] = {(float)(0.6 + 0.4 * frand()), (float)(0.6 + 0.4 * frand()),
                        (float)(0.6 + 0.4 * frand())};
        double scale = e / (lum3(col) * pl_sg_integral(l->solid_angle_sr));
        for (int c = 0; c < 3; c++)
            l->rgb[c] = (float)(col[c] * scale);
    }
    for (int c = 0; c < 3; c++)
        L->ambient[c] = (float)(0.02 + 0.05 * frand());
}

static void check_recovery(const pl_lighting *truth, int width, const char *name, double *worst_deg,
                           double *worst_e)
{
    pl_image_f32 map;
    CHECK(pl_envmap_from_lights(truth, width, &map) == 0, "%s: %s", name, pl_last_error());
    pl_extract_params p;
    pl_extract_default_params(&p);
    pl_lighting L;
    pl_extract_info info;
    int st = pl_extract_lights(&map, &p, &L, &info);
    CHECK(st == 0, "%s: extract: %s", name, pl_last_error());
    pl_image_f32_free(&map);
    if (st < 0) return;
    CHECK(L.n_lights == truth->n_lights, "%s: %d lights extracted, %d in the scene", name,
          L.n_lights, truth->n_lights);
    for (int i = 0; i < truth->n_lights; i++) {
        const pl_light *t = &truth->lights[i];
        int best = -1;
        double bd = 1e9;
        for (int j = 0; j < L.n_lights; j++) {
            double d = angle_deg(t->dir, L.lights[j].dir);
            if (d < bd) bd = d, best = j;
        }
        if (best < 0) continue;
        double er = energy(&L.lights[best]) / energy(t) - 1.0;
        double sr = L.lights[best].solid_angle_sr / t->solid_angle_sr;
        printf("  %s light %d: angle %.3f deg, energy %+.2f%%, s ratio %.3f (SG 1/3 region: %.3f), "
               "rgb ratio %.3f %.3f %.3f\n",
               name, i, bd, 100 * er, sr, log(3.0) / 2, L.lights[best].rgb[0] / t->rgb[0] * sr,
               L.lights[best].rgb[1] / t->rgb[1] * sr, L.lights[best].rgb[2] / t->rgb[2] * sr);
        CHECK(bd < 2.0, "%s light %d: direction off by %.2f degrees", name, i, bd);
        CHECK(fabs(er) < 0.05, "%s light %d: energy off by %.1f%%", name, i, 100 * er);
        if (bd > *worst_deg) *worst_deg = bd;
        if (fabs(er) > *worst_e) *worst_e = fabs(er);
        CHECK(L.lights[best].distance_m > 0, "%s: distance %g", name, L.lights[best].distance_m);
    }
    for (int c = 0; c < 3; c++)
        CHECK(fabs(L.ambient[c] - truth->ambient[c]) < 0.25 * truth->ambient[c] + 0.01,
              "%s: ambient[%d] %g vs %g", name, c, L.ambient[c], truth->ambient[c]);
}

static void test_room(void)
{
    pl_extract_params p;
    pl_extract_default_params(&p);
    float up[3] = {0, 1, 0}, down[3] = {0, -1, 0}, fwd[3] = {0, 0, -1}, diag[3];
    CHECK(fabs(pl_room_distance(&p.room, up) - 1.2) < 1e-6, "ceiling %g",
          pl_room_distance(&p.room, up));
    CHECK(fabs(pl_room_distance(&p.room, down) - 1.6) < 1e-6, "floor %g",
          pl_room_distance(&p.room, down));
    CHECK(fabs(pl_room_distance(&p.room, fwd) - 3.0) < 1e-6, "wall %g",
          pl_room_distance(&p.room, fwd));
    double s = 1 / sqrt(2.0);
    diag[0] = 0, diag[1] = (float)s, diag[2] = (float)-s; /* 45 deg up: ceiling at 1.2 m height */
    CHECK(fabs(pl_room_distance(&p.room, diag) - 1.2 / s) < 1e-5, "diagonal %g",
          pl_room_distance(&p.room, diag));
}

static void test_edge_cases(void)
{
    pl_extract_params p;
    pl_extract_default_params(&p);
    pl_lighting L;
    pl_image_f32 img;
    pl_image_f32_alloc(&img, 64, 32);
    memset(img.data, 0, 64 * 32 * 3 * sizeof(float));
    CHECK(pl_extract_lights(&img, &p, &L, NULL) == 0 && L.n_lights == 0 && L.ambient[0] == 0,
          "black panorama: %d lights, %s", L.n_lights, pl_last_error());
    for (int i = 0; i < 64 * 32 * 3; i++)
        img.data[i] = 0.5f;
    CHECK(pl_extract_lights(&img, &p, &L, NULL) == 0 && L.n_lights == 0 &&
              fabsf(L.ambient[0] - 0.5f) < 1e-5f && fabsf(L.ambient[2] - 0.5f) < 1e-5f,
          "constant 0.5 panorama: %d light(s), ambient %g (%s)", L.n_lights, L.ambient[0],
          pl_last_error());
    img.data[5] = NAN;
    CHECK(pl_extract_lights(&img, &p, &L, NULL) == PL_E_ARG, "NaN pixel accepted");
    img.data[5] = -1;
    CHECK(pl_extract_lights(&img, &p, &L, NULL) == PL_E_ARG, "negative pixel accepted");
    img.data[5] = 0.5f;
    /* one bright pixel: a tiny light with a positive size */
    img.data[(10 * 64 + 20) * 3 + 1] = 1000;
    CHECK(pl_extract_lights(&img, &p, &L, NULL) == 0 && L.n_lights == 1 &&
              L.lights[0].solid_angle_sr > 0,
          "single hot pixel: %d lights (%s)", L.n_lights, pl_last_error());
    img.width = 60;
    CHECK(pl_extract_lights(&img, &p, &L, NULL) == PL_E_ARG, "60 x 32 accepted as a panorama");
    img.width = 64;
    p.max_lights = 0;
    CHECK(pl_extract_lights(&img, &p, &L, NULL) == PL_E_ARG, "max_lights 0 accepted");
    pl_extract_default_params(&p);
    p.room.camera_height = 3.0;
    CHECK(pl_extract_lights(&img, &p, &L, NULL) == PL_E_ARG, "camera above the ceiling accepted");
    pl_image_f32_free(&img);
}

/* The 10% rule: a light with 5% of the strongest's energy is dropped, one with 20% kept. */
static void test_keep_rule(void)
{
    pl_lighting T;
    memset(&T, 0, sizeof T);
    T.n_lights = 3;
    float d[3][3] = {{0, 0.5f, -0.866f}, {0.866f, 0.5f, 0}, {-0.866f, 0.5f, 0}};
    double e[3] = {10, 2, 0.5};
    for (int i = 0; i < 3; i++) {
        memcpy(T.lights[i].dir, d[i], sizeof d[i]);
        T.lights[i].solid_angle_sr = 0.1f;
        T.lights[i].distance_m = 2;
        float c = (float)(e[i] / pl_sg_integral(0.1));
        T.lights[i].rgb[0] = T.lights[i].rgb[1] = T.lights[i].rgb[2] = c;
    }
    T.ambient[0] = T.ambient[1] = T.ambient[2] = 0.05f;
    pl_image_f32 map;
    pl_envmap_from_lights(&T, 512, &map);
    pl_extract_params p;
    pl_extract_default_params(&p);
    pl_lighting L;
    CHECK(pl_extract_lights(&map, &p, &L, NULL) == 0, "%s", pl_last_error());
    CHECK(L.n_lights == 2, "10%% rule: %d lights kept, expected 2", L.n_lights);
    p.max_lights = 1;
    CHECK(pl_extract_lights(&map, &p, &L, NULL) == 0 && L.n_lights == 1 &&
              angle_deg(L.lights[0].dir, d[0]) < 2,
          "max_lights 1: %d lights", L.n_lights);
    pl_image_f32_free(&map);
}

int main(void)
{
    test_room();
    test_edge_cases();
    test_keep_rule();
    double wd = 0, we = 0;
    int widths[] = {1024, 512, 256};
    for (int s = 0; s < 6; s++) {
        pl_lighting T;
        random_scene(&T, 1 + s % 4);
        char name[32];
        snprintf(name, sizeof name, "scene%d@%d", s, widths[s % 3]);
        check_recovery(&T, widths[s % 3], name, &wd, &we);
    }
    printf("worst direction error %.3f deg, worst energy error %.2f%%\n", wd, 100 * we);

    /* timing: 1024 x 512, three lights */
    pl_lighting T;
    random_scene(&T, 3);
    pl_image_f32 map;
    pl_envmap_from_lights(&T, 1024, &map);
    pl_extract_params p;
    pl_extract_default_params(&p);
    pl_lighting L;
    pl_extract_info info;
    double best = 1e9;
    for (int r = 0; r < 3; r++) {
        pl_extract_lights(&map, &p, &L, &info);
        if (info.ms_total < best) best = info.ms_total;
    }
    printf("extraction 1024x512: %.1f ms (detect %.1f, refine %.1f)\n", best, info.ms_detect,
           info.ms_refine);
    pl_image_f32_free(&map);
    if (failures) {
        printf("%d failure(s)\n", failures);
        return 1;
    }
    printf("all extract tests passed\n");
    return 0;
}
