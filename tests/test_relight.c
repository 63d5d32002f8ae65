/* light/sg.c pl_lighting_at_point: relighting geometry (DESIGN.md: seen from p along d*l - p,
 * at |d*l - p|, solid angle times (d / |d*l - p|)^2). p = 0 is the identity; moving p halfway
 * toward a light halves its distance and quadruples its solid angle; a sideways move turns its
 * direction by the predicted angle; ambient and colour are unchanged; p at a light is an error. */
#include <string.h>

#include "core/util.h"
#include "light/light.h"
#include "light_test.h"

static pl_lighting two_lights(void)
{
    pl_lighting L;
    memset(&L, 0, sizeof L);
    L.n_lights = 2;
    L.lights[0] = (pl_light){{0, 1, 0}, 2.0f, 0.1f, {5, 4, 3}};
    L.lights[1] = (pl_light){{0.6f, 0, -0.8f}, 3.0f, 0.2f, {1, 2, 3}};
    L.ambient[0] = 0.1f, L.ambient[1] = 0.2f, L.ambient[2] = 0.3f;
    return L;
}

int main(void)
{
    pl_lighting L = two_lights(), R;
    const float zero[3] = {0, 0, 0};
    CHECK(pl_lighting_at_point(&L, zero, &R) == 0 && !memcmp(&L, &R, sizeof L),
          "p = 0 is the identity");

    /* halfway toward light 0 (at (0, 2, 0)): distance 1, solid angle x4, direction unchanged */
    const float half[3] = {0, 1, 0};
    CHECK(pl_lighting_at_point(&L, half, &R) == 0, "relight: %s", pl_last_error());
    CHECK(fabsf(R.lights[0].distance_m - 1.0f) < 1e-6f, "distance %g, expected 1",
          (double)R.lights[0].distance_m);
    CHECK(fabsf(R.lights[0].solid_angle_sr - 0.4f) < 1e-6f, "solid angle %g, expected 4 x 0.1",
          (double)R.lights[0].solid_angle_sr);
    CHECK(fabsf(R.lights[0].dir[1] - 1) < 1e-6f && fabsf(R.lights[0].dir[0]) < 1e-6f,
          "direction kept");
    CHECK(!memcmp(R.lights[0].rgb, L.lights[0].rgb, sizeof R.lights[0].rgb) &&
              !memcmp(R.ambient, L.ambient, sizeof R.ambient),
          "peak radiance and ambient unchanged");
    /* the lobe's energy grows with the solid angle as the geometry says (~ s/2 for small s) */
    double ratio =
        pl_sg_integral(R.lights[0].solid_angle_sr) / pl_sg_integral(L.lights[0].solid_angle_sr);
    CHECK(fabs(ratio - 4) < 0.05, "energy ratio %g, expected about 4 = (2/1)^2", ratio);

    /* light 1 is at (1.8, 0, -2.4); from p = (1.8, 0, 0) it is straight ahead (-z) at 2.4 m */
    const float side[3] = {1.8f, 0, 0};
    CHECK(pl_lighting_at_point(&L, side, &R) == 0, "relight side");
    CHECK(fabsf(R.lights[1].dir[0]) < 1e-6f && fabsf(R.lights[1].dir[2] + 1) < 1e-6f,
          "light 1 now along -z: (%g, %g, %g)", (double)R.lights[1].dir[0],
          (double)R.lights[1].dir[1], (double)R.lights[1].dir[2]);
    CHECK(fabsf(R.lights[1].distance_m - 2.4f) < 1e-5f, "distance %g, expected 2.4",
          (double)R.lights[1].distance_m);
    CHECK(fabsf(R.lights[1].solid_angle_sr - 0.2f * (3 / 2.4f) * (3 / 2.4f)) < 1e-6f,
          "solid angle x (3/2.4)^2: %g", (double)R.lights[1].solid_angle_sr);
    /* light 0 at (0, 2, 0) seen from (1.8, 0, 0): along (-1.8, 2, 0) / |.|, turned by atan(1.8/2)
     */
    double n0 = sqrt(1.8 * 1.8 + 4);
    CHECK(fabs(R.lights[0].dir[0] + 1.8 / n0) < 1e-6 && fabs(R.lights[0].dir[1] - 2 / n0) < 1e-6,
          "light 0 direction (%g, %g)", (double)R.lights[0].dir[0], (double)R.lights[0].dir[1]);
    double turned = acos(R.lights[0].dir[1]);
    CHECK(fabs(turned - atan(1.8 / 2)) < 1e-6, "turned by %g rad, expected %g", turned,
          atan(1.8 / 2));

    /* moving away from a light shrinks it; in place (out == L) works */
    pl_lighting M = L;
    const float back[3] = {0, -2, 0};
    CHECK(pl_lighting_at_point(&M, back, &M) == 0 &&
              fabsf(M.lights[0].solid_angle_sr - 0.025f) < 1e-7f,
          "twice as far: a quarter of the solid angle (%g)", (double)M.lights[0].solid_angle_sr);

    /* the env map at p: the peak of light 0 moves where the geometry says */
    pl_image_f32 env;
    CHECK(pl_lighting_at_point(&L, side, &R) == 0 && pl_envmap_from_lights(&R, 256, &env) == 0,
          "map at p");
    if (env.data) {
        float u[3] = {(float)(-1.8 / n0), (float)(2 / n0), 0}, rgb[3];
        pl_lights_radiance(&R, u, rgb);
        CHECK(fabsf(rgb[0] - (5 + 0.1f)) < 1e-3f, "radiance toward the moved light is its peak: %g",
              (double)rgb[0]);
        pl_image_f32_free(&env);
    }

    /* errors */
    const float at_light[3] = {0, 2.0f, 0.0005f};
    CHECK(pl_lighting_at_point(&L, at_light, &R) == PL_E_ARG, "p at a light rejected");
    CHECK(strstr(pl_last_error(), "light 0") != NULL, "message names the light: %s",
          pl_last_error());
    const float bad[3] = {NAN, 0, 0};
    CHECK(pl_lighting_at_point(&L, bad, &R) == PL_E_ARG, "NaN point rejected");
    L.lights[1].distance_m = 0;
    CHECK(pl_lighting_at_point(&L, side, &R) == PL_E_ARG, "zero distance rejected");
    CHECK(strstr(pl_last_error(), "distance_m") != NULL, "message names the field: %s",
          pl_last_error());

    if (failures) {
        printf("%d failures\n", failures);
        return 1;
    }
    printf("ok\n");
    return 0;
}
