/* The int8 executor of densenet121-parametric: loader, arena plan and forward pass.
 *
 * The folding that makes this graph work (docs/QUANT.md, "DenseNet folding") was done by the
 * quantiser; the file holds int8 weights with the pre-activation BN scales and the producers'
 * per-segment scales already folded in, int32 biases, per-output-channel weight scales, each
 * layer's output quantisation and the per-input-channel clamps. Activations are int8 NHWC.
 *
 * Arena (bytes), one allocation at load:
 *   A   conv0 output, block 2, block 4
 *   B   the padded u8 input (stored as s8, zero point -128), block 1, block 3
 *   T   the float resized input (before conversion), a dense layer's bottleneck, a
 *       transition's pooled input
 *   small: z (s8 and float), h (s8 and float), head outputs, the distance head's vectors
 *
 * Forward: pad + conv0 (7x7/2, ReLU) -> max pool 3x3/2 into block 1 at channel 0; each dense
 * layer: 1x1 conv of the clamped block channels [0, c) (nn_conv1x1_clamp_s8__ref) + ReLU into T,
 * 3x3 conv into the block at channel offset c with the layer's own scale; each transition: clamp
 * in place, 2x2 average pool into T, 1x1 conv into the next block at channel 0; norm5: clamp in
 * place, band pooling (int32 sums, rounded half away from zero) -> z, int8 FC + ReLU -> h; the
 * heads run in float on the dequantised z and h. */
#include "model/net_s8.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/image.h"
#include "core/util.h"
#include "kernels/dispatch.h"
#include "kernels/ref/nn_ref.h"
#include "kernels/ref/nn_ref_s8.h"
#include "kernels/ref/nn_ref_s8_clamp.h"
#include "kernels/requant.h"
#include "model/binder.h"
#include "model/heads.h"
#include "model/profile.h"
#include "model/resize.h"

#define STEM_PAD 3

/* One int8 conv / FC as it runs. */
struct s8_layer {
    const int8_t *w;
    const int32_t *bias;
    int32_t *mult, *shift;            /* per output channel, in s->qbuf */
    const float *out_scale, *out_zps; /* per output channel: real = scale*(q - zp); out_zps
                                         NULL for ReLU outputs (zero point -128) */
    int32_t out_zp;                   /* the kernel's output offset (-128 for ReLU outputs) */
    const int8_t *lo, *hi;            /* per input channel clamps, or NULL */
    nn_conv_s8_params p;
    nn_dims in, filt, out;
    int in_stride, out_stride;
    pl_s8_conv pc; /* the packed path's plan and weights (SIMD tables) */
    pl_s8_a_kind a_kind; /* how the packed path builds its input */
};

struct s8_dense {
    struct s8_layer c1, c2;
    int cin;
};

struct s8_trans {
    struct s8_layer conv;
    const int8_t *lo, *hi;
    int cin;
    /* kept float by the quantiser (--keep-float transitionN): the norm + ReLU as
     * max(0, deq[c]*q + deq[cin + c]), the 1x1 conv in float with int8-stored weights w8
     * [cin/2][cin] and a scale per row ws; conv keeps only its output grid (out_scale, out_zps) */
    const float *deq, *ws;
    const int8_t *w8;
};

struct pl_s8 {
    const pl_plm *file;
    pl_net_shape sh;
    int64_t n_params;
    uint8_t pad_px[3];

    struct s8_layer conv0, fc;
    struct s8_dense layers[MAX_LAYERS];
    struct s8_trans trans[N_BLOCKS - 1];
    const int8_t *n5_lo, *n5_hi;
    const float *n5_deq;        /* [2][1024]: z = A[c]*zq + B[c] */
    /* --keep-float fc: a float FC on the exact z, weights float (fc_wf) or int8-stored with a
     * scale per row (fc_w8, fc_ws); fc_bf its float bias. NULL: the int8 fc */
    const float *fc_wf, *fc_ws, *fc_bf;
    const int8_t *fc_w8;
    pl_heads heads; /* model/heads.h; heads.d1_w is d1_w */
    float *d1_w;    /* dequantised at load from s8 + per-row scales */
    int32_t *qbuf;

    const pl_kernels *k; /* the kernel table this executor runs */
    void *packed;        /* weights packed for k (SIMD paths), one allocation at load */
    size_t packed_bytes;
    size_t a1_bytes, a2_bytes; /* A buffers: 1x1 / fc inputs, k x k inputs */

    uint8_t *arena;
    uint8_t *a1, *a2;
    size_t arena_bytes;
    int8_t *buf_a, *buf_b, *t, *zq, *hq;
    float *tf_in, *tf_out; /* kept-float transitions: pooled input, conv output (or NULL) */
    size_t tf_in_n, tf_out_n;
    float *fin, *z, *h;
    int z_len;

    pl_layer_observer observer;
    void *observer_ctx;
    float *obs_buf, *obs_floor;
    size_t obs_floats;
    pl_profile *prof; /* pl_s8_set_profile, or NULL */
};

/* ---- loading ----------------------------------------------------------------------------- */

static size_t max_sz(size_t a, size_t b)
{
    return a > b ? a : b;
}

struct binder {
    pl_binder t; /* model/binder.h */
    pl_s8 *s;
    size_t q_used, q_cap;
};

static const pl_tensor *find(struct binder *b, const char *name, pl_dtype dt, int ndim, int d0,
                             int d1, int d2, int d3)
{
    return pl_bind(&b->t, name, dt, ndim, d0, d1, d2, d3);
}

/* An activation's quantisation (docs/FORMAT.md): for a ReLU output the f32 [c] tensor `name`
 * holds the per-channel scales (zero point -128), otherwise f32 [2][c] the scales and the zero
 * points; the table zero_point field is the kernel's output offset. */
static int bind_act(struct binder *b, const char *name, int c, int relu, struct s8_layer *L)
{
    const pl_tensor *t =
        relu ? find(b, name, PL_DT_F32, 1, c, 0, 0, 0) : find(b, name, PL_DT_F32, 2, 2, c, 0, 0);
    if (!t) return b->t.rc;
    const float *sc = t->data, *zp = relu ? NULL : sc + c;
    const char *path = b->s->file->path;
    for (int i = 0; i < c; i++) {
        if (!(sc[i] > 0) || sc[i] > 1e9f)
            return b->t.rc = pl_error(PL_E_MODEL,
                                    "%s: tensor '%s': channel %d scale %g, expected a "
                                    "finite value in (0, 1e9]",
                                    path, name, i, (double)sc[i]);
        if (zp && (!(zp[i] >= -32767 && zp[i] <= 32767) || zp[i] != floorf(zp[i])))
            return b->t.rc = pl_error(PL_E_MODEL,
                                    "%s: tensor '%s': channel %d zero point %g, "
                                    "expected an integer in [-32767, 32767]",
                                    path, name, i, (double)zp[i]);
    }
    if (t->zero_point < -128 || t->zero_point > 127 || (relu && t->zero_point != -128))
        return b->t.rc = pl_error(PL_E_MODEL,
                                "%s: tensor '%s': zero point (output offset) %d, "
                                "expected %s",
                                path, name, t->zero_point,
                                relu ? "-128 (a ReLU output)" : "[-128, 127]");
    L->out_scale = sc;
    L->out_zps = zp;
    L->out_zp = t->zero_point;
    return PL_OK;
}

