/* The fp32 executor of the network's graph (model/graph.h; tools/model.py, docs/FORMAT.md),
 * private to model/ (model/net_f32.h): the public API (model/model.c) parses the metadata both
 * precisions share and hands a float file here.
 *
 * pl_f32net_load builds the graph, binds every node's tensors (names, dtypes, shapes; nothing
 * missing, nothing extra), then plans one arena from the graph's slots:
 *
 *   A  slot A: conv0 output, block 2, block 4      (ping)
 *   B  slot B: the input tensor, block 1, block 3  (pong)
 *   T1 pre-activated copy of a node's input channels (BN + ReLU), the largest
 *   T2 slot T (the bottlenecks) and pooled transition inputs
 *   small vectors: z, h, head outputs, the distance head's input and hidden layer
 *
 * A node reads channels [0, c) of its tensor and writes at its channel offset in place, so
 * concatenation never copies. A pooled convolution (a transition) runs BN+ReLU, then the 2x2
 * average pool, then the 1x1 convolution (pool and conv commute: 4x less work). After loading,
 * estimates allocate nothing.
 *
 * Kernels come from the dispatch table (kernels/dispatch.h, PARLIGHT_ISA). On a path with packed
 * fp32 kernels (kernels/kernels_f32.h) every convolution's weights are packed once at load into
 * one buffer, and each convolution runs as a packed GEMM: the dense layer's norm1 BN+ReLU is
 * applied while its 1x1 convolution builds its input tiles, so T1 serves only the transitions
 * and norm5. The dense layers' 3x3s run as Winograd F(4x4, 3x3) or F(2x2, 3x3) where the map has
 * enough tiles (pl_f32_wino_choose; PARLIGHT_WINOGRAD=0 keeps them direct), with U = G g G^T
 * packed at load in place of the GEMM panels. The GEMM's per-thread scratch (implicit im2col
 * tiles, 46 KiB a thread; Winograd's transformed tiles, 1.1 MB a thread at 192x256) is one more
 * buffer, sized at load for the largest convolution and grown by pl_f32net_set_threads. The
 * packed weights (~28 MB at 192x256, ~39 MB with Winograd) come on top of the mapped file;
 * pl_f32net_memory_bytes counts arena, scratch and packed weights. On the reference path
 * the kernels of kernels/ref/ run as they are. Outputs do not depend on the thread count on
 * either path (each output's summation order is fixed by the kernel and its K).
 *
 * The observer (model/observer.h, pl_f32net_set_observer) sees each layer's output, for
 * calibration and `parlight qcheck`. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/threads.h"
#include "core/util.h"
#include "kernels/dispatch.h"
#include "kernels/ref/nn_ref.h"
#include "model/binder.h"
#include "model/graph.h"
#include "model/heads.h"
#include "model/net_f32.h"
#include "model/observer.h"
#include "model/plm.h"
#include "model/profile.h"
#include "model/resize.h"

/* What the executor keeps of a node (model/graph.h): its tensors in the file and, for a
 * convolution, how it runs. */
struct node {
    const float *scale, *shift; /* the pre-activation BN, or NULL */
    const float *w, *b;         /* weights and bias, or NULL */
    pl_f32_conv conv;           /* CONV: packed paths: with norm1's BN+ReLU unless pooled first */
};

struct pl_f32net {
    const pl_plm *file; /* owned by the caller (model/model.c) */
    pl_graph g;
    int64_t n_params;

    struct node nodes[PL_GRAPH_MAX_NODES];
    pl_heads heads; /* model/heads.h: weights in the file, outputs in the arena */

    const pl_kernels *kern;
    float *wpack; /* packed paths: every convolution's packed weights */
    size_t wpack_floats;
    float *scratch; /* packed paths: scratch_floats per pool thread */
    size_t scratch_floats;
    int scratch_threads;

    float *arena;
    size_t arena_floats;
    float *tensor[PL_GRAPH_MAX_TENSORS]; /* each graph tensor's buffer */
    float *t1, *t2; /* T1: a pre-activated copy (reference path, pooled inputs); T2 = slot T */
    pl_pool *pool;  /* the caller's, for the estimate running */
    pl_layer_observer observer;
    void *observer_ctx;
    pl_profile *prof; /* pl_f32net_set_profile, or NULL */
};

