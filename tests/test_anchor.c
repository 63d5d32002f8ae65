/* light/anchor.c, the intensity anchor (docs/LIGHTING.md): the lighting's mean luminance against
 * an equirectangular map integrated pixel by pixel, the frame's mean linear luminance, what the
 * anchor does for w = 0, 1/2, 1 and b (and that it leaves black frames and lightings alone), its
 * range checks, and pl_render_rms with the identity that lets tools/train/fit_anchor.py score any
 * intensity without rendering again. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/util.h"
#include "light/light.h"
#include "light_test.h"

static double lum3(const float c[3])
{
    return 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2];
}

static pl_lighting two_lights(void)
{
    pl_lighting L;
    memset(&L, 0, sizeof L);
    L.n_lights = 2;
    const pl_light a = {{0.6f, 0.64f, -0.48f}, 2.0f, 0.3f, {8.0f, 6.0f, 4.0f}};
    const pl_light b = {{-0.8f, 0.0f, 0.6f}, 3.0f, 1.0f, {0.5f, 1.5f, 2.5f}};
    L.lights[0] = a;
    L.lights[1] = b;
    L.ambient[0] = 0.1f, L.ambient[1] = 0.2f, L.ambient[2] = 0.3f;
    return L;
}

/* The mean over the sphere of the map of L, each row weighted by its band's solid angle. */
static double map_mean_luminance(const pl_lighting *L, int width)
{
    pl_image_f32 env;
    if (pl_envmap_from_lights(L, width, &env) < 0) return NAN;
    const int W = env.width, H = env.height;
    double sum = 0;
    for (int y = 0; y < H; y++) {
        double band = sin(M_PI / 2 - y * M_PI / H) - sin(M_PI / 2 - (y + 1) * M_PI / H);
        double row = 0;
        for (int x = 0; x < W; x++)
            row += lum3(&env.data[((size_t)y * W + x) * 3]);
        sum += row * band * (2 * M_PI / W);
    }
    pl_image_f32_free(&env);
    return sum / (4 * M_PI);
}

static void test_mean_luminance(void)
{
    pl_lighting L = two_lights();
    double closed = pl_lighting_mean_luminance(&L), map = map_mean_luminance(&L, 1024);
    CHECK(fabs(closed - map) < 2e-3 * map, "mean luminance %.6g, the map's %.6g", closed, map);
    L.n_lights = 0;
    CHECK(fabs(pl_lighting_mean_luminance(&L) - lum3(L.ambient)) < 1e-9,
          "ambient only: %.9g, expected Y(a) %.9g", pl_lighting_mean_luminance(&L),
          lum3(L.ambient));
}

static void test_frame_luminance(void)
{
    enum { W = 8, H = 6, S = W * 3 + 5 }; /* rows padded: the stride is honoured */
    uint8_t img[H * S];
    memset(img, 0xEE, sizeof img);
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            uint8_t *p = img + y * S + 3 * x;
            if (x < 4) p[0] = p[1] = p[2] = 255;           /* left half white */
            else p[0] = 128, p[1] = 128, p[2] = 128;       /* right half mid-grey */
        }
    const double g = pow(128 / 255.0, 2.2);
    double all = pl_frame_mean_luminance(img, S, 0, 0, W, H, 2.2);
    CHECK(fabs(all - (1 + g) / 2) < 1e-9, "whole frame %.9g, expected %.9g", all, (1 + g) / 2);
    double left = pl_frame_mean_luminance(img, S, 0, 0, 4, H, 2.2);
    double right = pl_frame_mean_luminance(img, S, 4, 1, 4, 3, 1.0);
    CHECK(fabs(left - 1) < 1e-9, "left half %.9g, expected 1", left);
    CHECK(fabs(right - 128 / 255.0) < 1e-9, "right half, gamma 1: %.9g", right);
    img[0] = 255, img[1] = 0, img[2] = 0; /* one red pixel: luminance 0.2126 */
    double one = pl_frame_mean_luminance(img, S, 0, 0, 1, 1, 2.2);
    CHECK(fabs(one - 0.2126) < 1e-9, "red pixel %.9g, expected 0.2126", one);
    CHECK(isnan(pl_frame_mean_luminance(NULL, S, 0, 0, 1, 1, 2.2)), "NULL frame");
    CHECK(isnan(pl_frame_mean_luminance(img, S, 0, 0, 0, 1, 2.2)), "empty region");
    CHECK(isnan(pl_frame_mean_luminance(img, S, 0, 0, 1, 1, 0)), "gamma 0");
}

