/* Evaluation of lighting estimates on crops of HDR panoramas, against the ground truth and four
 * baselines: the per-crop maths of `parlight eval` (every rule in docs/EVAL.md).
 *
 * A crop is the paper's: light/crop.h's pinhole at the panorama's centre, exposed by its scale k,
 * through the response v = clip(k L)^(1/gamma), 8 bits. Everything below is on the crop's scale
 * (the panorama's radiance times k) and in the crop's camera frame (x right, y up, looking
 * along -z), like the ground truth that `parlight crop --gt` writes.
 *
 * Per crop and method, these scores (pl_eval_scores):
 *   rmse, si_rmse  pl_render_rmse / pl_render_si_rmse between the diffuse sphere (size x size,
 *                  light/light.h) lit by the method's lighting and the TRUTH: the diffuse sphere
 *                  lit by the real panorama rotated into the crop's camera frame, times k
 *                  (pl_eval_truth_render).
 *   scale_ev       log2 of the si-RMSE's least-squares scale (pl_render_ls_scale): by how many
 *                  stops the method's render must be brightened (> 0) or dimmed (< 0) to best
 *                  match the truth, its intensity error without its shape error; NaN when the
 *                  render or that scale is 0.
 *   render_rms     the RMS of the method's own render (pl_render_rms): with rmse, si_rmse and
 *                  scale_ev it gives the RMSE the method would score at any other intensity
 *                  (tools/train/fit_anchor.py).
 *   angle_deg      the angle between the method's primary light (pl_lighting_primary) and the
 *                  ground-truth lights' primary light; NaN when the ground truth has no light.
 *                  A lighting without lights has WebXR's default primary direction (0, 1, 0).
 *
 * The methods (pl_eval_method):
 *   MODEL      the estimate under test (given by the caller: pl_estimate_rgb8 of the crop)
 *   AMBIENT    (a) no light; ambient = the crop's mean linear colour
 *   BRIGHTEST  (b) one light toward the crop's brightest cell plus the ambient of the rest
 *   GT_LIGHTS  (c) the extracted ground-truth lights in the crop's frame (pl_crop_lighting): the
 *              parametric representation's ceiling
 *   RIDGE      (d) a linear model of the crop's coarse log pixels fit on the training crops
 *              (light/ridge.h; given by the caller, pl_ridge_predict of the crop): what a few
 *              thousand learned parameters get. Optional: without a model its scores are NaN.
 * Linear colour of an 8-bit value v: (v / 255)^gamma with the crop's gamma, the inverse of the
 * response; clipped (saturated) pixels stay at 1, so the baselines see only what the camera saw. */
#ifndef PL_LIGHT_EVAL_H
#define PL_LIGHT_EVAL_H

#include "core/image.h"
#include "light/crop.h"
#include "parlight.h"

typedef enum pl_eval_method {
    PL_EVAL_MODEL = 0,
    PL_EVAL_AMBIENT,
    PL_EVAL_BRIGHTEST,
    PL_EVAL_GT_LIGHTS,
    PL_EVAL_RIDGE,
    PL_EVAL_N_METHODS
} pl_eval_method;

/* Baseline (b): the grid's cell side is the crop's width / PL_EVAL_CELL_DIV pixels (80 px, 7.5
 * degrees, for the 640 x 480, 60-degree crops), and the light's fixed solid angle. */
#define PL_EVAL_CELL_DIV 8
#define PL_EVAL_BRIGHT_SR 0.1

/* Short key ("model", "ambient", "brightest", "gt_lights", "ridge") and a label for tables;
 * NULL / "?" outside 0..PL_EVAL_N_METHODS-1. */
const char *pl_eval_method_key(int m);
const char *pl_eval_method_label(int m);

typedef struct pl_eval_scores {
    double rmse, si_rmse; /* render metrics (light/light.h), on the crop's scale */
    double scale_ev;      /* log2 of the least-squares scale; NaN when undefined */
    double render_rms;    /* RMS of the method's own render (pl_render_rms) */
    double angle_deg;     /* 0..180, NaN when the ground truth has no light */
} pl_eval_scores;

/* The crop's 8-bit image (light/crop.h: pl_crop_linear, pl_crop_exposure_scale with
 * p->exposure_ev, pl_crop_to_ldr with p->gamma) and its exposure scale k. *ldr is allocated
 * (pl_image_u8_free). */
int pl_eval_make_crop(const pl_image_f32 *pano, const pl_crop_params *p, pl_image_u8 *ldr,
                      double *k);

/* Baseline (a): n_lights 0, ambient = mean over pixels of (v / 255)^gamma per channel. */
int pl_eval_baseline_ambient(const pl_image_u8 *ldr, double gamma, pl_lighting *out);

