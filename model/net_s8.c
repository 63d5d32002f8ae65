/* The int8 executor of the network's graph (model/graph.h): loader, arena plan and forward pass,
 * each a walk over the graph's nodes.
 *
 * The folding that makes this graph work (docs/QUANT.md, "DenseNet folding") was done by the
 * quantiser; the file holds int8 weights with the pre-activation BN scales and the producers'
 * per-segment scales already folded in, int32 biases, per-output-channel weight scales, each
 * layer's output quantisation and the per-input-channel clamps. Activations are int8 NHWC.
 *
 * Arena (bytes), one allocation at load, from the graph's slots:
 *   A   slot A: conv0 output, block 2, block 4
 *   B   slot B: the padded u8 input (stored as s8, zero point -128), block 1, block 3
 *   T   slot T (the bottlenecks), the float resized input (before conversion), a
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
#include "model/graph.h"
#include "model/heads.h"
#include "model/profile.h"
#include "model/resize.h"

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
    pl_s8_conv pc;       /* the packed path's plan and weights (SIMD tables) */
    pl_s8_a_kind a_kind; /* how the packed path builds its input */
};

/* What the executor keeps of a node (model/graph.h). */
struct s8_node {
    struct s8_layer L; /* CONV and FC; BANDS and pooled convs keep their input clamps in L.lo/hi */
    int into_next;     /* packed path: a 1x1 whose output goes straight into the interior of the
                          next node's padded A (kernels/kernels_s8.h) */
    int fill_pad;      /* packed path, the next node of an into_next: set its A's border (the
                          zero point) first, as the A's shape changed since it was last set */
    /* kept float by the quantiser (--keep-float transitionN or fc): a pooled conv's norm + ReLU
     * as max(0, deq[c]*q + deq[in_c + c]), its 1x1 conv in float with int8-stored weights w8
     * [out_c][in_c] and a scale per row ws, L keeping only its output grid (out_scale, out_zps);
     * a float FC on the exact z, weights float (wf) or int8-stored with a scale per row (w8,
     * ws), bf its float bias. BANDS: deq is [2][in_c], z = A[c]*zq + B[c]. */
    const float *deq, *ws, *wf, *bf;
    const int8_t *w8;
};

struct pl_s8 {
    const pl_plm *file;
    pl_graph g;
    int64_t n_params;
    uint8_t pad_px[3];
    int in_pad;  /* the input's border, the mean pixel, around the first conv's input */
    int z_exact; /* the fc is kept float: it reads the exact band means */

