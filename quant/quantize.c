#include "quant/quantize.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/util.h"
#include "model/graph.h"
#include "model/observer.h"
#include "model/plm.h"
#include "model/plm_write.h"
#include "parlight.h"
#include "port/source.h"
#include "quant/fold.h"

/* The activations the int8 graph quantises, in execution order (model/observer.h names): the
 * outputs of the graph's convolutions and of its fc. */
#define MAX_ACTS PL_GRAPH_MAX_NODES

/* Activations are quantised per channel (scales) with one zero point per activation. */
struct acts {
    int n;
    char names[MAX_ACTS][64];
    int relu[MAX_ACTS];
    int block[MAX_ACTS], ch0[MAX_ACTS]; /* the concatenation (graph tensor) and channel offset
                                           its values end in (pl_gnode.lands), or block -1 */
    int channels[MAX_ACTS];
    pl_hist *hist[MAX_ACTS]; /* [channels] each, allocated at the first observation */
    pl_qparams *q[MAX_ACTS]; /* [channels] */
    int last;                /* index of the last match: observations come in order */
    int oom;
};

static void add_act(struct acts *a, const char *name, int relu, int block, int ch0)
{
    snprintf(a->names[a->n], sizeof a->names[a->n], "%s", name);
    a->relu[a->n] = relu;
    a->block[a->n] = block;
    a->ch0[a->n] = ch0;
    a->n++;
}

/* The range of channel c of concatenation `t` that matters: every consumer (a node with a
 * pre-activation norm reading t: the later dense layers' norm1, the transition's or norm5's norm)
 * computes relu(a*x + b), which is 0 below t = -b/a for a > 0 and above t for a < 0. Below the
 * smallest such t of the a > 0 consumers (when no consumer has a < 0) every consumer clamps
 * anyway, so the producer may clip there: lo[c]; likewise hi[c]. */
static int consumer_bounds(const pl_plm *f, const pl_graph *g, int t, double *lo, double *hi)
{
    const int ctot = g->tensors[t].c;
    int *has_neg = calloc((size_t)ctot, sizeof *has_neg),
        *has_pos = calloc((size_t)ctot, sizeof *has_pos);
    if (!has_neg || !has_pos) {
        free(has_neg);
        free(has_pos);
        return pl_error(PL_E_NOMEM, "out of memory");
    }
    for (int c = 0; c < ctot; c++) {
        lo[c] = INFINITY;
        hi[c] = -INFINITY;
    }
    char sn[PL_PLM_NAME_MAX], hn[PL_PLM_NAME_MAX];
    int rc = PL_OK;
    for (int i = 0; i < g->n_nodes && rc == PL_OK; i++) {
        const pl_gnode *n = &g->nodes[i];
        if (n->in != t || !n->norm[0]) continue;
        const int cin = n->in_c;
        snprintf(sn, sizeof sn, "%s.scale", n->norm);
        snprintf(hn, sizeof hn, "%s.shift", n->norm);
        const pl_tensor *ts = pl_plm_tensor(f, sn), *th = pl_plm_tensor(f, hn);
        if (!ts || !th || ts->dtype != PL_DT_F32 || th->dtype != PL_DT_F32 ||
            ts->count != (size_t)cin || th->count != (size_t)cin) {
            rc = pl_error(PL_E_MODEL, "%s: float tensors '%s' / '%s' missing", f->path, sn, hn);
            break;
        }
        const float *a = ts->data, *b = th->data;
        for (int c = 0; c < cin; c++) {
            if (a[c] == 0) continue;
            const double th_c = -(double)b[c] / a[c];
            if (a[c] > 0) {
                has_pos[c] = 1;
                if (th_c < lo[c]) lo[c] = th_c;
            } else {
                has_neg[c] = 1;
                if (th_c > hi[c]) hi[c] = th_c;
            }
        }
    }
    for (int c = 0; c < ctot; c++) {
        if (has_neg[c] || !has_pos[c]) lo[c] = -INFINITY;
        if (has_pos[c] || !has_neg[c]) hi[c] = INFINITY;
    }
    free(has_neg);
    free(has_pos);
    return rc;
}

/* Per-channel ranges from a finite calibration set are too narrow for the channels that saw few
 * values or only small ones: deep, low-resolution layers (block 4 sees 48 pixels a frame) and
 * above all the fc (ONE value per channel and frame). Values beyond them saturate on new frames,
 * and saturation, not rounding, dominated the int8 error (docs/QUANT.md, "What limited int8").
 * So each channel's step is floored at a fraction of the activation's largest step: fc is per
 * tensor (FLOOR_FC = 1, as TFLite's FC output), the bottleneck ReLU outputs keep at most a 2x
 * finer step than their widest channel, the block channels at most 4x (they keep most of their
 * per-channel resolution, which matters because their consumers' BNs scale each channel). */
