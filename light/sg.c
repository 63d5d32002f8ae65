/* Spherical-Gaussian lights: eq. (4) radiance, lobe energy, validation, environment maps,
 * relighting at a point and the primary light. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/util.h"
#include "light/equirect.h"
#include "light/light.h"

#define FOUR_PI (4.0 * M_PI)

double pl_sg_integral(double solid_angle_sr)
{
    double sigma = solid_angle_sr / FOUR_PI;
    if (!(sigma > 0)) return 0.0;
    return 2.0 * M_PI * sigma * -expm1(-2.0 / sigma);
}

double pl_light_energy(const pl_light *l)
{
    return pl_luminance(l->rgb[0], l->rgb[1], l->rgb[2]) * pl_sg_integral(l->solid_angle_sr);
}

int pl_lighting_check(const pl_lighting *L)
{
    if (!L) return pl_error(PL_E_ARG, "lighting is NULL");
    if (L->n_lights < 0 || L->n_lights > PL_MAX_LIGHTS)
        return pl_error(PL_E_ARG, "lighting: n_lights %d, expected 0..%d", L->n_lights,
                        PL_MAX_LIGHTS);
    for (int i = 0; i < L->n_lights; i++) {
        const pl_light *l = &L->lights[i];
        double n2 = 0;
        for (int k = 0; k < 3; k++) {
            if (!isfinite(l->dir[k]) || !isfinite(l->rgb[k]))
                return pl_error(PL_E_ARG, "lighting: light %d: non-finite dir or rgb", i);
            if (l->rgb[k] < 0)
                return pl_error(PL_E_ARG, "lighting: light %d: rgb[%d] = %g, expected >= 0", i, k,
                                (double)l->rgb[k]);
            n2 += (double)l->dir[k] * l->dir[k];
        }
        if (!(n2 >= 0.25 && n2 <= 4.0))
            return pl_error(PL_E_ARG, "lighting: light %d: |dir| = %g, expected a unit vector", i,
                            sqrt(n2));
        if (!(l->distance_m > 0) || !isfinite(l->distance_m))
            return pl_error(PL_E_ARG, "lighting: light %d: distance_m = %g, expected > 0", i,
                            (double)l->distance_m);
        if (!(l->solid_angle_sr > 0) || !isfinite(l->solid_angle_sr))
            return pl_error(PL_E_ARG, "lighting: light %d: solid_angle_sr = %g, expected > 0", i,
                            (double)l->solid_angle_sr);
    }
    for (int k = 0; k < 3; k++)
        if (!(L->ambient[k] >= 0) || !isfinite(L->ambient[k]))
            return pl_error(PL_E_ARG, "lighting: ambient[%d] = %g, expected >= 0", k,
                            (double)L->ambient[k]);
    return 0;
}

static void lights_radiance_d(const pl_lighting *L, const double u[3], double rgb[3])
{
    rgb[0] = L->ambient[0];
    rgb[1] = L->ambient[1];
    rgb[2] = L->ambient[2];
    for (int i = 0; i < L->n_lights; i++) {
        const pl_light *l = &L->lights[i];
        double lam = FOUR_PI / l->solid_angle_sr;
        double d = l->dir[0] * u[0] + l->dir[1] * u[1] + l->dir[2] * u[2];
        double e = exp(lam * (d - 1.0));
        rgb[0] += l->rgb[0] * e;
        rgb[1] += l->rgb[1] * e;
        rgb[2] += l->rgb[2] * e;
    }
}

void pl_lights_radiance(const pl_lighting *L, const float u[3], float rgb[3])
{
    double ud[3] = {u[0], u[1], u[2]}, r[3];
    lights_radiance_d(L, ud, r);
    for (int k = 0; k < 3; k++)
        rgb[k] = (float)r[k];
}

static int check_envmap_width(int width)
{
    if (width < 2 || width % 2 || width > PL_IMAGE_MAX_SIDE)
        return pl_error(PL_E_ARG, "environment map width %d: expected an even number in 2..%d",
                        width, PL_IMAGE_MAX_SIDE);
    return 0;
}

int pl_equirect_from_lights(const pl_lighting *L, int width, float *rgb)
{
    if (!rgb) return pl_error(PL_E_ARG, "pl_equirect_from_lights: rgb is NULL");
    int rc = pl_lighting_check(L);
    if (rc < 0 || (rc = check_envmap_width(width)) < 0) return rc;
    int H = width / 2;
    for (int y = 0; y < H; y++) {
        for (int x = 0; x < width; x++) {
            double u[3], r[3];
            pl_equirect_dir(width, H, x, y, u);
            lights_radiance_d(L, u, r);
            float *px = rgb + ((size_t)y * (size_t)width + (size_t)x) * 3;
            for (int k = 0; k < 3; k++)
                px[k] = (float)r[k];
        }
    }
    return 0;
}

int pl_envmap_from_lights(const pl_lighting *L, int width, pl_image_f32 *out)
{
    if (!out) return pl_error(PL_E_ARG, "pl_envmap_from_lights: out is NULL");
    int rc = pl_lighting_check(L);
    if (rc < 0 || (rc = check_envmap_width(width)) < 0) return rc;
    rc = pl_image_f32_alloc(out, width, width / 2);
    if (rc < 0) return rc;
    return pl_equirect_from_lights(L, width, out->data);
}

int pl_envmap_downsample(const pl_image_f32 *env, int width, pl_image_f32 *out)
{
    if (!env || !env->data || !out)
        return pl_error(PL_E_ARG, "pl_envmap_downsample: NULL argument");
    if (env->width != 2 * env->height || env->width < 2)
        return pl_error(PL_E_ARG, "environment map %dx%d: expected a 2:1 panorama", env->width,
                        env->height);
    if (width < 2 || width % 2 || width > env->width)
        return pl_error(PL_E_ARG, "downsample width %d: expected an even number in 2..%d", width,
                        env->width);
    int W = env->width, H = env->height, w = width, h = width / 2;
    int rc = pl_image_f32_alloc(out, w, h);
    if (rc < 0) return rc;
    double *acc = calloc((size_t)w * 4, sizeof *acc); /* r, g, b, weight per output column */
    if (!acc) {
        pl_image_f32_free(out);
        return pl_error(PL_E_NOMEM, "pl_envmap_downsample: out of memory");
    }
    /* Box overlap in x and in y; rows weighted by their solid angle so energy is kept. */
    double fx = (double)W / w, fy = (double)H / h;
    for (int oy = 0; oy < h; oy++) {
        memset(acc, 0, (size_t)w * 4 * sizeof *acc);
        double y0 = oy * fy, y1 = (oy + 1) * fy;
        for (int sy = (int)floor(y0); sy < H && sy < y1; sy++) {
            double wy = fmin(y1, sy + 1.0) - fmax(y0, (double)sy);
            if (wy <= 0) continue;
            wy *= pl_equirect_pixel_sr(W, H, sy);
            const float *row = env->data + (size_t)sy * (size_t)W * 3;
            for (int ox = 0; ox < w; ox++) {
                double x0 = ox * fx, x1 = (ox + 1) * fx;
                double *a = acc + (size_t)ox * 4;
                for (int sx = (int)floor(x0); sx < W && sx < x1; sx++) {
                    double wx = fmin(x1, sx + 1.0) - fmax(x0, (double)sx);
                    if (wx <= 0) continue;
                    double wgt = wx * wy;
                    a[0] += wgt * row[sx * 3 + 0];
                    a[1] += wgt * row[sx * 3 + 1];
                    a[2] += wgt * row[sx * 3 + 2];
                    a[3] += wgt;
                }
            }
        }
        for (int ox = 0; ox < w; ox++) {
            const double *a = acc + (size_t)ox * 4;
            float *o = out->data + ((size_t)oy * (size_t)w + (size_t)ox) * 3;
            for (int k = 0; k < 3; k++)
                o[k] = a[3] > 0 ? (float)(a[k] / a[3]) : 0.0f;
        }
    }
    free(acc);
    return 0;
}