    struct s8_node nodes[PL_GRAPH_MAX_NODES];
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
    int8_t *tensor[PL_GRAPH_MAX_TENSORS]; /* each graph tensor's int8 buffer (NHWC) */
    int8_t *t;             /* slot T: bottlenecks, pooled inputs (and fin before the stem) */
    float *tf_in, *tf_out; /* kept-float transitions: pooled input, conv output (or NULL) */
    size_t tf_in_n, tf_out_n;
    float *fin, *z, *h; /* the resized input; the float latent and fc output */

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

static size_t up64(size_t n)
{
    return (n + 63) & ~(size_t)63;
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

/* A CONV node's int8 layer: its input clamps (a pre-activated input), weights and requantisation;
 * the first conv reads the input padded by the executor (pad_input) and runs unpadded. */
static int bind_conv(struct binder *b, const pl_gnode *n, struct s8_node *N)
{
    const int i = (int)(N - b->s->nodes);
    pl_s8 *s = b->s;
    const pl_graph *g = &s->g;
    struct s8_layer *L = &N->L;
    char name[PL_PLM_NAME_MAX];
    if (n->unit[0]) {
        snprintf(name, sizeof name, "%s.clamp", n->unit);
        if (bind_clamp(b, name, n->in_c, &L->lo, &L->hi) < 0) return b->t.rc;
    }
    /* a ReLU output is quantised with zero point -128, unless a concatenation's consumers
     * clamp it anyway (the stem's ReLU: the quantiser keeps its range >= 0) */
    const int relu = n->relu && n->lands < 0;
    if (bind_layer(b, n->name, 4, (const int[4]){n->out_c, n->k, n->k, n->in_c}, relu, L) < 0)
        return b->t.rc;
    /* the input offset: the u8 input's -128, a ReLU producer's zero point; 0 for clamped inputs,
     * whose zero points are folded into the bias */
    int32_t in_zp = 0;
    const pl_gtensor *in = &g->tensors[n->in];
    if (n->in == g->input)
        in_zp = -128;
    else if (in->block < 0)
        for (int j = i - 1; j >= 0; j--)
            if (g->nodes[j].out == n->in) {
                in_zp = s->nodes[j].L.out_zp;
                break;
            }
    const int pad = n->in == g->input ? 0 : n->pad, ext = 2 * (n->pad - pad);
    conv_params(L, in_zp, relu, n->stride, pad);
    const int ih = n->pool2 ? n->out_h : n->in_h, iw = n->pool2 ? n->out_w : n->in_w;
    L->in = (nn_dims){1, ih + ext, iw + ext, n->in_c};
    L->filt = (nn_dims){n->out_c, n->k, n->k, n->in_c};
    L->out = (nn_dims){1, n->out_h, n->out_w, n->out_c};
    L->in_stride = in->c;
    L->out_stride = g->tensors[n->out].c;
    if (check_layer(s, n->name, L, n->k == 1) < 0) return b->t.rc = PL_E_MODEL;
    return PL_OK;
}

/* A pooled conv kept float by the quantiser (--keep-float transitionN). */
static int bind_float_conv(struct binder *b, const pl_gnode *n, struct s8_node *N)
{
    pl_s8 *s = b->s;
    char name[PL_PLM_NAME_MAX];
    snprintf(name, sizeof name, "%s.weight", n->name);
    const pl_tensor *w8 = find(b, name, PL_DT_S8, 2, n->out_c, n->in_c, 0, 0);
    if (!w8) return b->t.rc;
    N->w8 = w8->data;
    s->n_params += (int64_t)w8->count;
    snprintf(name, sizeof name, "%s.wscale", n->name);
    if (!(N->ws = bind_scales(b, name, n->out_c))) return b->t.rc;
    snprintf(name, sizeof name, "%s.dequant", n->norm);
    N->deq = bind_f32(b, name, 2, 2, n->in_c);
    snprintf(name, sizeof name, "%s.out", n->name);
    if (bind_act(b, name, n->out_c, 0, &N->L) < 0) return b->t.rc;
    N->L.out_stride = s->g.tensors[n->out].c;
    const size_t hwp = (size_t)n->out_h * (size_t)n->out_w;
    s->tf_in_n = max_sz(s->tf_in_n, hwp * (size_t)n->in_c);
    s->tf_out_n = max_sz(s->tf_out_n, hwp * (size_t)n->out_c);
    return PL_OK;
}

/* The fc: int8, or kept float (--keep-float fc) with float or int8-stored weights. */
static int bind_fc(struct binder *b, const pl_gnode *n, struct s8_node *N)
{
    pl_s8 *s = b->s;
    const pl_plm *f = s->file;
    char wn[PL_PLM_NAME_MAX], bn[PL_PLM_NAME_MAX], sn[PL_PLM_NAME_MAX];
    snprintf(wn, sizeof wn, "%s.weight", n->name);
    snprintf(bn, sizeof bn, "%s.bias", n->name);
    snprintf(sn, sizeof sn, "%s.wscale", n->name);
    const pl_tensor *fw = pl_plm_tensor(f, wn), *fbias = pl_plm_tensor(f, bn);
    if (fw && fw->dtype == PL_DT_F32) { /* kept float */
        N->wf = bind_f32(b, wn, 2, n->out_c, n->in_c);
        N->bf = bind_f32(b, bn, 1, n->out_c, 0);
    } else if (fbias && fbias->dtype == PL_DT_F32) { /* the same, weights stored int8 */
        const pl_tensor *w8 = find(b, wn, PL_DT_S8, 2, n->out_c, n->in_c, 0, 0);
        if (!w8) return b->t.rc;
        N->w8 = w8->data;
        s->n_params += (int64_t)w8->count;
        if (!(N->ws = bind_scales(b, sn, n->out_c))) return b->t.rc;
        N->bf = bind_f32(b, bn, 1, n->out_c, 0);
    } else {
        struct s8_layer *F = &N->L;
        if (bind_layer(b, n->name, 2, (const int[4]){n->out_c, n->in_c, 0, 0}, n->relu, F) < 0)
            return b->t.rc;
        conv_params(F, 0, n->relu, 1, 0);
        F->in = (nn_dims){1, 1, 1, n->in_c};
        F->filt = (nn_dims){n->out_c, 1, 1, n->in_c};
        F->out = (nn_dims){1, 1, 1, n->out_c};
        const nn_fc_s8_params fp = {0, 0, F->out_zp, F->out_zp, 127, 1};
        int rc = nn_fc_s8_check(&fp, 1, n->in_c, n->in_c, n->out_c, n->out_c);
        if (rc == PL_OK) rc = nn_quant_s8_check(F->mult, F->shift, n->out_c);
        if (rc < 0) return b->t.rc = pl_error_prefix(rc, "%s: layer '%s'", f->path, n->name);
    }
    s->z_exact = N->bf != NULL;
    return b->t.rc;
}

/* The heads: float, but for the distance head's first layer, stored s8 with a scale per row and
 * dequantised here. */
static int bind_heads(struct binder *b, const pl_gnode *n)
{
    pl_s8 *s = b->s;
    const pl_net_shape *sh = &s->g.shape;
    const int N = sh->n_lights, zl = n->in_c, dh = sh->dist_hidden, dd = zl + 3 * N;
    s->heads = (pl_heads){.n_lights = N, .fc_n = sh->fc_n, .dist_hidden = dh, .z_len = zl};
    pl_heads_bind(&b->t, &s->heads);
    const pl_tensor *d1 = find(b, "head_dist.fc1.weight", PL_DT_S8, 2, dh, dd, 0, 0);
    const float *d1s = bind_scales(b, "head_dist.fc1.wscale", dh);
    pl_heads_bind_dist(&b->t, &s->heads);
    if (b->t.rc < 0) return b->t.rc;
    s->n_params += (int64_t)d1->count;
    s->d1_w = malloc((size_t)dh * (size_t)dd * sizeof(float));
    if (!s->d1_w) return b->t.rc = pl_error(PL_E_NOMEM, "out of memory");
    s->heads.d1_w = s->d1_w;
    const int8_t *d1q = d1->data;
    for (int o = 0; o < dh; o++)
        for (int i = 0; i < dd; i++)
            s->d1_w[(size_t)o * dd + i] = d1s[o] * (float)d1q[(size_t)o * dd + i];
    return PL_OK;
}

/* Binds every node's tensors (model/graph.h) in graph order. */
static int bind_all(pl_s8 *s)
{
    struct binder bb = {.t = {.file = s->file, .missing_note = " (int8 model)"}, .s = s};
    struct binder *b = &bb;
    const pl_graph *g = &s->g;
    const pl_plm *f = s->file;
    char name[PL_PLM_NAME_MAX];

    for (int i = 0; i < g->n_nodes; i++)
        if (g->nodes[i].op == PL_NODE_CONV || g->nodes[i].op == PL_NODE_FC)
            b->q_cap += 2 * (size_t)g->nodes[i].out_c;
    s->qbuf = calloc(b->q_cap, sizeof *s->qbuf);
    if (!s->qbuf) return pl_error(PL_E_NOMEM, "out of memory");

    /* the u8 input and its pad pixel */
    const pl_tensor *in = find(b, g->tensors[g->input].name, PL_DT_U8, 1, 3, 0, 0, 0);
    if (!in) return b->t.rc;
    if (!(in->scale > 0) || in->zero_point != 0)
        return pl_error(PL_E_MODEL,
                        "%s: tensor 'input': scale %g zero point %d, expected a "
                        "scale > 0 and zero point 0 (u8 pixels)",
                        f->path, (double)in->scale, in->zero_point);
    memcpy(s->pad_px, in->data, 3);

    for (int i = 0; i < g->n_nodes; i++) {
        const pl_gnode *n = &g->nodes[i];
        struct s8_node *N = &s->nodes[i];
        if (n->in == g->input) s->in_pad = n->pad;
        int rc = PL_OK;
        switch (n->op) {
        case PL_NODE_CONV: {
            snprintf(name, sizeof name, "%s.weight", n->name);
            const pl_tensor *w = pl_plm_tensor(f, name);
            rc = n->pool2 && w && w->ndim == 2 ? bind_float_conv(b, n, N) : bind_conv(b, n, N);
            break;
        }
        case PL_NODE_BANDS:
            snprintf(name, sizeof name, "%s.clamp", n->unit);
            if ((rc = bind_clamp(b, name, n->in_c, &N->L.lo, &N->L.hi)) < 0) break;
            snprintf(name, sizeof name, "%s.dequant", n->norm);
            N->deq = bind_f32(b, name, 2, 2, n->in_c);
            break;
        case PL_NODE_FC:
            rc = bind_fc(b, n, N);
            break;
        case PL_NODE_HEADS:
            rc = bind_heads(b, n);
            break;
        case PL_NODE_MAXPOOL:
            break;
        }
        if (rc < 0 || b->t.rc < 0) return b->t.rc < 0 ? b->t.rc : rc;
    }
    s->n_params += b->t.params;
    return pl_bind_finish(&b->t, "an int8 " PL_ARCH_NAME);
}

/* SIMD tables: every int8 conv / fc's weights packed once for the path (kernels/kernels_s8.h), in
 * graph order into one allocation, each with how its A is built: a_rows for the stem (3
 * channels: the row taps folded into channels), a_pack for the 1x1s and the fc, a_pad for the
 * k x k ones; the sizes of the A buffers the arena needs. A 1x1 followed by the k x k conv that
 * reads its output writes that conv's A (into_next). */
static int pack_all(pl_s8 *s)
{
    if (pl_kernels_get(&s->k) < 0) return pl_error_prefix(PL_E_UNSUPPORTED, "%s", s->file->path);
    if (!s->k->s8.packed) return PL_OK;
    const pl_graph *g = &s->g;
    struct s8_layer *L[PL_GRAPH_MAX_NODES];
    int n = 0;
    for (int i = 0; i < g->n_nodes; i++) {
        const pl_gnode *d = &g->nodes[i];
        struct s8_node *N = &s->nodes[i];
        if ((d->op != PL_NODE_CONV && d->op != PL_NODE_FC) || N->w8 || N->wf) continue;
        N->L.a_kind = d->k == 1 ? PL_S8_A_PACK : d->in == g->input ? PL_S8_A_ROWS : PL_S8_A_PAD;
        L[n++] = &N->L;
    }
    size_t total = 0;
    for (int i = 0; i < n; i++) {
        const nn_per_channel_quant q = {L[i]->mult, L[i]->shift};
        pl_s8_conv_init(&L[i]->pc, &L[i]->p, &q, &L[i]->in, &L[i]->filt, &L[i]->out, L[i]->a_kind);
        total += up64(pl_s8_conv_packed_size(&L[i]->pc, s->k->s8.layout));
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
        p += up64(pl_s8_conv_packed_size(&L[i]->pc, s->k->s8.layout));
    }
    const pl_gnode *last = NULL; /* the last k x k conv whose A its producer wrote */
    for (int i = 0; i + 1 < g->n_nodes; i++) {
        const pl_gnode *d = &g->nodes[i], *nx = &g->nodes[i + 1];
        struct s8_node *N = &s->nodes[i];
        if (d->op != PL_NODE_CONV || N->L.a_kind != PL_S8_A_PACK || d->pool2 ||
            nx->op != PL_NODE_CONV || s->nodes[i + 1].L.a_kind != PL_S8_A_PAD || nx->in != d->out ||
            nx->in_c != d->out_c)
            continue;
        N->into_next = 1;
        N->fill_pad = !last || last->in_h != nx->in_h || last->in_w != nx->in_w;
        pl_s8_conv_write_a(&N->L.pc, s->nodes[i + 1].L.pc.a_w);
        last = nx;
    }
    return PL_OK;
}

static int plan_arena(pl_s8 *s)
{
    const pl_graph *g = &s->g;
    const pl_net_shape *sh = &g->shape;
    const size_t H = (size_t)sh->in_h, W = (size_t)sh->in_w, N = (size_t)sh->n_lights;
    const size_t inpad = 3 * (H + 2 * (size_t)s->in_pad) * (W + 2 * (size_t)s->in_pad);
    const size_t a = pl_graph_slot_size(g, PL_SLOT_A);
    const size_t b = max_sz(inpad, pl_graph_slot_size(g, PL_SLOT_B));
    size_t t = max_sz(3 * H * W * sizeof(float), pl_graph_slot_size(g, PL_SLOT_T));
    for (int i = 0; i < g->n_nodes; i++) /* pooled inputs */
        if (g->nodes[i].pool2)
            t = max_sz(t, (size_t)g->nodes[i].in_c * g->nodes[i].out_h * g->nodes[i].out_w);
    const size_t zl = pl_graph_tensor_size(g, g->z), fc = pl_graph_tensor_size(g, g->h);
    const size_t floats = zl + fc + 3 * N + N + 3 * N + 3 + zl + 3 * N + (size_t)sh->dist_hidden +
                          N + s->tf_in_n + s->tf_out_n;
    const size_t total = up64(a) + up64(b) + up64(t) + up64(zl) + up64(fc) +
                         up64(floats * sizeof(float)) + up64(s->a1_bytes) + up64(s->a2_bytes);
    s->arena = aligned_alloc(64, total);
    if (!s->arena) return pl_error(PL_E_NOMEM, "cannot allocate the %zu-byte arena", total);
    s->arena_bytes = total;
    uint8_t *p = s->arena;
    int8_t *slot[PL_SLOT_VEC];
    slot[PL_SLOT_A] = (int8_t *)p;
    p += up64(a);
    slot[PL_SLOT_B] = (int8_t *)p;
    p += up64(b);
    slot[PL_SLOT_T] = s->t = (int8_t *)p;
    s->fin = (float *)(void *)p;
    p += up64(t);
    for (int i = 0; i < g->n_tensors; i++)
        if (g->tensors[i].slot != PL_SLOT_VEC) s->tensor[i] = slot[g->tensors[i].slot];
    s->tensor[g->z] = (int8_t *)p;
    p += up64(zl);
    s->tensor[g->h] = (int8_t *)p;
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
    int rc = pl_graph_build(shape, &s->g);
    if (rc == PL_OK) rc = bind_all(s);
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
        size_t chans = 0;
        for (int i = 0; i < s->g.n_nodes; i++) {
            const pl_gnode *n = &s->g.nodes[i];
            s->obs_floats = max_sz(s->obs_floats, (size_t)n->out_c * n->out_h * n->out_w);
            chans = max_sz(chans, (size_t)n->out_c);
        }
        s->obs_buf = malloc(s->obs_floats * sizeof(float));
        s->obs_floor = malloc(chans * sizeof(float));
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

const pl_graph *pl_s8_graph(const pl_s8 *s)
{
    return &s->g;
}

void pl_s8_latent(const pl_s8 *s, const float **z, int *n)
{
    *z = s->z;
    *n = s->g.tensors[s->g.z].c;
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
    S8_A_PACK,    /* packed path: A from a 1x1 / fc input (pixels) */
    S8_A_PAD,     /* packed path: A from a k x k input (rows) */
    S8_A_ROWS,    /* packed path: A from a k x k input with the row taps folded (rows) */
    S8_RUN,       /* packed path: the convolution (pixels, or channels when j->by_channel) */
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
        j->k->avgpool(j->pool, j->in_dims, j->in, j->in_stride, j->lo, j->hi, j->out_dims, j->a_out,
                      j->out_stride, PL_S8_A_XOR, begin, end);
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
        } else if (j->op == S8_A_ROWS)
            k->a_rows(&L->in, j->in, L->in_stride, L->p.pad_h, L->p.pad_w,
                      pl_s8_pad_u(L->p.input_offset), L->filt.w, L->p.stride_w, L->p.dilation_w,
                      c->a_h, c->a_w, j->a_out, c->cs, begin, end);
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
static void layer_packed(const pl_s8 *s, pl_pool *pool, const struct s8_layer *L, const int8_t *in,
                         const int8_t *lo, const int8_t *hi, int8_t *out)
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
struct fc_w8_job {
    const pl_kernels_f32 *k;
    const struct s8_node *N;
    const float *in;
    int n_in;
    float *out;
};

static void fc_w8_rows(void *ctx, int begin, int end)
{
    const struct fc_w8_job *j = ctx;
    j->k->fc_w8(j->in, 1, j->n_in, j->N->w8, j->N->ws, j->N->bf, 1, j->out, 0, begin, end);
}

/* A transition kept float (--keep-float transitionN): the block buffer's channels through
 * max(0, A*q + B) (its norm and ReLU on the dequantised value) and the 2x2 average pool into
 * `pooled` (over pooled pixels), then the float 1x1 conv, its output rounded to the next block's
 * grid (over output channels). Each value is one thread's fixed-order sum: the same bits for
 * any thread count and kernel path. */
struct tf_job {
    const pl_kernels_f32 *k;
    const struct s8_node *T;
    int c, out_c;     /* the channels in (the block's) and out */
    const int8_t *in; /* the block buffer, NHWC, pixel stride c */
    int h, w;         /* the block's size, before the pool */
    float *pooled;    /* [(h/2)*(w/2)][c] */
    float *y;         /* [(h/2)*(w/2)][out_c], the conv's float output */
    int8_t *out;      /* the next block's buffer, pixel stride out_stride */
};

/* max(0, A*q + B) summed over the 4 pixels of n channels into o (which starts at 0), in chunks
 * of a fixed 16 so that gcc's -O2 vectorises them (it leaves a loop of unknown count scalar) */
static void tf_pool_add(float *restrict o, const int8_t *restrict q, const float *restrict A,
                        const float *restrict B, int n)
{
    int ch = 0;
    for (; ch + 16 <= n; ch += 16)
        for (int k = 0; k < 16; k++) {
            const float v = A[ch + k] * (float)q[ch + k] + B[ch + k];
            o[ch + k] += v > 0.0f ? v : 0.0f;
        }
    for (; ch < n; ch++) {
        const float v = A[ch] * (float)q[ch] + B[ch];
        o[ch] += v > 0.0f ? v : 0.0f;
    }
}

static void tf_pool(void *ctx, int begin, int end)
{
    const struct tf_job *j = ctx;
    const int c = j->c, wp = j->w / 2;
    const float *A = j->T->deq, *B = A + c;
    for (int p = begin; p < end; p++) {
        const int y = 2 * (p / wp), x = 2 * (p % wp);
        float *o = j->pooled + (size_t)p * c;
        for (int ch = 0; ch < c; ch++)
            o[ch] = 0.0f;
        for (int d = 0; d < 4; d++)
            tf_pool_add(o, j->in + ((size_t)(y + d / 2) * j->w + (size_t)(x + d % 2)) * c, A, B,
                        c);
        for (int ch = 0; ch < c; ch++)
            o[ch] *= 0.25f;
    }
}

static void tf_conv(void *ctx, int begin, int end)
{
    const struct tf_job *j = ctx;
    const struct s8_layer *L = &j->T->L;
    const int c = j->c, np = (j->h / 2) * (j->w / 2);
    j->k->fc_w8(j->pooled, np, c, j->T->w8, j->T->ws, NULL, 0, j->y, j->out_c, begin, end);
    for (int p = 0; p < np; p++) {
        const float *y = j->y + (size_t)p * j->out_c;
        for (int o = begin; o < end; o++) {
            float q = rintf(y[o] / L->out_scale[o]) + L->out_zps[o];
            q = q < -128.0f ? -128.0f : q > 127.0f ? 127.0f : q;
            j->out[(size_t)p * L->out_stride + o] = (int8_t)q;
        }
    }
}

/* A CONV node: on the packed path a 1x1 into_next writes the next node's A, which then only
 * runs; a pooled conv (a transition) clamps, pools and convolves in one pass, or in float when
 * kept float. */
static void run_conv(pl_s8 *s, pl_pool *pool, const pl_gnode *n, const struct s8_node *N,
                     int8_t *in, int8_t *out)
{
    const pl_graph *g = &s->g;
    const struct s8_layer *L = &N->L;
    const int packed = s->k->s8.packed;
    if (n->pool2) {
        const nn_pool_s8_params ap = {2, 2, 2, 2, 0, 0, -128, 127};
        const int cs = g->tensors[n->in].c;
        const nn_dims bd = {1, n->in_h, n->in_w, n->in_c}, pd = {1, n->out_h, n->out_w, n->in_c};
        if (N->w8) {
            struct tf_job tj = {&s->k->f32, N,         n->in_c,   n->out_c, in,
                                n->in_h,    n->in_w,   s->tf_in, s->tf_out, out};
            pl_pool_for(pool, n->out_h * n->out_w, tf_pool, &tj);
            pl_pool_for(pool, n->out_c, tf_conv, &tj);
        } else if (packed) {
            /* clamp + 2x2 average pool straight into the conv's A, and the 1x1 conv */
            struct s8_job pj = {.op = S8_AVGPOOL_P,
                                .L = L,
                                .out = out,
                                .fuse = 1,
                                .k = &s->k->s8,
                                .pool = &ap,
                                .in_dims = &bd,
                                .out_dims = &pd,
                                .in = in,
                                .in_stride = cs,
                                .lo = L->lo,
                                .hi = L->hi,
                                .a_out = s->a1,
                                .out_stride = L->pc.cs};
            pl_pool_for(pool, n->out_h * n->out_w, run_s8, &pj);
        } else {
            struct s8_job cj = {.op = S8_CLAMP,
                                .in_dims = &bd,
                                .out = in,
                                .out_stride = cs,
                                .lo = L->lo,
                                .hi = L->hi};
            pl_pool_for(pool, n->in_c, run_s8, &cj);
            struct s8_job pj = {.op = S8_AVGPOOL,
                                .pool = &ap,
                                .in_dims = &bd,
                                .out_dims = &pd,
                                .in = in,
                                .out = s->t,
                                .in_stride = cs,
                                .out_stride = cs};
            pl_pool_for(pool, n->in_c, run_s8, &pj);
            layer(s, pool, S8_CONV1X1, L, s->t, out);
        }
        return;
    }
    if (packed && N->into_next) {
        const struct s8_node *nx = N + 1;
        const int p = (n + 1)->pad;
        if (N->fill_pad) pl_s8_a_fill_pad(&nx->L.pc, s->a2);
        layer_packed(s, pool, L, in, L->lo, L->hi, (int8_t *)pl_s8_a_at(&nx->L.pc, s->a2, p, p));
        if (s->observer) /* the observer reads the output as s8 in T */
            pl_s8_a_read_s8(&nx->L.pc, s->a2, p, p, n->out_h, n->out_w, s->t);
    } else if (packed && N > s->nodes && (N - 1)->into_next) {
        run_packed(pool, &s->k->s8, L, s->a2, out);
    } else {
        const enum s8_op op = n->k > 1 ? S8_CONV : L->lo ? S8_CONV1X1_CLAMP : S8_CONV1X1;
        layer(s, pool, op, L, in, out);
    }
}

/* A BANDS node: the clamp in place, then the band pooling (nn_band_pool_f32__ref's bands) of
 * the clamped input, rounded half away from zero like the average pool: zq; z = A[c]*mean +
 * B[c] for the float heads, the mean on the int8 grid unless a float fc reads it exact. */
static void run_bands(pl_s8 *s, pl_pool *pool, const pl_gnode *n, const struct s8_node *N,
                      int8_t *in, int8_t *zq)
{
    const int cs = s->g.tensors[n->in].c, h = n->in_h, w = n->in_w, C = n->in_c;
    const nn_dims bd = {1, h, w, C};
    struct s8_job cj = {
        .op = S8_CLAMP, .in_dims = &bd, .out = in, .out_stride = cs, .lo = N->L.lo, .hi = N->L.hi};
    if (s->k->s8.packed) {
        cj.op = S8_CLAMP_P;
        cj.k = &s->k->s8;
        pl_pool_for(pool, h * w, run_s8, &cj);
    } else {
        pl_pool_for(pool, C, run_s8, &cj);
    }
    const int bands = s->g.shape.bands;
    for (int c = 0; c < C; c++)
        for (int k = 0; k < bands; k++) {
            const int y0 = k * h / bands, y1 = ((k + 1) * h + bands - 1) / bands;
            const int32_t n_px = (y1 - y0) * w;
            int32_t sum = 0;
            for (int y = y0; y < y1; y++)
                for (int x = 0; x < w; x++)
                    sum += in[((size_t)y * w + x) * cs + c];
            const int32_t avg = sum > 0 ? (sum + n_px / 2) / n_px : (sum - n_px / 2) / n_px;
            zq[c * bands + k] = (int8_t)avg;
            const float mean = s->z_exact ? (float)sum / (float)n_px : (float)avg;
            s->z[c * bands + k] = N->deq[c] * mean + N->deq[C + c];
        }
}

/* An FC node: int8 (then dequantised to h), or kept float. */
static void run_fc(pl_s8 *s, pl_pool *pool, const pl_gnode *n, const struct s8_node *N,
                   const int8_t *zq, int8_t *hq)
{
    if (N->wf) {
        fc_f32(pool, s->z, n->in_c, N->wf, N->bf, n->out_c, n->relu, s->h);
    } else if (N->w8) {
        struct fc_w8_job j = {&s->k->f32, N, s->z, n->in_c, s->h};
        pl_pool_for(pool, n->out_c, fc_w8_rows, &j);
    } else {
        layer(s, pool, S8_FC, &N->L, zq, hq);
        for (int i = 0; i < n->out_c; i++)
            s->h[i] = N->L.out_scale[i] * ((float)hq[i] + 128.0f);
    }
}

/* Runs the graph's nodes in order (model/graph.h); tensors are NHWC, a node's output starts at
 * channel out_c0 of each pixel. */
static void forward(pl_s8 *s, pl_pool *pool, int64_t t)
{
    const pl_graph *g = &s->g;
    for (int i = 0; i < g->n_nodes; i++) {
        const pl_gnode *n = &g->nodes[i];
        const struct s8_node *N = &s->nodes[i];
        int8_t *in = s->tensor[n->in];
        int8_t *out = n->out >= 0 ? s->tensor[n->out] + n->out_c0 : NULL;
        switch (n->op) {
        case PL_NODE_CONV:
            run_conv(s, pool, n, N, in, out);
            break;
        case PL_NODE_MAXPOOL: {
            const nn_pool_s8_params mp = {n->k,   n->k,   n->stride, n->stride,
                                          n->pad, n->pad, -128,      127};
            const nn_dims id = {1, n->in_h, n->in_w, n->in_c},
                          od = {1, n->out_h, n->out_w, n->in_c};
            struct s8_job j = {.op = S8_MAXPOOL,
                               .pool = &mp,
                               .in_dims = &id,
                               .out_dims = &od,
                               .in = in,
                               .out = out,
                               .in_stride = g->tensors[n->in].c,
                               .out_stride = g->tensors[n->out].c};
            if (s->k->s8.packed) {
                j.op = S8_MAXPOOL_P;
                j.k = &s->k->s8;
                pl_pool_for(pool, n->out_h * n->out_w, run_s8, &j);
            } else {
                pl_pool_for(pool, n->in_c, run_s8, &j);
            }
            break;
        }
        case PL_NODE_BANDS:
            run_bands(s, pool, n, N, in, out);
            break;
        case PL_NODE_FC:
            run_fc(s, pool, n, N, in, out);
            break;
        case PL_NODE_HEADS:
            pl_heads_run(&s->heads, s->z, s->h, heads_fc, pool);
            break;
        }
        pl_prof_mark(s->prof, n->stage, &t);
        if (!s->observer || !out || n->op == PL_NODE_MAXPOOL) continue;
        if (n->op == PL_NODE_BANDS || n->op == PL_NODE_FC) { /* dequantised already */
            s->observer(s->observer_ctx, n->name, n->op == PL_NODE_FC ? s->h : s->z, n->out_c, 1, 1,
                        NULL);
            continue;
        }
        const int8_t *x = out; /* an into_next's output was copied from the next A into T */
        int stride = g->tensors[n->out].c;
        if (s->k->s8.packed && N->into_next) x = s->t, stride = n->out_c;
        observe_s8(s, n->name, x, n->out_c, n->out_h, n->out_w, stride, &N->L);
    }
}

/* Rows [y0, y1) of the padded stem input: the resized frame (floats in T) as s8 (zero point
 * -128), padded by the first conv's padding with the mean pixel, so that conv runs unpadded and the
 * border is the normalised network's zero. */
static void pad_input(void *ctx, int y0, int y1)
{
    const pl_s8 *s = ctx;
    const int H = s->g.shape.in_h, W = s->g.shape.in_w, P = s->in_pad, PW = W + 2 * P;
    const size_t plane = (size_t)H * W;
    const int8_t pad[3] = {(int8_t)(s->pad_px[0] - 128), (int8_t)(s->pad_px[1] - 128),
                           (int8_t)(s->pad_px[2] - 128)};
    for (int y = y0; y < y1; y++) {
        int8_t *row = s->tensor[s->g.input] + (size_t)y * PW * 3;
        const int inside = y >= P && y < P + H;
        for (int xx = 0; xx < PW; xx++)
            if (!inside || xx < P || xx >= P + W) memcpy(row + 3 * xx, pad, 3);
        if (!inside) continue;
        for (int c = 0; c < 3; c++) {
            const float *f = s->fin + c * plane + (size_t)(y - P) * W;
            int8_t *px = row + 3 * P + c;
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
    const int H = s->g.shape.in_h, W = s->g.shape.in_w, PH = H + 2 * s->in_pad;
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