#define FLOOR_FC 1.0
#define FLOOR_RELU 0.5
#define FLOOR_BLOCK 0.25

static void floor_scales(struct acts *a, int i, double block_floor)
{
    double f = FLOOR_RELU;
    if (a->block[i] >= 0) f = block_floor;
    if (!strcmp(a->names[i], "fc")) f = FLOOR_FC;
    double mx = 0;
    for (int k = 0; k < a->channels[i]; k++)
        mx = fmax(mx, a->q[i][k].scale);
    const double s = (double)(float)(f * mx);
    for (int k = 0; k < a->channels[i]; k++) {
        pl_qparams *q = &a->q[i][k];
        if (!(q->scale < s)) continue;
        if (a->block[i] >= 0) { /* keep the range's start (the consumers' clamp), widen the top */
            const double lo = (double)q->scale * (-128.0 - q->zero_point);
            pl_qparams_clipped(lo, lo + 255.0 * s, q);
        } else { /* ReLU output, zero point -128 */
            q->scale = (float)s;
        }
    }
}

static int act_index(const struct acts *a, const char *name)
{
    for (int k = 0; k < a->n; k++) {
        const int i = (a->last + k) % a->n;
        if (!strcmp(a->names[i], name)) return i;
    }
    return -1;
}

static void observe(void *ctx, const char *layer, const float *chw, int c, int h, int w,
                    const float *floor)
{
    (void)floor;
    struct acts *a = ctx;
    const int i = act_index(a, layer);
    if (i < 0) return; /* z: not quantised on its own (it inherits norm5's clamps) */
    a->last = i;
    const size_t hw = (size_t)h * (size_t)w;
    if (!a->hist[i]) {
        a->hist[i] = malloc((size_t)c * sizeof *a->hist[i]);
        a->q[i] = calloc((size_t)c, sizeof *a->q[i]);
        if (!a->hist[i] || !a->q[i]) {
            a->oom = 1;
            return;
        }
        a->channels[i] = c;
        for (int k = 0; k < c; k++)
            pl_hist_init(&a->hist[i][k]);
    }
    if (a->channels[i] != c) {
        a->oom = 1;
        return;
    }
    for (int k = 0; k < c; k++)
        pl_hist_add(&a->hist[i][k], chw + (size_t)k * hw, hw);
}

/* ---- building the int8 file ----------------------------------------------------------------- */

struct qctx {
    const pl_plm *f;
    const pl_graph *g;
    pl_plm_writer *w;
    const struct acts *a;
    int keep[PL_GRAPH_MAX_NODES]; /* --keep-float: nodes kept float */
    char kept[256];               /* the layers kept float, in network order ("" for none) */
};

static const float *tensor_f32(const struct qctx *q, const char *name, size_t count, int *rc)
{
    if (*rc < 0) return NULL;
    const pl_tensor *t = pl_plm_tensor(q->f, name);
    if (!t || t->dtype != PL_DT_F32 || t->count != count) {
        *rc = pl_error(PL_E_MODEL, "%s: float tensor '%s' with %zu values missing", q->f->path,
                       name, count);
        return NULL;
    }
    return t->data;
}

static const pl_qparams *act_q(const struct qctx *q, const char *name)
{
    const int i = act_index(q->a, name);
    return q->a->q[i];
}

/* prefix.out: ReLU outputs f32 [c] per-channel scales (zero point -128); others f32 [2][c],
 * per-channel scales and zero points. The entry's zero point field is the kernel's output
 * offset. */
static int add_act_tensor(struct qctx *q, const char *prefix, const pl_qparams *p, int c, int relu)
{
    char name[PL_PLM_NAME_MAX];
    float *sc = malloc(2 * (size_t)c * sizeof *sc);
    if (!sc) return pl_error(PL_E_NOMEM, "out of memory");
    for (int i = 0; i < c; i++) {
        sc[i] = p[i].scale;
        sc[c + i] = (float)p[i].zero_point;
    }
    snprintf(name, sizeof name, "%s.out", prefix);
    const int rc = relu ? pl_plm_writer_add(q->w, name, PL_DT_F32, 1,
                                            (const uint32_t[]){(uint32_t)c}, sc, 0.0f, -128)
                        : pl_plm_writer_add(q->w, name, PL_DT_F32, 2,
                                            (const uint32_t[]){2, (uint32_t)c}, sc, 0.0f, 0);
    free(sc);
    return rc;
}

/* Quantises one conv / FC (weights already in OHWI / [out][depth] order) and adds
 * prefix.weight / .wscale / .bias / .out. */
