/* Perspective crops of equirectangular panoramas (light/crop.h). */
#include "light/crop.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/util.h"
#include "light/equirect.h"

#define DEG (M_PI / 180.0)

void pl_crop_default_params(pl_crop_params *p)
{
    p->yaw_deg = 0;
    p->pitch_deg = 0;
    p->fov_deg = 60;
    p->width = 640;
    p->height = 480;
    p->exposure_ev = 0;
    p->gamma = 2.2;
}

int pl_crop_check_params(const pl_crop_params *p)
{
    if (!p) return pl_error(PL_E_ARG, "crop: params is NULL");
    if (!(p->yaw_deg >= -360 && p->yaw_deg <= 360))
        return pl_error(PL_E_ARG, "crop: yaw %g degrees, expected -360..360", p->yaw_deg);
    if (!(p->pitch_deg >= -90 && p->pitch_deg <= 90))
        return pl_error(PL_E_ARG, "crop: pitch %g degrees, expected -90..90", p->pitch_deg);
    if (!(p->fov_deg >= 1 && p->fov_deg <= 170))
        return pl_error(PL_E_ARG, "crop: fov %g degrees, expected 1..170", p->fov_deg);
    if (p->width < 1 || p->width > 8192 || p->height < 1 || p->height > 8192)
        return pl_error(PL_E_ARG, "crop: size %d x %d, expected 1..8192 per side", p->width,
                        p->height);
    if (!(p->exposure_ev >= -20 && p->exposure_ev <= 20))
        return pl_error(PL_E_ARG, "crop: exposure %g EV, expected -20..20", p->exposure_ev);
    if (!(p->gamma >= 0.2 && p->gamma <= 5))
        return pl_error(PL_E_ARG, "crop: gamma %g, expected 0.2..5", p->gamma);
    return PL_OK;
}

void pl_crop_rotation(const pl_crop_params *p, double R[9])
{
    double yw = p->yaw_deg * DEG, pt = p->pitch_deg * DEG;
    double f[3] = {sin(yw) * cos(pt), sin(pt), -cos(yw) * cos(pt)};
    double r[3] = {cos(yw), 0, sin(yw)};
    double b[3] = {-f[0], -f[1], -f[2]};
    double u[3] = {b[1] * r[2] - b[2] * r[1], b[2] * r[0] - b[0] * r[2], b[0] * r[1] - b[1] * r[0]};
    for (int k = 0; k < 3; k++) {
        R[3 * k + 0] = r[k];
        R[3 * k + 1] = u[k];
        R[3 * k + 2] = b[k];
    }
}

int pl_crop_project(const pl_crop_params *p, const float d[3], double *x, double *y)
{
    if (!(d[2] < 0)) return 0;
    double t = tan(p->fov_deg * DEG / 2), aspect = (double)p->height / p->width;
    double xn = d[0] / -d[2], yn = d[1] / -d[2];
    *x = (xn / t + 1) * p->width / 2;
    *y = (1 - yn / (t * aspect)) * p->height / 2;
    return *x >= 0 && *x < p->width && *y >= 0 && *y < p->height;
}

static void sample_bilinear(const pl_image_f32 *pano, const double dir[3], float out[3])
{
    int W = pano->width, H = pano->height;
    double x, y;
    pl_equirect_pixel(W, H, dir, &x, &y);
    double fx = floor(x), fy = floor(y);
    int x0 = (int)fx, y0 = (int)fy;
    double ax = x - fx, ay = y - fy;
    int x1 = x0 + 1 >= W ? 0 : x0 + 1;
    if (x0 >= W) x0 -= W; /* rounding at the seam */
    int y1 = y0 + 1;
    if (y0 < 0) y0 = 0, ay = 0;
    if (y1 > H - 1) y1 = H - 1;
    if (y0 > H - 1) y0 = H - 1;
    const float *p00 = pano->data + ((size_t)y0 * W + x0) * 3,
                *p01 = pano->data + ((size_t)y0 * W + x1) * 3;
    const float *p10 = pano->data + ((size_t)y1 * W + x0) * 3,
                *p11 = pano->data + ((size_t)y1 * W + x1) * 3;
    for (int c = 0; c < 3; c++)
        out[c] = (float)((1 - ay) * ((1 - ax) * p00[c] + ax * p01[c]) +
                         ay * ((1 - ax) * p10[c] + ax * p11[c]));
}

