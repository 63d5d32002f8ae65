/* The fp32 executor of densenet121-parametric (tools/model.py, docs/FORMAT.md), private to
 * model/ (model/net_f32.h): the public API (model/model.c) parses the metadata both precisions
 * share and hands a float file here.
 *
 * pl_f32net_load validates the file against the architecture (every tensor's name, dtype and
 * shape; nothing missing, nothing extra), then plans one arena:
 *
 *   A  conv0 output, block 2, block 4      (ping)
 *   B  the input tensor, block 1, block 3  (pong)
 *   T1 pre-activated copy of a block's channels (BN + ReLU), the largest block
 *   T2 bottleneck (128 channels at block-1 size) and pooled transition inputs
 *   small vectors: z, h, head outputs, the distance head's input and hidden layer
 *
 * A dense layer reads channels [0, c) of its block buffer and writes its 32 new channels at
 * offset c in place, so concatenation never copies. Transitions run BN+ReLU, then the 2x2 average
 * pool, then the 1x1 convolution (pool and conv commute: 4x less work), writing into the next
 * block's buffer at channel 0. After loading, estimates allocate nothing.
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
#include "model/arch.h"
#include "model/binder.h"
#include "model/heads.h"
#include "model/net_f32.h"
#include "model/observer.h"
#include "model/plm.h"
#include "model/profile.h"
#include "model/resize.h"

struct dense_layer {
    int cin;
    const float *n1_scale, *n1_shift, *c1_w, *c1_b, *c2_w;
    pl_f32_conv c1, c2; /* packed paths: norm1 + conv1, conv2 */
};

struct transition {
    int cin;
    const float *scale, *shift, *w;
    pl_f32_conv conv; /* packed paths */
};

struct pl_f32net {
    const pl_plm *file; /* owned by the caller (model/model.c) */
    int n_lights, in_h, in_w, bands, fc_n, dist_hidden;
    float mean[3], std[3];
    int64_t n_params;

    const float *conv0_w, *conv0_b;
    struct dense_layer layers[MAX_LAYERS];
    struct transition trans[N_BLOCKS - 1];
    const float *n5_scale, *n5_shift, *fc_w, *fc_b;
    pl_heads heads; /* model/heads.h: weights in the file, outputs in the arena */

    const pl_kernels *kern;
    pl_f32_conv conv0;  /* packed paths */
    float *wpack;       /* packed paths: every convolution's packed weights */
    size_t wpack_floats;
    float *scratch;     /* packed paths: scratch_floats per pool thread */
    size_t scratch_floats;
    int scratch_threads;

    float *arena;
    size_t arena_floats;
    float *x_in, *buf_a, *buf_b, *t1, *t2, *z, *h;
    int z_len;
    pl_pool *pool; /* the caller's, for the estimate running */
    pl_layer_observer observer;
    void *observer_ctx;
    pl_profile *prof; /* pl_f32net_set_profile, or NULL */
};

/* ---- loading ----------------------------------------------------------------------------- */

