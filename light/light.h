/* Lighting maths: environment maps from parametric lights (the paper's eq. 4), relighting at
 * another point, AR outputs (primary light, L2 spherical harmonics, cube maps), sphere renders
 * and render metrics. All conventions (mapping, SG, SH basis and constants, cube-map faces, the
 * render model, metrics) are written down in docs/LIGHTING.md.
 *
 * Directions are unit vectors in the camera frame (x right, y up, camera looks along -z).
 * Images are pl_image_f32 (linear RGB, interleaved, packed rows); an environment map is a
 * W x W/2 equirectangular image in the light/equirect.h mapping. Images filled by these
 * functions are allocated here and owned by the caller (pl_image_f32_free). */
#ifndef PL_LIGHT_LIGHT_H
#define PL_LIGHT_LIGHT_H

#include "core/image.h"
#include "parlight.h"

/* Eq. (4), taken literally (DESIGN.md): radiance of the lights + ambient in unit direction u:
 * sum_i c_i exp((l_i.u - 1) / (s_i / 4pi)) + a. */
void pl_lights_radiance(const pl_lighting *L, const float u[3], float rgb[3]);

/* Energy (integral over the sphere) of one lobe per unit peak radiance, steradians:
 * 2 pi sigma (1 - exp(-2 / sigma)), sigma = s / 4pi  (about s / 2 for small s). */
double pl_sg_integral(double solid_angle_sr);

/* Luminance of linear RGB, the one weighting of light/ (Rec. 709): 0.2126 r + 0.7152 g +
 * 0.0722 b. */
static inline double pl_luminance(double r, double g, double b)
{
    return 0.2126 * r + 0.7152 * g + 0.0722 * b;
}
/* A light's energy: pl_luminance(c) * pl_sg_integral(s) (the primary-light and anchor measure). */
double pl_light_energy(const pl_light *l);

/* Checks a lighting for use by the functions here: 0 <= n_lights <= PL_MAX_LIGHTS, finite
 * values, unit-ish directions (|dir| in [0.5, 2], normalised by users), distance > 0, solid
 * angle > 0, rgb and ambient >= 0. Returns 0 or PL_E_ARG naming light and field. */
int pl_lighting_check(const pl_lighting *L);

/* Area-averaged copy of an equirectangular map at width x width/2 (width even, <= env->width):
 * each output pixel is the solid-angle-weighted mean of the source area it covers, so energy is
 * kept. When width == env->width it is a plain copy. *out is allocated. */
int pl_envmap_downsample(const pl_image_f32 *env, int width, pl_image_f32 *out);

/* Equirectangular W x W/2 map of the lights + ambient (light/equirect.h mapping), each pixel the
 * radiance at its centre direction. width even, 2..PL_IMAGE_MAX_SIDE. *out is allocated. */
int pl_envmap_from_lights(const pl_lighting *L, int width, pl_image_f32 *out);

/* The same projection of an equirectangular map (sum over pixels of L * Y * pixel solid angle). */
int pl_sh9_from_envmap(const pl_image_f32 *env, float sh[27]);

/* pl_cubemap_from_lights (the HDR cube map of lights) and pl_equirect_from_lights (the map above
 * into a caller's buffer) are public: include/parlight.h. */
/* A cube map (pl_cubemap_from_lights' layout) sampled bilinearly from an equirectangular map
 * (wrapping in longitude). */
int pl_cubemap_from_envmap(const pl_image_f32 *env, int face, float *out);
/* Unit direction through the centre of pixel (x, y) of cube face f (0..5); x, y may be fractional.
 */
void pl_cubemap_dir(int f, int face, double x, double y, double dir[3]);

/* A sphere seen from the camera (orthographic, looking along -z), size x size pixels, lit by an
 * equirectangular map or by lights; background pixels 0 and reported by pl_sphere_mask.
 * Diffuse: white Lambertian (albedo 1): (1/pi) int L(u) max(0, n.u) du.
 * Glossy: the radiance filtered by a normalised spherical-Gaussian lobe of sharpness
 * PL_GLOSSY_SHARPNESS around the mirror direction r = 2(n.v)n - v (v = +z toward the camera):
 * int L(u) D(u) du with D(u) = k exp(g (r.u - 1)), k = g / (2pi (1 - exp(-2g))), int D = 1
 * (docs/LIGHTING.md). Lights render analytically; maps by brute force over a copy area-averaged
 * to PL_RENDER_MAP_WIDTH x PL_RENDER_MAP_WIDTH/2 (when larger). size 1..4096. *out is allocated. */