/* ---- loading ----------------------------------------------------------------------------- */

static const float *bind_vec(pl_binder *bd, const char *prefix, const char *suffix, int n)
{
    char name[PL_PLM_NAME_MAX];
    snprintf(name, sizeof name, "%s.%s", prefix, suffix);
    return pl_bind_f32(bd, name, 1, n, 0, 0, 0);
}

static int bind_tensors(pl_f32net *m)
{
    pl_binder bd = {.file = m->file, .missing_note = ""};
    const pl_graph *g = &m->g;
    char name[PL_PLM_NAME_MAX];
    for (int i = 0; i < g->n_nodes; i++) {
        const pl_gnode *n = &g->nodes[i];
        struct node *N = &m->nodes[i];
        if (n->norm[0]) {
            N->scale = bind_vec(&bd, n->norm, "scale", n->in_c);
            N->shift = bind_vec(&bd, n->norm, "shift", n->in_c);
        }
        snprintf(name, sizeof name, "%s.weight", n->name);
        if (n->op == PL_NODE_CONV)
            N->w = pl_bind_f32(&bd, name, 4, n->out_c, n->in_c, n->k, n->k);
        else if (n->op == PL_NODE_FC)
            N->w = pl_bind_f32(&bd, name, 2, n->out_c, n->in_c, 0, 0);
        if (n->bias) N->b = bind_vec(&bd, n->name, "bias", n->out_c);
        if (n->op == PL_NODE_HEADS) {
            const pl_net_shape *sh = &g->shape;
            const int H = sh->dist_hidden, zl = n->in_c;
            m->heads = (pl_heads){
                .n_lights = sh->n_lights, .fc_n = sh->fc_n, .dist_hidden = H, .z_len = zl};
            pl_heads_bind(&bd, &m->heads);
            m->heads.d1_w =
                pl_bind_f32(&bd, "head_dist.fc1.weight", 2, H, zl + 3 * sh->n_lights, 0, 0);
            pl_heads_bind_dist(&bd, &m->heads);
        }
    }
    m->n_params += bd.params;
    return pl_bind_finish(&bd, PL_ARCH_NAME);
}

static size_t max_sz(size_t a, size_t b)
{
    return a > b ? a : b;
}

static size_t up16(size_t n)
{
    return (n + 15) & ~(size_t)15;
}

/* The arena (see the top of this file), from the graph's slots. Sizes in floats. */
static int plan_arena(pl_f32net *m)
{
    const pl_graph *g = &m->g;
    size_t t1 = 0, t2 = pl_graph_slot_size(g, PL_SLOT_T);
    for (int i = 0; i < g->n_nodes; i++) {
        const pl_gnode *n = &g->nodes[i];
        const size_t in = (size_t)n->in_c * (size_t)n->in_h * (size_t)n->in_w;
        if (n->norm[0]) t1 = max_sz(t1, in);
        if (n->pool2) t2 = max_sz(t2, in / 4);
    }
    const size_t zl = pl_graph_tensor_size(g, g->z), hl = pl_graph_tensor_size(g, g->h);
    const size_t a = pl_graph_slot_size(g, PL_SLOT_A), b = pl_graph_slot_size(g, PL_SLOT_B);
    const size_t total =
        up16(a) + up16(b) + up16(t1) + up16(t2) + up16(zl + hl + pl_heads_floats(&m->heads));
    size_t bytes;
    if (!pl_mul_size(total, sizeof(float), &bytes))
        return pl_error(PL_E_NOMEM, "arena size overflows");
    m->arena = aligned_alloc(64, (bytes + 63) & ~(size_t)63);
    if (!m->arena) return pl_error(PL_E_NOMEM, "cannot allocate the %zu-byte arena", bytes);
    m->arena_floats = total;
    float *slot[PL_SLOT_VEC] = {m->arena, m->arena + up16(a), NULL};
    m->t1 = slot[PL_SLOT_B] + up16(b);
    m->t2 = slot[PL_SLOT_T] = m->t1 + up16(t1);
    float *p = m->t2 + up16(t2);
    m->tensor[g->z] = p;
    m->tensor[g->h] = p + zl;
    pl_heads_place(&m->heads, p + zl + hl);
    for (int t = 0; t < g->n_tensors; t++)
        if (g->tensors[t].slot != PL_SLOT_VEC) m->tensor[t] = slot[g->tensors[t].slot];
    return PL_OK;
}