static void test_apply(void)
{
    const double F = 0.37; /* the frame's mean luminance */
    const pl_lighting L0 = two_lights();
    const double Y0 = pl_lighting_mean_luminance(&L0);

    pl_lighting L = L0;
    double ev = pl_anchor_apply(&L, F, 0, 0);
    CHECK(fabs(ev - log2(F / Y0)) < 1e-12, "ev %.9g, expected %.9g", ev, log2(F / Y0));
    CHECK(!memcmp(&L, &L0, sizeof L), "w = b = 0 changed the lighting");

    /* w = 1 takes the frame's luminance, whatever the network's scale was */
    for (int t = 0; t < 2; t++) {
        L = L0;
        const float k = t ? 10.0f : 1.0f;
        for (int k2 = 0; k2 < 3; k2++) {
            L.lights[0].rgb[k2] *= k, L.lights[1].rgb[k2] *= k, L.ambient[k2] *= k;
        }
        pl_anchor_apply(&L, F, 1, 0);
        double y = pl_lighting_mean_luminance(&L);
        CHECK(fabs(y - F) < 1e-5 * F, "w 1, network x%g: mean luminance %.7g, frame %.7g",
              (double)k, y, F);
        CHECK(fabs(L.ambient[2] / L.ambient[0] - 3) < 1e-5 &&
                  fabs(L.lights[0].rgb[0] / L.lights[0].rgb[2] - 2) < 1e-5,
              "w 1 changed the colours' ratios");
    }
    /* w = 1/2: the geometric mean of the two; b = 1 doubles on top */
    L = L0;
    pl_anchor_apply(&L, F, 0.5, 1);
    double y = pl_lighting_mean_luminance(&L), want = 2 * sqrt(F * Y0);
    CHECK(fabs(y - want) < 1e-5 * want, "w 0.5 b 1: %.7g, expected %.7g", y, want);
    CHECK(L.lights[0].distance_m == L0.lights[0].distance_m &&
              L.lights[1].solid_angle_sr == L0.lights[1].solid_angle_sr &&
              !memcmp(L.lights[0].dir, L0.lights[0].dir, sizeof L.lights[0].dir),
          "the anchor changed a direction, distance or size");
    /* w = 0: b alone is a gain */
    L = L0;
    pl_anchor_apply(&L, F, 0, -1);
    CHECK(fabs(L.ambient[1] - 0.1f) < 1e-7 && fabs(L.lights[0].rgb[0] - 4.0f) < 1e-6,
          "w 0 b -1: ambient g %.7g (0.1), light 0 r %.7g (4)", (double)L.ambient[1],
          (double)L.lights[0].rgb[0]);

    /* nothing to anchor to: unchanged, NaN */
    L = L0;
    CHECK(isnan(pl_anchor_apply(&L, 0.0, 1, 2)) && !memcmp(&L, &L0, sizeof L),
          "black frame: the lighting changed");
    CHECK(isnan(pl_anchor_apply(&L, NAN, 1, 2)) && !memcmp(&L, &L0, sizeof L),
          "NaN frame luminance: the lighting changed");
    pl_lighting black;
    memset(&black, 0, sizeof black);
    black.n_lights = 1;
    black.lights[0] = L0.lights[0];
    memset(black.lights[0].rgb, 0, sizeof black.lights[0].rgb);
    pl_lighting b2 = black;
    CHECK(isnan(pl_anchor_apply(&b2, F, 1, 2)) && !memcmp(&b2, &black, sizeof b2),
          "black lighting: changed");
}