typedef enum pl_material { PL_MATERIAL_DIFFUSE, PL_MATERIAL_GLOSSY } pl_material;
#define PL_GLOSSY_SHARPNESS 32.0
#define PL_RENDER_MAP_WIDTH 128
int pl_render_sphere_envmap(const pl_image_f32 *env, pl_material m, int size, pl_image_f32 *out);
int pl_render_sphere_lights(const pl_lighting *L, pl_material m, int size, pl_image_f32 *out);
/* 1 when pixel (x, y) of a size x size render is on the sphere (its centre within the disc). */
int pl_sphere_mask(int size, int x, int y);

/* Metrics over the sphere pixels (mask) of two renders of the same size, all three channels:
 *   RMSE    = sqrt(mean((a - b)^2))
 *   si-RMSE = RMSE after the least-squares scale alpha = <a,b>/<a,a> applied to a
 *             (alpha = 1 when a is all zero).
 * Negative (PL_E_ARG) when the sizes differ or an image is NULL. */
double pl_render_rmse(const pl_image_f32 *a, const pl_image_f32 *b);
double pl_render_si_rmse(const pl_image_f32 *a, const pl_image_f32 *b);
/* Root mean square of one render over the sphere pixels, all three channels (PL_E_ARG for NULL).
 * With it the RMSE of any scaled render c * a follows from the si-RMSE without rendering again:
 * RMSE(c)^2 = si-RMSE^2 + (c - alpha)^2 rms(a)^2 (the residual at alpha is orthogonal to a). */
double pl_render_rms(const pl_image_f32 *a);
/* The si-RMSE's scale alpha itself: how much a's intensity must be multiplied by to best match
 * b (NaN when a is all zero, where si-RMSE takes alpha = 1; PL_E_ARG as above). */
double pl_render_ls_scale(const pl_image_f32 *a, const pl_image_f32 *b);

/* ---- intensity anchor (docs/LIGHTING.md, "Intensity anchor") ----
 * A network's absolute intensity is its least certain output. The anchor pulls it toward the
 * frame's own brightness: the lighting is scaled by 2^(w ev + b), ev = log2(r), r = the frame's
 * mean linear luminance over the lighting's mean luminance over the sphere. w = 0 keeps the
 * network's intensity (then 2^b is a plain gain), w = 1 replaces it by the frame's; b is in
 * stops. Luminance is 0.2126 R + 0.7152 G + 0.0722 B throughout. */

/* Mean luminance of the radiance of eq. (4) over the sphere: Y(a) + sum_i Y(c_i) I(s_i) / 4pi
 * with I = pl_sg_integral. */
double pl_lighting_mean_luminance(const pl_lighting *L);
/* Mean linear luminance of the w x h region at (x0, y0) of an 8-bit RGB frame, each value
 * linearised as (v / 255)^gamma. NaN for a NULL frame, an empty region or gamma <= 0. */
double pl_frame_mean_luminance(const uint8_t *rgb, size_t stride, int x0, int y0, int w, int h,
                               double gamma);
/* log2(frame_lum / pl_lighting_mean_luminance(L)); NaN when either is not finite and > 0. */
double pl_anchor_ratio_ev(double frame_lum, const pl_lighting *L);
/* 0 for w in [0, 1], b in [-8, 8] and gamma in [1, 3]; else PL_E_ARG naming the values. */
int pl_anchor_check(double w, double b, double gamma);
/* Scales L's light colours and ambient by 2^(w ev + b), ev = pl_anchor_ratio_ev(frame_lum, L),
 * and returns ev. When ev is NaN (a black frame or a black lighting) L is left as it is: there
 * is nothing to anchor to. With w in [0, 1] the result's mean luminance lies between the two
 * means (times 2^b), so it stays finite. */
double pl_anchor_apply(pl_lighting *L, double frame_lum, double w, double b);

/* Display version of a linear image for PNG: exposure so that the 99th percentile of the pixels'
 * max(r,g,b) (over pixels with any non-zero channel) maps to 1, clip, sRGB OETF, rounded to
 * 8 bits. *out is allocated (pl_image_u8_free). */
int pl_tonemap_rgb8(const pl_image_f32 *img, pl_image_u8 *out);

#endif
