/* kernels/ref int8 kernels on random shapes (odd channel counts, strides, dilation, padding,
 * extreme values -128/127): the pixel-stride variants (input read from a wider buffer, output
 * written at a channel offset of a wider buffer) equal the packed ones and write nothing outside
 * their channels; computing the channel range in random pieces, in random order, equals computing
 * it whole; conv1x1 equals conv2d with a 1x1 filter; depthwise with one input channel equals
 * conv2d; FC equals conv1x1 on a 1x1 image and per-tensor equals per-channel with repeated
 * values; the accumulator at the depth limit; the argument checks reject bad shapes. Exact
 * comparisons only: int8 has no tolerance. Correctness against TFLite is tests/nn_vectors.
 * nn_fc_w8_f32__ref (float rows, int8-stored weights with a scale per row): against a double
 * sum (relative 1e-5 of the sum of |terms|), bias, ReLU and the output stride; a row's result is
 * the same bits whether it is computed alone, among several rows or in channel pieces. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <math.h>

#include "core/util.h"
#include "kernels/ref/nn_ref.h"
#include "kernels/ref/nn_ref_s8.h"
#include "kernels/requant.h"
#define CHECK_RNG_SEED 0x2545f4914f6cdd1dULL
#include "tests/check.h"

/* int8 values, a quarter of them at the extremes */
static void fill_s8(int8_t *p, size_t n)
{
    for (size_t i = 0; i < n; i++) {
        const uint32_t r = rnd();
        p[i] = (r & 3) == 0 ? ((r & 4) ? 127 : -128) : (int8_t)(r >> 8);
    }
}

static void *xmalloc(size_t n)
{
    void *p = malloc(n ? n : 1);
    if (!p) {
        printf("out of memory\n");
        exit(1);
    }
    return p;
}

enum { GUARD = 0x5b };

/* A kernel call on tensors with the given pixel strides, output channels [b, e). */
typedef struct job job;
typedef void (*run_fn)(const job *j, const int8_t *in, int in_s, int8_t *out, int out_s, int b,
                       int e);
struct job {
    nn_dims in, filter, out;
    nn_conv_s8_params conv;
    nn_fc_s8_params fc;
    nn_pool_s8_params pool;
    nn_per_channel_quant q;
    const int8_t *weights;
    const int32_t *bias;
};

static void run_conv2d(const job *j, const int8_t *in, int in_s, int8_t *out, int out_s, int b,
                       int e)
{
    nn_conv2d_s8__ref(&j->conv, &j->q, &j->in, in, in_s, &j->filter, j->weights, j->bias, &j->out,
                      out, out_s, b, e);
}
static void run_conv1x1(const job *j, const int8_t *in, int in_s, int8_t *out, int out_s, int b,
                        int e)
{
    nn_conv1x1_s8__ref(&j->conv, &j->q, &j->in, in, in_s, &j->filter, j->weights, j->bias, &j->out,
                       out, out_s, b, e);
}
static void run_depthwise(const job *j, const int8_t *in, int in_s, int8_t *out, int out_s, int b,
                          int e)
{
    nn_depthwise_conv2d_s8__ref(&j->conv, &j->q, &j->in, in, in_s, &j->filter, j->weights, j->bias,
                                &j->out, out, out_s, b, e);
}
static void run_fc(const job *j, const int8_t *in, int in_s, int8_t *out, int out_s, int b, int e)
{
    nn_fc_s8__ref(&j->fc, &j->q, j->in.n, j->in.c, in, in_s, j->weights, j->bias, j->out.c, out,
                  out_s, b, e);
}
static void run_maxpool(const job *j, const int8_t *in, int in_s, int8_t *out, int out_s, int b,
                        int e)
{
    nn_maxpool2d_s8__ref(&j->pool, &j->in, in, in_s, &j->out, out, out_s, b, e);
}
static void run_avgpool(const job *j, const int8_t *in, int in_s, int8_t *out, int out_s, int b,
                        int e)
{
    nn_avgpool2d_s8__ref(&j->pool, &j->in, in, in_s, &j->out, out, out_s, b, e);
}