static int add_layer(struct qctx *q, const char *prefix, int ndim, const uint32_t wdims[4],
                     const float *w, const float *bias, const pl_preact *fold, int ch_div,
                     int ch_mod, int32_t input_offset, const pl_qparams *out, int relu_out)
{
    const int out_c = (int)wdims[0];
    size_t depth = 1;
    for (int i = 1; i < ndim; i++)
        depth *= wdims[i];
    int8_t *wq = malloc((size_t)out_c * depth);
    int32_t *bq = malloc((size_t)out_c * sizeof *bq);
    float *ws = malloc((size_t)out_c * sizeof *ws);
    char name[PL_PLM_NAME_MAX];
    int rc = (!wq || !bq || !ws) ? pl_error(PL_E_NOMEM, "out of memory") : PL_OK;
    if (rc == PL_OK)
        rc = pl_quantize_layer(prefix, w, bias, out_c, (int)depth, fold, ch_div, ch_mod,
                               input_offset, wq, bq, ws);
    /* per-channel zero points through the bias: requant(acc + d) + off ~ requant(acc) + zp */
    /* the kernel's output offset: -128 for ReLU outputs (every zero point -128, also the ReLU's
     * act_min); 0 for the others, whose per-channel zero points go into the bias */
    const int32_t off = relu_out ? -128 : 0;
    for (int o = 0; rc == PL_OK && o < out_c; o++) {
        const double d = round((double)(out[o].zero_point - off) * out[o].scale / ws[o]);
        if (!(fabs((double)bq[o] + d) < 2147483647.0))
            rc = pl_error(PL_E_ARG, "%s: output channel %d: zero point shift overflows the bias",
                          prefix, o);
        else
            bq[o] += (int32_t)d;
    }
    if (rc == PL_OK) {
        snprintf(name, sizeof name, "%s.weight", prefix);
        rc = pl_plm_writer_add(q->w, name, PL_DT_S8, ndim, wdims, wq, 0.0f, 0);
    }
    if (rc == PL_OK) {
        snprintf(name, sizeof name, "%s.wscale", prefix);
        rc = pl_plm_writer_add(q->w, name, PL_DT_F32, 1, (const uint32_t[]){(uint32_t)out_c}, ws,
                               0.0f, 0);
    }
    if (rc == PL_OK) {
        snprintf(name, sizeof name, "%s.bias", prefix);
        rc = pl_plm_writer_add(q->w, name, PL_DT_S32, 1, (const uint32_t[]){(uint32_t)out_c}, bq,
                               0.0f, 0);
    }
    if (rc == PL_OK) rc = add_act_tensor(q, prefix, out, out_c, relu_out);
    free(wq);
    free(bq);
    free(ws);
    return rc;
}

/* OIHW -> OHWI. */
static float *to_ohwi(const float *w, int o, int i, int kh, int kw)
{
    float *r = malloc((size_t)o * i * kh * kw * sizeof *r);
    if (!r) return NULL;
    for (int a = 0; a < o; a++)
        for (int c = 0; c < i; c++)
            for (int y = 0; y < kh; y++)
                for (int x = 0; x < kw; x++)
                    r[(((size_t)a * kh + y) * kw + x) * i + c] =
                        w[(((size_t)a * i + c) * kh + y) * kw + x];
    return r;
}

/* Pre-activation folds of channels [0, c) of a block and the clamp tensor `name`. */
static int add_preact(struct qctx *q, const char *name, const float *scale, const float *shift,
                      const pl_qparams *seg, int c, pl_preact *fold)
{
    int8_t *cl = malloc(2 * (size_t)c);
    if (!cl) return pl_error(PL_E_NOMEM, "out of memory");
    for (int i = 0; i < c; i++) {
        pl_fold_preact(scale[i], shift[i], seg[i], &fold[i]);
        cl[i] = fold[i].active ? fold[i].lo : -128;
        cl[c + i] = fold[i].active ? fold[i].hi : 127;
    }
    int rc =
        pl_plm_writer_add(q->w, name, PL_DT_S8, 2, (const uint32_t[]){2, (uint32_t)c}, cl, 0.0f, 0);
    free(cl);
    return rc;
}

static int copy_f32(struct qctx *q, const char *name)
{
    const pl_tensor *t = pl_plm_tensor(q->f, name);
    if (!t || t->dtype != PL_DT_F32)
        return pl_error(PL_E_MODEL, "%s: float tensor '%s' missing", q->f->path, name);
    return pl_plm_writer_add(q->w, name, PL_DT_F32, t->ndim, t->dims, t->data, 0.0f, 0);
}

/* prefix.weight (s8 [rows][cols]) and prefix.wscale (f32 [rows]): a float layer's weights stored
 * as int8 with a symmetric scale per row, max|w|/127 (the layer still computes in float). */
