/* L2 spherical harmonics (radiance projection, WebXR order) of lights and of maps. */
#include <math.h>
#include <string.h>

#include "core/util.h"
#include "light/equirect.h"
#include "light/light.h"

/* Real orthonormal basis without the Condon-Shortley phase (docs/LIGHTING.md), WebXR order. */
static void sh_basis(const double u[3], double y[9])
{
    double x = u[0], yy = u[1], z = u[2];
    y[0] = 0.28209479177387814;      /* 1 / (2 sqrt(pi)) */
    y[1] = 0.48860251190291992 * yy; /* sqrt(3 / 4pi) */
    y[2] = 0.48860251190291992 * z;
    y[3] = 0.48860251190291992 * x;
    y[4] = 1.0925484305920792 * x * yy; /* sqrt(15 / 4pi) */
    y[5] = 1.0925484305920792 * yy * z;
    y[6] = 0.31539156525252005 * (3.0 * z * z - 1.0); /* sqrt(5 / 16pi) */
    y[7] = 1.0925484305920792 * x * z;
    y[8] = 0.54627421529603959 * (x * x - yy * yy); /* sqrt(15 / 16pi) */
}

/* Funk-Hecke factors of f(t) = exp(lam (t - 1)): 2pi int_{-1}^{1} f(t) P_l(t) dt, l = 0, 1, 2. */
static void sg_zonal(double lam, double g[3])
{
    if (lam < 0.5) {
        /* very wide lobes: the closed forms below cancel badly; the integrand is smooth here,
         * so Simpson's rule on 256 intervals is exact to ~1e-12 */
        double s0 = 0, s1 = 0, s2 = 0;
        for (int k = 0; k <= 256; k++) {
            double t = -1.0 + k / 128.0, w = (k == 0 || k == 256) ? 1 : (k % 2 ? 4 : 2);
            double f = exp(lam * (t - 1.0)) * w;
            s0 += f;
            s1 += f * t;
            s2 += f * 0.5 * (3.0 * t * t - 1.0);
        }
        double h = 1.0 / 128.0 / 3.0;
        g[0] = 2.0 * M_PI * s0 * h;
        g[1] = 2.0 * M_PI * s1 * h;
        g[2] = 2.0 * M_PI * s2 * h;
        return;
    }
    double E = exp(-2.0 * lam), il = 1.0 / lam;
    double i0 = -expm1(-2.0 * lam) * il;
    double i1 = il * (1.0 + E) - il * il * (-expm1(-2.0 * lam));
    double i2 =
        (il - 2.0 * il * il + 2.0 * il * il * il) - E * (il + 2.0 * il * il + 2.0 * il * il * il);
    g[0] = 2.0 * M_PI * i0;
    g[1] = 2.0 * M_PI * i1;
    g[2] = 2.0 * M_PI * 0.5 * (3.0 * i2 - i0);
}

void pl_sh9_from_lights(const pl_lighting *L, float sh[27])
{
    double acc[27];
    memset(acc, 0, sizeof acc);
    if (!sh) return;
    if (!L) {
        memset(sh, 0, 27 * sizeof *sh);
        return;
    }
    /* ambient: a constant projects onto Y00 only: a * 4pi * Y00 = a * 2 sqrt(pi) */
    for (int c = 0; c < 3; c++)
        acc[c] = L->ambient[c] * 3.5449077018110318;
    for (int i = 0; i < L->n_lights && i < PL_MAX_LIGHTS; i++) {
        const pl_light *l = &L->lights[i];
        double g[3], y[9], d[3] = {l->dir[0], l->dir[1], l->dir[2]};
        double n = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
        if (!(n > 0) || !(l->solid_angle_sr > 0)) continue;
        for (int k = 0; k < 3; k++)
            d[k] /= n;
        sg_zonal(4.0 * M_PI / l->solid_angle_sr, g);
        sh_basis(d, y);
        for (int k = 0; k < 9; k++) {
            double f = g[k == 0 ? 0 : k < 4 ? 1 : 2] * y[k];
            for (int c = 0; c < 3; c++)
                acc[k * 3 + c] += f * l->rgb[c];
        }
    }
    for (int k = 0; k < 27; k++)
        sh[k] = (float)acc[k];
}

int pl_sh9_from_envmap(const pl_image_f32 *env, float sh[27])
{
    if (!env || !env->data || !sh) return pl_error(PL_E_ARG, "pl_sh9_from_envmap: NULL argument");
    if (env->width < 2 || env->width != 2 * env->height)
        return pl_error(PL_E_ARG, "environment map %dx%d: expected a 2:1 panorama", env->width,
                        env->height);
    int W = env->width, H = env->height;
    double acc[27];
    memset(acc, 0, sizeof acc);
    for (int y = 0; y < H; y++) {
        double sr = pl_equirect_pixel_sr(W, H, y);
        for (int x = 0; x < W; x++) {
            double u[3], b[9];
            pl_equirect_dir(W, H, x, y, u);
            sh_basis(u, b);
            const float *px = env->data + ((size_t)y * (size_t)W + (size_t)x) * 3;
            for (int k = 0; k < 9; k++)
                for (int c = 0; c < 3; c++)
                    acc[k * 3 + c] += px[c] * b[k] * sr;
        }
    }
    for (int k = 0; k < 27; k++)
        sh[k] = (float)acc[k];
    return 0;
}

void pl_sh9_eval(const float sh[27], const float u[3], float rgb[3])
{
    double ud[3] = {u[0], u[1], u[2]}, b[9], r[3] = {0, 0, 0};
    sh_basis(ud, b);
    for (int k = 0; k < 9; k++)
        for (int c = 0; c < 3; c++)
            r[c] += sh[k * 3 + c] * b[k];
    for (int c = 0; c < 3; c++)
        rgb[c] = (float)r[c];
}
