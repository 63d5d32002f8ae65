/* light/sg.c and light/cubemap.c: eq. (4) radiance, the SG energy integral against numeric
 * integration, environment maps (pixel values, where a light lands, energy), the primary-light
 * rule, cube-map face orientation (a light along +x lands in the +X face centre, ...), and
 * argument checks. */
#include <stdlib.h>
#include <string.h>

#include "core/util.h"
#include "light/equirect.h"
#include "light/light.h"
#include "light_test.h"

/* int over the sphere of the lights' radiance, by quadrature in a frame around light 0's axis
 * (fine in the angle from the axis, so sharp lobes are resolved). */
static double numeric_energy(const pl_lighting *L, int channel)
{
    double l[3] = {L->lights[0].dir[0], L->lights[0].dir[1], L->lights[0].dir[2]}, e1[3], e2[3];
    frame3(l, e1, e2);
    const int NT = 20000, NP = 64;
    double sum = 0;
    for (int i = 0; i < NT; i++) {
        double th = (i + 0.5) * M_PI / NT, st = sin(th), ct = cos(th), ring = 0;
        for (int j = 0; j < NP; j++) {
            double ph = (j + 0.5) * 2 * M_PI / NP;
            float u[3], rgb[3];
            for (int k = 0; k < 3; k++)
                u[k] = (float)(ct * l[k] + st * (cos(ph) * e1[k] + sin(ph) * e2[k]));
            pl_lights_radiance(L, u, rgb);
            ring += rgb[channel];
        }
        sum += ring * st * (M_PI / NT) * (2 * M_PI / NP);
    }
    return sum;
}

static void test_energy(void)
{
    const double sizes[] = {0.01, 0.05, 0.3, 1.0, 4.0, 12.0};
    for (size_t i = 0; i < sizeof sizes / sizeof sizes[0]; i++) {
        pl_lighting L;
        memset(&L, 0, sizeof L);
        L.n_lights = 1;
        L.lights[0] = (pl_light){{0.3f, 0.8f, -0.5f}, 2.0f, (float)sizes[i], {1.0f, 2.0f, 0.5f}};
        unit3(L.lights[0].dir);
        double s = sizes[i], sigma = s / (4 * M_PI);
        double formula = 2 * M_PI * sigma * (1 - exp(-2 / sigma));
        double num = numeric_energy(&L, 1) / 2.0;
        CHECK(fabs(pl_sg_integral(s) - formula) < 1e-12 * formula, "pl_sg_integral(%g)", s);
        CHECK(fabs(num - formula) < 2e-4 * formula,
              "s=%g: numeric energy %.8g vs 2 pi sigma (1 - e^-2/sigma) = %.8g", s, num, formula);
        if (s < 0.5)
            CHECK(fabs(formula - s / 2) < 0.01 * s, "s=%g: energy %.6g, expected about s/2", s,
                  formula);
    }
}

static void test_radiance(void)
{
    pl_lighting L;
    memset(&L, 0, sizeof L);
    L.n_lights = 2;
    L.lights[0] = (pl_light){{0, 1, 0}, 2.0f, 0.2f, {5, 4, 3}};
    L.lights[1] = (pl_light){{1, 0, 0}, 3.0f, 0.5f, {1, 1, 1}};
    L.ambient[0] = 0.1f, L.ambient[1] = 0.2f, L.ambient[2] = 0.3f;
    float rgb[3];
    float up[3] = {0, 1, 0}, down[3] = {0, -1, 0}, side[3] = {0.6f, 0.8f, 0};
    pl_lights_radiance(&L, up, rgb);
    double e1 = exp(4 * M_PI / 0.5 * (0 - 1));
    CHECK(fabs(rgb[0] - (5 + 1 * e1 + 0.1)) < 1e-5, "peak radiance r = %g", rgb[0]);
    pl_lights_radiance(&L, down, rgb);
    CHECK(fabs(rgb[2] - 0.3f) < 1e-6, "far from the lights only the ambient: %g", rgb[2]);
    pl_lights_radiance(&L, side, rgb);
    double ex = 5 * exp(4 * M_PI / 0.2 * (0.8 - 1)) + exp(4 * M_PI / 0.5 * (0.6 - 1)) + 0.1;
    CHECK(fabs(rgb[0] - ex) < 1e-5 * ex, "eq. 4 literally: %g vs %g", rgb[0], ex);
}