static int add_rows_s8(struct qctx *q, const char *prefix, int rows, int cols, const float *w)
{
    char name[PL_PLM_NAME_MAX];
    int8_t *wq = malloc((size_t)rows * cols);
    float *ws = malloc((size_t)rows * sizeof *ws);
    int rc = (!wq || !ws) ? pl_error(PL_E_NOMEM, "out of memory") : PL_OK;
    for (int r = 0; rc == PL_OK && r < rows; r++) {
        const float *row = w + (size_t)r * cols;
        double mx = 0;
        for (int i = 0; i < cols; i++)
            mx = fmax(mx, fabs(row[i]));
        const float sc = (float)(mx > 0 ? mx / 127.0 : 1.0);
        ws[r] = sc;
        for (int i = 0; i < cols; i++)
            wq[(size_t)r * cols + i] = (int8_t)lrint(row[i] / sc);
    }
    snprintf(name, sizeof name, "%s.weight", prefix);
    if (rc == PL_OK)
        rc = pl_plm_writer_add(q->w, name, PL_DT_S8, 2,
                               (const uint32_t[]){(uint32_t)rows, (uint32_t)cols}, wq, 0.0f, 0);
    snprintf(name, sizeof name, "%s.wscale", prefix);
    if (rc == PL_OK)
        rc = pl_plm_writer_add(q->w, name, PL_DT_F32, 1, (const uint32_t[]){(uint32_t)rows}, ws,
                               0.0f, 0);
    free(wq);
    free(ws);
    return rc;
}

/* A transition kept float (--keep-float transitionN): its input is dequantised and its norm +
 * ReLU applied in one affine, max(0, A[c]*q + B[c]) (norm.dequant, f32 [2][c]), then the 2x2
 * average pool and the 1x1 conv in float (name.weight s8 [out_c][c] and name.wscale: the conv's
 * own weights, not folded with the input's per-channel scales, whose spread is what costs an
 * int8 transition its precision); its output is quantised to the next block's grid as an int8
 * transition's (name.out). */
static int add_float_transition(struct qctx *q, const pl_gnode *n, const float *scale,
                                const float *shift, const pl_qparams *seg, const float *w,
                                const pl_qparams *out)
{
    char name[PL_PLM_NAME_MAX];
    const int c = n->in_c;
    float *deq = malloc(2 * (size_t)c * sizeof *deq);
    if (!deq) return pl_error(PL_E_NOMEM, "out of memory");
    for (int i = 0; i < c; i++) {
        const double A = (double)scale[i] * seg[i].scale;
        deq[i] = (float)A;
        deq[c + i] = (float)(shift[i] - A * seg[i].zero_point);
    }
    snprintf(name, sizeof name, "%s.dequant", n->norm);
    int rc = pl_plm_writer_add(q->w, name, PL_DT_F32, 2, (const uint32_t[]){2, (uint32_t)c}, deq,
                               0.0f, 0);
    free(deq);
    if (rc == PL_OK) rc = add_rows_s8(q, n->name, n->out_c, c, w);
    if (rc == PL_OK) rc = add_act_tensor(q, n->name, out, n->out_c, 0);
    return rc;
}

/* Float tensor `prefix.suffix` with n values (rc as tensor_f32). */
static const float *node_f32(const struct qctx *q, const char *prefix, const char *suffix, size_t n,
                             int *rc)
{
    char name[PL_PLM_NAME_MAX];
    snprintf(name, sizeof name, "%s.%s", prefix, suffix);
    return tensor_f32(q, name, n, rc);
}

/* Writes node i's int8 tensors (docs/FORMAT.md "int8 models"): a conv's input clamps and
 * folded layer (or its float form, kept float), the band pooling's clamps and dequantisation,
 * the fc, the heads. seg: the producers' quantisation of each concatenation's channels, updated
 * as nodes write them. */
