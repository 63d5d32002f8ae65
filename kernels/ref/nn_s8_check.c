/* Argument checks for the int8 kernels (kernels/ref/nn_ref_s8.h): the "prepare" step that lets
 * the kernels run blindly. Shared by every ISA, since all int8 kernels have the same contract. */
#include "kernels/ref/nn_ref_s8.h"

#include <stdio.h>

#include "core/util.h"
#include "kernels/requant.h"

static int check_range(const char *field, long long v, long long lo, long long hi)
{
    if (v < lo || v > hi)
        return pl_error(PL_E_ARG, "%s %lld: expected [%lld, %lld]", field, v, lo, hi);
    return PL_OK;
}

int nn_tensor_s8_size(const nn_dims *d, int c_stride, size_t *elements)
{
    size_t pixels = 0, size = 0;
    if (d->n < 1 || d->h < 1 || d->w < 1 || d->c < 1 || c_stride < d->c)
        return pl_error(PL_E_ARG,
                        "tensor dims %dx%dx%dx%d, pixel stride %d: expected positive "
                        "dims and stride >= c",
                        d->n, d->h, d->w, d->c, c_stride);
    if (!pl_mul_size((size_t)d->n, (size_t)d->h, &pixels) ||
        !pl_mul_size(pixels, (size_t)d->w, &pixels) ||
        !pl_mul_size(pixels - 1, (size_t)c_stride, &size) ||
        !pl_add_size(size, (size_t)d->c, &size))
        return pl_error(PL_E_NOMEM, "tensor dims %dx%dx%dx%d, pixel stride %d: size overflows",
                        d->n, d->h, d->w, d->c, c_stride);
    *elements = size;
    return PL_OK;
}

/* An activation tensor: `io` is "input" or "output"; field names follow the vector JSON. */
static int check_tensor(const char *io, const nn_dims *d, int c_stride, const char *stride_name)
{
    char field[32];
    int rc;
    if ((rc = check_range("batches", d->n, 1, NN_S8_MAX_DIM)) < 0) return rc;
    snprintf(field, sizeof field, "%s_h", io);
    if ((rc = check_range(field, d->h, 1, NN_S8_MAX_DIM)) < 0) return rc;
    snprintf(field, sizeof field, "%s_w", io);
    if ((rc = check_range(field, d->w, 1, NN_S8_MAX_DIM)) < 0) return rc;
    snprintf(field, sizeof field, "%s_c", io);
    if ((rc = check_range(field, d->c, 1, NN_S8_MAX_CHANNELS)) < 0) return rc;
    if ((rc = check_range(stride_name, c_stride, d->c, NN_S8_MAX_CHANNELS)) < 0) return rc;
    size_t elements;
    return nn_tensor_s8_size(d, c_stride, &elements);
}

/* One spatial axis ("h" or "w") of a convolution or pooling window. */
static int check_axis(const char *axis, int in, int out, int kernel, int stride, int pad,
                      int dilation)
{
    char f[32], g[32];
    int rc;
    snprintf(f, sizeof f, "kernel_%s", axis);
    if ((rc = check_range(f, kernel, 1, NN_S8_MAX_DIM)) < 0) return rc;
    snprintf(f, sizeof f, "stride_%s", axis);
    if ((rc = check_range(f, stride, 1, NN_S8_MAX_DIM)) < 0) return rc;
    snprintf(f, sizeof f, "dilation_%s", axis);
    if ((rc = check_range(f, dilation, 1, NN_S8_MAX_DIM)) < 0) return rc;
    const long long reach = (long long)(kernel - 1) * dilation; /* last tap's offset */
    snprintf(f, sizeof f, "pad_%s", axis);
    if (pad < 0 || pad > reach)
        return pl_error(PL_E_ARG, "%s %d: expected [0, %lld] ((kernel_%s - 1)*dilation_%s)", f, pad,
                        reach, axis, axis);
    /* every window starts inside the input: (out - 1)*stride - pad < in */
    const long long max_out = ((long long)in + pad - 1) / stride + 1;
    snprintf(g, sizeof g, "output_%s", axis);
    if (out < 1 || out > max_out)
        return pl_error(PL_E_ARG,
                        "%s %d: expected [1, %lld] (each window must start inside the "
                        "input: (output_%s - 1)*stride_%s - pad_%s < input_%s)",
                        g, out, max_out, axis, axis, axis, axis);
    return PL_OK;
}