/* Per-input-channel clamps, s8 [2][c]: row 0 lower bounds, row 1 upper bounds. */
static int bind_clamp(struct binder *b, const char *name, int c, const int8_t **lo,
                      const int8_t **hi)
{
    const pl_tensor *t = find(b, name, PL_DT_S8, 2, 2, c, 0, 0);
    if (!t) return b->t.rc;
    const int8_t *d = t->data;
    for (int i = 0; i < c; i++)
        if (d[i] > d[c + i])
            return b->t.rc = pl_error(PL_E_MODEL,
                                    "%s: tensor '%s': channel %d clamp [%d, %d] has "
                                    "lower > upper bound",
                                    b->s->file->path, name, i, d[i], d[c + i]);
    *lo = d;
    *hi = d + c;
    return PL_OK;
}

/* prefix.weight (s8, wdims), prefix.wscale (f32 [out_c]), prefix.bias (s32 [out_c]),
 * prefix.out (the output activation): requantisation pairs from wscale[o] / out scale. */
static int bind_layer(struct binder *b, const char *prefix, int ndim, const int wdims[4], int relu,
                      struct s8_layer *L)
{
    char name[PL_PLM_NAME_MAX];
    const char *path = b->s->file->path;
    const int out_c = wdims[0];
    snprintf(name, sizeof name, "%s.weight", prefix);
    const pl_tensor *w = find(b, name, PL_DT_S8, ndim, wdims[0], wdims[1], wdims[2], wdims[3]);
    snprintf(name, sizeof name, "%s.wscale", prefix);
    const pl_tensor *ws = find(b, name, PL_DT_F32, 1, out_c, 0, 0, 0);
    snprintf(name, sizeof name, "%s.bias", prefix);
    const pl_tensor *bias = find(b, name, PL_DT_S32, 1, out_c, 0, 0, 0);
    snprintf(name, sizeof name, "%s.out", prefix);
    if (b->t.rc < 0 || bind_act(b, name, out_c, relu, L) < 0) return b->t.rc;
    L->w = w->data;
    L->bias = bias->data;
    b->s->n_params += (int64_t)w->count + (int64_t)bias->count;
    if (b->q_used + 2 * (size_t)out_c > b->q_cap)
        return b->t.rc = pl_error(PL_E_INTERNAL, "requantisation table too small");
    L->mult = b->s->qbuf + b->q_used;
    L->shift = L->mult + out_c;
    b->q_used += 2 * (size_t)out_c;
    const float *sc = ws->data;
    for (int o = 0; o < out_c; o++) {
        if (!(sc[o] > 0))
            return b->t.rc = pl_error(PL_E_MODEL,
                                    "%s: tensor '%s.wscale': element %d is %g, "
                                    "expected a finite scale > 0",
                                    path, prefix, o, (double)sc[o]);
        const double r = (double)sc[o] / (double)L->out_scale[o];
        if (pl_quantize_multiplier(r, &L->mult[o], &L->shift[o]) < 0)
            return b->t.rc = pl_error(PL_E_MODEL,
                                    "%s: layer '%s' output channel %d: requantisation "
                                    "scale %g (wscale / output scale) out of range, expected "
                                    "< 2^30",
                                    path, prefix, o, r);
    }
    return PL_OK;
}

static int check_layer(const pl_s8 *s, const char *name, const struct s8_layer *L, int is_1x1)
{
    const nn_per_channel_quant q = {L->mult, L->shift};
    int rc =
        is_1x1 ? nn_conv1x1_s8_check(&L->p, &L->in, L->in_stride, &L->filt, &L->out, L->out_stride)
               : nn_conv2d_s8_check(&L->p, &L->in, L->in_stride, &L->filt, &L->out, L->out_stride);
    if (rc == PL_OK) rc = nn_quant_s8_check(q.multiplier, q.shift, L->out.c);
    if (rc < 0) return pl_error_prefix(rc, "%s: layer '%s'", s->file->path, name);
    return PL_OK;
}

static void conv_params(struct s8_layer *L, int32_t in_zp, int relu, int stride, int pad)
{
    L->p = (nn_conv_s8_params){.input_offset = -in_zp,
                               .output_offset = L->out_zp,
                               .stride_h = stride,
                               .stride_w = stride,
                               .pad_h = pad,
                               .pad_w = pad,
                               .dilation_h = 1,
                               .dilation_w = 1,
                               .act_min = relu ? L->out_zp : -128,
                               .act_max = 127};
}

static const float *bind_f32(struct binder *b, const char *name, int ndim, int d0, int d1)
{
    return pl_bind_f32(&b->t, name, ndim, d0, d1, 0, 0); /* counted in b->t.params */
}

/* f32 [n] per-row weight scales, each finite and > 0. */
static const float *bind_scales(struct binder *b, const char *name, int n)
{
    const float *sc = bind_f32(b, name, 1, n, 0);
    for (int i = 0; sc && i < n; i++)
        if (!(sc[i] > 0) || sc[i] > 1e9f) {
            b->t.rc = pl_error(PL_E_MODEL,
                             "%s: tensor '%s': element %d is %g, expected a finite scale in "
                             "(0, 1e9]",
                             b->s->file->path, name, i, (double)sc[i]);
            return NULL;
        }
    return sc;
}