static int build_node(struct qctx *q, int i, const pl_preact *in_fold, pl_qparams **seg,
                      pl_preact *fold, pl_preact *zfold)
{
    const pl_graph *g = q->g;
    const pl_gnode *n = &g->nodes[i];
    const pl_plm *f = q->f;
    char name[PL_PLM_NAME_MAX];
    int rc = PL_OK;
    switch (n->op) {
    case PL_NODE_MAXPOOL:
        return PL_OK; /* values kept: its input's grid */
    case PL_NODE_CONV: {
        const size_t cin = (size_t)n->in_c, kk = (size_t)n->k * n->k;
        const float *sc = NULL, *sf = NULL;
        if (n->norm[0]) {
            sc = node_f32(q, n->norm, "scale", cin, &rc);
            sf = node_f32(q, n->norm, "shift", cin, &rc);
        }
        const float *w = node_f32(q, n->name, "weight", (size_t)n->out_c * cin * kk, &rc);
        const float *bias = n->bias ? node_f32(q, n->name, "bias", (size_t)n->out_c, &rc) : NULL;
        if (rc < 0) return rc;
        const pl_qparams *qo = act_q(q, n->name);
        if (q->keep[i]) {
            rc = add_float_transition(q, n, sc, sf, seg[n->in], w, qo);
        } else {
            const pl_preact *fl = fold;
            int32_t in_off = 0;
            if (n->in == g->input) { /* the u8 input: offset 128 from its s8 storage */
                fl = in_fold;
                in_off = 128;
            } else if (n->norm[0]) { /* a concatenation's channels through the BN + ReLU */
                snprintf(name, sizeof name, "%s.clamp", n->unit);
                if ((rc = add_preact(q, name, sc, sf, seg[n->in], n->in_c, fold)) < 0) return rc;
            } else { /* a ReLU output read as it is */
                int p = i - 1;
                while (g->nodes[p].out != n->in)
                    p--;
                const pl_qparams *qi = act_q(q, g->nodes[p].name);
                for (int c = 0; c < n->in_c; c++)
                    pl_fold_plain(qi[c], &fold[c]);
                in_off = -qi[0].zero_point;
            }
            float *wt = NULL;
            if (n->k > 1 && !(wt = to_ohwi(w, n->out_c, n->in_c, n->k, n->k)))
                return pl_error(PL_E_NOMEM, "out of memory");
            rc = add_layer(q, n->name, 4,
                           (const uint32_t[]){(uint32_t)n->out_c, (uint32_t)n->k, (uint32_t)n->k,
                                              (uint32_t)n->in_c},
                           wt ? wt : w, bias, fl, 1, n->in_c, in_off, qo, n->relu && n->lands < 0);
            free(wt);
        }
        if (rc == PL_OK && n->lands >= 0)
            for (int c = 0; c < n->out_c; c++)
                seg[n->lands][n->lands_c0 + c] = qo[c];
        return rc;
    }
    case PL_NODE_BANDS: {
        const int C = n->in_c;
        const float *sc = node_f32(q, n->norm, "scale", (size_t)C, &rc);
        const float *sf = node_f32(q, n->norm, "shift", (size_t)C, &rc);
        if (rc < 0) return rc;
        snprintf(name, sizeof name, "%s.clamp", n->unit);
        if ((rc = add_preact(q, name, sc, sf, seg[n->in], C, zfold)) < 0) return rc;
        float *deq = malloc(2 * (size_t)C * sizeof *deq);
        if (!deq) return pl_error(PL_E_NOMEM, "out of memory");
        for (int c = 0; c < C; c++) {
            deq[c] = zfold[c].active ? (float)zfold[c].A : 0.0f;
            deq[C + c] = (float)(zfold[c].active ? zfold[c].B : zfold[c].constant);
        }
        snprintf(name, sizeof name, "%s.dequant", n->norm);
        rc = pl_plm_writer_add(q->w, name, PL_DT_F32, 2, (const uint32_t[]){2, (uint32_t)C}, deq,
                               0.0f, 0);
        free(deq);
        return rc;
    }
    case PL_NODE_FC: { /* on z: element c*bands + k belongs to the pooled channel c */
        const pl_gnode *zn = &g->nodes[i - 1];
        const float *fw = node_f32(q, n->name, "weight", (size_t)n->out_c * n->in_c, &rc);
        if (q->keep[i]) { /* float on the exact z; weights stored int8 with a scale per row */
            snprintf(name, sizeof name, "%s.bias", n->name);
            if (rc < 0 || (rc = add_rows_s8(q, n->name, n->out_c, n->in_c, fw)) < 0) return rc;
            return copy_f32(q, name);
        }
        const float *fb = node_f32(q, n->name, "bias", (size_t)n->out_c, &rc);
        if (rc < 0) return rc;
        return add_layer(q, n->name, 2,
                         (const uint32_t[]){(uint32_t)n->out_c, (uint32_t)n->in_c, 0, 0}, fw, fb,
                         zfold, g->shape.bands, zn->in_c, 0, act_q(q, n->name), n->relu);
    }
    case PL_NODE_HEADS: {
        static const char *heads[] = {
            "head_dir.weight",      "head_dir.bias",     "head_size.weight",
            "head_size.bias",       "head_rgb.weight",   "head_rgb.bias",
            "head_ambient.weight",  "head_ambient.bias", "head_dist.fc1.bias",
            "head_dist.fc2.weight", "head_dist.fc2.bias"};
        for (size_t k = 0; k < sizeof heads / sizeof heads[0]; k++)
            if ((rc = copy_f32(q, heads[k])) < 0) return rc;
        /* the distance head's first layer (3072+3N inputs) is the one big head: stored as s8
         * with a scale per row, dequantised to float at load (it still runs in float) */
        const pl_tensor *d1 = pl_plm_tensor(f, "head_dist.fc1.weight");
        if (!d1 || d1->dtype != PL_DT_F32 || d1->ndim != 2)
            return pl_error(PL_E_MODEL, "%s: float tensor 'head_dist.fc1.weight' missing", f->path);
        return add_rows_s8(q, "head_dist.fc1", (int)d1->dims[0], (int)d1->dims[1], d1->data);
    }
    }
    return PL_OK;
}

