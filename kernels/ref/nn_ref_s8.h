/* Reference int8 kernels: the contract every SIMD int8 kernel must match bit-exactly.
 *
 * Semantics are TFLite's int8 reference kernels (as implemented by CMSIS-NN with its default
 * double rounding), checked against the CMSIS-NN golden vectors by tests/nn_vectors; the full
 * contract is docs/QUANT.md, "Kernels and rounding". In short, for conv / depthwise / FC:
 *
 *   acc = bias[oc] + sum over taps inside the input of (x + input_offset) * w       (int32)
 *   out = clamp(pl_requantize(acc, multiplier[oc], shift[oc]) + output_offset, act_min, act_max)
 *
 * Taps outside the input are skipped, which is the same as padding with the input zero point.
 * Pooling has no offsets: max pooling takes the largest raw value in the window, average pooling
 * rounds the mean half away from zero; padded cells count in neither (the window is clipped).
 *
 * Layouts.
 *  - Activations are int8 NHWC. A tensor is described by nn_dims {n, h, w, c} plus a pixel stride
 *    `c_stride` >= c, in elements: pixel (b, y, x) starts at  data + ((b*h + y)*w + x)*c_stride
 *    and holds channels [0, c). So a kernel can read the first c channels of a wider buffer (a
 *    dense block) and write its output channels at a channel offset of one (pass out + offset).
 *    Channels beyond c in an output pixel are never written. c_stride == c is the packed tensor.
 *  - Weights are packed, int8. conv2d / conv1x1: OHWI [out_c][k_h][k_w][in_c]
 *    (filter dims {n = out_c, h = k_h, w = k_w, c = in_c}). depthwise: TFLite's 1HWO
 *    [1][k_h][k_w][out_c] with out_c = in_c * depth_multiplier and output channel
 *    oc = ic * depth_multiplier + m reading input channel ic = oc / depth_multiplier (filter dims
 *    {n = 1, h = k_h, w = k_w, c = out_c}). fully connected: [out_c][depth].
 *  - bias: int32 [out_c], or NULL for none (the same as zeros). It is at scale s_in * s_w.
 *  - Requantisation: per output channel, multiplier[oc] in [2^30, 2^31) or 0 and shift[oc] in
 *    [-31, 30] (kernels/requant.h).
 *
 * Work split: every kernel computes only output channels [oc_begin, oc_end) (pools: channels
 * [c_begin, c_end)) of every output pixel and touches no other output byte, so a thread pool may
 * split the channel range any way it likes; each output value depends only on its own channel,
 * so the result is bit-identical however the range is split.
 *
 * Accumulator: the sum of products is int32 and cannot overflow within the depth limits below
 * (|(x + input_offset) * w| <= 255 * 128). Adding the bias wraps modulo 2^32, which is what
 * TFLite's int32 addition does on every two's-complement target; a sane model keeps |bias| far
 * below that. Wrapping (rather than saturating) keeps the result independent of summation order,
 * so a SIMD kernel that starts from the bias agrees bit-exactly.
 *
 * Kernels trust their arguments: validate them once with the nn_*_s8_check() functions below (a
 * model loader does this at load time, the vector runner per case), then run blindly. Kernels never
 * allocate, never print, and need no scratch buffer. */
#ifndef PL_KERNELS_REF_NN_REF_S8_H
#define PL_KERNELS_REF_NN_REF_S8_H

#include <stddef.h>
#include <stdint.h>

/* Limits enforced by the checks (they keep all index arithmetic inside int and size_t). */
#define NN_S8_MAX_DIM 16384        /* h, w, kernel, stride, dilation, pad, batches */
#define NN_S8_MAX_CHANNELS 65536   /* c and c_stride */
#define NN_S8_MAX_CONV_DEPTH 65536 /* k_h*k_w*in_c (conv), k_h*k_w (depthwise, pools) */
#define NN_S8_MAX_FC_DEPTH 32768   /* FC depth; |(x + in_off)*(w + w_off)| <= 255*255 */

/* Tensor shape, CMSIS-NN's cmsis_nn_dims: batches, height, width, channels. */
typedef struct nn_dims {
    int n, h, w, c;
} nn_dims;

