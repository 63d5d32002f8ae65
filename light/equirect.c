#include "light/equirect.h"

#include <math.h>

void pl_equirect_dir(int W, int H, double x, double y, double dir[3])
{
    double u = (x + 0.5) / W, v = (y + 0.5) / H;
    double phi = (u - 0.5) * 2.0 * M_PI, theta = (0.5 - v) * M_PI;
    double ct = cos(theta);
    dir[0] = sin(phi) * ct;
    dir[1] = sin(theta);
    dir[2] = -cos(phi) * ct;
}

void pl_equirect_pixel(int W, int H, const double dir[3], double *x, double *y)
{
    double n = sqrt(dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]);
    double s = n > 0 ? dir[1] / n : 0.0;
    if (s > 1.0) s = 1.0;
    if (s < -1.0) s = -1.0;
    double theta = asin(s), phi = atan2(dir[0], -dir[2]);
    double u = phi / (2.0 * M_PI) + 0.5, v = 0.5 - theta / M_PI;
    double px = u * W - 0.5, py = v * H - 0.5;
    if (px < 0) px += W;
    if (px >= W) px -= W;
    *x = px;
    *y = py;
}

double pl_equirect_pixel_sr(int W, int H, int y)
{
    double theta = (0.5 - (y + 0.5) / H) * M_PI;
    return (2.0 * M_PI / W) * (M_PI / H) * cos(theta);
}