static size_t pixels(const nn_dims *d)
{
    return (size_t)d->n * (size_t)d->h * (size_t)d->w;
}

/* Runs fn packed over the whole channel range into a new buffer (caller frees). */
static int8_t *run_packed(const job *j, run_fn fn, const int8_t *in)
{
    int8_t *out = xmalloc(pixels(&j->out) * (size_t)j->out.c);
    memset(out, GUARD, pixels(&j->out) * (size_t)j->out.c);
    fn(j, in, j->in.c, out, j->out.c, 0, j->out.c);
    return out;
}

/* Runs fn with random wider pixel strides, the output at a random channel offset, the channel
 * range cut in up to 4 random pieces run in random order; checks it equals `want` (packed) and
 * that nothing outside the output channels changed. */
static void check_strided_split(const job *j, run_fn fn, const int8_t *in, const int8_t *want,
                                const char *what)
{
    const int in_s = j->in.c + rint_in(0, 9), off = rint_in(0, 7);
    const int out_s = j->out.c + off + rint_in(0, 9), nc = j->out.c;
    const size_t pin = pixels(&j->in), pout = pixels(&j->out);
    int8_t *in2 = xmalloc(pin * (size_t)in_s), *out2 = xmalloc(pout * (size_t)out_s);
    fill_s8(in2, pin * (size_t)in_s); /* junk in the channels the kernel must not read */
    for (size_t p = 0; p < pin; p++)
        memcpy(in2 + p * (size_t)in_s, in + p * (size_t)j->in.c, (size_t)j->in.c);
    memset(out2, GUARD, pout * (size_t)out_s);

    int cuts[5] = {0, 0, 0, 0, nc}, n_pieces = rint_in(1, 4);
    for (int i = 1; i < n_pieces; i++)
        cuts[i] = rint_in(0, nc);
    cuts[n_pieces] = nc;
    for (int i = 1; i < n_pieces; i++) /* sort the inner cuts */
        for (int k = i + 1; k < n_pieces; k++)
            if (cuts[k] < cuts[i]) {
                const int t = cuts[i];
                cuts[i] = cuts[k];
                cuts[k] = t;
            }
    int order[4] = {0, 1, 2, 3};
    for (int i = n_pieces - 1; i > 0; i--) {
        const int k = rint_in(0, i), t = order[i];
        order[i] = order[k];
        order[k] = t;
    }
    /* one piece alone writes its channels and nothing else */
    const int b0 = cuts[order[0]], e0 = cuts[order[0] + 1];
    fn(j, in2, in_s, out2 + off, out_s, b0, e0);
    size_t stray = 0;
    for (size_t p = 0; p < pout; p++)
        for (int ch = 0; ch < out_s; ch++)
            if ((ch < off + b0 || ch >= off + e0) && out2[p * (size_t)out_s + (size_t)ch] != GUARD)
                stray++;
    CHECK(stray == 0, "%s: channel range [%d, %d) of %d wrote %zu bytes outside it", what, b0, e0,
          nc, stray);
    for (int i = 1; i < n_pieces; i++)
        fn(j, in2, in_s, out2 + off, out_s, cuts[order[i]], cuts[order[i] + 1]);

    size_t bad = 0, first = 0;
    for (size_t p = 0; p < pout; p++)
        for (int ch = 0; ch < out_s; ch++) {
            const int8_t g = out2[p * (size_t)out_s + (size_t)ch];
            const int inside = ch >= off && ch < off + nc;
            const int8_t w = inside ? want[p * (size_t)nc + (size_t)(ch - off)] : (int8_t)GUARD;
            if (g != w && bad++ == 0) first = p * (size_t)out_s + (size_t)ch;
        }
    CHECK(bad == 0,
          "%s: strided (in %d, out %d at +%d, %d pieces) differs from packed at byte %zu "
          "(%zu bytes)",
          what, in_s, out_s, off, n_pieces, first, bad);
    free(in2);
    free(out2);
}

static int same(const int8_t *a, const int8_t *b, size_t n)
{
    return memcmp(a, b, n) == 0;
}