static void test_check(void)
{
    CHECK(pl_anchor_check(0, 0, 2.2) == 0, "0,0,2.2 refused");
    CHECK(pl_anchor_check(1, 8, 3) == 0 && pl_anchor_check(0.25, -8, 1) == 0, "bounds refused");
    const double bad[][3] = {{1.01, 0, 2.2}, {-0.01, 0, 2.2}, {0.5, 8.5, 2.2}, {0.5, -9, 2.2},
                             {0.5, 0, 0.9}, {0.5, 0, 3.1}, {NAN, 0, 2.2}, {0.5, NAN, 2.2}};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        int rc = pl_anchor_check(bad[i][0], bad[i][1], bad[i][2]);
        CHECK(rc == PL_E_ARG && strstr(pl_last_error(), "intensity anchor"),
              "w %g b %g gamma %g: rc %d '%s'", bad[i][0], bad[i][1], bad[i][2], rc,
              pl_last_error());
    }
}

/* RMSE(c a, t)^2 = si^2 + (c - alpha)^2 rms(a)^2, rendering c a for real */
static void test_rms_identity(void)
{
    pl_lighting A = two_lights(), T = two_lights();
    T.lights[0].dir[0] = -0.6f; /* a different shape: si-RMSE > 0 */
    T.ambient[0] = 0.4f;
    pl_image_f32 a, t, ca;
    CHECK(pl_render_sphere_lights(&A, PL_MATERIAL_DIFFUSE, 48, &a) == 0 &&
              pl_render_sphere_lights(&T, PL_MATERIAL_DIFFUSE, 48, &t) == 0,
          "render failed: %s", pl_last_error());
    const double si = pl_render_si_rmse(&a, &t), alpha = pl_render_ls_scale(&a, &t),
                 rms = pl_render_rms(&a);
    CHECK(si > 0.01 && alpha > 0 && rms > 0, "si %g alpha %g rms %g", si, alpha, rms);
    const double cs[] = {0.3, 1.0, 2.5};
    for (size_t i = 0; i < sizeof cs / sizeof cs[0]; i++) {
        pl_lighting C = A;
        pl_anchor_apply(&C, pl_lighting_mean_luminance(&A) * cs[i], 1, 0); /* C = cs[i] A */
        CHECK(pl_render_sphere_lights(&C, PL_MATERIAL_DIFFUSE, 48, &ca) == 0, "render");
        double direct = pl_render_rmse(&ca, &t);
        double formula = sqrt(si * si + (cs[i] - alpha) * (cs[i] - alpha) * rms * rms);
        CHECK(fabs(direct - formula) < 1e-5 * direct, "c %g: RMSE %.9g, formula %.9g", cs[i],
              direct, formula);
        pl_image_f32_free(&ca);
    }
    /* an ambient-only lighting renders its ambient: rms = its RMS over the channels */
    pl_lighting amb;
    memset(&amb, 0, sizeof amb);
    amb.ambient[0] = 0.3f, amb.ambient[1] = 0.4f, amb.ambient[2] = 1.2f;
    pl_image_f32 r;
    CHECK(pl_render_sphere_lights(&amb, PL_MATERIAL_DIFFUSE, 32, &r) == 0, "render");
    double want = sqrt((0.09 + 0.16 + 1.44) / 3);
    CHECK(fabs(pl_render_rms(&r) - want) < 1e-4 * want, "ambient rms %.7g, expected %.7g",
          pl_render_rms(&r), want);
    CHECK(pl_render_rms(NULL) == PL_E_ARG, "NULL accepted");
    pl_image_f32_free(&r);
    pl_image_f32_free(&a);
    pl_image_f32_free(&t);
}

int main(void)
{
    test_mean_luminance();
    test_frame_luminance();
    test_apply();
    test_check();
    test_rms_identity();
    if (failures) {
        printf("%d failures\n", failures);
        return 1;
    }
    printf("ok\n");
    return 0;
}