static int bind_tensors(pl_f32net *m)
{
    pl_binder bd = {.file = m->file, .missing_note = ""};
    const int N = m->n_lights;
    char name[PL_PLM_NAME_MAX];
    m->conv0_w = pl_bind_f32(&bd, "conv0.weight", 4, 64, 3, 7, 7);
    m->conv0_b = pl_bind_f32(&bd, "conv0.bias", 1, 64, 0, 0, 0);
    int li = 0;
    for (int b = 0; b < N_BLOCKS; b++) {
        for (int l = 0; l < block_layers[b]; l++, li++) {
            struct dense_layer *L = &m->layers[li];
            L->cin = block_c0[b] + GROWTH * l;
#define NAME(fmt) (snprintf(name, sizeof name, "denseblock%d.denselayer%d." fmt, b + 1, l + 1), name)
            L->n1_scale = pl_bind_f32(&bd, NAME("norm1.scale"), 1, L->cin, 0, 0, 0);
            L->n1_shift = pl_bind_f32(&bd, NAME("norm1.shift"), 1, L->cin, 0, 0, 0);
            L->c1_w = pl_bind_f32(&bd, NAME("conv1.weight"), 4, BOTTLENECK, L->cin, 1, 1);
            L->c1_b = pl_bind_f32(&bd, NAME("conv1.bias"), 1, BOTTLENECK, 0, 0, 0);
            L->c2_w = pl_bind_f32(&bd, NAME("conv2.weight"), 4, GROWTH, BOTTLENECK, 3, 3);
#undef NAME
        }
        if (b < N_BLOCKS - 1) {
            struct transition *T = &m->trans[b];
            T->cin = block_c0[b] + GROWTH * block_layers[b];
            snprintf(name, sizeof name, "transition%d.norm.scale", b + 1);
            T->scale = pl_bind_f32(&bd, name, 1, T->cin, 0, 0, 0);
            snprintf(name, sizeof name, "transition%d.norm.shift", b + 1);
            T->shift = pl_bind_f32(&bd, name, 1, T->cin, 0, 0, 0);
            snprintf(name, sizeof name, "transition%d.conv.weight", b + 1);
            T->w = pl_bind_f32(&bd, name, 4, T->cin / 2, T->cin, 1, 1);
        }
    }
    const int feat = 1024, zl = feat * m->bands, H = m->dist_hidden;
    m->n5_scale = pl_bind_f32(&bd, "norm5.scale", 1, feat, 0, 0, 0);
    m->n5_shift = pl_bind_f32(&bd, "norm5.shift", 1, feat, 0, 0, 0);
    m->fc_w = pl_bind_f32(&bd, "fc.weight", 2, m->fc_n, zl, 0, 0);
    m->fc_b = pl_bind_f32(&bd, "fc.bias", 1, m->fc_n, 0, 0, 0);
    m->heads = (pl_heads){.n_lights = N, .fc_n = m->fc_n, .dist_hidden = H, .z_len = zl};
    pl_heads_bind(&bd, &m->heads);
    m->heads.d1_w = pl_bind_f32(&bd, "head_dist.fc1.weight", 2, H, zl + 3 * N, 0, 0);
    pl_heads_bind_dist(&bd, &m->heads);
    m->n_params += bd.params;
    if (bd.rc < 0) return bd.rc;
    if ((uint32_t)bd.used != m->file->n_tensors) {
        for (uint32_t i = 0; i < m->file->n_tensors; i++) {
            const char *n = m->file->tensors[i].name;
            /* find the first tensor the architecture does not name */
            int known = !strcmp(n, "conv0.weight") || !strcmp(n, "conv0.bias") ||
                        !strncmp(n, "denseblock", 10) || !strncmp(n, "transition", 10) ||
                        !strncmp(n, "norm5.", 6) || !strncmp(n, "fc.", 3) ||
                        !strncmp(n, "head_", 5);
            if (!known)
                return pl_error(PL_E_MODEL, "%s: unexpected tensor '%s' for %s", m->file->path, n,
                                PL_ARCH_NAME);
        }
        return pl_error(PL_E_MODEL, "%s: %u tensors, the architecture uses %d", m->file->path,
                        m->file->n_tensors, bd.used);
    }
    return PL_OK;
}

static size_t max_sz(size_t a, size_t b)
{
    return a > b ? a : b;
}