/* Random quantisation for n channels: multipliers in [2^30, 2^31), shifts in [-14, 3] (left
 * shifts included), bias within +-2^20 or NULL. */
static void random_quant(int n, int32_t *mult, int32_t *shift, int32_t *bias, int *has_bias)
{
    for (int i = 0; i < n; i++) {
        mult[i] = (int32_t)((1u << 30) | (rnd() & 0x3fffffffu));
        shift[i] = rint_in(-14, 3);
        bias[i] = rint_in(-(1 << 20), 1 << 20);
    }
    *has_bias = rnd() % 4 != 0;
}

static void random_act(int32_t *act_min, int32_t *act_max)
{
    *act_min = rnd() % 2 ? -128 : rint_in(-128, 0);
    *act_max = rnd() % 2 ? 127 : rint_in(*act_min, 127);
}

/* One spatial axis: kernel, stride, dilation, pad in [0, reach], output size valid for them. */
static void random_axis(int in, int max_k, int *k, int *s, int *d, int *pad, int *out)
{
    *k = rint_in(1, max_k);
    *s = rint_in(1, 3);
    *d = rint_in(1, 3);
    const int reach = (*k - 1) * *d;
    *pad = rint_in(0, reach);
    const int max_out = (in + *pad - 1) / *s + 1;
    *out = rnd() % 2 ? max_out : rint_in(1, max_out);
}

static void test_conv(int iter)
{
    job j;
    memset(&j, 0, sizeof j);
    const int n = rint_in(1, 2), ih = rint_in(1, 9), iw = rint_in(1, 9);
    const int in_c = rint_in(1, 19), out_c = rint_in(1, 21);
    nn_conv_s8_params *p = &j.conv;
    int kh, kw, oh, ow;
    random_axis(ih, 4, &kh, &p->stride_h, &p->dilation_h, &p->pad_h, &oh);
    random_axis(iw, 4, &kw, &p->stride_w, &p->dilation_w, &p->pad_w, &ow);
    if (iter % 4 == 0)
        kh = kw = 1, p->pad_h = p->pad_w = 0, oh = (ih - 1) / p->stride_h + 1,
        ow = (iw - 1) / p->stride_w + 1;
    j.in = (nn_dims){n, ih, iw, in_c};
    j.filter = (nn_dims){out_c, kh, kw, in_c};
    j.out = (nn_dims){n, oh, ow, out_c};
    p->input_offset = rint_in(-127, 128);
    p->output_offset = rint_in(-128, 127);
    random_act(&p->act_min, &p->act_max);
    CHECK(nn_conv2d_s8_check(p, &j.in, in_c, &j.filter, &j.out, out_c) == PL_OK, "conv check: %s",
          pl_last_error());

    const size_t n_w = (size_t)out_c * kh * kw * in_c, n_in = pixels(&j.in) * (size_t)in_c;
    int8_t *w = xmalloc(n_w), *in = xmalloc(n_in);
    int32_t mult[21], shift[21], bias[21];
    int has_bias;
    fill_s8(w, n_w);
    fill_s8(in, n_in);
    random_quant(out_c, mult, shift, bias, &has_bias);
    j.q = (nn_per_channel_quant){mult, shift};
    j.weights = w;
    j.bias = has_bias ? bias : NULL;

    int8_t *want = run_packed(&j, run_conv2d, in);
    check_strided_split(&j, run_conv2d, in, want, "conv2d");
    if (kh == 1 && kw == 1 && p->pad_h == 0 && p->pad_w == 0) {
        CHECK(nn_conv1x1_s8_check(p, &j.in, in_c, &j.filter, &j.out, out_c) == PL_OK,
              "conv1x1 check: %s", pl_last_error());
        int8_t *got = run_packed(&j, run_conv1x1, in);
        CHECK(same(got, want, pixels(&j.out) * (size_t)out_c), "conv1x1 == conv2d 1x1 (iter %d)",
              iter);
        check_strided_split(&j, run_conv1x1, in, want, "conv1x1");
        free(got);
    }
    free(want);
    free(w);
    free(in);
}

