#include "quant/quantize.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/util.h"
#include "model/arch.h"
#include "model/observer.h"
#include "model/plm.h"
#include "model/plm_write.h"
#include "parlight.h"
#include "port/source.h"
#include "quant/fold.h"

/* The activations the int8 graph quantises, in execution order (model/observer.h names). */
#define MAX_ACTS (1 + 2 * MAX_LAYERS + N_BLOCKS - 1 + 1)

/* Activations are quantised per channel (scales) with one zero point per activation. */
struct acts {
    int n;
    char names[MAX_ACTS][64];
    int relu[MAX_ACTS];
    int block[MAX_ACTS], ch0[MAX_ACTS]; /* the block buffer (0..3) and channel offset it writes,
                                           or block -1 */
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

/* The range of block channel c that matters: every consumer (the later dense layers' norm1, the
 * transition's or norm5's norm) computes relu(a*x + b), which is 0 below t = -b/a for a > 0 and
 * above t for a < 0. Below the smallest such t of the a > 0 consumers (when no consumer has
 * a < 0) every consumer clamps anyway, so the producer may clip there: lo[c]; likewise hi[c]. */
static int consumer_bounds(const pl_plm *f, int blk, double *lo, double *hi)
{
    const int ctot = block_c0[blk] + GROWTH * block_layers[blk];
    int has_neg[FEATURES] = {0}, has_pos[FEATURES] = {0};
    for (int c = 0; c < ctot; c++) {
        lo[c] = INFINITY;
        hi[c] = -INFINITY;
    }
    char sn[PL_PLM_NAME_MAX], hn[PL_PLM_NAME_MAX];
    for (int l = 0; l <= block_layers[blk]; l++) {
        int cin;
        if (l < block_layers[blk]) {
            cin = block_c0[blk] + GROWTH * l;
            snprintf(sn, sizeof sn, "denseblock%d.denselayer%d.norm1.scale", blk + 1, l + 1);
            snprintf(hn, sizeof hn, "denseblock%d.denselayer%d.norm1.shift", blk + 1, l + 1);
        } else {
            cin = ctot;
            if (blk < N_BLOCKS - 1) {
                snprintf(sn, sizeof sn, "transition%d.norm.scale", blk + 1);
                snprintf(hn, sizeof hn, "transition%d.norm.shift", blk + 1);
            } else {
                snprintf(sn, sizeof sn, "norm5.scale");
                snprintf(hn, sizeof hn, "norm5.shift");
            }
        }
        const pl_tensor *ts = pl_plm_tensor(f, sn), *th = pl_plm_tensor(f, hn);
        if (!ts || !th || ts->dtype != PL_DT_F32 || th->dtype != PL_DT_F32 ||
            ts->count != (size_t)cin || th->count != (size_t)cin)
            return pl_error(PL_E_MODEL, "%s: float tensors '%s' / '%s' missing", f->path, sn, hn);
        const float *a = ts->data, *b = th->data;
        for (int c = 0; c < cin; c++) {
            if (a[c] == 0) continue;
            const double t = -(double)b[c] / a[c];
            if (a[c] > 0) {
                has_pos[c] = 1;
                if (t < lo[c]) lo[c] = t;
            } else {
                has_neg[c] = 1;
                if (t > hi[c]) hi[c] = t;
            }
        }
    }
    for (int c = 0; c < ctot; c++) {
        if (has_neg[c] || !has_pos[c]) lo[c] = -INFINITY;
        if (has_pos[c] || !has_neg[c]) hi[c] = INFINITY;
    }
    return PL_OK;
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
    pl_plm_writer *w;
    const struct acts *a;
    int keep_fc;
    int keep_trans[N_BLOCKS - 1]; /* --keep-float transitionN */
    char kept[64];                /* the layers kept float, in network order ("" for none) */
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
    float sc[2 * FEATURES];
    for (int i = 0; i < c; i++) {
        sc[i] = p[i].scale;
        sc[c + i] = (float)p[i].zero_point;
    }
    snprintf(name, sizeof name, "%s.out", prefix);
    if (relu)
        return pl_plm_writer_add(q->w, name, PL_DT_F32, 1, (const uint32_t[]){(uint32_t)c}, sc,
                                 0.0f, -128);
    return pl_plm_writer_add(q->w, name, PL_DT_F32, 2, (const uint32_t[]){2, (uint32_t)c}, sc, 0.0f,
                             0);
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
 * ReLU applied in one affine, max(0, A[c]*q + B[c]) (prefix.norm.dequant, f32 [2][c]), then
 * the 2x2 average pool and the 1x1 conv in float (prefix.conv.weight s8 [c/2][c] and
 * prefix.conv.wscale: the conv's own weights, not folded with the input's per-channel scales,
 * whose spread is what costs an int8 transition its precision); its output is quantised to the
 * next block's grid as an int8 transition's (prefix.conv.out). */
static int add_float_transition(struct qctx *q, const char *pre, const float *scale,
                                const float *shift, const pl_qparams *seg, int c, const float *w,
                                const pl_qparams *out)
{
    char name[PL_PLM_NAME_MAX];
    float *deq = malloc(2 * (size_t)c * sizeof *deq);
    if (!deq) return pl_error(PL_E_NOMEM, "out of memory");
    for (int i = 0; i < c; i++) {
        const double A = (double)scale[i] * seg[i].scale;
        deq[i] = (float)A;
        deq[c + i] = (float)(shift[i] - A * seg[i].zero_point);
    }
    snprintf(name, sizeof name, "%s.norm.dequant", pre);
    int rc = pl_plm_writer_add(q->w, name, PL_DT_F32, 2, (const uint32_t[]){2, (uint32_t)c}, deq,
                               0.0f, 0);
    free(deq);
    snprintf(name, sizeof name, "%s.conv", pre);
    if (rc == PL_OK) rc = add_rows_s8(q, name, c / 2, c, w);
    if (rc == PL_OK) rc = add_act_tensor(q, name, out, c / 2, 0);
    return rc;
}

static int meta_int(const pl_plm *f, const char *key)
{
    const char *v = pl_plm_meta(f, key);
    return v ? atoi(v) : 0;
}

static int build(struct qctx *q, const pl_quantize_opts *o, const pl_quantize_report *rep)
{
    const pl_plm *f = q->f;
    int rc = PL_OK;
    char name[PL_PLM_NAME_MAX], pre[48], text[1024];
    const int bands = meta_int(f, "bands"), fc_n = meta_int(f, "fc");
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

    /* stem: u8 input, padded with the mean pixel; normalisation folded into conv0 */
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
    if ((rc = pl_plm_writer_add(q->w, "input", PL_DT_U8, 1, (const uint32_t[]){3}, pad,
                                1.0f / 255.0f, 0)) < 0)
        return rc;
    const float *c0w = tensor_f32(q, "conv0.weight", 64 * 3 * 49, &rc);
    const float *c0b = tensor_f32(q, "conv0.bias", 64, &rc);
    if (rc < 0) return rc;
    float *wt = to_ohwi(c0w, 64, 3, 7, 7);
    if (!wt) return pl_error(PL_E_NOMEM, "out of memory");
    rc = add_layer(q, "conv0", 4, (const uint32_t[]){64, 7, 7, 3}, wt, c0b, in_fold, 1, 3, 128,
                   act_q(q, "conv0"), 0);
    free(wt);
    if (rc < 0) return rc;

    pl_qparams seg[FEATURES];
    pl_preact fold[FEATURES];
    for (int c = 0; c < 64; c++)
        seg[c] = act_q(q, "conv0")[c];
    for (int b = 0; b < N_BLOCKS; b++) {
        for (int l = 0; l < block_layers[b]; l++) {
            const int cin = block_c0[b] + GROWTH * l;
            snprintf(pre, sizeof pre, "denseblock%d.denselayer%d", b + 1, l + 1);
#define T(suffix, n) (snprintf(name, sizeof name, "%s." suffix, pre), tensor_f32(q, name, n, &rc))
            const float *sc = T("norm1.scale", (size_t)cin), *sf = T("norm1.shift", (size_t)cin);
            const float *w1 = T("conv1.weight", (size_t)BOTTLENECK * cin);
            const float *b1 = T("conv1.bias", BOTTLENECK);
            const float *w2 = T("conv2.weight", (size_t)GROWTH * BOTTLENECK * 9);
#undef T
            if (rc < 0) return rc;
            snprintf(name, sizeof name, "%s.clamp", pre);
            if ((rc = add_preact(q, name, sc, sf, seg, cin, fold)) < 0) return rc;
            snprintf(name, sizeof name, "%s.conv1", pre);
            const pl_qparams *q1 = act_q(q, name);
            if ((rc = add_layer(q, name, 4, (const uint32_t[]){BOTTLENECK, 1, 1, (uint32_t)cin}, w1,
                                b1, fold, 1, cin, 0, q1, 1)) < 0)
                return rc;
            pl_preact plain[BOTTLENECK];
            for (int c = 0; c < BOTTLENECK; c++)
                pl_fold_plain(q1[c], &plain[c]);
            snprintf(name, sizeof name, "%s.conv2", pre);
            const pl_qparams *q2 = act_q(q, name);
            wt = to_ohwi(w2, GROWTH, BOTTLENECK, 3, 3);
            if (!wt) return pl_error(PL_E_NOMEM, "out of memory");
            rc = add_layer(q, name, 4, (const uint32_t[]){GROWTH, 3, 3, BOTTLENECK}, wt, NULL,
                           plain, 1, BOTTLENECK, -q1[0].zero_point, q2, 0);
            free(wt);
            if (rc < 0) return rc;
            for (int c = 0; c < GROWTH; c++)
                seg[cin + c] = q2[c];
        }
        const int ctot = block_c0[b] + GROWTH * block_layers[b];
        if (b < N_BLOCKS - 1) {
            snprintf(pre, sizeof pre, "transition%d", b + 1);
#define T(suffix, n) (snprintf(name, sizeof name, "%s." suffix, pre), tensor_f32(q, name, n, &rc))
            const float *sc = T("norm.scale", (size_t)ctot), *sf = T("norm.shift", (size_t)ctot);
            const float *tw = T("conv.weight", (size_t)ctot / 2 * ctot);
#undef T
            if (rc < 0) return rc;
            snprintf(name, sizeof name, "%s.conv", pre);
            const pl_qparams *qt = act_q(q, name);
            if (q->keep_trans[b])
                rc = add_float_transition(q, pre, sc, sf, seg, ctot, tw, qt);
            else {
                snprintf(name, sizeof name, "%s.clamp", pre);
                if ((rc = add_preact(q, name, sc, sf, seg, ctot, fold)) < 0) return rc;
                snprintf(name, sizeof name, "%s.conv", pre);
                rc = add_layer(q, name, 4,
                               (const uint32_t[]){(uint32_t)ctot / 2, 1, 1, (uint32_t)ctot}, tw,
                               NULL, fold, 1, ctot, 0, qt, 0);
            }
            if (rc < 0) return rc;
            for (int c = 0; c < ctot / 2; c++)
                seg[c] = qt[c];
        } else {
            const float *sc = tensor_f32(q, "norm5.scale", FEATURES, &rc);
            const float *sf = tensor_f32(q, "norm5.shift", FEATURES, &rc);
            if (rc < 0) return rc;
            if ((rc = add_preact(q, "norm5.clamp", sc, sf, seg, FEATURES, fold)) < 0) return rc;
            float deq[2 * FEATURES];
            for (int c = 0; c < FEATURES; c++) {
                deq[c] = fold[c].active ? (float)fold[c].A : 0.0f;
                deq[FEATURES + c] = (float)(fold[c].active ? fold[c].B : fold[c].constant);
            }
            if ((rc = pl_plm_writer_add(q->w, "norm5.dequant", PL_DT_F32, 2,
                                        (const uint32_t[]){2, FEATURES}, deq, 0.0f, 0)) < 0)
                return rc;
        }
    }
    /* fc on z (element c*bands + k belongs to norm5 channel c) */
    const int zl = FEATURES * bands;
    if (q->keep_fc) { /* float on the exact z; weights stored int8 with a scale per row */
        const float *fw = tensor_f32(q, "fc.weight", (size_t)fc_n * zl, &rc);
        if (rc < 0 || (rc = add_rows_s8(q, "fc", fc_n, zl, fw)) < 0 ||
            (rc = copy_f32(q, "fc.bias")) < 0)
            return rc;
    } else {
        const float *fw = tensor_f32(q, "fc.weight", (size_t)fc_n * zl, &rc);
        const float *fb = tensor_f32(q, "fc.bias", (size_t)fc_n, &rc);
        if (rc < 0) return rc;
        if ((rc = add_layer(q, "fc", 2, (const uint32_t[]){(uint32_t)fc_n, (uint32_t)zl, 0, 0}, fw,
                            fb, fold, bands, FEATURES, 0, act_q(q, "fc"), 1)) < 0)
            return rc;
    }
    static const char *heads[] = {"head_dir.weight",      "head_dir.bias",     "head_size.weight",
                                  "head_size.bias",       "head_rgb.weight",   "head_rgb.bias",
                                  "head_ambient.weight",  "head_ambient.bias", "head_dist.fc1.bias",
                                  "head_dist.fc2.weight", "head_dist.fc2.bias"};
    for (size_t i = 0; i < sizeof heads / sizeof heads[0]; i++)
        if ((rc = copy_f32(q, heads[i])) < 0) return rc;
    /* the distance head's first layer (3072+3N inputs) is the one big head: stored as s8 with a
     * scale per row, dequantised to float at load (it still runs in float) */
    const pl_tensor *d1 = pl_plm_tensor(f, "head_dist.fc1.weight");
    if (!d1 || d1->dtype != PL_DT_F32 || d1->ndim != 2)
        return pl_error(PL_E_MODEL, "%s: float tensor 'head_dist.fc1.weight' missing", f->path);
    return add_rows_s8(q, "head_dist.fc1", (int)d1->dims[0], (int)d1->dims[1], d1->data);
}

static int parse_keep_float(const char *list, int *keep_fc, int *keep_trans)
{
    *keep_fc = 0;
    for (int b = 0; b < N_BLOCKS - 1; b++)
        keep_trans[b] = 0;
    if (!list || !*list) return PL_OK;
    const char *p = list;
    while (*p) {
        const char *e = strchr(p, ',');
        const size_t n = e ? (size_t)(e - p) : strlen(p);
        if (n == 2 && !strncmp(p, "fc", 2)) {
            *keep_fc = 1;
        } else if (n == 11 && !strncmp(p, "transition", 10) && p[10] >= '1' &&
                   p[10] < '1' + N_BLOCKS - 1) {
            keep_trans[p[10] - '1'] = 1;
        } else if (n > 5 && !strncmp(p, "head_", 5)) {
            /* the heads are always float */
        } else {
            return pl_error(PL_E_ARG,
                            "--keep-float '%.*s': this layer cannot stay float (only "
                            "'fc' and 'transition1' .. 'transition3' can; the heads are always "
                            "float; the dense layers share int8 block buffers)",
                            (int)n, p);
        }
        p += n;
        if (*p == ',') p++;
    }
    return PL_OK;
}

int pl_quantize_model(const pl_quantize_opts *o, pl_quantize_report *rep)
{
    memset(rep, 0, sizeof *rep);
    int keep_fc, keep_trans[N_BLOCKS - 1], rc;
    if (o->method == PL_CALIB_PERCENTILE && !(o->percentile > 50 && o->percentile <= 100))
        return pl_error(PL_E_ARG, "percentile %g: expected (50, 100]", o->percentile);
    if (o->headroom != 0 && !(o->headroom >= 1 && o->headroom <= 16))
        return pl_error(PL_E_ARG, "headroom %g: expected [1, 16]", o->headroom);
    const double headroom = o->headroom > 0 ? o->headroom : 1.0;
    if (o->block_floor_set && !(o->block_floor >= 0 && o->block_floor <= 1))
        return pl_error(PL_E_ARG, "block floor %g: expected [0, 1]", o->block_floor);
    if ((rc = parse_keep_float(o->keep_float, &keep_fc, keep_trans)) < 0) return rc;

    pl_model *m = NULL;
    pl_source *src = NULL;
    pl_plm file;
    memset(&file, 0, sizeof file);
    pl_plm_writer *w = NULL;
    struct acts *a = calloc(1, sizeof *a);
    if (!a) return pl_error(PL_E_NOMEM, "out of memory");
    if ((rc = pl_model_load(o->float_path, &m)) < 0) goto done;
    if (strcmp(pl_model_precision(m), "fp32")) {
        rc = pl_error(PL_E_MODEL, "%s: precision '%s': quantize needs a float (fp32) model",
                      o->float_path, pl_model_precision(m));
        goto done;
    }
    if ((rc = pl_plm_open(o->float_path, &file)) < 0) goto done;

    char name[64];
    add_act(a, "conv0", 1, 0, 0);
    for (int b = 0; b < N_BLOCKS; b++) {
        for (int l = 0; l < block_layers[b]; l++) {
            snprintf(name, sizeof name, "denseblock%d.denselayer%d.conv1", b + 1, l + 1);
            add_act(a, name, 1, -1, 0);
            snprintf(name, sizeof name, "denseblock%d.denselayer%d.conv2", b + 1, l + 1);
            add_act(a, name, 0, b, block_c0[b] + GROWTH * l);
        }
        if (b < N_BLOCKS - 1) {
            snprintf(name, sizeof name, "transition%d.conv", b + 1);
            add_act(a, name, 0, b + 1, 0);
        }
    }
    add_act(a, "fc", 1, -1, 0);
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
    static double blo[N_BLOCKS][FEATURES], bhi[N_BLOCKS][FEATURES];
    for (int b = 0; b < N_BLOCKS; b++)
        if ((rc = consumer_bounds(&file, b, blo[b], bhi[b])) < 0) goto done;
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
                a->block[i] >= 0) { /* a block buffer segment: clip to its consumers */
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
    struct qctx q = {.f = &file, .w = w, .a = a, .keep_fc = keep_fc};
    memcpy(q.keep_trans, keep_trans, sizeof keep_trans);
    for (int b = 0; b < N_BLOCKS - 1; b++)
        if (keep_trans[b])
            snprintf(q.kept + strlen(q.kept), sizeof q.kept - strlen(q.kept), "%stransition%d",
                     q.kept[0] ? "," : "", b + 1);
    if (keep_fc) snprintf(q.kept + strlen(q.kept), sizeof q.kept - strlen(q.kept), "%sfc",
                          q.kept[0] ? "," : "");
    if ((rc = build(&q, o, rep)) < 0) goto done;
    rc = pl_plm_writer_save(w, o->out_path);
done:
    pl_plm_writer_free(w);
    pl_source_close(src);
    pl_plm_close(&file);
    pl_model_free(m);
    for (int i = 0; a && i < a->n; i++) {
        free(a->hist[i]);
        free(a->q[i]);
    }
    free(a);
    return rc;
}