static void test_envmap(void)
{
    pl_lighting L;
    memset(&L, 0, sizeof L);
    L.n_lights = 1;
    L.lights[0] = (pl_light){{0.5f, 0.5f, -0.7071068f}, 2.0f, 0.4f, {2, 1, 0.5f}};
    unit3(L.lights[0].dir);
    L.ambient[0] = L.ambient[1] = L.ambient[2] = 0.05f;
    pl_image_f32 env;
    int rc = pl_envmap_from_lights(&L, 512, &env);
    CHECK(rc == 0 && env.width == 512 && env.height == 256, "envmap 512: %d %s", rc,
          pl_last_error());
    if (rc) return;
    /* every pixel is the radiance at its centre direction */
    double maxerr = 0, energy = 0;
    int bx = 0, by = 0;
    float best = -1;
    for (int y = 0; y < 256; y++)
        for (int x = 0; x < 512; x++) {
            double d[3];
            pl_equirect_dir(512, 256, x, y, d);
            float u[3] = {(float)d[0], (float)d[1], (float)d[2]}, rgb[3];
            pl_lights_radiance(&L, u, rgb);
            const float *p = env.data + ((size_t)y * 512 + (size_t)x) * 3;
            for (int k = 0; k < 3; k++)
                maxerr = fmax(maxerr, fabs(p[k] - rgb[k]));
            if (p[0] > best) best = p[0], bx = x, by = y;
            energy += (p[0] - 0.05) * pl_equirect_pixel_sr(512, 256, y);
        }
    CHECK(maxerr < 1e-5, "envmap pixel vs radiance: max error %g", maxerr);
    double px, py, ld[3] = {L.lights[0].dir[0], L.lights[0].dir[1], L.lights[0].dir[2]};
    pl_equirect_pixel(512, 256, ld, &px, &py);
    CHECK(fabs(bx - px) <= 1 && fabs(by - py) <= 1, "peak at (%d,%d), light maps to (%.1f,%.1f)",
          bx, by, px, py);
    double want = 2 * pl_sg_integral(0.4);
    CHECK(fabs(energy - want) < 0.01 * want, "map energy %g vs 2 * lobe integral %g", energy, want);
    /* downsample keeps energy */
    pl_image_f32 small;
    rc = pl_envmap_downsample(&env, 128, &small);
    CHECK(rc == 0 && small.width == 128 && small.height == 64, "downsample");
    if (rc == 0) {
        double e2 = 0;
        for (int y = 0; y < 64; y++)
            for (int x = 0; x < 128; x++)
                e2 += (small.data[((size_t)y * 128 + (size_t)x) * 3] - 0.05) *
                      pl_equirect_pixel_sr(128, 64, y);
        CHECK(fabs(e2 - energy) < 2e-3 * energy, "downsampled energy %g vs %g", e2, energy);
        pl_image_f32_free(&small);
    }
    pl_image_f32_free(&env);
    /* a ratio that is not an integer (1000 -> 128) keeps energy too */
    if (pl_envmap_from_lights(&L, 1000, &env) == 0 &&
        pl_envmap_downsample(&env, 128, &small) == 0) {
        double e1 = 0, e2 = 0;
        for (int y = 0; y < 500; y++)
            for (int x = 0; x < 1000; x++)
                e1 += env.data[((size_t)y * 1000 + (size_t)x) * 3 + 1] *
                      pl_equirect_pixel_sr(1000, 500, y);
        for (int y = 0; y < 64; y++)
            for (int x = 0; x < 128; x++)
                e2 += small.data[((size_t)y * 128 + (size_t)x) * 3 + 1] *
                      pl_equirect_pixel_sr(128, 64, y);
        CHECK(fabs(e2 - e1) < 2e-3 * e1, "1000 -> 128: energy %g vs %g", e2, e1);
        pl_image_f32_free(&small);
    } else {
        CHECK(0, "1000-wide map or its downsample failed: %s", pl_last_error());
    }
    pl_image_f32_free(&env);
    CHECK(pl_envmap_downsample(&env, 64, &small) == PL_E_ARG,
          "downsample of an empty map rejected");
    CHECK(pl_envmap_from_lights(&L, 511, &env) == PL_E_ARG, "odd width rejected");
    CHECK(pl_envmap_from_lights(&L, 0, &env) == PL_E_ARG, "zero width rejected");
    L.lights[0].solid_angle_sr = NAN;
    CHECK(pl_envmap_from_lights(&L, 64, &env) == PL_E_ARG, "NaN solid angle rejected");
    CHECK(strstr(pl_last_error(), "solid_angle_sr") != NULL, "message names the field: %s",
          pl_last_error());
    L.lights[0].solid_angle_sr = 0.4f;
    L.n_lights = PL_MAX_LIGHTS + 1;
    CHECK(pl_envmap_from_lights(&L, 64, &env) == PL_E_ARG, "too many lights rejected");
}

static void test_primary(void)
{
    pl_lighting L;
    memset(&L, 0, sizeof L);
    float dir[3], rgb[3];
    CHECK(pl_lighting_primary(&L, dir, rgb) == 0 && dir[1] == 1 && rgb[0] == 0,
          "no lights: up, black");
    L.n_lights = 3;
    /* sharp and bright (peak 10, s 0.01: energy ~0.05) vs wide and dim (peak 1, s 0.5: ~0.25) */
    L.lights[0] = (pl_light){{0, 1, 0}, 2, 0.01f, {10, 10, 10}};
    L.lights[1] = (pl_light){{1, 0, 0}, 2, 0.5f, {1, 1, 1}};
    L.lights[2] = (pl_light){{0, 0, -1}, 2, 0.5f, {0.1f, 3, 0.1f}}; /* green: luminance 2.18 */
    int i = pl_lighting_primary(&L, dir, rgb);
    CHECK(i == 2 && dir[2] == -1 && rgb[1] == 3, "primary = largest luminance x energy: got %d", i);
    L.lights[2].rgb[1] = 0.1f;
    i = pl_lighting_primary(&L, dir, rgb);
    CHECK(i == 1, "wide dim light carries more energy than sharp bright one: got %d", i);
}