static void test_depthwise(int iter)
{
    job j;
    memset(&j, 0, sizeof j);
    const int n = rint_in(1, 2), ih = rint_in(1, 9), iw = rint_in(1, 9);
    const int in_c = iter % 3 == 0 ? 1 : rint_in(1, 11), mult_c = rint_in(1, 4);
    const int out_c = in_c * mult_c;
    nn_conv_s8_params *p = &j.conv;
    int kh, kw, oh, ow;
    random_axis(ih, 4, &kh, &p->stride_h, &p->dilation_h, &p->pad_h, &oh);
    random_axis(iw, 4, &kw, &p->stride_w, &p->dilation_w, &p->pad_w, &ow);
    j.in = (nn_dims){n, ih, iw, in_c};
    j.filter = (nn_dims){1, kh, kw, out_c};
    j.out = (nn_dims){n, oh, ow, out_c};
    p->input_offset = rint_in(-127, 128);
    p->output_offset = rint_in(-128, 127);
    random_act(&p->act_min, &p->act_max);
    CHECK(nn_depthwise_conv2d_s8_check(p, &j.in, in_c, &j.filter, &j.out, out_c) == PL_OK,
          "depthwise check: %s", pl_last_error());

    const size_t n_w = (size_t)kh * kw * out_c, n_in = pixels(&j.in) * (size_t)in_c;
    int8_t *w = xmalloc(n_w), *in = xmalloc(n_in);
    int32_t mult[44], shift[44], bias[44];
    int has_bias;
    fill_s8(w, n_w);
    fill_s8(in, n_in);
    random_quant(out_c, mult, shift, bias, &has_bias);
    j.q = (nn_per_channel_quant){mult, shift};
    j.weights = w;
    j.bias = has_bias ? bias : NULL;

    int8_t *want = run_packed(&j, run_depthwise, in);
    check_strided_split(&j, run_depthwise, in, want, "depthwise");
    if (in_c == 1) { /* = conv2d with OHWI weights [oc][ky][kx][0] = 1HWO [ky][kx][oc] */
        int8_t *w2 = xmalloc(n_w);
        for (int oc = 0; oc < out_c; oc++)
            for (int t = 0; t < kh * kw; t++)
                w2[(size_t)oc * kh * kw + t] = w[(size_t)t * out_c + oc];
        job c = j;
        c.filter = (nn_dims){out_c, kh, kw, 1};
        c.weights = w2;
        int8_t *got = run_packed(&c, run_conv2d, in);
        CHECK(same(got, want, pixels(&j.out) * (size_t)out_c),
              "depthwise with 1 input channel == conv2d (iter %d)", iter);
        free(got);
        free(w2);
    }
    free(want);
    free(w);
    free(in);
}

static void test_fc(int iter)
{
    job j;
    memset(&j, 0, sizeof j);
    const int batches = rint_in(1, 3), depth = rint_in(1, 77), out_c = rint_in(1, 23);
    j.in = (nn_dims){batches, 1, 1, depth};
    j.out = (nn_dims){batches, 1, 1, out_c};
    nn_fc_s8_params *p = &j.fc;
    p->input_offset = rint_in(-127, 128);
    p->weights_offset = iter % 2 ? rint_in(-127, 128) : 0;
    p->output_offset = rint_in(-128, 127);
    p->per_channel = 1;
    random_act(&p->act_min, &p->act_max);
    CHECK(nn_fc_s8_check(p, batches, depth, depth, out_c, out_c) == PL_OK, "fc check: %s",
          pl_last_error());
    const size_t n_w = (size_t)out_c * depth, n_in = (size_t)batches * depth;
    int8_t *w = xmalloc(n_w), *in = xmalloc(n_in);
    int32_t mult[23], shift[23], bias[23];
    int has_bias;
    fill_s8(w, n_w);
    fill_s8(in, n_in);
    random_quant(out_c, mult, shift, bias, &has_bias);
    j.q = (nn_per_channel_quant){mult, shift};
    j.weights = w;
    j.bias = has_bias ? bias : NULL;

    int8_t *want = run_packed(&j, run_fc, in);
    check_strided_split(&j, run_fc, in, want, "fc");

    /* per-tensor equals per-channel with every channel's pair equal to the first */
    int32_t mult_all[23], shift_all[23];
    for (int i = 0; i < out_c; i++)
        mult_all[i] = mult[0], shift_all[i] = shift[0];
    job pc = j, pt = j;
    pc.q = (nn_per_channel_quant){mult_all, shift_all};
    pt.fc.per_channel = 0;
    int8_t *a = run_packed(&pc, run_fc, in), *b = run_packed(&pt, run_fc, in);
    CHECK(same(a, b, (size_t)batches * out_c), "fc per-tensor == per-channel (iter %d)", iter);
    free(a);
    free(b);

    if (p->weights_offset == 0) { /* = conv1x1 on a 1x1 image per batch */
        job c = j;
        c.conv = (nn_conv_s8_params){p->input_offset, p->output_offset, 1, 1, 0, 0, 1, 1,
                                     p->act_min,      p->act_max};
        c.filter = (nn_dims){out_c, 1, 1, depth};
        int8_t *got = run_packed(&c, run_conv1x1, in);
        CHECK(same(got, want, (size_t)batches * out_c), "fc == conv1x1 on 1x1 (iter %d)", iter);
        free(got);
    }
    free(want);
    free(w);
    free(in);
}