static int bind_all(pl_s8 *s)
{
    struct binder bb = {.t = {.file = s->file, .missing_note = " (int8 model)"}, .s = s};
    struct binder *b = &bb;
    const pl_net_shape *sh = &s->sh;
    const pl_plm *f = s->file;
    char name[PL_PLM_NAME_MAX], pre[48];
    const int H = sh->in_h, W = sh->in_w, N = sh->n_lights;

    size_t chans = 64 + (size_t)MAX_LAYERS * (BOTTLENECK + GROWTH) + 2048 + (size_t)sh->fc_n;
    b->q_cap = 2 * chans;
    s->qbuf = calloc(b->q_cap, sizeof *s->qbuf);
    if (!s->qbuf) return pl_error(PL_E_NOMEM, "out of memory");

    /* stem: the u8 input with its pad pixel, conv0 + ReLU, max pool into block 1 */
    const pl_tensor *in = find(b, "input", PL_DT_U8, 1, 3, 0, 0, 0);
    if (!in) return b->t.rc;
    if (!(in->scale > 0) || in->zero_point != 0)
        return pl_error(PL_E_MODEL,
                        "%s: tensor 'input': scale %g zero point %d, expected a "
                        "scale > 0 and zero point 0 (u8 pixels)",
                        f->path, (double)in->scale, in->zero_point);
    memcpy(s->pad_px, in->data, 3);
    struct s8_layer *c0 = &s->conv0;
    if (bind_layer(b, "conv0", 4, (const int[4]){64, 7, 7, 3}, 0, c0) < 0) return b->t.rc;
    conv_params(c0, -128, 0, 2, 0); /* ReLU: the quantiser keeps conv0's range >= 0 */
    c0->in = (nn_dims){1, H + 2 * STEM_PAD, W + 2 * STEM_PAD, 3};
    c0->filt = (nn_dims){64, 7, 7, 3};
    c0->out = (nn_dims){1, H / 2, W / 2, 64};
    c0->in_stride = 3;
    c0->out_stride = 64;
    if (check_layer(s, "conv0", c0, 0) < 0) return PL_E_MODEL;

    int h = H / 4, w = W / 4, li = 0;
    for (int blk = 0; blk < N_BLOCKS; blk++) {
        const int ctot = block_c0[blk] + GROWTH * block_layers[blk];
        for (int l = 0; l < block_layers[blk]; l++, li++) {
            struct s8_dense *D = &s->layers[li];
            D->cin = block_c0[blk] + GROWTH * l;
            snprintf(pre, sizeof pre, "denseblock%d.denselayer%d", blk + 1, l + 1);
            snprintf(name, sizeof name, "%s.clamp", pre);
            if (bind_clamp(b, name, D->cin, &D->c1.lo, &D->c1.hi) < 0) return b->t.rc;
            snprintf(name, sizeof name, "%s.conv1", pre);
            if (bind_layer(b, name, 4, (const int[4]){BOTTLENECK, 1, 1, D->cin}, 1, &D->c1) < 0)
                return b->t.rc;
            conv_params(&D->c1, 0, 1, 1, 0);
            D->c1.in = (nn_dims){1, h, w, D->cin};
            D->c1.filt = (nn_dims){BOTTLENECK, 1, 1, D->cin};
            D->c1.out = (nn_dims){1, h, w, BOTTLENECK};
            D->c1.in_stride = ctot;
            D->c1.out_stride = BOTTLENECK;
            if (check_layer(s, name, &D->c1, 1) < 0) return PL_E_MODEL;
            snprintf(name, sizeof name, "%s.conv2", pre);
            if (bind_layer(b, name, 4, (const int[4]){GROWTH, 3, 3, BOTTLENECK}, 0, &D->c2) < 0)
                return b->t.rc;
            conv_params(&D->c2, D->c1.out_zp, 0, 1, 1);
            D->c2.in = (nn_dims){1, h, w, BOTTLENECK};
            D->c2.filt = (nn_dims){GROWTH, 3, 3, BOTTLENECK};
            D->c2.out = (nn_dims){1, h, w, GROWTH};
            D->c2.in_stride = BOTTLENECK;
            D->c2.out_stride = ctot;
            if (check_layer(s, name, &D->c2, 0) < 0) return PL_E_MODEL;
        }
        if (blk < N_BLOCKS - 1) {
            struct s8_trans *T = &s->trans[blk];
            T->cin = ctot;
            const int cnext = block_c0[blk + 1] + GROWTH * block_layers[blk + 1];
            snprintf(name, sizeof name, "transition%d.conv.weight", blk + 1);
            const pl_tensor *tw = pl_plm_tensor(f, name);
            T->conv.in = (nn_dims){1, h / 2, w / 2, ctot};
            T->conv.filt = (nn_dims){ctot / 2, 1, 1, ctot};
            T->conv.out = (nn_dims){1, h / 2, w / 2, ctot / 2};
            T->conv.in_stride = ctot;
            T->conv.out_stride = cnext;
            if (tw && tw->ndim == 2) { /* kept float (--keep-float transitionN) */
                const pl_tensor *w8 = find(b, name, PL_DT_S8, 2, ctot / 2, ctot, 0, 0);
                if (!w8) return b->t.rc;
                T->w8 = w8->data;
                b->s->n_params += (int64_t)w8->count;
                snprintf(name, sizeof name, "transition%d.conv.wscale", blk + 1);
                if (!(T->ws = bind_scales(b, name, ctot / 2))) return b->t.rc;
                snprintf(name, sizeof name, "transition%d.norm.dequant", blk + 1);
                T->deq = bind_f32(b, name, 2, 2, ctot);
                snprintf(name, sizeof name, "transition%d.conv.out", blk + 1);
                if (bind_act(b, name, ctot / 2, 0, &T->conv) < 0) return b->t.rc;
                const size_t hwp = (size_t)(h / 2) * (size_t)(w / 2);
                s->tf_in_n = max_sz(s->tf_in_n, hwp * (size_t)ctot);
                s->tf_out_n = max_sz(s->tf_out_n, hwp * (size_t)(ctot / 2));
            } else {
                snprintf(name, sizeof name, "transition%d.clamp", blk + 1);
                if (bind_clamp(b, name, ctot, &T->lo, &T->hi) < 0) return b->t.rc;
                snprintf(name, sizeof name, "transition%d.conv", blk + 1);
                if (bind_layer(b, name, 4, (const int[4]){ctot / 2, 1, 1, ctot}, 0, &T->conv) < 0)
                    return b->t.rc;
                conv_params(&T->conv, 0, 0, 1, 0);
                if (check_layer(s, name, &T->conv, 1) < 0) return PL_E_MODEL;
            }
            h /= 2;
            w /= 2;
        }
    }
    if (bind_clamp(b, "norm5.clamp", FEATURES, &s->n5_lo, &s->n5_hi) < 0) return b->t.rc;
    s->n5_deq = bind_f32(b, "norm5.dequant", 2, 2, FEATURES);
    const int zl = FEATURES * sh->bands;
    const pl_tensor *fw = pl_plm_tensor(f, "fc.weight");
    const pl_tensor *fbias = pl_plm_tensor(f, "fc.bias");
    if (fw && fw->dtype == PL_DT_F32) { /* kept float by the quantiser (--keep-float fc) */
        s->fc_wf = bind_f32(b, "fc.weight", 2, sh->fc_n, zl);
        s->fc_bf = bind_f32(b, "fc.bias", 1, sh->fc_n, 0);
    } else if (fbias && fbias->dtype == PL_DT_F32) { /* the same, weights stored int8 */
        const pl_tensor *w8 = find(b, "fc.weight", PL_DT_S8, 2, sh->fc_n, zl, 0, 0);
        if (!w8) return b->t.rc;
        s->fc_w8 = w8->data;
        s->n_params += (int64_t)w8->count;
        if (!(s->fc_ws = bind_scales(b, "fc.wscale", sh->fc_n))) return b->t.rc;
        s->fc_bf = bind_f32(b, "fc.bias", 1, sh->fc_n, 0);
    } else {
        struct s8_layer *F = &s->fc;
        if (bind_layer(b, "fc", 2, (const int[4]){sh->fc_n, zl, 0, 0}, 1, F) < 0) return b->t.rc;
        conv_params(F, 0, 1, 1, 0);
        F->in = (nn_dims){1, 1, 1, zl};
        F->filt = (nn_dims){sh->fc_n, 1, 1, zl};
        F->out = (nn_dims){1, 1, 1, sh->fc_n};
        const nn_fc_s8_params fp = {0, 0, F->out_zp, F->out_zp, 127, 1};
        int rc = nn_fc_s8_check(&fp, 1, zl, zl, sh->fc_n, sh->fc_n);
        if (rc == PL_OK) rc = nn_quant_s8_check(F->mult, F->shift, sh->fc_n);
        if (rc < 0) return pl_error_prefix(rc, "%s: layer 'fc'", f->path);
    }
    const int dh = sh->dist_hidden, dd = zl + 3 * N;
    s->heads = (pl_heads){.n_lights = N, .fc_n = sh->fc_n, .dist_hidden = dh, .z_len = zl};
    pl_heads_bind(&b->t, &s->heads);
    const pl_tensor *d1 = find(b, "head_dist.fc1.weight", PL_DT_S8, 2, dh, dd, 0, 0);
    const float *d1s = bind_f32(b, "head_dist.fc1.wscale", 1, dh, 0);
    pl_heads_bind_dist(&b->t, &s->heads);
    if (b->t.rc < 0) return b->t.rc;
    s->n_params += b->t.params + (int64_t)d1->count;
    s->d1_w = malloc((size_t)dh * (size_t)dd * sizeof(float));
    if (!s->d1_w) return pl_error(PL_E_NOMEM, "out of memory");
    s->heads.d1_w = s->d1_w;
    const int8_t *d1q = d1->data;
    for (int o = 0; o < dh; o++) {
        if (!(d1s[o] > 0))
            return pl_error(PL_E_MODEL,
                            "%s: tensor 'head_dist.fc1.wscale': element %d is %g, "
                            "expected a finite scale > 0",
                            f->path, o, (double)d1s[o]);
        for (int i = 0; i < dd; i++)
            s->d1_w[(size_t)o * dd + i] = d1s[o] * (float)d1q[(size_t)o * dd + i];
    }
    if ((uint32_t)b->t.used != f->n_tensors) {
        for (uint32_t i = 0; i < f->n_tensors; i++) {
            const char *n = f->tensors[i].name;
            int known = !strcmp(n, "input") || !strncmp(n, "conv0.", 6) ||
                        !strncmp(n, "denseblock", 10) || !strncmp(n, "transition", 10) ||
                        !strncmp(n, "norm5.", 6) || !strncmp(n, "fc.", 3) ||
                        !strncmp(n, "head_", 5);
            if (!known)
                return pl_error(PL_E_MODEL, "%s: unexpected tensor '%s' for an int8 %s", f->path, n,
                                PL_ARCH_NAME);
        }
        return pl_error(PL_E_MODEL, "%s: %u tensors, the int8 architecture uses %d", f->path,
                        f->n_tensors, b->t.used);
    }
    return PL_OK;
}