/* Per-thread GEMM scratch for `threads` threads (packed paths). */
static int make_scratch(pl_f32net *m, int threads)
{
    if (!m->kern->f32.packed || threads <= m->scratch_threads) return PL_OK;
    size_t bytes;
    if (!pl_mul_size(m->scratch_floats * sizeof(float), (size_t)threads, &bytes))
        return pl_error(PL_E_NOMEM, "GEMM scratch size overflows");
    float *p = aligned_alloc(64, bytes);
    if (!p)
        return pl_error(PL_E_NOMEM, "cannot allocate %zu bytes of GEMM scratch for %d threads",
                        bytes, threads);
    free(m->scratch);
    m->scratch = p;
    m->scratch_threads = threads;
    return PL_OK;
}

/* Floats of a packed convolution's weights: GEMM panels, or Winograd's T*T sets of them. */
static size_t packed_floats(const pl_f32_conv *c)
{
    return c->wino ? pl_f32_wino_weights_floats(&c->p, c->wino)
                   : pl_f32_packed_weights_floats(&c->p);
}

/* Describes every convolution (shapes at this model's input size) and, on packed paths, packs
 * their weights and sizes the scratch. A pooled convolution's BN + ReLU runs before its pool
 * (transition_pool), the others' inside the convolution. */
static int prepare_convs(pl_f32net *m)
{
    const pl_graph *g = &m->g;
    pl_f32_conv *all[PL_GRAPH_MAX_NODES];
    int n = 0;
    size_t plane = 0; /* a pooled convolution's one channel plane (transition_pool) */
    for (int i = 0; i < g->n_nodes; i++) {
        const pl_gnode *d = &g->nodes[i];
        struct node *N = &m->nodes[i];
        if (d->op != PL_NODE_CONV) continue;
        const int ih = d->pool2 ? d->out_h : d->in_h, iw = d->pool2 ? d->out_w : d->in_w;
        const nn_conv_params p = {d->in_c, ih,   iw,        d->out_c, d->out_h, d->out_w,
                                  d->k,    d->k, d->stride, d->pad,   d->relu};
        const int pre = !d->pool2 && N->scale;
        N->conv = (pl_f32_conv){p, N->w, N->b, pre ? N->scale : NULL, pre ? N->shift : NULL, 0};
        all[n++] = &N->conv;
        if (d->pool2) plane = max_sz(plane, up16((size_t)d->in_h * (size_t)d->in_w));
    }
    if (!m->kern->f32.packed) return PL_OK;

    size_t total = 0;
    for (int i = 0; i < n; i++) {
        /* the 3x3s: Winograd where pl_f32_wino_choose says so (PARLIGHT_WINOGRAD) */
        if (m->kern->f32.wino && pl_f32_wino_fits(all[i])) {
            all[i]->wino = pl_f32_wino_choose(&all[i]->p);
            if (all[i]->wino < 0)
                return pl_error(PL_E_ARG, "PARLIGHT_WINOGRAD=%s: expected 0, 2, 4 or auto",
                                getenv("PARLIGHT_WINOGRAD"));
        }
        total += up16(packed_floats(all[i]));
        const size_t sf = all[i]->wino ? pl_f32_wino_scratch_floats(&all[i]->p, all[i]->wino)
                                       : pl_f32_conv_scratch_floats(&all[i]->p);
        if (sf > m->scratch_floats) m->scratch_floats = sf;
    }
    if (plane > m->scratch_floats) m->scratch_floats = plane;
    size_t bytes;
    if (!pl_mul_size(total, sizeof(float), &bytes))
        return pl_error(PL_E_NOMEM, "packed weights size overflows");
    m->wpack = aligned_alloc(64, bytes);
    if (!m->wpack)
        return pl_error(PL_E_NOMEM, "cannot allocate %zu bytes for the packed weights", bytes);
    m->wpack_floats = total;
    float *dst = m->wpack;
    for (int i = 0; i < n; i++) {
        if (all[i]->wino)
            pl_f32_wino_pack_weights(&all[i]->p, all[i]->wino, all[i]->w, dst);
        else
            pl_f32_pack_weights(&all[i]->p, all[i]->w, dst);
        all[i]->w = dst;
        dst += up16(packed_floats(all[i]));
    }
    return make_scratch(m, 1);
}

