/* light/pose.c: quaternion -> rotation against rotations built by hand, the refusal of
 * non-unit and non-finite quaternions, the gravity frame, slerp, and lights turned with
 * everything else kept. */
#include <string.h>

#include "core/util.h"
#include "light/pose.h"
#include "light_test.h"

static double dist9(const double a[9], const double b[9])
{
    double d = 0;
    for (int k = 0; k < 9; k++)
        d = fmax(d, fabs(a[k] - b[k]));
    return d;
}

int main(void)
{
    double R[9], q[4];
    /* identity, and 90 degrees about y: x -> -z, z -> x (right-handed) */
    const double id[4] = {1, 0, 0, 0}, I[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
    CHECK(pl_quat_to_rotation(id, R) == 0 && dist9(R, I) < 1e-12, "identity");
    const double qy[4] = {sqrt(0.5), 0, sqrt(0.5), 0}, Ry[9] = {0, 0, 1, 0, 1, 0, -1, 0, 0};
    CHECK(pl_quat_to_rotation(qy, R) == 0 && dist9(R, Ry) < 1e-12, "90 deg about y");
    float v[3] = {1, 0, 0}, w[3], back[3];
    pl_rotate3(R, v, w);
    CHECK(fabs(w[2] + 1) < 1e-6 && fabs(w[0]) < 1e-6, "x turns to -z: %g %g %g", (double)w[0],
          (double)w[1], (double)w[2]);
    pl_rotate3_inverse(R, w, back);
    CHECK(fabs(back[0] - 1) < 1e-6, "R^T undoes R");
    /* a slightly off-unit quaternion is normalised; a far one, or NaN, refused with a reason */
    const double near[4] = {1.0005, 0, 0, 0}, far[4] = {2, 0, 0, 0}, bad[4] = {NAN, 0, 0, 0};
    CHECK(pl_quat_to_rotation(near, R) == 0 && dist9(R, I) < 1e-12, "within tolerance");
    CHECK(pl_quat_to_rotation(far, R) == PL_E_ARG && strstr(pl_last_error(), "length 2"),
          "length 2 refused: %s", pl_last_error());
    CHECK(pl_quat_to_rotation(bad, R) == PL_E_ARG && strstr(pl_last_error(), "not finite"),
          "NaN refused: %s", pl_last_error());
    /* gravity: level camera -> identity; rolled 90 deg (gravity along camera +x) -> +x down;
     * upside down -> y flipped */
    const float g0[3] = {0, -9.81f, 0}, g1[3] = {9.81f, 0, 0}, g2[3] = {0, 9.81f, 0};
    float x[3] = {1, 0, 0}, y[3] = {0, 1, 0}, r[3];
    CHECK(pl_rotation_from_gravity(g0, R, q) == 0 && dist9(R, I) < 1e-12, "level camera");
    CHECK(pl_rotation_from_gravity(g1, R, q) == 0, "rolled camera");
    pl_rotate3(R, x, r);
    CHECK(fabs(r[1] + 1) < 1e-6, "gravity along camera +x ends at world -y: %g %g %g",
          (double)r[0], (double)r[1], (double)r[2]);
    CHECK(pl_rotation_from_gravity(g2, R, q) == 0, "upside down");
    pl_rotate3(R, y, r);
    CHECK(fabs(r[1] + 1) < 1e-6, "upside down: camera up is world down");
    const float gz[3] = {0, 0, 0};
    CHECK(pl_rotation_from_gravity(gz, R, q) == PL_E_ARG, "zero gravity refused");
    /* slerp: halfway between identity and 90 deg about y is 45 deg about y; the shorter arc
     * is taken when the second quaternion has the opposite sign */
    double h[4], neg[4] = {-qy[0], -qy[1], -qy[2], -qy[3]}, h2[4];
    pl_quat_slerp(id, qy, 0.5, h);
    CHECK(fabs(h[0] - cos(M_PI / 8)) < 1e-12 && fabs(h[2] - sin(M_PI / 8)) < 1e-12,
          "slerp halfway: %g %g %g %g", h[0], h[1], h[2], h[3]);
    pl_quat_slerp(id, neg, 0.5, h2);
    CHECK(fabs(fabs(h2[0]) - cos(M_PI / 8)) < 1e-12, "slerp takes the shorter arc");
    /* lights: directions turn, the rest stays */
    pl_lighting L, T;
    memset(&L, 0, sizeof L);
    L.n_lights = 2;
    L.lights[0] = (pl_light){{1, 0, 0}, 2.5f, 0.1f, {3, 2, 1}};
    L.lights[1] = (pl_light){{0, 0, -1}, 4.0f, 0.5f, {1, 1, 1}};
    L.ambient[0] = 0.2f;
    pl_quat_to_rotation(qy, R);
    pl_lighting_rotate(&L, R, &T);
    CHECK(fabs(T.lights[0].dir[2] + 1) < 1e-6 && fabs(T.lights[1].dir[0] + 1) < 1e-6,
          "directions turned");
    CHECK(T.lights[0].distance_m == 2.5f && T.lights[1].solid_angle_sr == 0.5f &&
              T.lights[0].rgb[0] == 3 && T.ambient[0] == 0.2f && T.n_lights == 2,
          "everything else kept");
    pl_lighting_rotate(&L, R, &L);
    CHECK(!memcmp(&L, &T, sizeof L), "in place gives the same");
    if (failures) {
        printf("%d failure(s)\n", failures);
        return 1;
    }
    printf("pose: all passed\n");
    return 0;
}