/* Every int8 conv / fc in forward order, each with how its A is built: a_rows for the stem (3
 * channels: the 7 horizontal taps folded into 21 channels), a_pack for the 1x1s and the fc,
 * a_pad for the 3x3s. */
static int all_layers(pl_s8 *s, struct s8_layer **L)
{
    int n = 0;
    L[n] = &s->conv0;
    L[n++]->a_kind = PL_S8_A_ROWS;
    int li = 0;
    for (int blk = 0; blk < N_BLOCKS; blk++) {
        for (int l = 0; l < block_layers[blk]; l++, li++) {
            L[n] = &s->layers[li].c1;
            L[n++]->a_kind = PL_S8_A_PACK;
            L[n] = &s->layers[li].c2;
            L[n++]->a_kind = PL_S8_A_PAD;
        }
        if (blk < N_BLOCKS - 1 && !s->trans[blk].w8) {
            L[n] = &s->trans[blk].conv;
            L[n++]->a_kind = PL_S8_A_PACK;
        }
    }
    if (!s->fc_bf) {
        L[n] = &s->fc;
        L[n++]->a_kind = PL_S8_A_PACK;
    }
    return n;
}

/* SIMD tables: every conv's weights packed once for the path (kernels/kernels_s8.h), into one
 * allocation; the sizes of the A buffers the arena needs. */
static int pack_all(pl_s8 *s)
{
    if (pl_kernels_get(&s->k) < 0) return pl_error_prefix(PL_E_UNSUPPORTED, "%s", s->file->path);
    if (!s->k->s8.packed) return PL_OK;
    enum { MAXL = 1 + 2 * MAX_LAYERS + N_BLOCKS };
    struct s8_layer *L[MAXL];
    const int n = all_layers(s, L);
    size_t total = 0;
    for (int i = 0; i < n; i++) {
        const nn_per_channel_quant q = {L[i]->mult, L[i]->shift};
        pl_s8_conv_init(&L[i]->pc, &L[i]->p, &q, &L[i]->in, &L[i]->filt, &L[i]->out,
                        L[i]->a_kind);
        total += (pl_s8_conv_packed_size(&L[i]->pc, s->k->s8.layout) + 63) & ~(size_t)63;
        size_t *a = L[i]->a_kind == PL_S8_A_PACK ? &s->a1_bytes : &s->a2_bytes;
        *a = max_sz(*a, pl_s8_conv_a_size(&L[i]->pc));
    }
    s->packed = aligned_alloc(64, total);
    if (!s->packed)
        return pl_error(PL_E_NOMEM, "cannot allocate %zu bytes of packed weights", total);
    s->packed_bytes = total;
    uint8_t *p = s->packed;
    for (int i = 0; i < n; i++) {
        s->k->s8.pack(&L[i]->pc, L[i]->w, L[i]->bias, p);
        p += (pl_s8_conv_packed_size(&L[i]->pc, s->k->s8.layout) + 63) & ~(size_t)63;
    }
    for (int i = 0; i < MAX_LAYERS; i++) /* a dense layer's 1x1 writes the 3x3's A (forward()) */
        pl_s8_conv_write_a(&s->layers[i].c1.pc, s->layers[i].c2.pc.a_w);
    return PL_OK;
}

static size_t up64(size_t n)
{
    return (n + 63) & ~(size_t)63;
}