/* ---- execution ----------------------------------------------------------------------------- */

enum op { OP_CONV, OP_BN_RELU, OP_MAXPOOL, OP_AVGPOOL, OP_FC };

/* One kernel call, split over output channels by the pool. */
struct job {
    enum op op;
    const pl_kernels_f32 *k;
    const void *params;
    const float *in, *w, *b, *shift;
    float *out;
    int hw, n_in, relu;
};

static void run_job(void *ctx, int begin, int end)
{
    const struct job *j = ctx;
    const pl_kernels_f32 *k = j->k;
    switch (j->op) {
    case OP_CONV:
        nn_conv2d_f32__ref(j->params, j->in, j->w, j->b, j->out, begin, end);
        break;
    case OP_BN_RELU:
        k->bn_relu(j->in, j->w, j->shift, j->hw, j->out, begin, end);
        break;
    case OP_MAXPOOL:
        k->maxpool(j->params, j->in, j->out, begin, end);
        break;
    case OP_AVGPOOL:
        k->avgpool(j->params, j->in, j->out, begin, end);
        break;
    case OP_FC:
        k->fc(j->in, j->n_in, j->w, j->b, j->relu, j->out, begin, end);
        break;
    }
}

/* A packed convolution split over the pool: one item per thread (its scratch), each taking a
 * contiguous share of (tile, panel group) units (Winograd: blocks of NR tiles for tiles). Panels
 * are split only when there are too few tiles to share evenly (block 4 has one; Winograd F(4x4)
 * on block 2 one block), since each group rebuilds the tile's B block. */
struct gemm_job {
    const pl_kernels_f32 *k;
    const pl_f32_conv *c;
    const float *in;
    float *out, *scratch;
    size_t scratch_floats;
    int tiles, panels, groups, items;
};

static void run_gemm(void *ctx, int begin, int end)
{
    const struct gemm_job *j = ctx;
    const pl_f32_conv_fn fn = j->c->wino ? j->k->wino : j->k->conv;
    const long units = (long)j->tiles * j->groups;
    for (int i = begin; i < end; i++) {
        float *scratch = j->scratch + (size_t)i * j->scratch_floats;
        const int u0 = (int)(units * i / j->items), u1 = (int)(units * (i + 1) / j->items);
        if (j->groups == 1) {
            if (u0 < u1) fn(j->c, j->in, j->out, scratch, u0, u1, 0, j->panels);
            continue;
        }
        for (int u = u0; u < u1; u++) {
            const int t = u / j->groups, g = u % j->groups;
            fn(j->c, j->in, j->out, scratch, t, t + 1, j->panels * g / j->groups,
               j->panels * (g + 1) / j->groups);
        }
    }
}

/* A transition's BN + ReLU and 2x2 average pool, channel by channel through one plane of the
 * thread's scratch (still in L1 when the pool reads it): the same kernels on the same values as
 * the two passes over the whole block, without writing and reading the block once more. One
 * item per thread, each a contiguous share of the channels. */
struct trans_job {
    const pl_kernels_f32 *k;
    const float *in, *scale, *shift;
    float *out, *scratch;
    size_t scratch_floats;
    int c, h, w, items;
};

static void run_trans(void *ctx, int begin, int end)
{
    const struct trans_job *j = ctx;
    const nn_pool_params ap = {1, j->h, j->w, j->h / 2, j->w / 2, 2, 2, 0};
    const size_t hw = (size_t)j->h * (size_t)j->w, ohw = (size_t)(j->h / 2) * (size_t)(j->w / 2);
    for (int i = begin; i < end; i++) {
        float *plane = j->scratch + (size_t)i * j->scratch_floats;
        const int c0 = (int)((long)j->c * i / j->items),
                  c1 = (int)((long)j->c * (i + 1) / j->items);
        for (int c = c0; c < c1; c++) {
            j->k->bn_relu(j->in + (size_t)c * hw, j->scale + c, j->shift + c, (int)hw, plane, 0, 1);
            j->k->avgpool(&ap, plane, j->out + (size_t)c * ohw, 0, 1);
        }
    }
}