/* The arena plan (see the top of this file). Sizes in floats. */
static int plan_arena(pl_f32net *m)
{
    const size_t H = (size_t)m->in_h, W = (size_t)m->in_w;
    const size_t hw1 = (H / 4) * (W / 4), hw2 = hw1 / 4, hw3 = hw2 / 4, hw4 = hw3 / 4;
    const size_t stem = 64 * (H / 2) * (W / 2);
    const size_t a = max_sz(stem, max_sz(512 * hw2, 1024 * hw4));
    const size_t b = max_sz(3 * H * W, max_sz(256 * hw1, 1024 * hw3));
    const size_t t1 = max_sz(256 * hw1, max_sz(512 * hw2, 1024 * hw3));
    const size_t t2 = max_sz(BOTTLENECK * hw1, 256 * hw1 / 4);
    m->z_len = 1024 * m->bands;
    const size_t small = (size_t)m->z_len + (size_t)m->fc_n + pl_heads_floats(&m->heads);
    /* each region rounded up to 16 floats (64 bytes) */
    const size_t regions[] = {a, b, t1, t2, small};
    size_t total = 0;
    for (size_t i = 0; i < sizeof regions / sizeof regions[0]; i++)
        total += (regions[i] + 15) & ~(size_t)15;
    size_t bytes;
    if (!pl_mul_size(total, sizeof(float), &bytes))
        return pl_error(PL_E_NOMEM, "arena size overflows");
    m->arena = aligned_alloc(64, (bytes + 63) & ~(size_t)63);
    if (!m->arena) return pl_error(PL_E_NOMEM, "cannot allocate the %zu-byte arena", bytes);
    m->arena_floats = total;
    float *p = m->arena;
#define TAKE(dst, n) (dst = p, p += ((n) + 15) & ~(size_t)15)
    TAKE(m->buf_a, a);
    TAKE(m->buf_b, b);
    TAKE(m->t1, t1);
    TAKE(m->t2, t2);
#undef TAKE
    m->x_in = m->buf_b; /* the input is dead once conv0 has run; block 1 then takes B */
    m->z = p;
    p += m->z_len;
    m->h = p;
    p += m->fc_n;
    pl_heads_place(&m->heads, p);
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
 * their weights and sizes the scratch. */
static int prepare_convs(pl_f32net *m)
{
    int h = m->in_h / 2, w = m->in_w / 2;
    const nn_conv_params c0 = {3, m->in_h, m->in_w, 64, h, w, 7, 7, 2, 3, 1};
    m->conv0 = (pl_f32_conv){c0, m->conv0_w, m->conv0_b, NULL, NULL, 0};
    h /= 2;
    w /= 2;
    int li = 0;
    for (int b = 0; b < N_BLOCKS; b++) {
        for (int l = 0; l < block_layers[b]; l++, li++) {
            struct dense_layer *L = &m->layers[li];
            const nn_conv_params p1 = {L->cin, h, w, BOTTLENECK, h, w, 1, 1, 1, 0, 1};
            const nn_conv_params p2 = {BOTTLENECK, h, w, GROWTH, h, w, 3, 3, 1, 1, 0};
            L->c1 = (pl_f32_conv){p1, L->c1_w, L->c1_b, L->n1_scale, L->n1_shift, 0};
            L->c2 = (pl_f32_conv){p2, L->c2_w, NULL, NULL, NULL, 0};
        }
        if (b < N_BLOCKS - 1) {
            struct transition *T = &m->trans[b];
            h /= 2;
            w /= 2;
            const nn_conv_params pt = {T->cin, h, w, T->cin / 2, h, w, 1, 1, 1, 0, 0};
            T->conv = (pl_f32_conv){pt, T->w, NULL, NULL, NULL, 0};
        }
    }
    if (!m->kern->f32.packed) return PL_OK;

    pl_f32_conv *all[1 + MAX_LAYERS * 2 + N_BLOCKS];
    int n = 0;
    all[n++] = &m->conv0;
    for (int i = 0; i < li; i++) {
        all[n++] = &m->layers[i].c1;
        all[n++] = &m->layers[i].c2;
    }
    for (int b = 0; b < N_BLOCKS - 1; b++) all[n++] = &m->trans[b].conv;
    size_t total = 0;
    for (int i = 0; i < n; i++) {
        /* the 3x3s: Winograd where pl_f32_wino_choose says so (PARLIGHT_WINOGRAD) */
        if (m->kern->f32.wino && pl_f32_wino_fits(all[i])) {
            all[i]->wino = pl_f32_wino_choose(&all[i]->p);
            if (all[i]->wino < 0)
                return pl_error(PL_E_ARG, "PARLIGHT_WINOGRAD=%s: expected 0, 2, 4 or auto",
                                getenv("PARLIGHT_WINOGRAD"));
        }
        total += (packed_floats(all[i]) + 15) & ~(size_t)15;
        const size_t sf = all[i]->wino ? pl_f32_wino_scratch_floats(&all[i]->p, all[i]->wino)
                                       : pl_f32_conv_scratch_floats(&all[i]->p);
        if (sf > m->scratch_floats) m->scratch_floats = sf;
    }
    /* a transition's BN + ReLU of one channel plane of block 1 (transition_pool) */
    const size_t plane1 = (((size_t)(m->in_h / 4) * (size_t)(m->in_w / 4)) + 15) & ~(size_t)15;
    if (plane1 > m->scratch_floats) m->scratch_floats = plane1;
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
        dst += (packed_floats(all[i]) + 15) & ~(size_t)15;
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
    case OP_CONV: nn_conv2d_f32__ref(j->params, j->in, j->w, j->b, j->out, begin, end); break;
    case OP_BN_RELU: k->bn_relu(j->in, j->w, j->shift, j->hw, j->out, begin, end); break;
    case OP_MAXPOOL: k->maxpool(j->params, j->in, j->out, begin, end); break;
    case OP_AVGPOOL: k->avgpool(j->params, j->in, j->out, begin, end); break;
    case OP_FC: k->fc(j->in, j->n_in, j->w, j->b, j->relu, j->out, begin, end); break;
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
        const int c0 = (int)((long)j->c * i / j->items), c1 = (int)((long)j->c * (i + 1) / j->items);
        for (int c = c0; c < c1; c++) {
            j->k->bn_relu(j->in + (size_t)c * hw, j->scale + c, j->shift + c, (int)hw, plane, 0, 1);
            j->k->avgpool(&ap, plane, j->out + (size_t)c * ohw, 0, 1);
        }
    }
}