static void test_pool(int iter)
{
    job j;
    memset(&j, 0, sizeof j);
    const int n = rint_in(1, 2), ih = rint_in(1, 9), iw = rint_in(1, 9), c = rint_in(1, 13);
    nn_pool_s8_params *p = &j.pool;
    int dil, oh, ow;
    random_axis(ih, 4, &p->kernel_h, &p->stride_h, &dil, &p->pad_h, &oh);
    random_axis(iw, 4, &p->kernel_w, &p->stride_w, &dil, &p->pad_w, &ow);
    if (p->pad_h >= p->kernel_h) p->pad_h = p->kernel_h - 1; /* no dilation in pooling */
    if (p->pad_w >= p->kernel_w) p->pad_w = p->kernel_w - 1;
    if (oh > (ih + p->pad_h - 1) / p->stride_h + 1) oh = (ih + p->pad_h - 1) / p->stride_h + 1;
    if (ow > (iw + p->pad_w - 1) / p->stride_w + 1) ow = (iw + p->pad_w - 1) / p->stride_w + 1;
    j.in = (nn_dims){n, ih, iw, c};
    j.out = (nn_dims){n, oh, ow, c};
    random_act(&p->act_min, &p->act_max);
    CHECK(nn_pool2d_s8_check(p, &j.in, c, &j.out, c) == PL_OK, "pool check: %s", pl_last_error());
    int8_t *in = xmalloc(pixels(&j.in) * (size_t)c);
    fill_s8(in, pixels(&j.in) * (size_t)c);
    int8_t *want = run_packed(&j, run_maxpool, in);
    check_strided_split(&j, run_maxpool, in, want, "maxpool");
    free(want);
    want = run_packed(&j, run_avgpool, in);
    check_strided_split(&j, run_avgpool, in, want, "avgpool");
    free(want);

    /* a 1x1 window is the identity (then the clamp), for both */
    job id = j;
    id.pool.kernel_h = id.pool.kernel_w = id.pool.stride_h = id.pool.stride_w = 1;
    id.pool.pad_h = id.pool.pad_w = 0;
    id.out = j.in;
    int8_t *mx = run_packed(&id, run_maxpool, in), *av = run_packed(&id, run_avgpool, in);
    size_t bad = 0;
    for (size_t i = 0; i < pixels(&j.in) * (size_t)c; i++) {
        int v = in[i] < p->act_min ? p->act_min : in[i] > p->act_max ? p->act_max : in[i];
        bad += mx[i] != v || av[i] != v;
    }
    CHECK(bad == 0, "1x1 pooling is the clamped identity (iter %d, %zu bad)", iter, bad);
    free(mx);
    free(av);
    free(in);
}