static void bn_relu(pl_f32net *m, const float *in, const float *scale, const float *shift, int c,
                    int hw, float *out)
{
    struct job j = {.op = OP_BN_RELU,
                    .k = &m->kern->f32,
                    .in = in,
                    .w = scale,
                    .shift = shift,
                    .hw = hw,
                    .out = out};
    pl_pool_for(m->pool, c, run_job, &j);
}

/* One convolution (prepare_convs): packed GEMM, or on the reference path the optional
 * pre-activation into T1 and then nn_conv2d_f32__ref. */
static void conv(pl_f32net *m, const pl_f32_conv *c, const float *in, float *out)
{
    const nn_conv_params *p = &c->p;
    if (m->kern->f32.packed) {
        const int threads = pl_pool_threads(m->pool);
        const int tiles = c->wino ? pl_f32_wino_blocks(p, c->wino) : pl_f32_conv_tiles(p);
        const int panels = pl_f32_conv_panels(p);
        int groups = 1;
        if (threads > 1 && tiles % threads && tiles < 4 * threads)
            groups = threads < panels ? threads : panels;
        struct gemm_job g = {&m->kern->f32,     c,     in,     out,    m->scratch,
                             m->scratch_floats, tiles, panels, groups, threads};
        pl_pool_for(m->pool, threads, run_gemm, &g);
        return;
    }
    if (c->in_scale) {
        bn_relu(m, in, c->in_scale, c->in_shift, p->in_c, p->in_h * p->in_w, m->t1);
        in = m->t1;
    }
    struct job j = {.op = OP_CONV, .params = p, .in = in, .w = c->w, .b = c->bias, .out = out};
    pl_pool_for(m->pool, p->out_c, run_job, &j);
}

static void fc(pl_f32net *m, const float *in, int n_in, const float *w, const float *b, int n_out,
               int relu, float *out)
{
    struct job j = {.op = OP_FC,
                    .k = &m->kern->f32,
                    .in = in,
                    .n_in = n_in,
                    .w = w,
                    .b = b,
                    .relu = relu,
                    .out = out};
    pl_pool_for(m->pool, n_out, run_job, &j);
}

/* fc for the heads (model/heads.h) */
static void heads_fc(void *ctx, const float *in, int n_in, const float *w, const float *b,
                     int n_out, int relu, float *out)
{
    fc(ctx, in, n_in, w, b, n_out, relu, out);
}

/* A pooled convolution's input (a transition's): BN + ReLU, then the 2x2 average pool into T2. */
static void pool_input(pl_f32net *m, const pl_gnode *n, const struct node *N, const float *in)
{
    if (m->kern->f32.packed) {
        const int threads = pl_pool_threads(m->pool);
        struct trans_job tj = {&m->kern->f32,     in,      N->scale, N->shift, m->t2,  m->scratch,
                               m->scratch_floats, n->in_c, n->in_h,  n->in_w,  threads};
        pl_pool_for(m->pool, threads, run_trans, &tj);
        return;
    }
    bn_relu(m, in, N->scale, N->shift, n->in_c, n->in_h * n->in_w, m->t1);
    nn_pool_params ap = {n->in_c, n->in_h, n->in_w, n->out_h, n->out_w, 2, 2, 0};
    struct job j = {.op = OP_AVGPOOL, .k = &m->kern->f32, .params = &ap, .in = m->t1, .out = m->t2};
    pl_pool_for(m->pool, n->in_c, run_job, &j);
}

/* Runs the graph's nodes in order (model/graph.h); a tensor is CHW, a node's output starts at
 * channel out_c0 of its tensor. */
