/* Sphere renders (diffuse and glossy) from maps and from lights, render metrics and the PNG
 * tonemap (docs/LIGHTING.md). */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/util.h"
#include "light/equirect.h"
#include "light/light.h"

/* Samples of the 1D integral over the angle from a light (pl_render_sphere_lights, diffuse). */
#define DIFFUSE_SAMPLES 512

int pl_sphere_mask(int size, int x, int y)
{
    if (size < 1 || x < 0 || y < 0 || x >= size || y >= size) return 0;
    double sx = 2.0 * (x + 0.5) / size - 1.0, sy = 1.0 - 2.0 * (y + 0.5) / size;
    return sx * sx + sy * sy <= 1.0;
}

/* Normal and mirror direction (view +z, orthographic) at pixel (x, y); 0 off the sphere. */
static int sphere_geometry(int size, int x, int y, double n[3], double r[3])
{
    double sx = 2.0 * (x + 0.5) / size - 1.0, sy = 1.0 - 2.0 * (y + 0.5) / size;
    double r2 = sx * sx + sy * sy;
    if (r2 > 1.0) return 0;
    n[0] = sx;
    n[1] = sy;
    n[2] = sqrt(1.0 - r2);
    r[0] = 2.0 * n[2] * n[0];
    r[1] = 2.0 * n[2] * n[1];
    r[2] = 2.0 * n[2] * n[2] - 1.0;
    return 1;
}

static int check_render_args(pl_material m, int size, pl_image_f32 *out)
{
    if (!out) return pl_error(PL_E_ARG, "sphere render: out is NULL");
    if (m != PL_MATERIAL_DIFFUSE && m != PL_MATERIAL_GLOSSY)
        return pl_error(PL_E_ARG, "sphere render: unknown material %d", (int)m);
    if (size < 1 || size > 4096)
        return pl_error(PL_E_ARG, "sphere render size %d: expected 1..4096", size);
    return 0;
}

/* Normalisation of the glossy lobe D(u) = k exp(g (r.u - 1)) so that int D = 1. */
static double glossy_norm(double g)
{
    return g / (2.0 * M_PI * -expm1(-2.0 * g));
}

int pl_render_sphere_envmap(const pl_image_f32 *env, pl_material m, int size, pl_image_f32 *out)
{
    int rc = check_render_args(m, size, out);
    if (rc < 0) return rc;
    if (!env || !env->data || env->width < 2 || env->width != 2 * env->height)
        return pl_error(PL_E_ARG, "sphere render: environment map %dx%d, expected a 2:1 panorama",
                        env ? env->width : 0, env ? env->height : 0);
    pl_image_f32 small = {0, 0, NULL};
    const pl_image_f32 *map = env;
    if (env->width > PL_RENDER_MAP_WIDTH) {
        if ((rc = pl_envmap_downsample(env, PL_RENDER_MAP_WIDTH, &small)) < 0) return rc;
        map = &small;
    }
    int W = map->width, H = map->height;
    size_t np = (size_t)W * (size_t)H;
    /* per map pixel: direction (3), radiance times solid angle (3) and solid angle (1) */
    double *pre = malloc(np * 7 * sizeof *pre);
    if (!pre) {
        pl_image_f32_free(&small);
        return pl_error(PL_E_NOMEM, "sphere render: out of memory");
    }
    for (int y = 0; y < H; y++) {
        double sr = pl_equirect_pixel_sr(W, H, y);
        for (int x = 0; x < W; x++) {
            size_t i = (size_t)y * (size_t)W + (size_t)x;
            pl_equirect_dir(W, H, x, y, pre + i * 7);
            for (int k = 0; k < 3; k++)
                pre[i * 7 + 3 + k] = map->data[i * 3 + (size_t)k] * sr;
            pre[i * 7 + 6] = sr;
        }
    }
    if ((rc = pl_image_f32_alloc(out, size, size)) < 0) goto done;
    const double g = PL_GLOSSY_SHARPNESS, cut = 1.0 - 40.0 / g;
    for (int y = 0; y < size; y++) {
        for (int x = 0; x < size; x++) {
            float *o = out->data + ((size_t)y * (size_t)size + (size_t)x) * 3;
            double n[3], r[3], acc[4] = {0, 0, 0, 0};
            if (!sphere_geometry(size, x, y, n, r)) {
                o[0] = o[1] = o[2] = 0;
                continue;
            }
            for (size_t i = 0; i < np; i++) {
                const double *p = pre + i * 7;
                double w;
                if (m == PL_MATERIAL_DIFFUSE) {
                    w = n[0] * p[0] + n[1] * p[1] + n[2] * p[2];
                    if (w <= 0) continue;
                } else {
                    double c = r[0] * p[0] + r[1] * p[1] + r[2] * p[2];
                    if (c < cut) continue;
                    w = exp(g * (c - 1.0));
                }
                acc[0] += w * p[3];
                acc[1] += w * p[4];
                acc[2] += w * p[5];
                acc[3] += w * p[6];
            }
            /* Both kernels integrate to 1 once normalised (1/pi, and k); dividing by their
             * discrete integral on this grid instead keeps a constant map exact. */
            for (int k = 0; k < 3; k++)
                o[k] = acc[3] > 0 ? (float)(acc[k] / acc[3]) : 0.0f;
        }
    }
done:
    free(pre);
    pl_image_f32_free(&small);
    return rc;
}

