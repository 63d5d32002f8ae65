/* light/sh.c: L2 SH (radiance, WebXR order) of a known spherical Gaussian against numeric
 * integration of eq. (4) times an independently written basis; of a constant ambient; of an
 * environment map of the same lights; and the irradiance evaluation constants. */
#include <stdlib.h>
#include <string.h>

#include "core/util.h"
#include "light/light.h"
#include "light_test.h"

/* Real SH basis in WebXR order, written from the spherical-coordinate definitions
 * (Y_lm = K_lm P_l^|m|(cos theta) trig(m phi), theta from +z, phi from +x), not copied from
 * light/sh.c: polar angle theta and azimuth phi of u. */
static void basis_ref(const double u[3], double y[9])
{
    double ct = u[2], st = sqrt(fmax(0.0, 1 - ct * ct)), ph = atan2(u[1], u[0]);
    double k00 = sqrt(1 / (4 * M_PI)), k1 = sqrt(3 / (4 * M_PI));
    double k20 = sqrt(5 / (4 * M_PI)), k21 = sqrt(15 / (4 * M_PI)), k22 = sqrt(15 / (16 * M_PI));
    y[0] = k00;
    y[1] = k1 * st * sin(ph);
    y[2] = k1 * ct;
    y[3] = k1 * st * cos(ph);
    y[4] = k22 * st * st * sin(2 * ph);
    y[5] = k21 * st * ct * sin(ph);
    y[6] = k20 * 0.5 * (3 * ct * ct - 1);
    y[7] = k21 * st * ct * cos(ph);
    y[8] = k22 * st * st * cos(2 * ph);
}

/* sh[k] = int L(u) Y_k(u) du by quadrature around the first light's axis. */
static void numeric_sh(const pl_lighting *L, double sh[27])
{
    double l[3] = {L->lights[0].dir[0], L->lights[0].dir[1], L->lights[0].dir[2]}, e1[3], e2[3];
    frame3(l, e1, e2);
    memset(sh, 0, 27 * sizeof *sh);
    const int NT = 8000, NP = 32;
    for (int i = 0; i < NT; i++) {
        double th = (i + 0.5) * M_PI / NT, w = sin(th) * (M_PI / NT) * (2 * M_PI / NP);
        for (int j = 0; j < NP; j++) {
            double ph = (j + 0.5) * 2 * M_PI / NP, u[3], y[9];
            for (int k = 0; k < 3; k++)
                u[k] = cos(th) * l[k] + sin(th) * (cos(ph) * e1[k] + sin(ph) * e2[k]);
            float uf[3] = {(float)u[0], (float)u[1], (float)u[2]}, rgb[3];
            pl_lights_radiance(L, uf, rgb);
            basis_ref(u, y);
            for (int k = 0; k < 9; k++)
                for (int c = 0; c < 3; c++)
                    sh[k * 3 + c] += rgb[c] * y[k] * w;
        }
    }
}

static void test_sg_vs_numeric(void)
{
    const float sizes[] = {0.02f, 0.3f, 2.0f, 9.0f, 60.0f};
    const float dirs[][3] = {{0.3f, 0.8f, -0.5f}, {-0.7f, -0.2f, 0.6f}, {0, 0, -1}};
    for (size_t i = 0; i < sizeof sizes / sizeof sizes[0]; i++)
        for (size_t d = 0; d < sizeof dirs / sizeof dirs[0]; d++) {
            pl_lighting L;
            memset(&L, 0, sizeof L);
            L.n_lights = 1;
            L.lights[0] =
                (pl_light){{dirs[d][0], dirs[d][1], dirs[d][2]}, 2, sizes[i], {3, 1, 0.5f}};
            unit3(L.lights[0].dir);
            float sh[27];
            double ref[27], scale = 0, maxerr = 0;
            pl_sh9_from_lights(&L, sh);
            numeric_sh(&L, ref);
            for (int k = 0; k < 27; k++)
                scale = fmax(scale, fabs(ref[k]));
            for (int k = 0; k < 27; k++)
                maxerr = fmax(maxerr, fabs(sh[k] - ref[k]));
            CHECK(maxerr < 1e-4 * scale, "s=%g dir %zu: max |closed form - numeric| %g (scale %g)",
                  (double)sizes[i], d, maxerr, scale);
        }
}

