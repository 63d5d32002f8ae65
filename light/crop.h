/* Perspective LDR crops of HDR panoramas, for training and evaluation (the paper's dataset:
 * limited-field-of-view crops of each panorama; docs/EXTRACTION.md "Crops").
 *
 * Camera: a pinhole at the panorama's centre. Its optical axis looks at longitude yaw and latitude
 * pitch of the panorama (light/equirect.h: yaw 0 = the panorama's centre = -z, positive yaw turns
 * right toward +x, positive pitch looks up); no roll. fov is the HORIZONTAL field of view; the
 * vertical one follows from width/height (square pixels). The camera's frame is the usual one
 * (x right, y up, looking along -z), and the rotation R (world-from-camera, row-major 3x3) has
 * columns right, up, back:
 *   forward f = (sin(yaw) cos(pitch), sin(pitch), -cos(yaw) cos(pitch))
 *   right   r = (cos(yaw), 0, sin(yaw)),   back b = -f,   up u = b x r
 * Pixel (i, j) (centres at +0.5) looks along R * normalize(x_n, y_n, -1) with
 *   x_n = (2 (i + 0.5) / width - 1) tan(fov/2),  y_n = (1 - 2 (j + 0.5) / height) tan(fov/2)
 * height/width. The panorama is sampled bilinearly at that direction (wrapping in longitude,
 * clamped at the poles).
 *
 * Exposure rule: scale k = 2^ev * 0.18 / median(Y) of the linear crop (Y = 0.2126 R + 0.7152 G +
 * 0.0722 B): the crop's median luminance lands on 18% grey, and ev offsets it. When the median
 * is 0 the mean is used; when that is 0 too, k = 2^ev.
 * Camera response: v = clip(k * L, 0, 1) ^ (1 / gamma) per channel (gamma 2.2 by default;
 * gamma 1 is linear), then round(255 v) to 8 bits.
 * Ground truth: the panorama's lights expressed in the crop's camera frame (dir' = R^T dir),
 * rgb and ambient multiplied by k (the same scale as the pixels, before the response curve),
 * distance and solid angle unchanged. */
#ifndef PL_LIGHT_CROP_H
#define PL_LIGHT_CROP_H

#include "core/image.h"
#include "parlight.h"

typedef struct pl_crop_params {
    double yaw_deg;     /* -360..360 */
    double pitch_deg;   /* -90..90 */
    double fov_deg;     /* horizontal, 1..170, default 60 */
    int width, height;  /* output size, 1..8192, default 640 x 480 */
    double exposure_ev; /* offset of the auto exposure, -20..20, default 0 */
    double gamma;       /* response exponent 1/gamma, 0.2..5, default 2.2 */
} pl_crop_params;

void pl_crop_default_params(pl_crop_params *p);
/* PL_E_ARG naming the field when out of range. */
int pl_crop_check_params(const pl_crop_params *p);
/* World-from-camera rotation (row-major 3x3) of the crop's camera. */
void pl_crop_rotation(const pl_crop_params *p, double R[9]);
/* Projects a direction in the crop's CAMERA frame to continuous pixel coordinates (centres at
 * +0.5, so pixel i spans [i, i+1)); returns 1 when it is in front of the camera and inside the
 * image, else 0 (x, y still set when in front). */
int pl_crop_project(const pl_crop_params *p, const float dir_cam[3], double *x, double *y);

/* Linear crop: width x height, RGB float, *out allocated (pl_image_f32_free). */
int pl_crop_linear(const pl_image_f32 *pano, const pl_crop_params *p, pl_image_f32 *out);
/* The exposure scale k of the rule above for a linear crop. */
double pl_crop_exposure_scale(const pl_image_f32 *lin, double exposure_ev);
/* Camera response and 8-bit clipping; *out allocated (pl_image_u8_free). */
int pl_crop_to_ldr(const pl_image_f32 *lin, double scale, double gamma, pl_image_u8 *out);
/* The panorama's lighting in the crop's camera frame, colours and ambient times scale. */
int pl_crop_lighting(const pl_lighting *pano_lights, const pl_crop_params *p, double scale,
                     pl_lighting *out);

#endif
