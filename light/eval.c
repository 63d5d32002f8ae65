/* Per-crop evaluation maths: baselines, the truth render, scores and quartiles (light/eval.h,
 * docs/EVAL.md). */
#include "light/eval.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/util.h"
#include "light/equirect.h"
#include "light/light.h"

#define DEG (M_PI / 180.0)

static const char *const method_keys[PL_EVAL_N_METHODS] = {"model", "ambient", "brightest",
                                                           "gt_lights", "ridge"};
static const char *const method_labels[PL_EVAL_N_METHODS] = {
    "model", "(a) mean ambient", "(b) brightest + ambient", "(c) gt lights", "(d) ridge"};

const char *pl_eval_method_key(int m)
{
    return m >= 0 && m < PL_EVAL_N_METHODS ? method_keys[m] : NULL;
}

const char *pl_eval_method_label(int m)
{
    return m >= 0 && m < PL_EVAL_N_METHODS ? method_labels[m] : "?";
}

int pl_eval_make_crop(const pl_image_f32 *pano, const pl_crop_params *p, pl_image_u8 *ldr,
                      double *k)
{
    if (!ldr || !k) return pl_error(PL_E_ARG, "eval: NULL output");
    pl_image_f32 lin = {0, 0, NULL};
    int rc = pl_crop_linear(pano, p, &lin);
    if (rc < 0) return rc;
    *k = pl_crop_exposure_scale(&lin, p->exposure_ev);
    rc = pl_crop_to_ldr(&lin, *k, p->gamma, ldr);
    pl_image_f32_free(&lin);
    return rc;
}

static int check_ldr(const pl_image_u8 *ldr, double gamma)
{
    if (!ldr || !ldr->data || ldr->width < 1 || ldr->height < 1 ||
        ldr->stride < (size_t)ldr->width * 3)
        return pl_error(PL_E_ARG, "eval: bad crop image");
    if (!(gamma >= 0.2 && gamma <= 5))
        return pl_error(PL_E_ARG, "eval: gamma %g: expected 0.2..5", gamma);
    return 0;
}

/* (v / 255)^gamma for v = 0..255: the inverse of the crop's response (clipped values stay 1). */
static void linear_table(double gamma, double lut[256])
{
    for (int v = 0; v < 256; v++)
        lut[v] = pow(v / 255.0, gamma);
}

/* Sum of the linear colours of the pixels in [x0, x1) x [y0, y1). */
static void sum_linear(const pl_image_u8 *ldr, const double lut[256], int x0, int y0, int x1,
                       int y1, double sum[3])
{
    sum[0] = sum[1] = sum[2] = 0;
    for (int y = y0; y < y1; y++) {
        const uint8_t *row = ldr->data + (size_t)y * ldr->stride;
        for (int x = x0; x < x1; x++)
            for (int c = 0; c < 3; c++)
                sum[c] += lut[row[3 * x + c]];
    }
}

int pl_eval_baseline_ambient(const pl_image_u8 *ldr, double gamma, pl_lighting *out)
{
    int rc = check_ldr(ldr, gamma);
    if (rc < 0) return rc;
    if (!out) return pl_error(PL_E_ARG, "eval: NULL output");
    double lut[256], sum[3];
    linear_table(gamma, lut);
    sum_linear(ldr, lut, 0, 0, ldr->width, ldr->height, sum);
    memset(out, 0, sizeof *out);
    double n = (double)ldr->width * ldr->height;
    for (int c = 0; c < 3; c++)
        out->ambient[c] = (float)(sum[c] / n);
    return 0;
}

/* Unit direction (camera frame) through continuous pixel coordinates (x, y) of the crop. */
static void pinhole_dir(const pl_crop_params *p, double x, double y, double d[3])
{
    double t = tan(p->fov_deg * DEG / 2), aspect = (double)p->height / p->width;
    d[0] = (2.0 * x / p->width - 1) * t;
    d[1] = (1 - 2.0 * y / p->height) * t * aspect;
    d[2] = -1;
    double n = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    for (int k = 0; k < 3; k++)
        d[k] /= n;
}

