/* The intensity anchor (light/light.h, docs/LIGHTING.md "Intensity anchor"): the frame's mean
 * linear luminance against the lighting's mean luminance over the sphere. */
#include <math.h>
#include <stddef.h>
#include <stdint.h>

#include "core/util.h"
#include "light/light.h"

#define FOUR_PI (4.0 * M_PI)

double pl_lighting_mean_luminance(const pl_lighting *L)
{
    double y = pl_luminance(L->ambient[0], L->ambient[1], L->ambient[2]);
    for (int i = 0; i < L->n_lights && i < PL_MAX_LIGHTS; i++)
        y += pl_light_energy(&L->lights[i]) / FOUR_PI;
    return y;
}

double pl_frame_mean_luminance(const uint8_t *rgb, size_t stride, int x0, int y0, int w, int h,
                               double gamma)
{
    if (!rgb || w < 1 || h < 1 || x0 < 0 || y0 < 0 || !(gamma > 0)) return NAN;
    double lut[256];
    for (int v = 0; v < 256; v++)
        lut[v] = pow(v / 255.0, gamma);
    double sum[3] = {0, 0, 0};
    for (int y = y0; y < y0 + h; y++) {
        const uint8_t *row = rgb + (size_t)y * stride + (size_t)x0 * 3;
        for (int x = 0; x < w; x++)
            for (int c = 0; c < 3; c++)
                sum[c] += lut[row[3 * x + c]];
    }
    return pl_luminance(sum[0], sum[1], sum[2]) / ((double)w * h);
}

double pl_anchor_ratio_ev(double frame_lum, const pl_lighting *L)
{
    double y = L ? pl_lighting_mean_luminance(L) : NAN;
    if (!(frame_lum > 0) || !(y > 0) || !isfinite(frame_lum) || !isfinite(y)) return NAN;
    return log2(frame_lum / y);
}

int pl_anchor_check(double w, double b, double gamma)
{
    if (!(w >= 0 && w <= 1) || !(b >= -8 && b <= 8) || !(gamma >= 1 && gamma <= 3))
        return pl_error(PL_E_ARG, "intensity anchor w=%g b=%g gamma=%g: expected w in 0..1, "
                        "b in -8..8 (stops), gamma in 1..3", w, b, gamma);
    return 0;
}

double pl_anchor_apply(pl_lighting *L, double frame_lum, double w, double b)
{
    double ev = pl_anchor_ratio_ev(frame_lum, L);
    if (!isfinite(ev) || (w == 0 && b == 0)) return ev;
    const float s = (float)exp2(w * ev + b);
    for (int i = 0; i < L->n_lights && i < PL_MAX_LIGHTS; i++)
        for (int k = 0; k < 3; k++)
            L->lights[i].rgb[k] *= s;
    for (int k = 0; k < 3; k++)
        L->ambient[k] *= s;
    return ev;
}