static void bn_relu(pl_f32net *m, const float *in, const float *scale, const float *shift, int c,
                    int hw, float *out)
{
    struct job j = {.op = OP_BN_RELU, .k = &m->kern->f32, .in = in, .w = scale, .shift = shift,
                    .hw = hw, .out = out};
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
        struct gemm_job g = {&m->kern->f32, c,      in,     out,     m->scratch,
                             m->scratch_floats,     tiles,  panels,  groups,
                             threads};
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
    struct job j = {.op = OP_FC, .k = &m->kern->f32, .in = in, .n_in = n_in, .w = w, .b = b, .relu = relu, .out = out};
    pl_pool_for(m->pool, n_out, run_job, &j);
}

/* Reports a layer's output to the observer (model/observer.h), if one is set. */
static void observe(const pl_f32net *m, const char *layer, const float *chw, int c, int h, int w)
{
    if (m->observer) m->observer(m->observer_ctx, layer, chw, c, h, w, NULL);
}

/* fc for the heads (model/heads.h) */
static void heads_fc(void *ctx, const float *in, int n_in, const float *w, const float *b,
                     int n_out, int relu, float *out)
{
    fc(ctx, in, n_in, w, b, n_out, relu, out);
}

static void forward(pl_f32net *m, int64_t clk)
{
    int h = m->in_h / 2, w = m->in_w / 2;
    conv(m, &m->conv0, m->x_in, m->buf_a);
    pl_prof_mark(m->prof, PL_PROF_STEM, &clk);
    observe(m, "conv0", m->buf_a, 64, h, w);

    nn_pool_params p0 = {64, h, w, h / 2, w / 2, 3, 2, 1};
    h /= 2;
    w /= 2;
    float *cur = m->buf_b, *next = m->buf_a;
    struct job mp = {.op = OP_MAXPOOL, .k = &m->kern->f32, .params = &p0, .in = m->buf_a, .out = cur};
    pl_pool_for(m->pool, 64, run_job, &mp);
    pl_prof_mark(m->prof, PL_PROF_MAXPOOL, &clk);

    int li = 0;
    char name[64];
    for (int b = 0; b < N_BLOCKS; b++) {
        const int hw = h * w;
        for (int l = 0; l < block_layers[b]; l++, li++) {
            const struct dense_layer *L = &m->layers[li];
            conv(m, &L->c1, cur, m->t2);
            pl_prof_mark(m->prof, PL_PROF_DENSE1 + 2 * b, &clk);
            conv(m, &L->c2, m->t2, cur + (size_t)L->cin * hw);
            pl_prof_mark(m->prof, PL_PROF_DENSE3 + 2 * b, &clk);
            if (m->observer) {
                snprintf(name, sizeof name, "denseblock%d.denselayer%d.conv1", b + 1, l + 1);
                observe(m, name, m->t2, BOTTLENECK, h, w);
                snprintf(name, sizeof name, "denseblock%d.denselayer%d.conv2", b + 1, l + 1);
                observe(m, name, cur + (size_t)L->cin * hw, GROWTH, h, w);
            }
        }
        if (b < N_BLOCKS - 1) {
            const struct transition *T = &m->trans[b];
            if (m->kern->f32.packed) {
                const int threads = pl_pool_threads(m->pool);
                struct trans_job tj = {&m->kern->f32, cur,  T->scale, T->shift, m->t2,
                                       m->scratch,    m->scratch_floats, T->cin, h, w,
                                       threads};
                pl_pool_for(m->pool, threads, run_trans, &tj);
            } else {
                bn_relu(m, cur, T->scale, T->shift, T->cin, hw, m->t1);
                nn_pool_params ap = {T->cin, h, w, h / 2, w / 2, 2, 2, 0};
                struct job j = {.op = OP_AVGPOOL, .k = &m->kern->f32, .params = &ap,
                                .in = m->t1, .out = m->t2};
                pl_pool_for(m->pool, T->cin, run_job, &j);
            }
            h /= 2;
            w /= 2;
            conv(m, &T->conv, m->t2, next);
            pl_prof_mark(m->prof, PL_PROF_TRANS + b, &clk);
            if (m->observer) {
                snprintf(name, sizeof name, "transition%d.conv", b + 1);
                observe(m, name, next, T->cin / 2, h, w);
            }
            float *t = cur;
            cur = next;
            next = t;
        }
    }
    bn_relu(m, cur, m->n5_scale, m->n5_shift, 1024, h * w, m->t1);
    nn_band_pool_f32__ref(m->t1, 1024, h, w, m->bands, m->z);
    pl_prof_mark(m->prof, PL_PROF_NORM5, &clk);
    observe(m, "z", m->z, m->z_len, 1, 1);

    fc(m, m->z, m->z_len, m->fc_w, m->fc_b, m->fc_n, 1, m->h);
    observe(m, "fc", m->h, m->fc_n, 1, 1);
    pl_heads_run(&m->heads, m->z, m->h, heads_fc, m);
    pl_prof_mark(m->prof, PL_PROF_HEADS, &clk);
}

