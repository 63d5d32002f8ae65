/* Camera orientation (light/pose.h). */
#include "light/pose.h"

#include <math.h>
#include <string.h>

#include "core/util.h"

int pl_quat_to_rotation(const double q[4], double R[9])
{
    for (int k = 0; k < 4; k++)
        if (!isfinite(q[k]))
            return pl_error(PL_E_ARG, "quaternion (%g, %g, %g, %g): not finite", q[0], q[1],
                            q[2], q[3]);
    double n = sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    if (fabs(n - 1.0) > PL_QUAT_UNIT_TOL)
        return pl_error(PL_E_ARG,
                        "quaternion (%g, %g, %g, %g): length %.6g, expected 1 (within %g; "
                        "order w, x, y, z)",
                        q[0], q[1], q[2], q[3], n, PL_QUAT_UNIT_TOL);
    double w = q[0] / n, x = q[1] / n, y = q[2] / n, z = q[3] / n;
    R[0] = 1 - 2 * (y * y + z * z), R[1] = 2 * (x * y - w * z), R[2] = 2 * (x * z + w * y);
    R[3] = 2 * (x * y + w * z), R[4] = 1 - 2 * (x * x + z * z), R[5] = 2 * (y * z - w * x);
    R[6] = 2 * (x * z - w * y), R[7] = 2 * (y * z + w * x), R[8] = 1 - 2 * (x * x + y * y);
    return 0;
}

int pl_rotation_from_gravity(const float g[3], double R[9], double q[4])
{
    double a[3] = {g[0], g[1], g[2]};
    double n = sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]);
    if (!isfinite(n) || !(n > 0))
        return pl_error(PL_E_ARG, "gravity (%g, %g, %g): expected a finite non-zero vector",
                        (double)g[0], (double)g[1], (double)g[2]);
    for (int k = 0; k < 3; k++)
        a[k] /= n;
    /* the quaternion turning a onto b = (0, -1, 0): (1 + a.b, a x b), normalised; for a = -b
     * (camera upside down) any half turn about an axis perpendicular to y: about z */
    const double b[3] = {0, -1, 0};
    double d = a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    double qq[4] = {1 + d, a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2],
                    a[0] * b[1] - a[1] * b[0]};
    if (1 + d < 1e-9) {
        qq[0] = 0, qq[1] = 0, qq[2] = 0, qq[3] = 1;
    }
    double m = sqrt(qq[0] * qq[0] + qq[1] * qq[1] + qq[2] * qq[2] + qq[3] * qq[3]);
    for (int k = 0; k < 4; k++)
        qq[k] /= m;
    if (q) memcpy(q, qq, sizeof qq);
    return pl_quat_to_rotation(qq, R);
}

void pl_quat_slerp(const double a[4], const double b[4], double t, double out[4])
{
    double bb[4] = {b[0], b[1], b[2], b[3]};
    double d = a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3];
    if (d < 0) { /* q and -q are the same rotation: take the shorter arc */
        d = -d;
        for (int k = 0; k < 4; k++)
            bb[k] = -bb[k];
    }
    double wa = 1 - t, wb = t;
    if (d < 0.9995) {
        double th = acos(d), s = sin(th);
        wa = sin((1 - t) * th) / s;
        wb = sin(t * th) / s;
    }
    double n = 0;
    for (int k = 0; k < 4; k++) {
        out[k] = wa * a[k] + wb * bb[k];
        n += out[k] * out[k];
    }
    n = sqrt(n);
    for (int k = 0; k < 4; k++)
        out[k] /= n;
}

void pl_rotate3(const double R[9], const float v[3], float out[3])
{
    double r[3];
    for (int i = 0; i < 3; i++)
        r[i] = R[3 * i] * v[0] + R[3 * i + 1] * v[1] + R[3 * i + 2] * v[2];
    for (int i = 0; i < 3; i++)
        out[i] = (float)r[i];
}

void pl_rotate3_inverse(const double R[9], const float v[3], float out[3])
{
    double r[3];
    for (int i = 0; i < 3; i++)
        r[i] = R[i] * v[0] + R[3 + i] * v[1] + R[6 + i] * v[2];
    for (int i = 0; i < 3; i++)
        out[i] = (float)r[i];
}

void pl_lighting_rotate(const pl_lighting *L, const double R[9], pl_lighting *out)
{
    if (out != L) *out = *L;
    for (int i = 0; i < out->n_lights && i < PL_MAX_LIGHTS; i++)
        pl_rotate3(R, L->lights[i].dir, out->lights[i].dir);
}