/* Average pooling rounds half away from zero: windows of 2 holding (1, 2) and (-1, -2). */
static void test_avg_rounding(void)
{
    const int8_t in[4] = {1, 2, -1, -2};
    int8_t out[2];
    const nn_dims di = {1, 1, 4, 1}, dout = {1, 1, 2, 1};
    const nn_pool_s8_params p = {1, 2, 1, 2, 0, 0, -128, 127};
    CHECK(nn_pool2d_s8_check(&p, &di, 1, &dout, 1) == PL_OK, "avg check: %s", pl_last_error());
    nn_avgpool2d_s8__ref(&p, &di, in, 1, &dout, out, 1, 0, 1);
    CHECK(out[0] == 2 && out[1] == -2, "avg of (1,2) = %d (want 2), of (-1,-2) = %d (want -2)",
          out[0], out[1]);
}

/* The accumulator at the documented depth limit: 65536 products of 255 * -128 reach -2^31 + 2^23
 * without overflow; a bias of -2^23 lands exactly on INT32_MIN, and one more wraps (the
 * documented modulo-2^32 bias addition). */
static void test_depth_limit(void)
{
    const int depth = NN_S8_MAX_CONV_DEPTH;
    int8_t *in = xmalloc((size_t)depth), *w = xmalloc((size_t)depth * 2);
    memset(in, 127, (size_t)depth);
    memset(w, -128, (size_t)depth * 2);
    const nn_dims di = {1, 1, 1, depth}, df = {2, 1, 1, depth}, dout = {1, 1, 1, 2};
    const nn_conv_s8_params p = {128, 0, 1, 1, 0, 0, 1, 1, -128, 127};
    const int32_t mult[2] = {1 << 30, 1 << 30}, shift[2] = {-24, -24};
    const int32_t bias[2] = {-(1 << 23), -(1 << 23) - 1};
    const nn_per_channel_quant q = {mult, shift};
    CHECK(nn_conv1x1_s8_check(&p, &di, depth, &df, &dout, 2) == PL_OK, "depth-limit check: %s",
          pl_last_error());
    const int64_t acc = (int64_t)depth * 255 * -128 + bias[0];
    CHECK(acc == INT32_MIN, "test arithmetic");
    int8_t out[2] = {0, 0}, out2[2] = {0, 0};
    nn_conv1x1_s8__ref(&p, &q, &di, in, depth, &df, w, bias, &dout, out, 2, 0, 2);
    nn_conv2d_s8__ref(&p, &q, &di, in, depth, &df, w, bias, &dout, out2, 2, 0, 2);
    CHECK(out[0] == pl_requantize_s8(INT32_MIN, 1 << 30, -24, 0, -128, 127) && out[0] == -64,
          "acc INT32_MIN -> -64, got %d", out[0]);
    CHECK(out[1] == pl_requantize_s8(INT32_MAX, 1 << 30, -24, 0, -128, 127) && out[1] == 64,
          "acc INT32_MIN - 1 wraps to INT32_MAX -> 64, got %d", out[1]);
    CHECK(out2[0] == out[0] && out2[1] == out[1], "conv2d agrees at the depth limit");
    free(in);
    free(w);
}