static int build(struct qctx *q, const pl_quantize_opts *o, const pl_quantize_report *rep)
{
    const pl_plm *f = q->f;
    const pl_graph *g = q->g;
    int rc = PL_OK;
    char text[1024];
    float mean[3], std[3];
    if (sscanf(pl_plm_meta(f, "mean"), "%f,%f,%f", &mean[0], &mean[1], &mean[2]) != 3 ||
        sscanf(pl_plm_meta(f, "std"), "%f,%f,%f", &std[0], &std[1], &std[2]) != 3)
        return pl_error(PL_E_MODEL, "%s: metadata mean/std unreadable", f->path);

    /* metadata: the float file's, with precision int8 and the quantisation recorded */
    for (int i = 0; i < f->n_meta && rc == PL_OK; i++) {
        const char *k = f->meta_keys[i], *v = f->meta_vals[i];
        if (!strcmp(k, "precision") || !strncmp(k, "quant_", 6)) continue;
        if (!strcmp(k, "provenance")) {
            char opts[160] = "";
            if (q->kept[0]) snprintf(opts, sizeof opts, ", --keep-float %s", q->kept);
            if (o->block_floor_set)
                snprintf(opts + strlen(opts), sizeof opts - strlen(opts), ", --block-floor %g",
                         o->block_floor);
            if (o->headroom > 1)
                snprintf(opts + strlen(opts), sizeof opts - strlen(opts), ", --headroom %g",
                         o->headroom);
            snprintf(text, sizeof text, "%.700s; int8 by parlight quantize (%s, %lld frames%s)", v,
                     pl_calib_method_name(o->method), (long long)rep->frames_good, opts);
            v = text;
        }
        rc = pl_plm_writer_meta(q->w, k, v);
    }
    if (rc == PL_OK) rc = pl_plm_writer_meta(q->w, "precision", "int8");
    if (rc == PL_OK) rc = pl_plm_writer_meta(q->w, "quant_method", pl_calib_method_name(o->method));
    snprintf(text, sizeof text, "%lld", (long long)rep->frames_good);
    if (rc == PL_OK) rc = pl_plm_writer_meta(q->w, "quant_calib_frames", text);
    if (rc == PL_OK && o->headroom > 1) {
        snprintf(text, sizeof text, "%g", o->headroom);
        rc = pl_plm_writer_meta(q->w, "quant_headroom", text);
    }
    if (rc == PL_OK && o->block_floor_set) {
        snprintf(text, sizeof text, "%g", o->block_floor);
        rc = pl_plm_writer_meta(q->w, "quant_block_floor", text);
    }
    if (rc == PL_OK && q->kept[0]) rc = pl_plm_writer_meta(q->w, "quant_keep_float", q->kept);
    if (rc == PL_OK && o->method == PL_CALIB_PERCENTILE) {
        snprintf(text, sizeof text, "%g", o->percentile);
        rc = pl_plm_writer_meta(q->w, "quant_percentile", text);
    }
    if (rc < 0) return rc;

    /* the u8 input, padded with the mean pixel; the normalisation folds into its first conv */
    uint8_t pad[3];
    pl_preact in_fold[3];
    for (int c = 0; c < 3; c++) {
        const long v = lround(mean[c] * 255.0);
        pad[c] = (uint8_t)(v < 0 ? 0 : v > 255 ? 255 : v);
        in_fold[c] = (pl_preact){.A = 1.0 / (255.0 * std[c]),
                                 .B = 128.0 / (255.0 * std[c]) - mean[c] / std[c],
                                 .lo = -128,
                                 .hi = 127,
                                 .center = pad[c] - 128, /* the mean pixel */
                                 .active = 1};
    }
    if ((rc = pl_plm_writer_add(q->w, g->tensors[g->input].name, PL_DT_U8, 1, (const uint32_t[]){3},
                                pad, 1.0f / 255.0f, 0)) < 0)
        return rc;

    /* seg[t]: per channel of concatenation t, the quantisation of the producer that wrote it;
     * fold: a node's input folds; zfold: the band pooling's, which the fc reads */
    pl_qparams *seg[PL_GRAPH_MAX_TENSORS] = {0};
    int max_c = 0;
    for (int t = 0; t < g->n_tensors; t++) {
        if (g->tensors[t].c > max_c) max_c = g->tensors[t].c;
        if (g->tensors[t].block >= 0 && !(seg[t] = calloc((size_t)g->tensors[t].c, sizeof **seg)))
            rc = pl_error(PL_E_NOMEM, "out of memory");
    }
    pl_preact *fold = malloc((size_t)max_c * sizeof *fold);
    pl_preact *zfold = malloc((size_t)max_c * sizeof *zfold);
    if (!fold || !zfold) rc = pl_error(PL_E_NOMEM, "out of memory");
    for (int i = 0; i < g->n_nodes && rc == PL_OK; i++)
        rc = build_node(q, i, in_fold, seg, fold, zfold);
    for (int t = 0; t < g->n_tensors; t++)
        free(seg[t]);
    free(fold);
    free(zfold);
    return rc;
}