static int plan_arena(pl_s8 *s)
{
    const size_t H = (size_t)s->sh.in_h, W = (size_t)s->sh.in_w, N = (size_t)s->sh.n_lights;
    const size_t hw1 = (H / 4) * (W / 4), hw2 = hw1 / 4, hw3 = hw2 / 4, hw4 = hw3 / 4;
    const size_t stem = 64 * (H / 2) * (W / 2);
    const size_t inpad = 3 * (H + 2 * STEM_PAD) * (W + 2 * STEM_PAD);
    const size_t a = max_sz(stem, max_sz(512 * hw2, 1024 * hw4));
    const size_t b = max_sz(inpad, max_sz(256 * hw1, 1024 * hw3));
    const size_t t =
        max_sz(3 * H * W * sizeof(float),
               max_sz(BOTTLENECK * hw1, max_sz(256 * hw2, max_sz(512 * hw3, 1024 * hw4))));
    s->z_len = FEATURES * s->sh.bands;
    const size_t zl = (size_t)s->z_len, fc = (size_t)s->sh.fc_n;
    const size_t floats = zl + fc + 3 * N + N + 3 * N + 3 + zl + 3 * N +
                          (size_t)s->sh.dist_hidden + N + s->tf_in_n + s->tf_out_n;
    const size_t total = up64(a) + up64(b) + up64(t) + up64(zl) + up64(fc) +
                         up64(floats * sizeof(float)) + up64(s->a1_bytes) + up64(s->a2_bytes);
    s->arena = aligned_alloc(64, total);
    if (!s->arena) return pl_error(PL_E_NOMEM, "cannot allocate the %zu-byte arena", total);
    s->arena_bytes = total;
    uint8_t *p = s->arena;
    s->buf_a = (int8_t *)p;
    p += up64(a);
    s->buf_b = (int8_t *)p;
    p += up64(b);
    s->t = (int8_t *)p;
    s->fin = (float *)(void *)p;
    p += up64(t);
    s->zq = (int8_t *)p;
    p += up64(zl);
    s->hq = (int8_t *)p;
    p += up64(fc);
    float *q = (float *)(void *)p;
    s->z = q;
    q += zl;
    s->h = q;
    q += fc;
    q = pl_heads_place(&s->heads, q);
    s->tf_in = s->tf_in_n ? q : NULL;
    q += s->tf_in_n;
    s->tf_out = s->tf_out_n ? q : NULL;
    q += s->tf_out_n;
    p = (uint8_t *)q;
    p = s->arena + up64((size_t)(p - s->arena));
    s->a1 = s->a1_bytes ? p : NULL;
    p += up64(s->a1_bytes);
    s->a2 = s->a2_bytes ? p : NULL;
    return PL_OK;
}

int pl_s8_load(const pl_plm *file, const pl_net_shape *shape, pl_s8 **out)
{
    *out = NULL;
    pl_s8 *s = calloc(1, sizeof *s);
    if (!s) return pl_error(PL_E_NOMEM, "out of memory");
    s->file = file;
    s->sh = *shape;
    int rc = bind_all(s);
    if (rc == PL_OK) rc = pack_all(s);
    if (rc == PL_OK) rc = plan_arena(s);
    if (rc < 0) {
        pl_s8_free(s);
        return rc;
    }
    *out = s;
    return PL_OK;
}

void pl_s8_free(pl_s8 *s)
{
    if (!s) return;
    free(s->qbuf);
    free(s->packed);
    free(s->d1_w);
    free(s->arena);
    free(s->obs_buf);
    free(s->obs_floor);
    free(s);
}

size_t pl_s8_arena_bytes(const pl_s8 *s)
{
    return s->arena_bytes;
}

int64_t pl_s8_params(const pl_s8 *s)
{
    return s->n_params;
}

int pl_s8_set_observer(pl_s8 *s, pl_layer_observer fn, void *ctx)
{
    if (fn && !s->obs_buf) {
        const size_t H = (size_t)s->sh.in_h, W = (size_t)s->sh.in_w;
        s->obs_floats = max_sz(64 * (H / 2) * (W / 2),
                               max_sz(BOTTLENECK * (H / 4) * (W / 4),
                                      max_sz((size_t)FEATURES * 3, (size_t)s->sh.fc_n)));
        s->obs_buf = malloc(s->obs_floats * sizeof(float));
        s->obs_floor = malloc(FEATURES * sizeof(float));
        if (!s->obs_buf || !s->obs_floor)
            return pl_error(PL_E_NOMEM, "out of memory (observer buffer)");
    }
    s->observer = fn;
    s->observer_ctx = ctx;
    return PL_OK;
}

void pl_s8_set_profile(pl_s8 *s, pl_profile *p)
{
    s->prof = p;
}

void pl_s8_latent(const pl_s8 *s, const float **z, int *n)
{
    *z = s->z;
    *n = s->z_len;
}

/* ---- execution ----------------------------------------------------------------------------- */

enum s8_op {
    S8_CONV,
    S8_CONV1X1,
    S8_CONV1X1_CLAMP,
    S8_MAXPOOL,
    S8_AVGPOOL,
    S8_CLAMP,
    S8_FC,
    S8_FC_F32,
    S8_A_PACK, /* packed path: A from a 1x1 / fc input (pixels) */
    S8_A_PAD,  /* packed path: A from a k x k input (rows) */
    S8_A_ROWS, /* packed path: A from a k x k input with the row taps folded (rows) */
    S8_RUN,    /* packed path: the convolution (pixels, or channels when j->by_channel) */
    S8_MAXPOOL_P, /* packed path: pools and clamp over pixels */
    S8_AVGPOOL_P,
    S8_CLAMP_P,
};

struct s8_job {
    enum s8_op op;
    const struct s8_layer *L;
    const nn_pool_s8_params *pool;
    const nn_dims *in_dims, *out_dims;
    const int8_t *in;
    int8_t *out;
    int in_stride, out_stride;
    const int8_t *lo, *hi;
    const pl_kernels_s8 *k;
    const float *fin, *fw, *fb;
    float *fout;
    int n_in;
    const uint8_t *a;
    uint8_t *a_out;
    int by_channel;
    int fuse; /* S8_A_PACK / S8_AVGPOOL_P: run L's convolution on the same pixels right after
                 (a 1x1's output pixel reads only its own A pixel: no barrier needed) */
};