/* Convolution parameters (conv2d, conv1x1, depthwise), CMSIS-NN's cmsis_nn_conv_params. */
typedef struct nn_conv_s8_params {
    int32_t input_offset;       /* -input_zero_point, in [-127, 128] */
    int32_t output_offset;      /* +output_zero_point, in [-128, 127]; added after requantising */
    int stride_h, stride_w;     /* [1, NN_S8_MAX_DIM] */
    int pad_h, pad_w;           /* top / left padding, [0, (k - 1)*dilation] for each axis; the
                                   bottom / right padding follows from the output size */
    int dilation_h, dilation_w; /* [1, NN_S8_MAX_DIM]; tap ky reads row oy*stride_h - pad_h +
                                   ky*dilation_h */
    int32_t act_min, act_max;   /* -128 <= act_min <= act_max <= 127, applied last */
} nn_conv_s8_params;

/* Fully connected parameters. */
typedef struct nn_fc_s8_params {
    int32_t input_offset;     /* -input_zero_point, [-127, 128] */
    int32_t weights_offset;   /* -weights_zero_point, [-127, 128]; 0 for symmetric weights */
    int32_t output_offset;    /* +output_zero_point, [-128, 127] */
    int32_t act_min, act_max; /* -128 <= act_min <= act_max <= 127 */
    int per_channel;          /* 1: multiplier/shift[oc] per output; 0: [0] for every output
                                 (per-tensor) */
} nn_fc_s8_params;

/* Pooling parameters (max and average). Input and output share scale and zero point. */
typedef struct nn_pool_s8_params {
    int kernel_h, kernel_w;   /* [1, NN_S8_MAX_DIM] */
    int stride_h, stride_w;   /* [1, NN_S8_MAX_DIM] */
    int pad_h, pad_w;         /* top / left, [0, kernel - 1]; padded cells are left out */
    int32_t act_min, act_max; /* -128 <= act_min <= act_max <= 127 */
} nn_pool_s8_params;

/* Requantisation per output channel: arrays of out_c entries (FC per-tensor: 1 entry). */
typedef struct nn_per_channel_quant {
    const int32_t *multiplier; /* [2^30, 2^31) or 0 */
    const int32_t *shift;      /* [-31, 30]; > 0 is a left shift */
} nn_per_channel_quant;

/* Offset in elements of pixel (b, y, x) of a tensor with dims d and pixel stride c_stride. */
static inline size_t nn_pixel_offset(const nn_dims *d, int b, int y, int x, int c_stride)
{
    return (((size_t)b * (size_t)d->h + (size_t)y) * (size_t)d->w + (size_t)x) * (size_t)c_stride;
}

/* --- Validation (call once, before running a kernel) -------------------------------------------
 * Each returns PL_OK, or PL_E_ARG with a message naming the field and the expected range
 * (e.g. "pad_h 5: expected [0, 4] ((kernel_h - 1)*dilation_h)"). Field names are those of the
 * golden-vector JSON (input_h, kernel_w, output_c, ...). They check ranges, consistency
 * (filter and output channels, output size: every window starts inside the input) and the depth
 * limits; they do not look at data. */
int nn_conv2d_s8_check(const nn_conv_s8_params *p, const nn_dims *in_dims, int in_c_stride,
                       const nn_dims *filter_dims, const nn_dims *out_dims, int out_c_stride);
/* conv2d's checks plus a 1x1 filter and no padding. */
int nn_conv1x1_s8_check(const nn_conv_s8_params *p, const nn_dims *in_dims, int in_c_stride,
                        const nn_dims *filter_dims, const nn_dims *out_dims, int out_c_stride);
/* out_c a multiple of in_c; filter dims {1, k_h, k_w, out_c}. */
int nn_depthwise_conv2d_s8_check(const nn_conv_s8_params *p, const nn_dims *in_dims,
                                 int in_c_stride, const nn_dims *filter_dims,
                                 const nn_dims *out_dims, int out_c_stride);