void pl_f32net_estimate(pl_f32net *m, pl_pool *pool, const uint8_t *rgb, size_t stride, int x0,
                        int y0, int cw, int ch, pl_lighting *out, int64_t *t_pre)
{
    m->pool = pool;
    int64_t pt = pl_prof_now(m->prof);
    pl_resize_job rj = {rgb, stride, x0, y0, cw, ch, m->x_in, m->in_w, m->in_h};
    pl_pool_for(m->pool, m->in_h, pl_resize_job_rows, &rj);
    const size_t plane = (size_t)m->in_h * m->in_w;
    for (int c = 0; c < 3; c++) {
        const float a = 1.0f / (255.0f * m->std[c]), b = -m->mean[c] / m->std[c];
        float *x = m->x_in + c * plane;
        for (size_t i = 0; i < plane; i++) x[i] = x[i] * a + b;
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
    m->n_lights = shape->n_lights;
    m->in_h = shape->in_h;
    m->in_w = shape->in_w;
    m->bands = shape->bands;
    m->fc_n = shape->fc_n;
    m->dist_hidden = shape->dist_hidden;
    memcpy(m->mean, shape->mean, sizeof m->mean);
    memcpy(m->std, shape->std, sizeof m->std);
    int rc;
    if ((rc = bind_tensors(m)) < 0 || (rc = plan_arena(m)) < 0) {
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

void pl_f32net_latent(const pl_f32net *m, const float **z, int *n)
{
    *z = m->z;
    *n = m->z_len;
}