static void run_s8(void *ctx, int begin, int end)
{
    const struct s8_job *j = ctx;
    const struct s8_layer *L = j->L;
    if (j->op == S8_MAXPOOL || j->op == S8_AVGPOOL) {
        (j->op == S8_MAXPOOL ? nn_maxpool2d_s8__ref : nn_avgpool2d_s8__ref)(
            j->pool, j->in_dims, j->in, j->in_stride, j->out_dims, j->out, j->out_stride, begin,
            end);
        return;
    }
    if (j->op == S8_CLAMP) {
        nn_clamp_s8__ref(j->in_dims, j->out, j->out_stride, j->lo, j->hi, begin, end);
        return;
    }
    if (j->op == S8_FC_F32) {
        nn_fc_f32__ref(j->fin, j->n_in, j->fw, j->fb, 1, j->fout, begin, end);
        return;
    }
    if (j->op == S8_MAXPOOL_P) {
        j->k->maxpool(j->pool, j->in_dims, j->in, j->in_stride, j->out_dims, j->out, j->out_stride,
                      begin, end);
        return;
    }
    if (j->op == S8_AVGPOOL_P) {
        j->k->avgpool(j->pool, j->in_dims, j->in, j->in_stride, j->lo, j->hi, j->out_dims,
                      j->a_out, j->out_stride, PL_S8_A_XOR, begin, end);
        if (j->fuse) j->k->run(&L->pc, j->a_out, j->out, L->out_stride, begin, end, 0, L->pc.out_c);
        return;
    }
    if (j->op == S8_CLAMP_P) {
        j->k->clamp(j->in_dims, j->out, j->out_stride, j->lo, j->hi, begin, end);
        return;
    }
    if (j->op == S8_A_PACK || j->op == S8_A_PAD || j->op == S8_A_ROWS || j->op == S8_RUN) {
        const pl_kernels_s8 *k = j->k;
        const pl_s8_conv *c = &L->pc;
        if (j->op == S8_A_PACK) {
            k->a_pack(&L->in, j->in, L->in_stride, j->lo, j->hi, L->p.stride_h, L->p.stride_w,
                      &L->out, j->a_out, c->cs, begin, end);
            if (j->fuse) k->run(c, j->a_out, j->out, L->out_stride, begin, end, 0, c->out_c);
        }
        else if (j->op == S8_A_ROWS)
            k->a_rows(&L->in, j->in, L->in_stride, L->p.pad_h, L->p.pad_w,
                      pl_s8_pad_u(L->p.input_offset), L->filt.w, L->p.stride_w,
                      L->p.dilation_w, c->a_h, c->a_w, j->a_out, c->cs, begin, end);
        else if (j->op == S8_A_PAD)
            k->a_pad(&L->in, j->in, L->in_stride, L->p.pad_h, L->p.pad_w,
                     pl_s8_pad_u(L->p.input_offset), c->a_h, c->a_w, j->a_out, c->cs, begin, end);
        else if (j->by_channel)
            k->run(c, j->a, j->out, L->out_stride, 0, c->n * c->out_h * c->out_w, begin, end);
        else
            k->run(c, j->a, j->out, L->out_stride, begin, end, 0, c->out_c);
        return;
    }
    const nn_per_channel_quant q = {L->mult, L->shift};
    switch (j->op) {
    case S8_CONV:
        nn_conv2d_s8__ref(&L->p, &q, &L->in, j->in, L->in_stride, &L->filt, L->w, L->bias, &L->out,
                          j->out, L->out_stride, begin, end);
        break;
    case S8_CONV1X1:
        nn_conv1x1_s8__ref(&L->p, &q, &L->in, j->in, L->in_stride, &L->filt, L->w, L->bias, &L->out,
                           j->out, L->out_stride, begin, end);
        break;
    case S8_CONV1X1_CLAMP:
        nn_conv1x1_clamp_s8__ref(&L->p, &q, &L->in, j->in, L->in_stride, L->lo, L->hi, &L->filt,
                                 L->w, L->bias, &L->out, j->out, L->out_stride, begin, end);
        break;
    case S8_FC: {
        const nn_fc_s8_params fp = {0, 0, L->out_zp, L->out_zp, 127, 1};
        nn_fc_s8__ref(&fp, &q, 1, L->in.c, j->in, L->in.c, L->w, L->bias, L->out.c, j->out,
                      L->out.c, begin, end);
        break;
    }
    default:
        break;
    }
}

/* The packed convolution of an A already built. */
static void run_packed(pl_pool *pool, const pl_kernels_s8 *k, const struct s8_layer *L,
                       const uint8_t *a, int8_t *out)
{
    const pl_s8_conv *c = &L->pc;
    const int npix = c->n * c->out_h * c->out_w;
    struct s8_job j = {.op = S8_RUN, .L = L, .k = k, .a = a, .out = out};
    j.by_channel = npix < 2 * pl_pool_threads(pool);
    pl_pool_for(pool, j.by_channel ? c->out_c : npix, run_s8, &j);
}

/* The packed path: build A (clamped when lo), then the convolution, split over output pixels
 * (over channels for the one-pixel fc). Each output value depends only on its pixel and channel,
 * so the split never changes a bit. */
static void layer_packed(const pl_s8 *s, pl_pool *pool, const struct s8_layer *L,
                         const int8_t *in, const int8_t *lo, const int8_t *hi, int8_t *out)
{
    const pl_s8_conv *c = &L->pc;
    const int dense = L->a_kind == PL_S8_A_PACK;
    uint8_t *a = dense ? s->a1 : s->a2;
    struct s8_job j = {.L = L, .in = in, .lo = lo, .hi = hi, .k = &s->k->s8, .a_out = a};
    const int npix = c->n * c->out_h * c->out_w;
    if (dense && npix >= 2 * pl_pool_threads(pool)) {
        j.op = S8_A_PACK;
        j.fuse = 1;
        j.out = out;
        pl_pool_for(pool, npix, run_s8, &j);
        return;
    }
    if (dense) {
        j.op = S8_A_PACK;
        run_s8(&j, 0, npix); /* the fc's one pixel */
    } else {
        j.op = L->a_kind == PL_S8_A_ROWS ? S8_A_ROWS : S8_A_PAD;
        pl_pool_for(pool, c->n * c->a_h, run_s8, &j);
    }
    run_packed(pool, &s->k->s8, L, a, out);
}

static void layer(const pl_s8 *s, pl_pool *pool, enum s8_op op, const struct s8_layer *L,
                  const int8_t *in, int8_t *out)
{
    if (s->k->s8.packed) {
        layer_packed(s, pool, L, in, op == S8_CONV1X1_CLAMP ? L->lo : NULL,
                     op == S8_CONV1X1_CLAMP ? L->hi : NULL, out);
        return;
    }
    struct s8_job j = {.op = op, .L = L, .in = in, .out = out};
    pl_pool_for(pool, L->out.c, run_s8, &j);
}

/* Dequantises a layer's NHWC output (per-channel scales and zero points) to CHW floats for the
 * observer. */
static void observe_s8(pl_s8 *s, const char *name, const int8_t *x, int c, int h, int w, int stride,
                       const struct s8_layer *L)
{
    if (!s->observer) return;
    for (int ch = 0; ch < c; ch++) {
        const float zp = L->out_zps ? L->out_zps[ch] : -128.0f;
        for (int i = 0; i < h * w; i++)
            s->obs_buf[(size_t)ch * h * w + i] =
                L->out_scale[ch] * ((float)x[(size_t)i * stride + ch] - zp);
        if (L->out_zps) s->obs_floor[ch] = L->out_scale[ch] * (-128.0f - zp);
    }
    s->observer(s->observer_ctx, name, s->obs_buf, c, h, w, L->out_zps ? s->obs_floor : NULL);
}

static void fc_f32(pl_pool *pool, const float *in, int n_in, const float *w, const float *b,
                   int n_out, int relu, float *out)
{
    struct s8_job j = {.op = S8_FC_F32, .fin = in, .n_in = n_in, .fw = w, .fb = b, .fout = out};
    if (relu) {
        pl_pool_for(pool, n_out, run_s8, &j);
    } else {
        nn_fc_f32__ref(in, n_in, w, b, 0, out, 0, n_out);
    }
}

/* fc_f32 for the heads (model/heads.h); ctx is the pool */
static void heads_fc(void *ctx, const float *in, int n_in, const float *w, const float *b,
                     int n_out, int relu, float *out)
{
    fc_f32(ctx, in, n_in, w, b, n_out, relu, out);
}

/* The fc kept float with int8-stored weights: h[o] = relu(ws[o] * (w8[o] . z) + b[o]). */
static void fc_w8_rows(void *ctx, int begin, int end)
{
    const pl_s8 *s = ctx;
    nn_fc_w8_f32__ref(s->z, 1, s->z_len, s->fc_w8, s->fc_ws, s->fc_bf, 1, s->h, 0, begin, end);
}