int nn_fc_s8_check(const nn_fc_s8_params *p, int batches, int depth, int in_stride, int out_c,
                   int out_stride);
/* Max and average pooling: out c == in c. */
int nn_pool2d_s8_check(const nn_pool_s8_params *p, const nn_dims *in_dims, int in_c_stride,
                       const nn_dims *out_dims, int out_c_stride);
/* Each multiplier[i] in [2^30, 2^31) or 0 and shift[i] in [-31, 30], i < n. */
int nn_quant_s8_check(const int32_t *multiplier, const int32_t *shift, int n);
/* Elements a buffer needs for dims with pixel stride c_stride: (n*h*w - 1)*c_stride + c.
 * PL_OK, or PL_E_NOMEM when it does not fit in size_t. */
int nn_tensor_s8_size(const nn_dims *dims, int c_stride, size_t *elements);

/* --- Kernels ---------------------------------------------------------------------------------- */

/* k x k convolution with stride, padding and dilation. Output channels [oc_begin, oc_end). */
void nn_conv2d_s8__ref(const nn_conv_s8_params *p, const nn_per_channel_quant *q,
                       const nn_dims *in_dims, const int8_t *in, int in_c_stride,
                       const nn_dims *filter_dims, const int8_t *weights, const int32_t *bias,
                       const nn_dims *out_dims, int8_t *out, int out_c_stride, int oc_begin,
                       int oc_end);

/* 1 x 1 convolution (pointwise; stride allowed, padding and dilation ignored as they must be
 * 0 / irrelevant). Same arguments and results as nn_conv2d_s8__ref with a 1x1 filter. */
void nn_conv1x1_s8__ref(const nn_conv_s8_params *p, const nn_per_channel_quant *q,
                        const nn_dims *in_dims, const int8_t *in, int in_c_stride,
                        const nn_dims *filter_dims, const int8_t *weights, const int32_t *bias,
                        const nn_dims *out_dims, int8_t *out, int out_c_stride, int oc_begin,
                        int oc_end);

/* Depthwise convolution, depth_multiplier = out_dims->c / in_dims->c, weights 1HWO (above).
 * Output channels [oc_begin, oc_end). */
void nn_depthwise_conv2d_s8__ref(const nn_conv_s8_params *p, const nn_per_channel_quant *q,
                                 const nn_dims *in_dims, const int8_t *in, int in_c_stride,
                                 const nn_dims *filter_dims, const int8_t *weights,
                                 const int32_t *bias, const nn_dims *out_dims, int8_t *out,
                                 int out_c_stride, int oc_begin, int oc_end);

/* Fully connected: for each of `batches` rows, out[b*out_stride + oc] for oc in
 * [oc_begin, oc_end) from in[b*in_stride + d], d < depth, and weights[oc][depth]:
 * acc = bias[oc] + sum_d (in + input_offset) * (w + weights_offset). in_stride >= depth,
 * out_stride >= out_c (the output channel count, for the quantisation arrays). */
void nn_fc_s8__ref(const nn_fc_s8_params *p, const nn_per_channel_quant *q, int batches, int depth,
                   const int8_t *in, int in_stride, const int8_t *weights, const int32_t *bias,
                   int out_c, int8_t *out, int out_stride, int oc_begin, int oc_end);

/* Max pooling: max of the raw int8 values in the window clipped to the input, then clamped to
 * [act_min, act_max]. Channels [c_begin, c_end). */
void nn_maxpool2d_s8__ref(const nn_pool_s8_params *p, const nn_dims *in_dims, const int8_t *in,
                          int in_c_stride, const nn_dims *out_dims, int8_t *out, int out_c_stride,
                          int c_begin, int c_end);

/* Average pooling: sum over the window clipped to the input divided by the number of cells in
 * it, rounded half away from zero, then clamped to [act_min, act_max]. Channels
 * [c_begin, c_end). */
void nn_avgpool2d_s8__ref(const nn_pool_s8_params *p, const nn_dims *in_dims, const int8_t *in,
                          int in_c_stride, const nn_dims *out_dims, int8_t *out, int out_c_stride,
                          int c_begin, int c_end);

#endif
