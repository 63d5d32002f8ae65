#include "kernels/ref/nn_ref.h"

void nn_band_pool_f32__ref(const float *in, int c, int h, int w, int bands, float *out)
{
    for (int ch = 0; ch < c; ch++) {
        const float *x = in + (size_t)ch * h * w;
        for (int b = 0; b < bands; b++) {
            const int y0 = b * h / bands, y1 = ((b + 1) * h + bands - 1) / bands;
            double sum = 0.0;
            for (int y = y0; y < y1; y++)
                for (int xx = 0; xx < w; xx++) sum += x[y * w + xx];
            out[ch * bands + b] = (float)(sum / ((y1 - y0) * w));
        }
    }
}
