/* Reference fp32 kernels: the contract every optimised kernel is measured against.
 *
 * Layout: activations are CHW planes (channel-major, rows contiguous), batch 1. Weights are
 * PyTorch's: conv [out_c][in_c][k_h][k_w], fully connected [out][in]. Kernels compute the output
 * channels [oc_begin, oc_end) only, so a caller may split the work across threads; the result of
 * each channel does not depend on the split. Kernels trust their arguments (validated when the
 * model loads); they never allocate. */
#ifndef PL_KERNELS_REF_NN_REF_H
#define PL_KERNELS_REF_NN_REF_H

#include <stddef.h>
#include <stdint.h>

typedef struct nn_conv_params {
    int in_c, in_h, in_w;    /* input planes */
    int out_c, out_h, out_w; /* out_h = (in_h + 2*pad - k_h) / stride + 1, same for w */
    int k_h, k_w;            /* 1..7 */
    int stride, pad;         /* stride >= 1, 0 <= pad < k; padded pixels are 0 */
    int relu;                /* 1: max(0, .) on the output */
} nn_conv_params;

typedef struct nn_pool_params {
    int c, in_h, in_w, out_h, out_w;
    int k, stride, pad; /* max pool: padding never wins; average pool: pad must be 0 */
} nn_pool_params;

/* out[oc] = act(bias[oc] + sum_ic,ky,kx w[oc][ic][ky][kx] * in[ic][oy*s-pad+ky][ox*s-pad+kx]).
 * `bias` may be NULL. `out` holds out_c planes of out_h*out_w (it may point into a larger
 * buffer, e.g. a dense block at a channel offset). */
void nn_conv2d_f32__ref(const nn_conv_params *p, const float *in, const float *w,
                        const float *bias, float *out, int oc_begin, int oc_end);

/* out[c][i] = max(0, scale[c] * in[c][i] + shift[c]) for channels [c_begin, c_end): a
 * pre-activation batch norm and ReLU over `hw` pixels per plane. */
void nn_bn_relu_f32__ref(const float *in, const float *scale, const float *shift, int hw,
                         float *out, int c_begin, int c_end);

/* Max pooling k x k, stride, padding (padded cells are ignored). Channels [c_begin, c_end). */
void nn_maxpool2d_f32__ref(const nn_pool_params *p, const float *in, float *out, int c_begin,
                           int c_end);

/* Average pooling k x k, stride, no padding. Channels [c_begin, c_end). */
void nn_avgpool2d_f32__ref(const nn_pool_params *p, const float *in, float *out, int c_begin,
                           int c_end);

/* Band pooling (PyTorch adaptive_avg_pool2d(x, (bands, 1))): band b averages rows
 * [floor(b*h/bands), ceil((b+1)*h/bands)) over all w columns. out[c*bands + b]. */
void nn_band_pool_f32__ref(const float *in, int c, int h, int w, int bands, float *out);

/* out[o] = act(bias[o] + sum_i w[o][i] * in[i]) for outputs [o_begin, o_end); bias may be NULL. */
void nn_fc_f32__ref(const float *in, int n_in, const float *w, const float *bias, int relu,
                    float *out, int o_begin, int o_end);

/* The same with int8-stored weights and a scale per row (a float layer whose weights are kept
 * int8, docs/QUANT.md "--keep-float"), for n_rows input rows in[r][n_in] at once:
 * out[r * out_stride + o] = act(wscale[o] * sum_i w[o][i] * in[r][i] + bias[o]), bias may be
 * NULL. 32 partial sums per dot product in a fixed order: the same bits wherever it runs, and
 * whether a weight row is used once (one input row) or converted once for all of them. */
void nn_fc_w8_f32__ref(const float *in, int n_rows, int n_in, const int8_t *w,
                       const float *wscale, const float *bias, int relu, float *out,
                       int out_stride, int o_begin, int o_end);

#endif