/* A transition kept float (--keep-float transitionN): the block buffer's channels through
 * max(0, A*q + B) (its norm and ReLU on the dequantised value) and the 2x2 average pool into
 * `pooled` (over pooled pixels), then the float 1x1 conv, its output rounded to the next block's
 * grid (over output channels). Each value is one thread's fixed-order sum: the same bits for
 * any thread count and kernel path. */
struct tf_job {
    const struct s8_trans *T;
    const int8_t *in; /* the block buffer, NHWC, pixel stride T->cin */
    int h, w;         /* the block's size, before the pool */
    float *pooled;    /* [(h/2)*(w/2)][cin] */
    float *y;         /* [(h/2)*(w/2)][cin/2], the conv's float output */
    int8_t *out;      /* the next block's buffer, pixel stride out_stride */
};

static void tf_pool(void *ctx, int begin, int end)
{
    const struct tf_job *j = ctx;
    const int c = j->T->cin, wp = j->w / 2;
    const float *A = j->T->deq, *B = A + c;
    for (int p = begin; p < end; p++) {
        const int y = 2 * (p / wp), x = 2 * (p % wp);
        float *o = j->pooled + (size_t)p * c;
        for (int ch = 0; ch < c; ch++)
            o[ch] = 0.0f;
        for (int d = 0; d < 4; d++) {
            const int8_t *q = j->in + ((size_t)(y + d / 2) * j->w + (size_t)(x + d % 2)) * c;
            for (int ch = 0; ch < c; ch++) {
                const float v = A[ch] * (float)q[ch] + B[ch];
                o[ch] += v > 0.0f ? v : 0.0f;
            }
        }
        for (int ch = 0; ch < c; ch++)
            o[ch] *= 0.25f;
    }
}

static void tf_conv(void *ctx, int begin, int end)
{
    const struct tf_job *j = ctx;
    const struct s8_layer *L = &j->T->conv;
    const int c = j->T->cin, np = (j->h / 2) * (j->w / 2);
    nn_fc_w8_f32__ref(j->pooled, np, c, j->T->w8, j->T->ws, NULL, 0, j->y, c / 2, begin, end);
    for (int p = 0; p < np; p++) {
        const float *y = j->y + (size_t)p * (c / 2);
        for (int o = begin; o < end; o++) {
            float q = rintf(y[o] / L->out_scale[o]) + L->out_zps[o];
            q = q < -128.0f ? -128.0f : q > 127.0f ? 127.0f : q;
            j->out[(size_t)p * L->out_stride + o] = (int8_t)q;
        }
    }
}

