/* light/render.c: sphere renders and metrics. A constant ambient renders to itself (both
 * materials, both paths); the diffuse pixel facing a light matches its closed form; lights
 * rendered analytically agree with the same lights rendered through their map (diffuse and
 * glossy, stated tolerances); the mask; RMSE and si-RMSE on known cases; the tonemap; timing. */
#include <stdlib.h>
#include <string.h>

#include "core/util.h"
#include "light/light.h"
#include "light_test.h"

static double rel_rmse(const pl_image_f32 *a, const pl_image_f32 *b)
{
    double r = pl_render_rmse(a, b), s = 0;
    size_t n = 0;
    for (int y = 0; y < b->height; y++)
        for (int x = 0; x < b->width; x++)
            if (pl_sphere_mask(b->width, x, y)) {
                const float *p = b->data + ((size_t)y * (size_t)b->width + (size_t)x) * 3;
                s += (double)p[0] * p[0] + (double)p[1] * p[1] + (double)p[2] * p[2];
                n += 3;
            }
    return r / sqrt(s / (double)n);
}

static void test_ambient(void)
{
    pl_lighting L;
    memset(&L, 0, sizeof L);
    L.ambient[0] = 0.5f, L.ambient[1] = 1, L.ambient[2] = 2;
    pl_image_f32 env, img;
    pl_envmap_from_lights(&L, 256, &env);
    for (int m = 0; m < 2; m++) {
        for (int path = 0; path < 2; path++) {
            int rc = path ? pl_render_sphere_envmap(&env, (pl_material)m, 32, &img)
                          : pl_render_sphere_lights(&L, (pl_material)m, 32, &img);
            CHECK(rc == 0, "render: %s", pl_last_error());
            double maxerr = 0;
            for (int y = 0; y < 32; y++)
                for (int x = 0; x < 32; x++) {
                    const float *p = img.data + ((size_t)y * 32 + (size_t)x) * 3;
                    if (!pl_sphere_mask(32, x, y)) {
                        CHECK(p[0] == 0 && p[1] == 0 && p[2] == 0, "background is 0");
                        continue;
                    }
                    for (int k = 0; k < 3; k++)
                        maxerr = fmax(maxerr, fabs(p[k] - L.ambient[k]));
                }
            CHECK(maxerr < (path ? 2e-3 : 1e-6),
                  "material %d path %d: ambient renders to itself (err %g)", m, path, maxerr);
            pl_image_f32_free(&img);
        }
    }
    pl_image_f32_free(&env);
}

static void test_diffuse_closed_form(void)
{
    /* a light straight at the camera (+z): the centre pixel's normal is +z, and
     * (1/pi) int_{hemisphere} e^{lam (cos - 1)} cos = 2 [(1/lam - 1/lam^2) + e^{-lam}/lam^2] */
    const float sizes[] = {0.05f, 1.0f, 6.0f};
    for (int i = 0; i < 3; i++) {
        pl_lighting L;
        memset(&L, 0, sizeof L);
        L.n_lights = 1;
        L.lights[0] = (pl_light){{0, 0, 1}, 2, sizes[i], {1, 1, 1}};
        pl_image_f32 img;
        CHECK(pl_render_sphere_lights(&L, PL_MATERIAL_DIFFUSE, 33, &img) == 0, "render");
        double lam = 4 * M_PI / sizes[i];
        double want = 2 * ((1 / lam - 1 / (lam * lam)) + exp(-lam) / (lam * lam));
        float got = img.data[((size_t)16 * 33 + 16) * 3];
        CHECK(fabs(got - want) < 1e-4 * want, "s=%g: centre pixel %.7g, closed form %.7g",
              (double)sizes[i], (double)got, want);
        pl_image_f32_free(&img);
    }
}

/* glossy: the centre pixel (n = r = +z) facing a light at +z has the closed form
 * k 2pi (1 - e^{-2(lam+g)}) / (lam + g); a light along +x is mirrored where n = (1, 0, 1)/sqrt 2 */
