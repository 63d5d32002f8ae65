#include "kernels/ref/nn_ref.h"

#define LANES 32 /* partial sums per dot product: enough independent adds to keep the FP units
                    busy once the compiler vectorises the lane loop */
#define ROW_MAX 4096 /* longest weight row converted to float once for all input rows */

/* One output: wscale * (w . x) + bias, ReLU'd if asked; the products' order is fixed (LANES
 * partial sums, then pairwise), whatever the caller's loop order. wf is the weight row, either
 * as int8 (wf == NULL) or already converted to float (exactly: int8 fits in a float). */
static float dot_row(const float *x, const int8_t *wr, const float *wf, int n_in, float scale,
                     float bias, int relu)
{
    float acc[LANES] = {0};
    int i = 0;
    if (wf) {
        for (; i + LANES <= n_in; i += LANES)
            for (int k = 0; k < LANES; k++)
                acc[k] += wf[i + k] * x[i + k];
    } else {
        for (; i + LANES <= n_in; i += LANES)
            for (int k = 0; k < LANES; k++)
                acc[k] += (float)wr[i + k] * x[i + k];
    }
    for (int s = LANES / 2; s > 0; s /= 2) /* pairwise, in a fixed order */
        for (int k = 0; k < s; k++)
            acc[k] += acc[k + s];
    float sum = acc[0];
    for (; i < n_in; i++)
        sum += (wf ? wf[i] : (float)wr[i]) * x[i];
    const float v = scale * sum + bias;
    return relu && v < 0.0f ? 0.0f : v;
}

void nn_fc_w8_f32__ref(const float *in, int n_rows, int n_in, const int8_t *w,
                       const float *wscale, const float *bias, int relu, float *out,
                       int out_stride, int o_begin, int o_end)
{
    if (n_rows == 1 || n_in > ROW_MAX) { /* one pass over the weights: convert as they stream */
        for (int r = 0; r < n_rows; r++)
            for (int o = o_begin; o < o_end; o++)
                out[(size_t)r * out_stride + o] =
                    dot_row(in + (size_t)r * n_in, w + (size_t)o * n_in, NULL, n_in, wscale[o],
                            bias ? bias[o] : 0.0f, relu);
        return;
    }
    /* several rows (a kept-float transition's pooled pixels): each weight row is converted to
     * float once and used for every input row while it sits in L1 */
    float wf[ROW_MAX];
    for (int o = o_begin; o < o_end; o++) {
        const int8_t *wr = w + (size_t)o * n_in;
        for (int i = 0; i < n_in; i++)
            wf[i] = (float)wr[i];
        for (int r = 0; r < n_rows; r++)
            out[(size_t)r * out_stride + o] = dot_row(in + (size_t)r * n_in, NULL, wf, n_in,
                                                      wscale[o], bias ? bias[o] : 0.0f, relu);
    }
}