/* int over the sphere of exp(lam (l.u - 1)) max(0, n.u) du, with cos_a = n.l: a 1D integral
 * over t = 1 - l.u (inverse-CDF samples of exp(-lam t) on [0, 2]) of the azimuthal integral of
 * the clamped cosine, which has a closed form. */
static double sg_clamped_cosine(double lam, double cos_a)
{
    if (cos_a > 1) cos_a = 1;
    if (cos_a < -1) cos_a = -1;
    double sin_a = sqrt(1.0 - cos_a * cos_a);
    double mass = -expm1(-2.0 * lam); /* 1 - exp(-2 lam) */
    double sum = 0;
    for (int k = 0; k < DIFFUSE_SAMPLES; k++) {
        double q = (k + 0.5) / DIFFUSE_SAMPLES;
        double t = -log1p(-q * mass) / lam;
        if (t > 2) t = 2;
        double ct = 1.0 - t, st = sqrt(fmax(0.0, t * (2.0 - t)));
        double a = cos_a * ct, b = sin_a * st, A;
        if (a >= b)
            A = 2.0 * M_PI * a;
        else if (a <= -b)
            A = 0;
        else {
            double phi0 = acos(-a / b);
            A = 2.0 * (a * phi0 + b * sin(phi0));
        }
        sum += A;
    }
    return sum / DIFFUSE_SAMPLES * mass / lam;
}

/* int over the sphere of exp(lam (l.u - 1)) exp(g (r.u - 1)) du, closed form. */
static double sg_product(double lam, const float l[3], double g, const double r[3])
{
    double v[3];
    for (int k = 0; k < 3; k++)
        v[k] = lam * l[k] + g * r[k];
    double m = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    if (m < 1e-8) return 4.0 * M_PI * exp(-lam - g);
    /* 4pi e^(-lam-g) sinh(m)/m, written so nothing overflows (m <= lam + g) */
    return 2.0 * M_PI * (exp(m - lam - g) - exp(-m - lam - g)) / m;
}

int pl_render_sphere_lights(const pl_lighting *L, pl_material m, int size, pl_image_f32 *out)
{
    int rc = check_render_args(m, size, out);
    if (rc < 0) return rc;
    if ((rc = pl_lighting_check(L)) < 0) return rc;
    if ((rc = pl_image_f32_alloc(out, size, size)) < 0) return rc;
    const double g = PL_GLOSSY_SHARPNESS, kg = glossy_norm(g);
    for (int y = 0; y < size; y++) {
        for (int x = 0; x < size; x++) {
            float *o = out->data + ((size_t)y * (size_t)size + (size_t)x) * 3;
            double n[3], r[3];
            if (!sphere_geometry(size, x, y, n, r)) {
                o[0] = o[1] = o[2] = 0;
                continue;
            }
            /* a constant ambient a gives a for both materials (both kernels integrate to 1) */
            double acc[3] = {L->ambient[0], L->ambient[1], L->ambient[2]};
            for (int i = 0; i < L->n_lights; i++) {
                const pl_light *l = &L->lights[i];
                double lam = 4.0 * M_PI / l->solid_angle_sr, w;
                double dn = sqrt((double)l->dir[0] * l->dir[0] + (double)l->dir[1] * l->dir[1] +
                                 (double)l->dir[2] * l->dir[2]);
                float ld[3] = {(float)(l->dir[0] / dn), (float)(l->dir[1] / dn),
                               (float)(l->dir[2] / dn)};
                if (m == PL_MATERIAL_DIFFUSE)
                    w = sg_clamped_cosine(lam, n[0] * ld[0] + n[1] * ld[1] + n[2] * ld[2]) / M_PI;
                else
                    w = kg * sg_product(lam, ld, g, r);
                for (int k = 0; k < 3; k++)
                    acc[k] += w * l->rgb[k];
            }
            for (int k = 0; k < 3; k++)
                o[k] = (float)acc[k];
        }
    }
    return 0;
}