int pl_eval_baseline_brightest(const pl_image_u8 *ldr, const pl_crop_params *p, pl_lighting *out)
{
    if (!p || !out) return pl_error(PL_E_ARG, "eval: NULL argument");
    int rc = pl_crop_check_params(p);
    if (rc < 0 || (rc = check_ldr(ldr, p->gamma)) < 0) return rc;
    if (ldr->width != p->width || ldr->height != p->height)
        return pl_error(PL_E_ARG, "eval: crop image %dx%d, parameters say %dx%d", ldr->width,
                        ldr->height, p->width, p->height);
    const int W = ldr->width, H = ldr->height;
    const int cs = W / PL_EVAL_CELL_DIV > 1 ? W / PL_EVAL_CELL_DIV : 1;
    double lut[256];
    linear_table(p->gamma, lut);

    int bx = 0, by = 0;
    double best = -1;
    for (int y0 = 0; y0 < H; y0 += cs)
        for (int x0 = 0; x0 < W; x0 += cs) {
            int x1 = x0 + cs < W ? x0 + cs : W, y1 = y0 + cs < H ? y0 + cs : H;
            double s[3];
            sum_linear(ldr, lut, x0, y0, x1, y1, s);
            double mean_y = pl_luminance(s[0], s[1], s[2]) / ((double)(x1 - x0) * (y1 - y0));
            if (mean_y > best) best = mean_y, bx = x0, by = y0;
        }
    const int bx1 = bx + cs < W ? bx + cs : W, by1 = by + cs < H ? by + cs : H;

    double wsum = 0, cx = 0, cy = 0, cell[3], all[3];
    for (int y = by; y < by1; y++) {
        const uint8_t *row = ldr->data + (size_t)y * ldr->stride;
        for (int x = bx; x < bx1; x++) {
            const double rgb[3] = {lut[row[3 * x]], lut[row[3 * x + 1]], lut[row[3 * x + 2]]};
            double w = pl_luminance(rgb[0], rgb[1], rgb[2]);
            wsum += w;
            cx += w * (x + 0.5);
            cy += w * (y + 0.5);
        }
    }
    if (wsum > 0)
        cx /= wsum, cy /= wsum;
    else
        cx = 0.5 * (bx + bx1), cy = 0.5 * (by + by1);
    double dir[3];
    pinhole_dir(p, cx, cy, dir);

    sum_linear(ldr, lut, bx, by, bx1, by1, cell);
    sum_linear(ldr, lut, 0, 0, W, H, all);
    const double n_all = (double)W * H, n_cell = (double)(bx1 - bx) * (by1 - by);
    double amb[3], mean[3];
    for (int c = 0; c < 3; c++) {
        mean[c] = all[c] / n_all;
        amb[c] = n_all > n_cell ? (all[c] - cell[c]) / (n_all - n_cell) : mean[c];
    }

    /* G: the lobe's mean over the crop's pixel directions */
    const double sigma = PL_EVAL_BRIGHT_SR / (4.0 * M_PI);
    double G = 0;
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            double u[3];
            pinhole_dir(p, x + 0.5, y + 0.5, u);
            G += exp((dir[0] * u[0] + dir[1] * u[1] + dir[2] * u[2] - 1) / sigma);
        }
    G /= n_all;

    memset(out, 0, sizeof *out);
    out->n_lights = 1;
    pl_light *l = &out->lights[0];
    for (int k = 0; k < 3; k++) {
        l->dir[k] = (float)dir[k];
        l->rgb[k] = (float)(G > 0 && mean[k] > amb[k] ? (mean[k] - amb[k]) / G : 0.0);
        out->ambient[k] = (float)amb[k];
    }
    l->distance_m = 2.0f;
    l->solid_angle_sr = (float)PL_EVAL_BRIGHT_SR;
    return 0;
}

/* Bilinear sample of an equirectangular map at continuous pixel coordinates (x, y) as
 * pl_equirect_pixel gives them: x wraps, y is clamped to the first and last rows. */