/* Baseline (b), in the crop's camera frame (p gives gamma, fov and the size, which must be
 * ldr's):
 *  1. linear colours as above; luminance Y = 0.2126 R + 0.7152 G + 0.0722 B;
 *  2. the image is cut into square cells of side max(1, width / PL_EVAL_CELL_DIV) pixels (the
 *     last row and column of cells may be smaller); the brightest cell is the one with the
 *     largest mean Y (the first in raster order on ties);
 *  3. direction: through the pinhole (light/crop.h) at the Y-weighted centroid of that cell's
 *     pixel centres (the cell's centre when its Y is all 0);
 *  4. solid angle PL_EVAL_BRIGHT_SR; distance 2 m (unused by the metrics, which are at the
 *     camera);
 *  5. ambient a = the mean linear colour of the pixels outside that cell (of all pixels when the
 *     cell is the whole image);
 *  6. colour c = max(0, (m - a) / G) per channel, m the crop's mean linear colour and G the mean
 *     over the crop's pixel directions of the lobe exp((l.u - 1) / (s / 4pi)): the lighting's
 *     mean radiance over the crop's field of view then equals the crop's mean colour. */
int pl_eval_baseline_brightest(const pl_image_u8 *ldr, const pl_crop_params *p, pl_lighting *out);

/* An equirectangular map rotated into the crop's camera frame: out is width x width/2 (even,
 * 2..4096) with out(u) = scale * env(R u), R = pl_crop_rotation(p). env is first area-averaged
 * to `width` (pl_envmap_downsample) when wider, then sampled bilinearly (wrapping in longitude,
 * clamped at the poles), so a yaw-only rotation by a multiple of 360 / width degrees is an exact
 * shift of columns. *out is allocated. */
int pl_eval_envmap_to_camera(const pl_image_f32 *env, const pl_crop_params *p, double scale,
                             int width, pl_image_f32 *out);

/* The truth render: the diffuse sphere (size x size) lit by pl_eval_envmap_to_camera(pano, p, k,
 * PL_EVAL_TRUTH_MAP_WIDTH) (which pl_render_sphere_envmap then averages to its
 * PL_RENDER_MAP_WIDTH). *out is allocated. */
#define PL_EVAL_TRUTH_MAP_WIDTH 256
int pl_eval_truth_render(const pl_image_f32 *pano, const pl_crop_params *p, double k, int size,
                         pl_image_f32 *out);

/* Angle in degrees between two non-zero directions (0..180). */
double pl_eval_angle_deg(const float a[3], const float b[3]);

/* Scores of lighting L against the truth render (its size is the render size) and the
 * ground-truth lights gt (for the angle). */
int pl_eval_score(const pl_lighting *L, const pl_image_f32 *truth, const pl_lighting *gt,
                  pl_eval_scores *out);

/* Everything for one crop: the truth render of pano at size, the baselines from ldr, the
 * ground-truth lights pano_lights rotated and scaled by k (pl_crop_lighting), and the scores of
 * the methods, out[PL_EVAL_MODEL] for `pred`, out[PL_EVAL_RIDGE] for `ridge_pred` (all NaN when
 * it is NULL: (d) not scored). pano_lights in the panorama's frame (as
 * pl_extract_lights gives them), ldr and k from pl_eval_make_crop(pano, p). Reentrant: crops
 * can be scored on several threads at once. gt_out and brightest_out (each may be NULL) receive
 * the crop's ground truth and baseline (b)'s lighting; truth_out (may be NULL) the truth render,
 * to score more lightings with pl_eval_score (the caller frees it; untouched on failure). */
int pl_eval_crop(const pl_image_f32 *pano, const pl_lighting *pano_lights, const pl_crop_params *p,
                 const pl_image_u8 *ldr, double k, const pl_lighting *pred,
                 const pl_lighting *ridge_pred, int size, pl_eval_scores out[PL_EVAL_N_METHODS],
                 pl_lighting *gt_out, pl_lighting *brightest_out, pl_image_f32 *truth_out);

/* Median and quartiles of the finite values among v[0..n) (NaN are left out): linear
 * interpolation between order statistics at positions q (n' - 1), q = 0.25, 0.5, 0.75 (numpy's
 * default, "type 7"), n' the count of finite values. All NaN when n' = 0. v is not modified;
 * allocates a temporary copy (PL_E_NOMEM). */
typedef struct pl_eval_stats {
    double q1, median, q3;
    int n; /* finite values used */
} pl_eval_stats;
int pl_eval_quartiles(const double *v, int n, pl_eval_stats *out);

#endif
