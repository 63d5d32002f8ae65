/* The one pixel <-> direction mapping for equirectangular (latitude-longitude) images, used by
 * every reader, renderer, extractor and crop in parlight (docs/LIGHTING.md).
 *
 * Image W x H (W = 2H), pixel (x, y) with x to the right and y down, pixel centres at +0.5:
 *   u = (x + 0.5) / W,  v = (y + 0.5) / H
 *   longitude phi = (u - 0.5) * 2pi   in (-pi, pi]     (0 at the image centre)
 *   latitude theta = (0.5 - v) * pi   in (-pi/2, pi/2] (+pi/2 at the top row)
 *   dir = (sin(phi) cos(theta), sin(theta), -cos(phi) cos(theta))
 * So the centre of the panorama looks along -z (the camera's forward), its top is +y, and moving
 * right in the image turns toward +x. A pixel covers the solid angle
 *   (2pi / W) * (pi / H) * cos(theta). */
#ifndef PL_LIGHT_EQUIRECT_H
#define PL_LIGHT_EQUIRECT_H

/* Direction (unit) of the centre of pixel (x, y) in a W x H panorama; x, y may be fractional. */
void pl_equirect_dir(int W, int H, double x, double y, double dir[3]);
/* Continuous pixel coordinates (pixel centres at integers, the inverse of pl_equirect_dir) of
 * direction `dir` (need not be unit): x wrapped into [0, W), y in [-0.5, H - 0.5]. */
void pl_equirect_pixel(int W, int H, const double dir[3], double *x, double *y);
/* Solid angle of one pixel of row y (steradians). */
double pl_equirect_pixel_sr(int W, int H, int y);

#endif