static void test_glossy_geometry(void)
{
    pl_lighting L;
    memset(&L, 0, sizeof L);
    L.n_lights = 1;
    L.lights[0] = (pl_light){{0, 0, 1}, 2, 0.2f, {1, 1, 1}};
    pl_image_f32 img;
    CHECK(pl_render_sphere_lights(&L, PL_MATERIAL_GLOSSY, 33, &img) == 0, "render");
    double lam = 4 * M_PI / 0.2, g = PL_GLOSSY_SHARPNESS, k = g / (2 * M_PI * (1 - exp(-2 * g)));
    double want = k * 2 * M_PI * (1 - exp(-2 * (lam + g))) / (lam + g);
    float got = img.data[((size_t)16 * 33 + 16) * 3];
    CHECK(fabs(got - want) < 1e-4 * want, "glossy centre %.7g, closed form %.7g", (double)got,
          want);
    pl_image_f32_free(&img);
    L.lights[0] = (pl_light){{1, 0, 0}, 2, 0.01f, {1, 1, 1}};
    for (int path = 0; path < 4; path++) {
        pl_material m = path < 2 ? PL_MATERIAL_GLOSSY : PL_MATERIAL_DIFFUSE;
        pl_image_f32 env;
        int rc = path % 2 ? pl_envmap_from_lights(&L, 512, &env) : 0;
        rc = rc         ? rc
             : path % 2 ? pl_render_sphere_envmap(&env, m, 101, &img)
                        : pl_render_sphere_lights(&L, m, 101, &img);
        CHECK(rc == 0, "render");
        if (path % 2) pl_image_f32_free(&env);
        int bx = 0, by = 0;
        float best = -1;
        for (int y = 0; y < 101; y++)
            for (int x = 0; x < 101; x++)
                if (img.data[((size_t)y * 101 + (size_t)x) * 3] > best)
                    best = img.data[((size_t)y * 101 + (size_t)x) * 3], bx = x, by = y;
        /* diffuse: brightest where n = +x, the right rim */
        int wx = m == PL_MATERIAL_DIFFUSE ? 100 : (int)((sqrt(0.5) + 1) / 2 * 101);
        /* (the rim column has n.x equal on many rows: diffuse ties in y) */
        CHECK(abs(bx - wx) <= 1 && (by == 50 || m == PL_MATERIAL_DIFFUSE),
              "path %d: highlight of a +x light at (%d,%d), expected (%d,50)", path, bx, by, wx);
        pl_image_f32_free(&img);
    }
}

static void test_lights_vs_map(void)
{
    pl_lighting L;
    memset(&L, 0, sizeof L);
    L.n_lights = 3;
    L.lights[0] = (pl_light){{0.3f, 0.8f, 0.3f}, 2, 0.3f, {4, 3, 2}};
    L.lights[1] = (pl_light){{-0.7f, 0.2f, 0.5f}, 3, 0.08f, {10, 10, 12}};
    L.lights[2] = (pl_light){{0.2f, -0.3f, -0.9f}, 3, 1.2f, {0.5f, 1, 0.5f}};
    for (int i = 0; i < 3; i++)
        unit3(L.lights[i].dir);
    L.ambient[0] = 0.05f, L.ambient[1] = 0.06f, L.ambient[2] = 0.08f;
    pl_image_f32 env, a, b;
    CHECK(pl_envmap_from_lights(&L, 1024, &env) == 0, "map");
    const double tol[2] = {0.002, 0.01};
    for (int m = 0; m < 2; m++) {
        int64_t t0 = pl_now_ns();
        CHECK(pl_render_sphere_envmap(&env, (pl_material)m, 64, &a) == 0, "map render");
        double ms_map = (double)(pl_now_ns() - t0) / 1e6;
        t0 = pl_now_ns();
        CHECK(pl_render_sphere_lights(&L, (pl_material)m, 64, &b) == 0, "lights render");
        double ms_lights = (double)(pl_now_ns() - t0) / 1e6;
        double r = rel_rmse(a.data ? &a : &b, &b);
        printf("%s: analytic vs 1024x512 map (area-averaged to %d): relative RMSE %.4f; 64x64 "
               "render %.1f ms "
               "from the map, %.1f ms from the lights\n",
               m ? "glossy" : "diffuse", PL_RENDER_MAP_WIDTH, r, ms_map, ms_lights);
        CHECK(r < tol[m], "%s: relative RMSE %g > %g", m ? "glossy" : "diffuse", r, tol[m]);
        pl_image_f32_free(&a);
        pl_image_f32_free(&b);
    }
    pl_image_f32_free(&env);
}