int pl_lighting_at_point(const pl_lighting *L, const float p[3], pl_lighting *out)
{
    if (!out || !p) return pl_error(PL_E_ARG, "pl_lighting_at_point: NULL argument");
    int rc = pl_lighting_check(L);
    if (rc < 0) return rc;
    for (int k = 0; k < 3; k++)
        if (!isfinite(p[k]))
            return pl_error(PL_E_ARG, "relighting point p[%d] = %g: expected a finite value", k,
                            (double)p[k]);
    pl_lighting R = *L;
    if (p[0] == 0 && p[1] == 0 && p[2] == 0) {
        *out = R;
        return 0;
    }
    for (int i = 0; i < L->n_lights; i++) {
        const pl_light *l = &L->lights[i];
        double n = sqrt((double)l->dir[0] * l->dir[0] + (double)l->dir[1] * l->dir[1] +
                        (double)l->dir[2] * l->dir[2]);
        double v[3], d = l->distance_m;
        for (int k = 0; k < 3; k++)
            v[k] = d * l->dir[k] / n - p[k];
        double dist = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
        if (!(dist >= 1e-3))
            return pl_error(
                PL_E_ARG, "relighting point (%g, %g, %g) is %.3g m from light %d, expected >= 1 mm",
                (double)p[0], (double)p[1], (double)p[2], dist, i);
        pl_light *o = &R.lights[i];
        for (int k = 0; k < 3; k++)
            o->dir[k] = (float)(v[k] / dist);
        o->distance_m = (float)dist;
        double s = l->solid_angle_sr * (d / dist) * (d / dist);
        if (!isfinite(s) || s > 3.0e38) s = 3.0e38;
        o->solid_angle_sr = (float)s;
    }
    *out = R;
    return 0;
}