static void test_checks(void)
{
    const nn_dims in = {1, 5, 5, 3}, f = {4, 3, 3, 3}, out = {1, 5, 5, 4};
    nn_conv_s8_params p = {128, 0, 1, 1, 1, 1, 1, 1, -128, 127};
    CHECK(nn_conv2d_s8_check(&p, &in, 3, &f, &out, 4) == PL_OK, "valid conv: %s", pl_last_error());
    CHECK(nn_conv2d_s8_check(&p, &in, 2, &f, &out, 4) == PL_E_ARG, "in_c_stride < c");
    CHECK(nn_conv2d_s8_check(&p, &in, 3, &f, &out, 3) == PL_E_ARG, "out_c_stride < c");
    p.pad_h = 3;
    CHECK(nn_conv2d_s8_check(&p, &in, 3, &f, &out, 4) == PL_E_ARG &&
              strstr(pl_last_error(), "pad_h"),
          "pad_h beyond the kernel: %s", pl_last_error());
    p.pad_h = 1;
    p.stride_w = 0;
    CHECK(nn_conv2d_s8_check(&p, &in, 3, &f, &out, 4) == PL_E_ARG &&
              strstr(pl_last_error(), "stride_w"),
          "stride_w 0: %s", pl_last_error());
    p.stride_w = 2;
    CHECK(nn_conv2d_s8_check(&p, &in, 3, &f, &out, 4) == PL_E_ARG &&
              strstr(pl_last_error(), "output_w"),
          "output_w too large for stride 2: %s", pl_last_error());
    p.stride_w = 1;
    p.act_min = 10;
    p.act_max = 5;
    CHECK(nn_conv2d_s8_check(&p, &in, 3, &f, &out, 4) == PL_E_ARG &&
              strstr(pl_last_error(), "act_max"),
          "act_min > act_max: %s", pl_last_error());
    p.act_min = -128;
    p.act_max = 127;
    p.input_offset = 129;
    CHECK(nn_conv2d_s8_check(&p, &in, 3, &f, &out, 4) == PL_E_ARG, "input_offset 129");
    p.input_offset = 128;
    const nn_dims f_bad = {4, 3, 3, 2};
    CHECK(nn_conv2d_s8_check(&p, &in, 3, &f_bad, &out, 4) == PL_E_ARG, "filter in_c mismatch");
    CHECK(nn_conv1x1_s8_check(&p, &in, 3, &f, &out, 4) == PL_E_ARG, "3x3 is not 1x1");
    const nn_dims big_in = {1, 1, 1, 60000}, big_f = {1, 3, 1, 60000}, big_out = {1, 1, 1, 1};
    const nn_conv_s8_params pb = {0, 0, 1, 1, 1, 0, 1, 1, -128, 127};
    CHECK(nn_conv2d_s8_check(&pb, &big_in, 60000, &big_f, &big_out, 1) == PL_E_ARG,
          "depth over the limit");
    const nn_dims dw_f = {1, 3, 3, 5}, dw_out = {1, 5, 5, 5};
    CHECK(nn_depthwise_conv2d_s8_check(&p, &in, 3, &dw_f, &dw_out, 5) == PL_E_ARG,
          "depthwise out_c not a multiple of in_c");
    const nn_fc_s8_params fp = {128, 0, 0, -128, 127, 1};
    CHECK(nn_fc_s8_check(&fp, 1, NN_S8_MAX_FC_DEPTH + 1, NN_S8_MAX_FC_DEPTH + 1, 4, 4) == PL_E_ARG,
          "fc depth over the limit");
    CHECK(nn_fc_s8_check(&fp, 2, 10, 9, 4, 4) == PL_E_ARG, "fc in_stride < depth");
    const nn_pool_s8_params pp = {2, 2, 2, 2, 2, 0, -128, 127};
    const nn_dims pin = {1, 4, 4, 3}, pout = {1, 3, 2, 3};
    CHECK(nn_pool2d_s8_check(&pp, &pin, 3, &pout, 3) == PL_E_ARG &&
              strstr(pl_last_error(), "pad_h"),
          "pool pad == kernel: %s", pl_last_error());
    const int32_t m_ok[2] = {1 << 30, 0}, s_ok[2] = {-31, 30};
    const int32_t m_bad[1] = {(1 << 30) - 1}, s_bad[1] = {31};
    CHECK(nn_quant_s8_check(m_ok, s_ok, 2) == PL_OK, "quant ranges ok");
    CHECK(nn_quant_s8_check(m_bad, s_ok, 1) == PL_E_ARG, "multiplier below 2^30");
    CHECK(nn_quant_s8_check(m_ok, s_bad, 1) == PL_E_ARG, "shift 31");
    size_t sz = 0;
    const nn_dims huge = {16384, 16384, 16384, 65536};
    CHECK(nn_tensor_s8_size(&huge, 65536, &sz) == (sizeof(size_t) >= 8 ? PL_OK : PL_E_NOMEM),
          "size of a huge tensor");
    const nn_dims d = {2, 3, 4, 5};
    CHECK(nn_tensor_s8_size(&d, 8, &sz) == PL_OK && sz == 23 * 8 + 5, "strided size %zu", sz);
}