static int check_act(int32_t act_min, int32_t act_max)
{
    int rc;
    if ((rc = check_range("act_min", act_min, -128, 127)) < 0) return rc;
    return check_range("act_max", act_max, act_min, 127);
}

static int check_conv_common(const nn_conv_s8_params *p, const nn_dims *in, int in_c_stride,
                             const nn_dims *filter, const nn_dims *out, int out_c_stride)
{
    int rc;
    if (!p || !in || !filter || !out) return pl_error(PL_E_ARG, "conv: NULL argument");
    if ((rc = check_tensor("input", in, in_c_stride, "in_c_stride")) < 0) return rc;
    if ((rc = check_tensor("output", out, out_c_stride, "out_c_stride")) < 0) return rc;
    if (out->n != in->n)
        return pl_error(PL_E_ARG, "output batches %d: expected %d (input batches)", out->n, in->n);
    if ((rc = check_range("input_offset", p->input_offset, -127, 128)) < 0) return rc;
    if ((rc = check_range("output_offset", p->output_offset, -128, 127)) < 0) return rc;
    if ((rc = check_act(p->act_min, p->act_max)) < 0) return rc;
    if ((rc = check_axis("h", in->h, out->h, filter->h, p->stride_h, p->pad_h, p->dilation_h)) < 0)
        return rc;
    return check_axis("w", in->w, out->w, filter->w, p->stride_w, p->pad_w, p->dilation_w);
}

int nn_conv2d_s8_check(const nn_conv_s8_params *p, const nn_dims *in_dims, int in_c_stride,
                       const nn_dims *filter_dims, const nn_dims *out_dims, int out_c_stride)
{
    int rc = check_conv_common(p, in_dims, in_c_stride, filter_dims, out_dims, out_c_stride);
    if (rc < 0) return rc;
    if (filter_dims->n != out_dims->c)
        return pl_error(PL_E_ARG, "filter out channels %d: expected output_c %d", filter_dims->n,
                        out_dims->c);
    if (filter_dims->c != in_dims->c)
        return pl_error(PL_E_ARG, "filter in channels %d: expected input_c %d", filter_dims->c,
                        in_dims->c);
    const long long depth = (long long)filter_dims->h * filter_dims->w * filter_dims->c;
    if (depth > NN_S8_MAX_CONV_DEPTH)
        return pl_error(PL_E_ARG,
                        "kernel_h*kernel_w*input_c %lld: expected at most %d (int32 "
                        "accumulator)",
                        depth, NN_S8_MAX_CONV_DEPTH);
    return PL_OK;
}

int nn_conv1x1_s8_check(const nn_conv_s8_params *p, const nn_dims *in_dims, int in_c_stride,
                        const nn_dims *filter_dims, const nn_dims *out_dims, int out_c_stride)
{
    int rc = nn_conv2d_s8_check(p, in_dims, in_c_stride, filter_dims, out_dims, out_c_stride);
    if (rc < 0) return rc;
    if (filter_dims->h != 1 || filter_dims->w != 1)
        return pl_error(PL_E_ARG, "kernel %dx%d: expected 1x1", filter_dims->h, filter_dims->w);
    if (p->pad_h != 0 || p->pad_w != 0)
        return pl_error(PL_E_ARG, "pad %d,%d: expected 0 for a 1x1 convolution", p->pad_h,
                        p->pad_w);
    return PL_OK;
}

int nn_depthwise_conv2d_s8_check(const nn_conv_s8_params *p, const nn_dims *in_dims,
                                 int in_c_stride, const nn_dims *filter_dims,
                                 const nn_dims *out_dims, int out_c_stride)
{
    int rc = check_conv_common(p, in_dims, in_c_stride, filter_dims, out_dims, out_c_stride);
    if (rc < 0) return rc;
    if (out_dims->c % in_dims->c != 0)
        return pl_error(PL_E_ARG,
                        "output_c %d: expected a multiple of input_c %d (depth "
                        "multiplier)",
                        out_dims->c, in_dims->c);
    if (filter_dims->n != 1 || filter_dims->c != out_dims->c)
        return pl_error(PL_E_ARG, "depthwise filter dims %dx%dx%dx%d: expected 1x%dx%dx%d (1HWO)",
                        filter_dims->n, filter_dims->h, filter_dims->w, filter_dims->c,
                        filter_dims->h, filter_dims->w, out_dims->c);
    const long long depth = (long long)filter_dims->h * filter_dims->w;
    if (depth > NN_S8_MAX_CONV_DEPTH)
        return pl_error(PL_E_ARG, "kernel_h*kernel_w %lld: expected at most %d", depth,
                        NN_S8_MAX_CONV_DEPTH);
    return PL_OK;
}