int pl_lighting_primary(const pl_lighting *L, float dir[3], float rgb[3])
{
    int best = -1;
    double best_e = -1;
    if (!dir || !rgb) return pl_error(PL_E_ARG, "pl_lighting_primary: NULL output");
    for (int i = 0; L && i < L->n_lights && i < PL_MAX_LIGHTS; i++) {
        double e = pl_light_energy(&L->lights[i]);
        if (!(e == e)) e = 0;
        if (e > best_e) {
            best_e = e;
            best = i;
        }
    }
    if (best < 0) {
        dir[0] = 0, dir[1] = 1, dir[2] = 0;
        rgb[0] = rgb[1] = rgb[2] = 0;
        return 0;
    }
    const pl_light *l = &L->lights[best];
    for (int k = 0; k < 3; k++) {
        dir[k] = l->dir[k];
        rgb[k] = l->rgb[k];
    }
    return best;
}

int pl_lighting_aim_primary(const pl_lighting *L, const float dir[3], pl_lighting *out)
{
    if (!L || !dir || !out) return pl_error(PL_E_ARG, "pl_lighting_aim_primary: NULL argument");
    const double n =
        sqrt((double)dir[0] * dir[0] + (double)dir[1] * dir[1] + (double)dir[2] * dir[2]);
    if (!(n > 1e-12) || !isfinite(n))
        return pl_error(PL_E_ARG, "pl_lighting_aim_primary: the direction (%g, %g, %g) is %s",
                        (double)dir[0], (double)dir[1], (double)dir[2],
                        isfinite(n) ? "zero" : "not finite");
    float d[3], rgb[3];
    const int p = pl_lighting_primary(L, d, rgb);
    if (out != L) *out = *L;
    if (L->n_lights <= 0) return 0;
    for (int k = 0; k < 3; k++)
        out->lights[p].dir[k] = (float)(dir[k] / n);
    return p;
}