static int face_argmax(const float *cube, int F, int *fx, int *fy)
{
    int bf = 0;
    float best = -1;
    for (int f = 0; f < 6; f++)
        for (int y = 0; y < F; y++)
            for (int x = 0; x < F; x++) {
                float v = cube[(((size_t)f * (size_t)F + (size_t)y) * (size_t)F + (size_t)x) * 3];
                if (v > best) best = v, bf = f, *fx = x, *fy = y;
            }
    return bf;
}

static void test_cubemap(void)
{
    const int F = 16;
    float *cube = malloc(sizeof(float) * 6 * F * F * 3),
          *cube2 = malloc(sizeof(float) * 6 * F * F * 3);
    const float axes[6][3] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
    pl_lighting L;
    memset(&L, 0, sizeof L);
    L.n_lights = 1;
    for (int f = 0; f < 6; f++) {
        L.lights[0] = (pl_light){{axes[f][0], axes[f][1], axes[f][2]}, 2, 0.05f, {1, 1, 1}};
        CHECK(pl_cubemap_from_lights(&L, F, cube) == 0, "cubemap");
        int x = -1, y = -1, g = face_argmax(cube, F, &x, &y);
        CHECK(g == f && (x == F / 2 || x == F / 2 - 1) && (y == F / 2 || y == F / 2 - 1),
              "light along axis %d lands in face %d at (%d,%d), expected face %d centre", f, g, x,
              y, f);
    }
    /* orientation inside a face (OpenGL: +X face, s -> -z, t -> -y) */
    L.lights[0] = (pl_light){{1, 0.4f, -0.4f}, 2, 0.01f, {1, 1, 1}};
    unit3(L.lights[0].dir);
    pl_cubemap_from_lights(&L, F, cube);
    int x, y, g = face_argmax(cube, F, &x, &y);
    CHECK(g == 0 && x > F / 2 && y < F / 2, "(1, .4, -.4): face %d (%d,%d), expected +X right-top",
          g, x, y);
    /* +Z face: s -> +x, t -> -y;  +Y face: s -> +x, t -> +z;  -Z face: s -> -x */
    L.lights[0] = (pl_light){{0.4f, 0, 1}, 2, 0.01f, {1, 1, 1}};
    unit3(L.lights[0].dir);
    pl_cubemap_from_lights(&L, F, cube);
    g = face_argmax(cube, F, &x, &y);
    CHECK(g == 4 && x > F / 2, "(.4, 0, 1): face %d x %d, expected +Z right half", g, x);
    L.lights[0] = (pl_light){{0, 1, 0.4f}, 2, 0.01f, {1, 1, 1}};
    unit3(L.lights[0].dir);
    pl_cubemap_from_lights(&L, F, cube);
    g = face_argmax(cube, F, &x, &y);
    CHECK(g == 2 && y > F / 2, "(0, 1, .4): face %d y %d, expected +Y bottom half", g, y);
    L.lights[0] = (pl_light){{0.4f, 0, -1}, 2, 0.01f, {1, 1, 1}};
    unit3(L.lights[0].dir);
    pl_cubemap_from_lights(&L, F, cube);
    g = face_argmax(cube, F, &x, &y);
    CHECK(g == 5 && x < F / 2, "(.4, 0, -1): face %d x %d, expected -Z left half", g, x);
    /* from a map: close to the analytic cube map for a smooth lighting */
    L.n_lights = 2;
    L.lights[0] = (pl_light){{0.3f, 0.9f, 0.2f}, 2, 1.0f, {2, 1, 1}};
    L.lights[1] = (pl_light){{-0.8f, 0.1f, -0.5f}, 2, 0.6f, {0, 1, 2}};
    unit3(L.lights[0].dir);
    unit3(L.lights[1].dir);
    L.ambient[0] = L.ambient[1] = L.ambient[2] = 0.1f;
    pl_image_f32 env;
    pl_envmap_from_lights(&L, 1024, &env);
    pl_cubemap_from_lights(&L, F, cube);
    CHECK(pl_cubemap_from_envmap(&env, F, cube2) == 0, "cubemap from envmap");
    double maxerr = 0;
    for (size_t i = 0; i < (size_t)6 * F * F * 3; i++)
        maxerr = fmax(maxerr, fabs(cube[i] - cube2[i]));
    CHECK(maxerr < 0.01, "cube map from envmap vs from lights: max error %g", maxerr);
    pl_image_f32_free(&env);
    CHECK(pl_cubemap_from_lights(&L, 0, cube) == PL_E_ARG, "face 0 rejected");
    free(cube);
    free(cube2);
}

int main(void)
{
    test_energy();
    test_radiance();
    test_envmap();
    test_primary();
    test_cubemap();
    if (failures) {
        printf("%d failures\n", failures);
        return 1;
    }
    printf("ok\n");
    return 0;
}