/* A node that can stay float: a pooled conv (a transition) or the fc, by its unit name. */
static int keepable(const pl_gnode *n)
{
    return n->unit[0] && (n->op == PL_NODE_FC || (n->op == PL_NODE_CONV && n->pool2));
}

/* --keep-float: sets q->keep and q->kept (network order). */
static int parse_keep_float(const char *list, const pl_graph *g, struct qctx *q)
{
    const char *p = list ? list : "";
    while (*p) {
        const char *e = strchr(p, ',');
        const size_t n = e ? (size_t)(e - p) : strlen(p);
        int found = n > 5 && !strncmp(p, "head_", 5); /* the heads are always float */
        for (int i = 0; i < g->n_nodes && !found; i++)
            if (keepable(&g->nodes[i]) && strlen(g->nodes[i].unit) == n &&
                !strncmp(p, g->nodes[i].unit, n))
                found = q->keep[i] = 1;
        if (!found) {
            char can[256] = "";
            for (int i = 0; i < g->n_nodes; i++)
                if (keepable(&g->nodes[i]))
                    snprintf(can + strlen(can), sizeof can - strlen(can), "%s'%s'",
                             can[0] ? ", " : "", g->nodes[i].unit);
            return pl_error(PL_E_ARG,
                            "--keep-float '%.*s': this layer cannot stay float (only %s can; the "
                            "heads are always float; the dense layers share int8 block buffers)",
                            (int)n, p, can);
        }
        p += n;
        if (*p == ',') p++;
    }
    for (int i = 0; i < g->n_nodes; i++)
        if (q->keep[i])
            snprintf(q->kept + strlen(q->kept), sizeof q->kept - strlen(q->kept), "%s%s",
                     q->kept[0] ? "," : "", g->nodes[i].unit);
    return PL_OK;
}