static void test_metrics(void)
{
    pl_image_f32 a, b, c;
    pl_image_f32_alloc(&a, 16, 16);
    pl_image_f32_alloc(&b, 16, 16);
    size_t n = 16 * 16 * 3, on = 0;
    for (size_t i = 0; i < n; i++) {
        a.data[i] = (float)(0.1 + 0.01 * (double)(i % 17));
        b.data[i] = 2.5f * a.data[i];
    }
    for (int y = 0; y < 16; y++)
        for (int x = 0; x < 16; x++)
            on += (size_t)pl_sphere_mask(16, x, y);
    CHECK(on > 150 && on < 16 * 16, "mask covers the disc only: %zu pixels", on);
    CHECK(pl_sphere_mask(16, 0, 0) == 0 && pl_sphere_mask(16, 8, 8) == 1 &&
              pl_sphere_mask(16, -1, 8) == 0,
          "mask");
    CHECK(pl_render_rmse(&a, &a) == 0, "rmse of identical = 0");
    CHECK(pl_render_si_rmse(&a, &b) < 1e-6, "si-rmse of a scaled copy = 0: %g",
          pl_render_si_rmse(&a, &b));
    CHECK(pl_render_rmse(&a, &b) > 0.1, "rmse of a scaled copy > 0");
    /* b = a + 1 on the sphere: RMSE exactly 1 (background differences do not count) */
    for (int y = 0; y < 16; y++)
        for (int x = 0; x < 16; x++)
            for (int k = 0; k < 3; k++) {
                size_t i = ((size_t)y * 16 + (size_t)x) * 3 + (size_t)k;
                b.data[i] = a.data[i] + (pl_sphere_mask(16, x, y) ? 1.0f : 100.0f);
            }
    CHECK(fabs(pl_render_rmse(&a, &b) - 1) < 1e-6, "rmse of +1 = 1: %g", pl_render_rmse(&a, &b));
    pl_image_f32_alloc(&c, 8, 8);
    CHECK(pl_render_rmse(&a, &c) < 0 && pl_render_si_rmse(&a, &c) < 0, "size mismatch is an error");
    /* tonemap: the 99th percentile maps to 255, zero stays 0 */
    pl_image_u8 u8;
    for (size_t i = 0; i < n; i++)
        a.data[i] = (float)(i / 3) / 256.0f * 4.0f;
    CHECK(pl_tonemap_rgb8(&a, &u8) == 0, "tonemap");
    CHECK(u8.data[0] == 0 && u8.data[(size_t)253 * 3] == 255 && u8.data[(size_t)100 * 3] > 100 &&
              u8.data[(size_t)100 * 3] < 255,
          "tonemap values %d %d %d", u8.data[0], u8.data[253 * 3], u8.data[100 * 3]);
    pl_image_u8_free(&u8);
    pl_image_f32_free(&a);
    pl_image_f32_free(&b);
    pl_image_f32_free(&c);
}

static void test_args(void)
{
    pl_image_f32 img, env = {6, 3, NULL};
    pl_lighting L;
    memset(&L, 0, sizeof L);
    CHECK(pl_render_sphere_lights(&L, PL_MATERIAL_DIFFUSE, 0, &img) == PL_E_ARG, "size 0");
    CHECK(pl_render_sphere_lights(&L, (pl_material)7, 8, &img) == PL_E_ARG, "bad material");
    CHECK(pl_render_sphere_envmap(&env, PL_MATERIAL_DIFFUSE, 8, &img) == PL_E_ARG, "bad map");
    L.ambient[1] = -1;
    CHECK(pl_render_sphere_lights(&L, PL_MATERIAL_DIFFUSE, 8, &img) == PL_E_ARG,
          "negative ambient");
}

int main(void)
{
    test_ambient();
    test_diffuse_closed_form();
    test_glossy_geometry();
    test_lights_vs_map();
    test_metrics();
    test_args();
    if (failures) {
        printf("%d failures\n", failures);
        return 1;
    }
    printf("ok\n");
    return 0;
}