static void forward(pl_f32net *m, int64_t clk)
{
    const pl_graph *g = &m->g;
    for (int i = 0; i < g->n_nodes; i++) {
        const pl_gnode *n = &g->nodes[i];
        const struct node *N = &m->nodes[i];
        const float *in = m->tensor[n->in];
        float *out =
            n->out >= 0 ? m->tensor[n->out] + (size_t)n->out_c0 * n->out_h * n->out_w : NULL;
        switch (n->op) {
        case PL_NODE_CONV:
            if (n->pool2) {
                pool_input(m, n, N, in);
                in = m->t2;
            }
            conv(m, &N->conv, in, out);
            break;
        case PL_NODE_MAXPOOL: {
            nn_pool_params p = {n->in_c,  n->in_h, n->in_w,   n->out_h,
                                n->out_w, n->k,    n->stride, n->pad};
            struct job j = {
                .op = OP_MAXPOOL, .k = &m->kern->f32, .params = &p, .in = in, .out = out};
            pl_pool_for(m->pool, n->in_c, run_job, &j);
            break;
        }
        case PL_NODE_BANDS:
            bn_relu(m, in, N->scale, N->shift, n->in_c, n->in_h * n->in_w, m->t1);
            nn_band_pool_f32__ref(m->t1, n->in_c, n->in_h, n->in_w, g->shape.bands, out);
            break;
        case PL_NODE_FC:
            fc(m, in, n->in_c, N->w, N->b, n->out_c, n->relu, out);
            break;
        case PL_NODE_HEADS:
            pl_heads_run(&m->heads, in, m->tensor[n->in2], heads_fc, m);
            break;
        }
        pl_prof_mark(m->prof, n->stage, &clk);
        if (m->observer && out && n->op != PL_NODE_MAXPOOL)
            m->observer(m->observer_ctx, n->name, out, n->out_c, n->out_h, n->out_w, NULL);
    }
}

void pl_f32net_estimate(pl_f32net *m, pl_pool *pool, const uint8_t *rgb, size_t stride, int x0,
                        int y0, int cw, int ch, pl_lighting *out, int64_t *t_pre)
{
    m->pool = pool;
    int64_t pt = pl_prof_now(m->prof);
    const pl_net_shape *sh = &m->g.shape;
    float *x_in = m->tensor[m->g.input];
    pl_resize_job rj = {rgb, stride, x0, y0, cw, ch, x_in, sh->in_w, sh->in_h};
    pl_pool_for(m->pool, sh->in_h, pl_resize_job_rows, &rj);
    const size_t plane = (size_t)sh->in_h * sh->in_w;
    for (int c = 0; c < 3; c++) {
        const float a = 1.0f / (255.0f * sh->std[c]), b = -sh->mean[c] / sh->std[c];
        float *x = x_in + c * plane;
        for (size_t i = 0; i < plane; i++)
            x[i] = x[i] * a + b;
    }
    *t_pre = pl_now_ns();
    pl_prof_mark(m->prof, PL_PROF_PRE, &pt);
    forward(m, pt);

    pl_heads_lighting(&m->heads, out);
}

/* ---- the executor's interface (model/net_f32.h) ------------------------------------------- */

int pl_f32net_load(const pl_plm *file, const pl_net_shape *shape, pl_f32net **out)
{
    *out = NULL;
    pl_f32net *m = calloc(1, sizeof *m);
    if (!m) return pl_error(PL_E_NOMEM, "out of memory");
    m->file = file;
    int rc;
    if ((rc = pl_graph_build(shape, &m->g)) < 0 || (rc = bind_tensors(m)) < 0 ||
        (rc = plan_arena(m)) < 0) {
        pl_f32net_free(m);
        return rc;
    }
    if ((rc = pl_kernels_get(&m->kern)) < 0 || (rc = prepare_convs(m)) < 0) {
        pl_error_prefix(rc, "%s", file->path);
        pl_f32net_free(m);
        return rc;
    }
    *out = m;
    return PL_OK;
}

void pl_f32net_free(pl_f32net *m)
{
    if (!m) return;
    free(m->wpack);
    free(m->scratch);
    free(m->arena);
    free(m);
}

int64_t pl_f32net_params(const pl_f32net *m)
{
    return m->n_params;
}

size_t pl_f32net_memory_bytes(const pl_f32net *m)
{
    return (m->arena_floats + m->scratch_floats * (size_t)m->scratch_threads + m->wpack_floats) *
           sizeof(float);
}

int pl_f32net_set_threads(pl_f32net *m, int n)
{
    return make_scratch(m, n);
}

void pl_f32net_set_observer(pl_f32net *m, pl_layer_observer fn, void *ctx)
{
    m->observer = fn;
    m->observer_ctx = ctx;
}

void pl_f32net_set_profile(pl_f32net *m, pl_profile *p)
{
    m->prof = p;
}

const pl_graph *pl_f32net_graph(const pl_f32net *m)
{
    return &m->g;
}

void pl_f32net_latent(const pl_f32net *m, const float **z, int *n)
{
    *z = m->tensor[m->g.z];
    *n = m->g.tensors[m->g.z].c;
}