static void test_ambient(void)
{
    pl_lighting L;
    memset(&L, 0, sizeof L);
    L.ambient[0] = 1, L.ambient[1] = 0.5f, L.ambient[2] = 0.25f;
    float sh[27];
    pl_sh9_from_lights(&L, sh);
    double c0 = 2 * sqrt(M_PI); /* a * 4pi * Y00 */
    CHECK(fabs(sh[0] - c0) < 1e-6 && fabs(sh[1] - c0 / 2) < 1e-6 && fabs(sh[2] - c0 / 4) < 1e-6,
          "ambient L00 = a * 2 sqrt(pi): %g %g %g", sh[0], sh[1], sh[2]);
    for (int k = 3; k < 27; k++)
        CHECK(sh[k] == 0, "ambient has no higher band: sh[%d] = %g", k, sh[k]);
    /* reconstruction of a constant is exact */
    float u[3] = {0.2f, -0.9f, 0.3f}, rgb[3];
    unit3(u);
    pl_sh9_eval(sh, u, rgb);
    CHECK(fabs(rgb[0] - 1) < 1e-6 && fabs(rgb[2] - 0.25) < 1e-6, "eval of ambient SH: %g %g",
          rgb[0], rgb[2]);
}

static void test_envmap_path(void)
{
    pl_lighting L;
    memset(&L, 0, sizeof L);
    L.n_lights = 2;
    L.lights[0] = (pl_light){{0.3f, 0.8f, -0.5f}, 2, 0.5f, {3, 1, 0.5f}};
    L.lights[1] = (pl_light){{-0.6f, 0.1f, 0.7f}, 2, 1.5f, {0.2f, 0.4f, 1}};
    unit3(L.lights[0].dir);
    unit3(L.lights[1].dir);
    L.ambient[0] = L.ambient[1] = L.ambient[2] = 0.1f;
    float a[27], b[27];
    pl_image_f32 env;
    CHECK(pl_envmap_from_lights(&L, 1024, &env) == 0, "envmap");
    CHECK(pl_sh9_from_envmap(&env, b) == 0, "sh from envmap");
    pl_image_f32_free(&env);
    pl_sh9_from_lights(&L, a);
    double maxerr = 0;
    for (int k = 0; k < 27; k++)
        maxerr = fmax(maxerr, fabs(a[k] - b[k]));
    CHECK(maxerr < 2e-3 * fabs(a[0]), "SH from lights vs from 1024x512 map: max error %g (L00 %g)",
          maxerr, a[0]);
    pl_image_f32 bad = {10, 10, NULL};
    CHECK(pl_sh9_from_envmap(&bad, b) == PL_E_ARG, "NULL data rejected");
}

/* The irradiance convolution in docs/LIGHTING.md: E(n) = sum_l A_l sum_m L_lm Y_lm(n) with
 * A = (pi, 2pi/3, pi/4); compare with a brute-force cosine-weighted integral of the SH-projected
 * radiance (so this checks the documented constants, not the SH truncation). */
static void test_irradiance_constants(void)
{
    pl_lighting L;
    memset(&L, 0, sizeof L);
    L.n_lights = 1;
    L.lights[0] = (pl_light){{0.3f, 0.8f, -0.5f}, 2, 1.0f, {1, 1, 1}};
    unit3(L.lights[0].dir);
    float sh[27], shA[27];
    pl_sh9_from_lights(&L, sh);
    const double A[3] = {M_PI, 2 * M_PI / 3, M_PI / 4};
    for (int k = 0; k < 9; k++)
        for (int c = 0; c < 3; c++)
            shA[k * 3 + c] = (float)(sh[k * 3 + c] * A[k == 0 ? 0 : k < 4 ? 1 : 2]);
    float n[3] = {0.1f, 0.9f, 0.2f}, e[3];
    unit3(n);
    pl_sh9_eval(shA, n, e);
    double ref = 0;
    const int NT = 400, NP = 800;
    for (int i = 0; i < NT; i++)
        for (int j = 0; j < NP; j++) {
            double th = (i + 0.5) * M_PI / NT, ph = (j + 0.5) * 2 * M_PI / NP;
            float u[3] = {(float)(sin(th) * cos(ph)), (float)(sin(th) * sin(ph)), (float)cos(th)},
                  r[3];
            double c = u[0] * n[0] + u[1] * n[1] + u[2] * n[2];
            if (c <= 0) continue;
            pl_sh9_eval(sh, u, r);
            ref += r[0] * c * sin(th) * (M_PI / NT) * (2 * M_PI / NP);
        }
    CHECK(fabs(e[0] - ref) < 1e-3 * ref, "irradiance from constants %g vs brute force %g", e[0],
          ref);
}

int main(void)
{
    test_sg_vs_numeric();
    test_ambient();
    test_envmap_path();
    test_irradiance_constants();
    if (failures) {
        printf("%d failures\n", failures);
        return 1;
    }
    printf("ok\n");
    return 0;
}