static void sample_map(const pl_image_f32 *m, double x, double y, double out[3])
{
    const int W = m->width, H = m->height;
    double fx = floor(x), fy = floor(y), ax = x - fx, ay = y - fy;
    int xa = (int)fx % W, ya = (int)fy;
    if (xa < 0) xa += W;
    int xb = xa + 1 == W ? 0 : xa + 1, yb = ya + 1;
    if (ya < 0) ya = 0;
    if (ya > H - 1) ya = H - 1;
    if (yb < 0) yb = 0;
    if (yb > H - 1) yb = H - 1;
    const float *r0 = m->data + (size_t)ya * (size_t)W * 3,
                *r1 = m->data + (size_t)yb * (size_t)W * 3;
    for (int c = 0; c < 3; c++) {
        double top = (1 - ax) * (double)r0[3 * xa + c] + ax * (double)r0[3 * xb + c];
        double bot = (1 - ax) * (double)r1[3 * xa + c] + ax * (double)r1[3 * xb + c];
        out[c] = (1 - ay) * top + ay * bot;
    }
}

int pl_eval_envmap_to_camera(const pl_image_f32 *env, const pl_crop_params *p, double scale,
                             int width, pl_image_f32 *out)
{
    if (!env || !env->data || !p || !out) return pl_error(PL_E_ARG, "eval: NULL argument");
    if (env->width < 2 || env->width != 2 * env->height)
        return pl_error(PL_E_ARG, "eval: environment map %dx%d, expected a 2:1 panorama",
                        env->width, env->height);
    if (width < 2 || width > 4096 || width % 2)
        return pl_error(PL_E_ARG, "eval: map width %d: expected an even number in 2..4096", width);
    if (!(scale >= 0) || !isfinite(scale))
        return pl_error(PL_E_ARG, "eval: scale %g: expected a finite number >= 0", scale);
    int rc = pl_crop_check_params(p);
    if (rc < 0) return rc;
    pl_image_f32 small = {0, 0, NULL};
    const pl_image_f32 *src = env;
    if (env->width > width) {
        if ((rc = pl_envmap_downsample(env, width, &small)) < 0) return rc;
        src = &small;
    }
    const int W = width, H = width / 2;
    if ((rc = pl_image_f32_alloc(out, W, H)) < 0) goto done;
    double R[9];
    pl_crop_rotation(p, R);
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            double u[3], w[3], sx, sy, v[3];
            pl_equirect_dir(W, H, x, y, u);
            for (int k = 0; k < 3; k++)
                w[k] = R[3 * k] * u[0] + R[3 * k + 1] * u[1] + R[3 * k + 2] * u[2];
            pl_equirect_pixel(src->width, src->height, w, &sx, &sy);
            sample_map(src, sx, sy, v);
            float *o = out->data + ((size_t)y * (size_t)W + (size_t)x) * 3;
            for (int c = 0; c < 3; c++)
                o[c] = (float)(scale * v[c]);
        }
done:
    pl_image_f32_free(&small);
    return rc;
}

int pl_eval_truth_render(const pl_image_f32 *pano, const pl_crop_params *p, double k, int size,
                         pl_image_f32 *out)
{
    pl_image_f32 cam = {0, 0, NULL};
    int rc = pl_eval_envmap_to_camera(pano, p, k, PL_EVAL_TRUTH_MAP_WIDTH, &cam);
    if (rc < 0) return rc;
    rc = pl_render_sphere_envmap(&cam, PL_MATERIAL_DIFFUSE, size, out);
    pl_image_f32_free(&cam);
    return rc;
}

double pl_eval_angle_deg(const float a[3], const float b[3])
{
    double d = 0, na = 0, nb = 0;
    for (int k = 0; k < 3; k++) {
        d += (double)a[k] * (double)b[k];
        na += (double)a[k] * (double)a[k];
        nb += (double)b[k] * (double)b[k];
    }
    if (!(na > 0 && nb > 0)) return NAN;
    double c = d / sqrt(na * nb);
    return acos(c > 1 ? 1 : c < -1 ? -1 : c) / DEG;
}

int pl_eval_score(const pl_lighting *L, const pl_image_f32 *truth, const pl_lighting *gt,
                  pl_eval_scores *out)
{
    if (!L || !truth || !truth->data || !gt || !out)
        return pl_error(PL_E_ARG, "eval: NULL argument");
    pl_image_f32 r = {0, 0, NULL};
    int rc = pl_render_sphere_lights(L, PL_MATERIAL_DIFFUSE, truth->width, &r);
    if (rc < 0) return rc;
    out->rmse = pl_render_rmse(&r, truth);
    out->si_rmse = pl_render_si_rmse(&r, truth);
    const double alpha = pl_render_ls_scale(&r, truth); /* NaN for a black render */
    out->render_rms = pl_render_rms(&r);
    pl_image_f32_free(&r);
    if (out->rmse < 0 || out->si_rmse < 0 || alpha < 0 || out->render_rms < 0)
        return PL_E_ARG; /* message set by the metric */
    out->scale_ev = alpha > 0 ? log2(alpha) : NAN;
    out->angle_deg = NAN;
    if (gt->n_lights > 0) {
        float da[3], db[3], rgb[3];
        pl_lighting_primary(L, da, rgb);
        pl_lighting_primary(gt, db, rgb);
        out->angle_deg = pl_eval_angle_deg(da, db);
    }
    return 0;
}

