/* L2 spherical harmonics (radiance projection, WebXR order) of lights and of maps. */
#include <float.h>
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

/* The intensity of the directional light that stands for a lobe exp(lam (t - 1)) of unit peak in
 * pl_lighting_engine. Directional light + probe reproduce the lobe's irradiance exactly in bands
 * 0..2 whatever the intensity E (the probe gets the lobe minus a delta of power E, and the engine
 * adds E max(0, n.l)); what is left is bands l >= 4 (odd ones vanish), in irradiance
 *     sum_l (2l+1)/4pi C_l (g_l - E) P_l(n.l),
 * g_l = 2pi int exp(lam (t - 1)) P_l(t) dt the lobe's Funk-Hecke factors, C_l = 2pi int_0^1 t P_l
 * the clamped cosine's. E minimising its L2 norm: sum w_l g_l / sum w_l, w_l = (2l+1) C_l^2,
 * l = 4, 6, .., 16. For a small lobe g_l -> g_0 (its energy); for a wide one g_l falls with l
 * and so does E: the probe keeps the share of the lobe a directional light cannot carry. */
static double lobe_directional_share(double lam)
{
    enum { LMAX = 16, NY = 600 };
    double g[LMAX + 1] = {0};
    /* t = 1 - y / lam: the integrand exp(-y) P_l(1 - y/lam), y in [0, min(2 lam, 60)], Simpson */
    double ymax = fmin(2.0 * lam, 60.0), h = ymax / NY;
    for (int k = 0; k <= NY; k++) {
        double y = k * h, t = 1.0 - y / lam, w = (k == 0 || k == NY) ? 1 : (k % 2 ? 4 : 2);
        double p0 = 1, p1 = t, f = exp(-y) * w;
        g[0] += f;
        g[1] += f * t;
        for (int l = 2; l <= LMAX; l++) {
            double p2 = ((2 * l - 1) * t * p1 - (l - 1) * p0) / l;
            g[l] += f * p2;
            p0 = p1;
            p1 = p2;
        }
    }
    double num = 0, den = 0, fact = h / 3.0 * 2.0 * M_PI / lam;
    for (int l = 4; l <= LMAX; l += 2) {
        /* C_l = 2pi (-1)^(l/2+1) / ((l+2)(l-1)) * l! / (2^l ((l/2)!)^2), even l >= 2 */
        double binom = 1; /* l! / (2^l ((l/2)!)^2) = prod_{j=1}^{l/2} (2j-1)/(2j) */
        for (int j = 1; j <= l / 2; j++)
            binom *= (2.0 * j - 1) / (2.0 * j);
        double c = 2.0 * M_PI * ((l / 2) % 2 ? 1 : -1) * binom / ((l + 2.0) * (l - 1.0));
        double w = (2 * l + 1) * c * c;
        num += w * g[l] * fact;
        den += w;
    }
    return num / den;
}

void pl_lighting_engine(const pl_lighting *L, pl_engine_lighting *out)
{
    if (!out) return;
    float rgb[3];
    int i = pl_lighting_primary(L, out->dir, rgb);
    pl_sh9_from_lights(L, out->sh9);
    memset(out->intensity, 0, sizeof out->intensity);
    if (!L || i >= L->n_lights || !(L->lights[i].solid_angle_sr > 0)) return;
    double d[3] = {out->dir[0], out->dir[1], out->dir[2]};
    double n = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    if (!(n > 0)) return;
    /* The maths below uses d normalised in double. dir itself stays the primary light's, bit for
     * bit, when that is already unit to float precision (the network's, normalised in float):
     * normalising it again in double can move its last bit, and engine.dir then reads as
     * another direction than primary.dir. A user's unit-ish direction is normalised. */
    int renorm = fabs(n - 1.0) > 4.0 * FLT_EPSILON;
    for (int k = 0; k < 3; k++) {
        d[k] /= n;
        if (renorm) out->dir[k] = (float)d[k];
    }
    double e = lobe_directional_share(4.0 * M_PI / L->lights[i].solid_angle_sr), y[9];
    sh_basis(d, y);
    for (int c = 0; c < 3; c++) {
        double ec = e * rgb[c];
        out->intensity[c] = (float)ec;
        /* a delta light of power ec in d projects to ec * Y_k(d) */
        for (int k = 0; k < 9; k++)
            out->sh9[k * 3 + c] = (float)(out->sh9[k * 3 + c] - ec * y[k]);
    }
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