int nn_fc_s8_check(const nn_fc_s8_params *p, int batches, int depth, int in_stride, int out_c,
                   int out_stride)
{
    int rc;
    if (!p) return pl_error(PL_E_ARG, "fully connected: NULL parameters");
    if ((rc = check_range("batches", batches, 1, NN_S8_MAX_DIM)) < 0) return rc;
    if ((rc = check_range("accum_depth", depth, 1, NN_S8_MAX_FC_DEPTH)) < 0) return rc;
    if ((rc = check_range("in_stride", in_stride, depth, INT32_MAX)) < 0) return rc;
    if ((rc = check_range("output_c", out_c, 1, NN_S8_MAX_CHANNELS)) < 0) return rc;
    if ((rc = check_range("out_stride", out_stride, out_c, INT32_MAX)) < 0) return rc;
    if ((rc = check_range("input_offset", p->input_offset, -127, 128)) < 0) return rc;
    if ((rc = check_range("weights_offset", p->weights_offset, -127, 128)) < 0) return rc;
    if ((rc = check_range("output_offset", p->output_offset, -128, 127)) < 0) return rc;
    if ((rc = check_range("per_channel", p->per_channel, 0, 1)) < 0) return rc;
    size_t size;
    const nn_dims in = {batches, 1, 1, depth}, out = {batches, 1, 1, out_c};
    if ((rc = nn_tensor_s8_size(&in, in_stride, &size)) < 0) return rc;
    if ((rc = nn_tensor_s8_size(&out, out_stride, &size)) < 0) return rc;
    return check_act(p->act_min, p->act_max);
}

int nn_pool2d_s8_check(const nn_pool_s8_params *p, const nn_dims *in_dims, int in_c_stride,
                       const nn_dims *out_dims, int out_c_stride)
{
    int rc;
    if (!p || !in_dims || !out_dims) return pl_error(PL_E_ARG, "pool: NULL argument");
    if ((rc = check_tensor("input", in_dims, in_c_stride, "in_c_stride")) < 0) return rc;
    if ((rc = check_tensor("output", out_dims, out_c_stride, "out_c_stride")) < 0) return rc;
    if (out_dims->n != in_dims->n)
        return pl_error(PL_E_ARG, "output batches %d: expected %d (input batches)", out_dims->n,
                        in_dims->n);
    if (out_dims->c != in_dims->c)
        return pl_error(PL_E_ARG, "output_c %d: expected input_c %d", out_dims->c, in_dims->c);
    if ((rc = check_act(p->act_min, p->act_max)) < 0) return rc;
    if ((long long)p->kernel_h * p->kernel_w > NN_S8_MAX_CONV_DEPTH)
        return pl_error(PL_E_ARG, "kernel_h*kernel_w %lld: expected at most %d (int32 sum)",
                        (long long)p->kernel_h * p->kernel_w, NN_S8_MAX_CONV_DEPTH);
    if ((rc = check_axis("h", in_dims->h, out_dims->h, p->kernel_h, p->stride_h, p->pad_h, 1)) < 0)
        return rc;
    return check_axis("w", in_dims->w, out_dims->w, p->kernel_w, p->stride_w, p->pad_w, 1);
}

int nn_quant_s8_check(const int32_t *multiplier, const int32_t *shift, int n)
{
    if (!multiplier || !shift || n < 1)
        return pl_error(PL_E_ARG, "requantisation: NULL arrays or %d channels", n);
    for (int i = 0; i < n; i++) {
        if (multiplier[i] != 0 && multiplier[i] < PL_REQUANT_MULT_MIN)
            return pl_error(PL_E_ARG, "multiplier[%d] %ld: expected 0 or [2^30, 2^31)", i,
                            (long)multiplier[i]);
        if (shift[i] < PL_REQUANT_SHIFT_MIN || shift[i] > PL_REQUANT_SHIFT_MAX)
            return pl_error(PL_E_ARG, "shift[%d] %ld: expected [%d, %d]", i, (long)shift[i],
                            PL_REQUANT_SHIFT_MIN, PL_REQUANT_SHIFT_MAX);
    }
    return PL_OK;
}