static int same_renders(const pl_image_f32 *a, const pl_image_f32 *b)
{
    if (!a || !b || !a->data || !b->data) return pl_error(PL_E_ARG, "render metric: NULL image");
    if (a->width != b->width || a->height != b->height || a->width != a->height)
        return pl_error(PL_E_ARG,
                        "render metric: renders %dx%d and %dx%d, expected the same square size",
                        a->width, a->height, b->width, b->height);
    return 0;
}

static double rmse_scaled(const pl_image_f32 *a, const pl_image_f32 *b, double alpha)
{
    int s = a->width;
    double sum = 0;
    size_t n = 0;
    for (int y = 0; y < s; y++)
        for (int x = 0; x < s; x++) {
            if (!pl_sphere_mask(s, x, y)) continue;
            size_t i = ((size_t)y * (size_t)s + (size_t)x) * 3;
            for (int k = 0; k < 3; k++) {
                double d = alpha * a->data[i + (size_t)k] - b->data[i + (size_t)k];
                sum += d * d;
            }
            n += 3;
        }
    return n ? sqrt(sum / (double)n) : 0.0;
}

double pl_render_rmse(const pl_image_f32 *a, const pl_image_f32 *b)
{
    int rc = same_renders(a, b);
    if (rc < 0) return rc;
    return rmse_scaled(a, b, 1.0);
}

double pl_render_rms(const pl_image_f32 *a)
{
    int rc = same_renders(a, a);
    if (rc < 0) return rc;
    return rmse_scaled(a, a, 0.0); /* the RMSE of 0 * a against a */
}

double pl_render_ls_scale(const pl_image_f32 *a, const pl_image_f32 *b)
{
    int rc = same_renders(a, b);
    if (rc < 0) return rc;
    int s = a->width;
    double ab = 0, aa = 0;
    for (int y = 0; y < s; y++)
        for (int x = 0; x < s; x++) {
            if (!pl_sphere_mask(s, x, y)) continue;
            size_t i = ((size_t)y * (size_t)s + (size_t)x) * 3;
            for (int k = 0; k < 3; k++) {
                ab += (double)a->data[i + (size_t)k] * b->data[i + (size_t)k];
                aa += (double)a->data[i + (size_t)k] * a->data[i + (size_t)k];
            }
        }
    return aa > 0 ? ab / aa : NAN;
}

double pl_render_si_rmse(const pl_image_f32 *a, const pl_image_f32 *b)
{
    double alpha = pl_render_ls_scale(a, b);
    if (alpha < 0) return alpha;
    return rmse_scaled(a, b, isnan(alpha) ? 1.0 : alpha);
}

static int cmp_float(const void *pa, const void *pb)
{
    float a = *(const float *)pa, b = *(const float *)pb;
    return (a > b) - (a < b);
}

int pl_tonemap_rgb8(const pl_image_f32 *img, pl_image_u8 *out)
{
    if (!img || !img->data || !out) return pl_error(PL_E_ARG, "tonemap: NULL argument");
    size_t np;
    if (img->width < 1 || img->height < 1 ||
        !pl_mul_size((size_t)img->width, (size_t)img->height, &np))
        return pl_error(PL_E_ARG, "tonemap: bad image size %dx%d", img->width, img->height);
    float *v = malloc(np * sizeof *v);
    if (!v) return pl_error(PL_E_NOMEM, "tonemap: out of memory");
    size_t nv = 0;
    for (size_t i = 0; i < np; i++) {
        const float *p = img->data + i * 3;
        float mx = fmaxf(p[0], fmaxf(p[1], p[2]));
        if (mx > 0 && isfinite(mx)) v[nv++] = mx;
    }
    double ref = 0;
    if (nv) {
        qsort(v, nv, sizeof *v, cmp_float);
        size_t k = (size_t)floor(0.99 * (double)(nv - 1) + 0.5);
        ref = v[k];
    }
    free(v);
    double expo = ref > 0 ? 1.0 / ref : 1.0;
    int rc = pl_image_u8_alloc(out, img->width, img->height);
    if (rc < 0) return rc;
    for (int y = 0; y < img->height; y++)
        for (int x = 0; x < img->width; x++) {
            const float *p = img->data + ((size_t)y * (size_t)img->width + (size_t)x) * 3;
            uint8_t *o = out->data + (size_t)y * out->stride + (size_t)x * 3;
            for (int k = 0; k < 3; k++) {
                double c = p[k] * expo;
                if (!(c > 0)) c = 0;
                if (c > 1) c = 1;
                c = c <= 0.0031308 ? 12.92 * c : 1.055 * pow(c, 1.0 / 2.4) - 0.055;
                o[k] = (uint8_t)lrint(c * 255.0);
            }
        }
    return 0;
}