int pl_quantize_model(const pl_quantize_opts *o, pl_quantize_report *rep)
{
    memset(rep, 0, sizeof *rep);
    int rc;
    if (o->method == PL_CALIB_PERCENTILE && !(o->percentile > 50 && o->percentile <= 100))
        return pl_error(PL_E_ARG, "percentile %g: expected (50, 100]", o->percentile);
    if (o->headroom != 0 && !(o->headroom >= 1 && o->headroom <= 16))
        return pl_error(PL_E_ARG, "headroom %g: expected [1, 16]", o->headroom);
    const double headroom = o->headroom > 0 ? o->headroom : 1.0;
    if (o->block_floor_set && !(o->block_floor >= 0 && o->block_floor <= 1))
        return pl_error(PL_E_ARG, "block floor %g: expected [0, 1]", o->block_floor);

    pl_model *m = NULL;
    pl_source *src = NULL;
    pl_plm file;
    memset(&file, 0, sizeof file);
    pl_plm_writer *w = NULL;
    struct qctx q = {.f = &file};
    double *blo[PL_GRAPH_MAX_TENSORS] = {0}, *bhi[PL_GRAPH_MAX_TENSORS] = {0};
    struct acts *a = calloc(1, sizeof *a);
    if (!a) return pl_error(PL_E_NOMEM, "out of memory");
    if ((rc = pl_model_load(o->float_path, &m)) < 0) goto done;
    if (strcmp(pl_model_precision(m), "fp32")) {
        rc = pl_error(PL_E_MODEL, "%s: precision '%s': quantize needs a float (fp32) model",
                      o->float_path, pl_model_precision(m));
        goto done;
    }
    const pl_graph *g = pl_model_graph(m);
    q.g = g;
    if ((rc = parse_keep_float(o->keep_float, g, &q)) < 0) goto done;
    if ((rc = pl_plm_open(o->float_path, &file)) < 0) goto done;

    /* every conv's and the fc's output (block: the concatenation it ends in, or -1) */
    for (int i = 0; i < g->n_nodes; i++) {
        const pl_gnode *n = &g->nodes[i];
        if (n->op == PL_NODE_CONV || n->op == PL_NODE_FC)
            add_act(a, n->name, n->relu, n->lands, n->lands >= 0 ? n->lands_c0 : 0);
    }
    if ((rc = pl_model_set_observer(m, observe, a)) < 0) goto done;

    if ((rc = pl_source_open_path(o->calib, &src)) < 0) {
        rc = pl_error_prefix(rc, "calibration input");
        goto done;
    }
    for (;;) {
        if (o->max_frames > 0 && rep->frames_good >= o->max_frames) break;
        pl_frame fr;
        rc = pl_source_read(src, &fr);
        if (rc == PL_E_EOF) break;
        const char *err = NULL;
        if (rc == PL_OK) {
            pl_lighting L;
            rc = pl_estimate_rgb8(m, fr.image.data, fr.image.width, fr.image.height,
                                  fr.image.stride, &L, NULL);
        }
        if (a->oom) {
            rc = pl_error(PL_E_NOMEM, "out of memory (calibration histograms)");
            goto done;
        }
        if (rc < 0) {
            rep->frames_bad++;
            err = pl_last_error();
        } else {
            rep->frames_good++;
        }
        if (o->progress)
            o->progress(o->progress_ctx, rep->frames_good, rep->frames_bad,
                        rc == PL_OK ? fr.name : "", err);
    }
    if (rep->frames_good == 0) {
        rc = pl_error(PL_E_FORMAT, "calibration input %s: no usable frame (%lld bad)", o->calib,
                      (long long)rep->frames_bad);
        goto done;
    }
    for (int t = 0; t < g->n_tensors; t++) {
        if (g->tensors[t].block < 0) continue;
        blo[t] = malloc((size_t)g->tensors[t].c * sizeof **blo);
        bhi[t] = malloc((size_t)g->tensors[t].c * sizeof **bhi);
        if (!blo[t] || !bhi[t]) {
            rc = pl_error(PL_E_NOMEM, "out of memory");
            goto done;
        }
        if ((rc = consumer_bounds(&file, g, t, blo[t], bhi[t])) < 0) goto done;
    }
    for (int i = 0; i < a->n; i++) {
        if (!a->hist[i]) {
            rc = pl_error(PL_E_INTERNAL, "activation '%s' was never observed", a->names[i]);
            goto done;
        }
        for (int k = 0; k < a->channels[i]; k++) {
            double lo, hi;
            /* a block channel keeps its whole calibrated range, whatever the method: a value
             * clipped there is seen by every later consumer, each scaling the error by its BN */
            const pl_calib_method meth = a->block[i] >= 0 ? PL_CALIB_MINMAX : o->method;
            rc = pl_hist_range(&a->hist[i][k], meth, o->percentile, a->relu[i], &lo, &hi);
            lo *= headroom;
            hi *= headroom;
            if (rc == PL_OK &&
                a->block[i] >= 0) { /* a concatenation's segment: clip to its consumers */
                const int c = a->ch0[i] + k, b = a->block[i];
                if (lo > 0) lo = 0; /* as pl_qparams_from_range: the range holds 0 */
                if (hi < 0) hi = 0;
                if (a->relu[i] && lo < 0) lo = 0;
                if (blo[b][c] > lo) lo = blo[b][c];
                if (bhi[b][c] < hi) hi = bhi[b][c];
                if (a->relu[i] && lo < 0) lo = 0; /* conv0: the ReLU stays (lo >= 0) */
                if (!(hi > lo)) hi = lo + 1e-6 * (fabs(lo) + 1);
                rc = pl_qparams_clipped(lo, hi, &a->q[i][k]);
            } else if (rc == PL_OK) {
                rc = pl_qparams_from_range(lo, hi, a->relu[i], &a->q[i][k]);
            }
            if (rc < 0) {
                rc = pl_error_prefix(rc, "activation '%s' channel %d", a->names[i], k);
                goto done;
            }
        }
    }
    for (int i = 0; i < a->n; i++)
        floor_scales(a, i, o->block_floor_set ? o->block_floor : FLOOR_BLOCK);
    rep->n_activations = a->n;
    if ((rc = pl_plm_writer_create(&w)) < 0) goto done;
    q.w = w;
    q.a = a;
    if ((rc = build(&q, o, rep)) < 0) goto done;
    rc = pl_plm_writer_save(w, o->out_path);
done:
    pl_plm_writer_free(w);
    pl_source_close(src);
    pl_plm_close(&file);
    pl_model_free(m);
    for (int t = 0; t < PL_GRAPH_MAX_TENSORS; t++) {
        free(blo[t]);
        free(bhi[t]);
    }
    for (int i = 0; a && i < a->n; i++) {
        free(a->hist[i]);
        free(a->q[i]);
    }
    free(a);
    return rc;
}