int pl_crop_linear(const pl_image_f32 *pano, const pl_crop_params *p, pl_image_f32 *out)
{
    if (!pano || !pano->data || !out) return pl_error(PL_E_ARG, "crop: NULL argument");
    int st = pl_crop_check_params(p);
    if (st < 0) return st;
    if (pano->height < 1 || pano->width != 2 * pano->height)
        return pl_error(PL_E_ARG, "crop: %d x %d is not a 2:1 panorama", pano->width, pano->height);
    if ((st = pl_image_f32_alloc(out, p->width, p->height)) < 0) return st;
    double R[9], t = tan(p->fov_deg * DEG / 2), aspect = (double)p->height / p->width;
    pl_crop_rotation(p, R);
    for (int j = 0; j < p->height; j++) {
        for (int i = 0; i < p->width; i++) {
            double c[3] = {(2.0 * (i + 0.5) / p->width - 1) * t,
                           (1 - 2.0 * (j + 0.5) / p->height) * t * aspect, -1};
            double w[3];
            for (int k = 0; k < 3; k++)
                w[k] = R[3 * k] * c[0] + R[3 * k + 1] * c[1] + R[3 * k + 2] * c[2];
            sample_bilinear(pano, w, out->data + ((size_t)j * p->width + i) * 3);
        }
    }
    return PL_OK;
}

static int cmp_float(const void *a, const void *b)
{
    float x = *(const float *)a, y = *(const float *)b;
    return (x > y) - (x < y);
}

double pl_crop_exposure_scale(const pl_image_f32 *lin, double ev)
{
    size_t n = (size_t)lin->width * (size_t)lin->height;
    double k = pow(2.0, ev);
    float *Y = malloc(n * sizeof *Y);
    if (!Y || n == 0) {
        free(Y);
        return k;
    }
    double mean = 0;
    for (size_t i = 0; i < n; i++) {
        const float *px = lin->data + i * 3;
        Y[i] = (float)(0.2126 * px[0] + 0.7152 * px[1] + 0.0722 * px[2]);
        mean += Y[i];
    }
    mean /= (double)n;
    qsort(Y, n, sizeof *Y, cmp_float);
    double med = Y[n / 2];
    free(Y);
    double ref = med > 0 ? med : mean;
    return ref > 0 ? k * 0.18 / ref : k;
}

int pl_crop_to_ldr(const pl_image_f32 *lin, double scale, double gamma, pl_image_u8 *out)
{
    if (!lin || !lin->data || !out || !(scale >= 0) || !isfinite(scale) || !(gamma > 0))
        return pl_error(PL_E_ARG, "crop: bad arguments to pl_crop_to_ldr");
    int st = pl_image_u8_alloc(out, lin->width, lin->height);
    if (st < 0) return st;
    double inv = 1.0 / gamma;
    for (int j = 0; j < lin->height; j++) {
        uint8_t *row = out->data + (size_t)j * out->stride;
        const float *src = lin->data + (size_t)j * lin->width * 3;
        for (int i = 0; i < lin->width * 3; i++) {
            double v = src[i] * scale;
            v = v > 0 ? (v < 1 ? pow(v, inv) : 1.0) : 0.0;
            row[i] = (uint8_t)lround(v * 255.0);
        }
    }
    return PL_OK;
}

int pl_crop_lighting(const pl_lighting *in, const pl_crop_params *p, double scale, pl_lighting *out)
{
    if (!in || !out || !p || !(scale >= 0) || !isfinite(scale))
        return pl_error(PL_E_ARG, "crop: bad arguments to pl_crop_lighting");
    double R[9];
    pl_crop_rotation(p, R);
    pl_lighting L = *in;
    for (int i = 0; i < L.n_lights; i++) {
        const float *d = in->lights[i].dir;
        for (int k = 0; k < 3; k++) /* R^T d: column k of R dotted with d */
            L.lights[i].dir[k] = (float)(R[k] * d[0] + R[3 + k] * d[1] + R[6 + k] * d[2]);
        for (int c = 0; c < 3; c++)
            L.lights[i].rgb[c] = (float)(in->lights[i].rgb[c] * scale);
    }
    for (int c = 0; c < 3; c++)
        L.ambient[c] = (float)(in->ambient[c] * scale);
    *out = L;
    return PL_OK;
}
