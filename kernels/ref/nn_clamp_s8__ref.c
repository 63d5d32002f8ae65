#include "kernels/ref/nn_ref_s8_clamp.h"

void nn_clamp_s8__ref(const nn_dims *d, int8_t *data, int c_stride, const int8_t *clamp_lo,
                      const int8_t *clamp_hi, int c_begin, int c_end)
{
    for (int b = 0; b < d->n; b++)
        for (int y = 0; y < d->h; y++)
            for (int x = 0; x < d->w; x++) {
                int8_t *px = data + nn_pixel_offset(d, b, y, x, c_stride);
                for (int c = c_begin; c < c_end; c++) {
                    if (px[c] < clamp_lo[c]) px[c] = clamp_lo[c];
                    if (px[c] > clamp_hi[c]) px[c] = clamp_hi[c];
                }
            }
}