static void test_fc_w8(int iter)
{
    /* now and then rows longer than the kernel converts to float once (4096): the other path */
    const int rows = 1 + (int)(rnd() % 5), n_out = 1 + (int)(rnd() % 40);
    const int n_in = iter % 50 == 7 ? 4086 + (int)(rnd() % 20) : 1 + (int)(rnd() % 300);
    const int stride = n_out + (int)(rnd() % 3), relu = (int)(rnd() % 2), has_bias = iter % 3 != 0;
    float *x = xmalloc((size_t)rows * n_in * sizeof *x), *ws = xmalloc((size_t)n_out * sizeof *ws);
    float *b = xmalloc((size_t)n_out * sizeof *b);
    float *y = xmalloc((size_t)rows * stride * sizeof *y), *y1 = xmalloc((size_t)stride * sizeof *y1);
    int8_t *w = xmalloc((size_t)n_out * n_in);
    fill_s8(w, (size_t)n_out * n_in);
    for (int i = 0; i < rows * n_in; i++)
        x[i] = (float)((int)(rnd() % 20001) - 10000) / 1000.0f;
    for (int o = 0; o < n_out; o++) {
        ws[o] = (float)(1 + rnd() % 1000) / 1e5f;
        b[o] = (float)((int)(rnd() % 2001) - 1000) / 100.0f;
    }
    for (int i = 0; i < rows * stride; i++)
        y[i] = -777.0f;
    nn_fc_w8_f32__ref(x, rows, n_in, w, ws, has_bias ? b : NULL, relu, y, stride, 0, n_out);
    for (int r = 0; r < rows; r++) {
        for (int o = 0; o < n_out; o++) {
            double sum = 0, mag = 0;
            for (int i = 0; i < n_in; i++) {
                sum += (double)w[(size_t)o * n_in + i] * x[(size_t)r * n_in + i];
                mag += fabs((double)w[(size_t)o * n_in + i] * x[(size_t)r * n_in + i]);
            }
            double want = ws[o] * sum + (has_bias ? b[o] : 0);
            if (relu && want < 0) want = 0;
            const float got = y[(size_t)r * stride + o];
            CHECK(fabs(got - want) <= 1e-5 * ws[o] * mag + 1e-5 * fabs(has_bias ? b[o] : 0) + 1e-6,
                  "fc_w8 %dx%d->%d row %d out %d: %g, want %g", rows, n_in, n_out, r, o, got, want);
        }
        for (int o = n_out; o < stride; o++)
            CHECK(y[(size_t)r * stride + o] == -777.0f, "fc_w8 wrote outside its channels");
        /* the same row alone, its channels in two pieces: the same bits */
        const int cut = (int)(rnd() % (unsigned)(n_out + 1));
        nn_fc_w8_f32__ref(x + (size_t)r * n_in, 1, n_in, w, ws, has_bias ? b : NULL, relu, y1, 0,
                          cut, n_out);
        nn_fc_w8_f32__ref(x + (size_t)r * n_in, 1, n_in, w, ws, has_bias ? b : NULL, relu, y1, 0,
                          0, cut);
        CHECK(!memcmp(y1, y + (size_t)r * stride, (size_t)n_out * sizeof *y1),
              "fc_w8 row %d differs alone or in pieces", r);
    }
    free(x), free(ws), free(b), free(y), free(y1), free(w);
}

int main(void)
{
    for (int i = 0; i < 300; i++)
        test_fc_w8(i);
    for (int i = 0; i < 1000; i++)
        test_conv(i);
    for (int i = 0; i < 1000; i++)
        test_depthwise(i);
    for (int i = 0; i < 1000; i++)
        test_fc(i);
    for (int i = 0; i < 1000; i++)
        test_pool(i);
    test_avg_rounding();
    test_depth_limit();
    test_checks();
    if (failures) {
        printf("%d checks failed\n", failures);
        return 1;
    }
    printf("all int8 kernel checks passed\n");
    return 0;
}
