/* HDR cube maps in OpenGL / WebGL TEXTURE_CUBE_MAP conventions (docs/LIGHTING.md). */
#include <math.h>

#include "core/util.h"
#include "light/equirect.h"
#include "light/light.h"

void pl_cubemap_dir(int f, int face, double x, double y, double dir[3])
{
    /* sc, tc in [-1, 1]: s to the right, t down the stored rows (row 0 = t = 0) */
    double sc = 2.0 * (x + 0.5) / face - 1.0, tc = 2.0 * (y + 0.5) / face - 1.0;
    double v[3];
    switch (f) {
    case 0: /* +X */
        v[0] = 1, v[1] = -tc, v[2] = -sc;
        break;
    case 1: /* -X */
        v[0] = -1, v[1] = -tc, v[2] = sc;
        break;
    case 2: /* +Y */
        v[0] = sc, v[1] = 1, v[2] = tc;
        break;
    case 3: /* -Y */
        v[0] = sc, v[1] = -1, v[2] = -tc;
        break;
    case 4: /* +Z */
        v[0] = sc, v[1] = -tc, v[2] = 1;
        break;
    default: /* -Z */
        v[0] = -sc, v[1] = -tc, v[2] = -1;
        break;
    }
    double n = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    for (int k = 0; k < 3; k++)
        dir[k] = v[k] / n;
}

static int check_face(int face, const float *out)
{
    if (!out) return pl_error(PL_E_ARG, "cube map: output buffer is NULL");
    if (face < 1 || face > 4096)
        return pl_error(PL_E_ARG, "cube map face size %d: expected 1..4096", face);
    return 0;
}

int pl_cubemap_from_lights(const pl_lighting *L, int face, float *out)
{
    int rc = check_face(face, out);
    if (rc < 0) return rc;
    if ((rc = pl_lighting_check(L)) < 0) return rc;
    size_t i = 0;
    for (int f = 0; f < 6; f++)
        for (int y = 0; y < face; y++)
            for (int x = 0; x < face; x++, i += 3) {
                double d[3];
                pl_cubemap_dir(f, face, x, y, d);
                float u[3] = {(float)d[0], (float)d[1], (float)d[2]};
                pl_lights_radiance(L, u, out + i);
            }
    return 0;
}

/* Bilinear sample of an equirectangular map at continuous pixel (px, py), wrapping in x and
 * clamping in y. */
static void sample_bilinear(const pl_image_f32 *env, double px, double py, float rgb[3])
{
    int W = env->width, H = env->height;
    double fx = floor(px), fy = floor(py);
    double ax = px - fx, ay = py - fy;
    int x0 = (int)fx, y0 = (int)fy;
    int x1 = x0 + 1, y1 = y0 + 1;
    x0 = ((x0 % W) + W) % W;
    x1 = ((x1 % W) + W) % W;
    if (y0 < 0) y0 = 0;
    if (y1 < 0) y1 = 0;
    if (y0 > H - 1) y0 = H - 1;
    if (y1 > H - 1) y1 = H - 1;
    const float *p00 = env->data + ((size_t)y0 * (size_t)W + (size_t)x0) * 3;
    const float *p01 = env->data + ((size_t)y0 * (size_t)W + (size_t)x1) * 3;
    const float *p10 = env->data + ((size_t)y1 * (size_t)W + (size_t)x0) * 3;
    const float *p11 = env->data + ((size_t)y1 * (size_t)W + (size_t)x1) * 3;
    for (int k = 0; k < 3; k++)
        rgb[k] = (float)((1 - ay) * ((1 - ax) * p00[k] + ax * p01[k]) +
                         ay * ((1 - ax) * p10[k] + ax * p11[k]));
}

int pl_cubemap_from_envmap(const pl_image_f32 *env, int face, float *out)
{
    int rc = check_face(face, out);
    if (rc < 0) return rc;
    if (!env || !env->data || env->width < 2 || env->width != 2 * env->height)
        return pl_error(PL_E_ARG, "cube map: environment map %dx%d, expected a 2:1 panorama",
                        env ? env->width : 0, env ? env->height : 0);
    size_t i = 0;
    for (int f = 0; f < 6; f++)
        for (int y = 0; y < face; y++)
            for (int x = 0; x < face; x++, i += 3) {
                double d[3], px, py;
                pl_cubemap_dir(f, face, x, y, d);
                pl_equirect_pixel(env->width, env->height, d, &px, &py);
                sample_bilinear(env, px, py, out + i);
            }
    return 0;
}