int pl_eval_crop(const pl_image_f32 *pano, const pl_lighting *pano_lights, const pl_crop_params *p,
                 const pl_image_u8 *ldr, double k, const pl_lighting *pred,
                 const pl_lighting *ridge_pred, int size, pl_eval_scores out[PL_EVAL_N_METHODS],
                 pl_lighting *gt_out, pl_lighting *brightest_out, pl_image_f32 *truth_out)
{
    if (!pano || !pano_lights || !p || !ldr || !pred || !out)
        return pl_error(PL_E_ARG, "eval: NULL argument");
    pl_image_f32 truth = {0, 0, NULL};
    pl_lighting L[PL_EVAL_N_METHODS], gt;
    int rc = pl_crop_lighting(pano_lights, p, k, &gt);
    if (rc < 0) return rc;
    L[PL_EVAL_MODEL] = *pred;
    L[PL_EVAL_GT_LIGHTS] = gt;
    if (ridge_pred) L[PL_EVAL_RIDGE] = *ridge_pred;
    if ((rc = pl_eval_baseline_ambient(ldr, p->gamma, &L[PL_EVAL_AMBIENT])) < 0 ||
        (rc = pl_eval_baseline_brightest(ldr, p, &L[PL_EVAL_BRIGHTEST])) < 0 ||
        (rc = pl_eval_truth_render(pano, p, k, size, &truth)) < 0)
        return rc;
    for (int m = 0; m < PL_EVAL_N_METHODS && rc == 0; m++) {
        if (m == PL_EVAL_RIDGE && !ridge_pred) {
            out[m].rmse = out[m].si_rmse = out[m].scale_ev = out[m].render_rms = NAN;
            out[m].angle_deg = NAN;
            continue;
        }
        if ((rc = pl_eval_score(&L[m], &truth, &gt, &out[m])) < 0)
            pl_error_prefix(rc, "eval: %s", pl_eval_method_key(m));
    }
    if (rc == 0 && truth_out)
        *truth_out = truth;
    else
        pl_image_f32_free(&truth);
    if (rc == 0 && gt_out) *gt_out = gt;
    if (rc == 0 && brightest_out) *brightest_out = L[PL_EVAL_BRIGHTEST];
    return rc;
}

static int cmp_double(const void *pa, const void *pb)
{
    double a = *(const double *)pa, b = *(const double *)pb;
    return (a > b) - (a < b);
}

static double quantile_sorted(const double *s, int n, double q)
{
    double pos = q * (n - 1);
    int i = (int)floor(pos);
    if (i >= n - 1) return s[n - 1];
    double f = pos - i;
    return s[i] + f * (s[i + 1] - s[i]);
}

int pl_eval_quartiles(const double *v, int n, pl_eval_stats *out)
{
    if (!out || n < 0 || (n > 0 && !v)) return pl_error(PL_E_ARG, "eval: bad quartile arguments");
    out->q1 = out->median = out->q3 = NAN;
    out->n = 0;
    if (n == 0) return 0;
    double *s = malloc((size_t)n * sizeof *s);
    if (!s) return pl_error(PL_E_NOMEM, "eval: out of memory for %d values", n);
    int m = 0;
    for (int i = 0; i < n; i++)
        if (isfinite(v[i])) s[m++] = v[i];
    if (m > 0) {
        qsort(s, (size_t)m, sizeof *s, cmp_double);
        out->q1 = quantile_sorted(s, m, 0.25);
        out->median = quantile_sorted(s, m, 0.5);
        out->q3 = quantile_sorted(s, m, 0.75);
    }
    out->n = m;
    free(s);
    return 0;
}