static void forward(pl_s8 *s, pl_pool *pool, int64_t t)
{
    const int H = s->sh.in_h, W = s->sh.in_w;
    char name[64];
    layer(s, pool, S8_CONV, &s->conv0, s->buf_b, s->buf_a);
    pl_prof_mark(s->prof, PL_PROF_STEM, &t);
    observe_s8(s, "conv0", s->buf_a, 64, H / 2, W / 2, 64, &s->conv0);

    int h = H / 4, w = W / 4;
    int8_t *cur = s->buf_b, *next = s->buf_a;
    {
        const nn_pool_s8_params mp = {3, 3, 2, 2, 1, 1, -128, 127};
        const nn_dims in = {1, H / 2, W / 2, 64}, out = {1, h, w, 64};
        struct s8_job j = {.op = S8_MAXPOOL,
                           .pool = &mp,
                           .in_dims = &in,
                           .out_dims = &out,
                           .in = s->buf_a,
                           .out = cur,
                           .in_stride = 64,
                           .out_stride = block_c0[0] + GROWTH * block_layers[0]};
        if (s->k->s8.packed) {
            j.op = S8_MAXPOOL_P;
            j.k = &s->k->s8;
            pl_pool_for(pool, h * w, run_s8, &j);
        } else {
            pl_pool_for(pool, 64, run_s8, &j);
        }
    }
    pl_prof_mark(s->prof, PL_PROF_MAXPOOL, &t);
    int li = 0;
    for (int b = 0; b < N_BLOCKS; b++) {
        const int ctot = block_c0[b] + GROWTH * block_layers[b];
        for (int l = 0; l < block_layers[b]; l++, li++) {
            const struct s8_dense *D = &s->layers[li];
            if (s->k->s8.packed) {
                /* the 1x1 writes its output straight into the interior of the 3x3's padded A
                 * (kernels/kernels_s8.h; the border, the zero point, is set once per block) */
                if (l == 0) pl_s8_a_fill_pad(&D->c2.pc, s->a2);
                layer_packed(s, pool, &D->c1, cur, D->c1.lo, D->c1.hi,
                             (int8_t *)pl_s8_a_at(&D->c2.pc, s->a2, 1, 1));
                pl_prof_mark(s->prof, PL_PROF_DENSE1 + 2 * b, &t);
                run_packed(pool, &s->k->s8, &D->c2, s->a2, cur + D->cin);
                pl_prof_mark(s->prof, PL_PROF_DENSE3 + 2 * b, &t);
                if (s->observer) /* the observer reads the bottleneck as s8 in T */
                    pl_s8_a_read_s8(&D->c2.pc, s->a2, 1, 1, h, w, s->t);
            } else {
                layer(s, pool, S8_CONV1X1_CLAMP, &D->c1, cur, s->t);
                pl_prof_mark(s->prof, PL_PROF_DENSE1 + 2 * b, &t);
                layer(s, pool, S8_CONV, &D->c2, s->t, cur + D->cin);
                pl_prof_mark(s->prof, PL_PROF_DENSE3 + 2 * b, &t);
            }
            if (s->observer) {
                snprintf(name, sizeof name, "denseblock%d.denselayer%d.conv1", b + 1, l + 1);
                observe_s8(s, name, s->t, BOTTLENECK, h, w, BOTTLENECK, &D->c1);
                snprintf(name, sizeof name, "denseblock%d.denselayer%d.conv2", b + 1, l + 1);
                observe_s8(s, name, cur + D->cin, GROWTH, h, w, ctot, &D->c2);
            }
        }
        const nn_dims bd = {1, h, w, ctot};
        if (b < N_BLOCKS - 1) {
            const struct s8_trans *T = &s->trans[b];
            const nn_pool_s8_params ap = {2, 2, 2, 2, 0, 0, -128, 127};
            const nn_dims pd = {1, h / 2, w / 2, ctot};
            if (T->w8) { /* kept float */
                struct tf_job tj = {T, cur, h, w, s->tf_in, s->tf_out, next};
                pl_pool_for(pool, (h / 2) * (w / 2), tf_pool, &tj);
                pl_pool_for(pool, ctot / 2, tf_conv, &tj);
            } else if (s->k->s8.packed) {
                /* clamp + 2x2 average pool straight into the transition conv's A */
                struct s8_job pj = {.op = S8_AVGPOOL_P,
                                    .L = &T->conv,
                                    .out = next,
                                    .fuse = 1,
                                    .k = &s->k->s8,
                                    .pool = &ap,
                                    .in_dims = &bd,
                                    .out_dims = &pd,
                                    .in = cur,
                                    .in_stride = ctot,
                                    .lo = T->lo,
                                    .hi = T->hi,
                                    .a_out = s->a1,
                                    .out_stride = T->conv.pc.cs};
                pl_pool_for(pool, (h / 2) * (w / 2), run_s8, &pj); /* and the 1x1 conv */
            } else {
                struct s8_job cj = {.op = S8_CLAMP,
                                    .in_dims = &bd,
                                    .out = cur,
                                    .out_stride = ctot,
                                    .lo = T->lo,
                                    .hi = T->hi};
                pl_pool_for(pool, ctot, run_s8, &cj);
                struct s8_job pj = {.op = S8_AVGPOOL,
                                    .pool = &ap,
                                    .in_dims = &bd,
                                    .out_dims = &pd,
                                    .in = cur,
                                    .out = s->t,
                                    .in_stride = ctot,
                                    .out_stride = ctot};
                pl_pool_for(pool, ctot, run_s8, &pj);
                layer(s, pool, S8_CONV1X1, &T->conv, s->t, next);
            }
            pl_prof_mark(s->prof, PL_PROF_TRANS + b, &t);
            h /= 2;
            w /= 2;
            if (s->observer) {
                snprintf(name, sizeof name, "transition%d.conv", b + 1);
                observe_s8(s, name, next, ctot / 2, h, w, T->conv.out_stride, &T->conv);
            }
            int8_t *tmp = cur;
            cur = next;
            next = tmp;
        } else {
            struct s8_job cj = {.op = S8_CLAMP,
                                .in_dims = &bd,
                                .out = cur,
                                .out_stride = ctot,
                                .lo = s->n5_lo,
                                .hi = s->n5_hi};
            if (s->k->s8.packed) {
                cj.op = S8_CLAMP_P;
                cj.k = &s->k->s8;
                pl_pool_for(pool, h * w, run_s8, &cj);
            } else {
                pl_pool_for(pool, ctot, run_s8, &cj);
            }
        }
    }
    /* band pooling of the clamped norm5 input (nn_band_pool_f32__ref's bands), rounded half away
     * from zero like the average pool; then z = A[c]*zq + B[c] for the float heads */
    const int bands = s->sh.bands;
    for (int c = 0; c < FEATURES; c++)
        for (int k = 0; k < bands; k++) {
            const int y0 = k * h / bands, y1 = ((k + 1) * h + bands - 1) / bands;
            const int32_t n = (y1 - y0) * w;
            int32_t sum = 0;
            for (int y = y0; y < y1; y++)
                for (int x = 0; x < w; x++)
                    sum += cur[((size_t)y * w + x) * FEATURES + c];
            const int32_t avg = sum > 0 ? (sum + n / 2) / n : (sum - n / 2) / n;
            s->zq[c * bands + k] = (int8_t)avg;
            /* a float fc reads the exact mean; the int8 fc needs it on the int8 grid */
            const float mean = s->fc_bf ? (float)sum / (float)n : (float)avg;
            s->z[c * bands + k] = s->n5_deq[c] * mean + s->n5_deq[FEATURES + c];
        }
    pl_prof_mark(s->prof, PL_PROF_NORM5, &t);
    if (s->observer) s->observer(s->observer_ctx, "z", s->z, s->z_len, 1, 1, NULL);

    const int fcn = s->sh.fc_n;
    if (s->fc_wf) {
        fc_f32(pool, s->z, s->z_len, s->fc_wf, s->fc_bf, fcn, 1, s->h);
    } else if (s->fc_w8) {
        pl_pool_for(pool, fcn, fc_w8_rows, s);
    } else {
        layer(s, pool, S8_FC, &s->fc, s->zq, s->hq);
        for (int i = 0; i < fcn; i++)
            s->h[i] = s->fc.out_scale[i] * ((float)s->hq[i] + 128.0f);
    }
    if (s->observer) s->observer(s->observer_ctx, "fc", s->h, fcn, 1, 1, NULL);

    pl_heads_run(&s->heads, s->z, s->h, heads_fc, pool);
    pl_prof_mark(s->prof, PL_PROF_HEADS, &t);
}

/* Rows [y0, y1) of the padded stem input: the resized frame (floats in T) as s8 (zero point
 * -128), padded by STEM_PAD with the mean pixel, so conv0 runs unpadded and the border is the
 * normalised network's zero. */
static void pad_input(void *ctx, int y0, int y1)
{
    const pl_s8 *s = ctx;
    const int H = s->sh.in_h, W = s->sh.in_w, PW = W + 2 * STEM_PAD;
    const size_t plane = (size_t)H * W;
    const int8_t pad[3] = {(int8_t)(s->pad_px[0] - 128), (int8_t)(s->pad_px[1] - 128),
                           (int8_t)(s->pad_px[2] - 128)};
    for (int y = y0; y < y1; y++) {
        int8_t *row = s->buf_b + (size_t)y * PW * 3;
        const int inside = y >= STEM_PAD && y < STEM_PAD + H;
        for (int xx = 0; xx < PW; xx++)
            if (!inside || xx < STEM_PAD || xx >= STEM_PAD + W) memcpy(row + 3 * xx, pad, 3);
        if (!inside) continue;
        for (int c = 0; c < 3; c++) {
            const float *f = s->fin + c * plane + (size_t)(y - STEM_PAD) * W;
            int8_t *px = row + 3 * STEM_PAD + c;
            for (int i = 0; i < W; i++) {
                /* lrintf of the value clamped to [0, 255] (the same as clamping lrintf's
                 * result): adding and subtracting 1.5 * 2^23 rounds to nearest even */
                float v = f[i] > 0.0f ? (f[i] < 255.0f ? f[i] : 255.0f) : 0.0f;
                v = (v + 12582912.0f) - 12582912.0f;
                px[3 * i] = (int8_t)((int)v - 128);
            }
        }
    }
}

void pl_s8_estimate(pl_s8 *s, pl_pool *pool, const uint8_t *rgb, int width, int height,
                    size_t stride, pl_lighting *out, int64_t *t_pre_end)
{
    const int H = s->sh.in_h, W = s->sh.in_w, PH = H + 2 * STEM_PAD;
    int64_t pt = pl_prof_now(s->prof);
    int x0, y0, cw, ch;
    pl_crop_to_aspect(width, height, W, H, &x0, &y0, &cw, &ch);
    pl_resize_job rj = {rgb, stride, x0, y0, cw, ch, s->fin, W, H};
    pl_pool_for(pool, H, pl_resize_job_rows, &rj);
    pl_pool_for(pool, PH, pad_input, s);
    *t_pre_end = pl_now_ns();
    pl_prof_mark(s->prof, PL_PROF_PRE, &pt);
    forward(s, pool, pt);

    pl_heads_lighting(&s->heads, out);
}
