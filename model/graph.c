/* The network's description (model/graph.h): densenet121-parametric, built from its constants
 * and a model's shape. */
#include "model/graph.h"

#include <stdarg.h>
#include <stdio.h>
#include <string.h>

#include "core/util.h"
#include "model/profile.h"

/* torchvision's DenseNet-121 features (tools/model.py): a 7x7/2 stem, a 3x3/2 max pool, dense
 * blocks whose layers append `growth` channels through a `bottleneck`-wide 1x1 and a 3x3, and
 * transitions that halve the channels and the map between blocks. */
static const struct {
    int stem_c, growth, bottleneck, n_blocks;
    int layers[4];
} densenet121 = {64, 32, 128, 4, {6, 12, 24, 16}};

struct builder {
    pl_graph *g;
    int rc;
};

static int add_tensor(struct builder *b, const char *name, int c, int h, int w, pl_slot slot,
                      int block)
{
    pl_graph *g = b->g;
    if (g->n_tensors == PL_GRAPH_MAX_TENSORS) {
        b->rc = pl_error(PL_E_INTERNAL, "graph: more than %d tensors", PL_GRAPH_MAX_TENSORS);
        return -1;
    }
    pl_gtensor *t = &g->tensors[g->n_tensors];
    memset(t, 0, sizeof *t);
    snprintf(t->name, sizeof t->name, "%s", name);
    t->c = c;
    t->h = h;
    t->w = w;
    t->slot = slot;
    t->block = block;
    return g->n_tensors++;
}

static void set_name(char *dst, const char *fmt, ...) __attribute__((format(printf, 2, 3)));

static void set_name(char *dst, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(dst, PL_GRAPH_NAME_MAX, fmt, ap);
    va_end(ap);
}

/* A node reading [0, in_c) of `in` and writing [out_c0, out_c0 + out_c) of `out` (-1: none);
 * the caller fills the names and the window. */
static pl_gnode *add_node(struct builder *b, pl_node_op op, int in, int in_c, int out, int out_c0,
                          int out_c, int stage)
{
    pl_graph *g = b->g;
    if (g->n_nodes == PL_GRAPH_MAX_NODES) {
        b->rc = pl_error(PL_E_INTERNAL, "graph: more than %d nodes", PL_GRAPH_MAX_NODES);
        return NULL;
    }
    pl_gnode *n = &g->nodes[g->n_nodes++];
    *n = (pl_gnode){.op = op,
                    .in = in,
                    .in2 = -1,
                    .out = out,
                    .in_c = in_c,
                    .out_c0 = out_c0,
                    .out_c = out_c,
                    .k = 1,
                    .stride = 1,
                    .stage = stage};
    n->in_h = in >= 0 ? g->tensors[in].h : 1;
    n->in_w = in >= 0 ? g->tensors[in].w : 1;
    n->out_h = out >= 0 ? g->tensors[out].h : 1;
    n->out_w = out >= 0 ? g->tensors[out].w : 1;
    return n;
}

/* A k x k window with stride and padding (convolutions default to 1 x 1, stride 1). */
static void set_window(pl_gnode *n, int k, int stride, int pad)
{
    n->k = k;
    n->stride = stride;
    n->pad = pad;
}

static int build_densenet(struct builder *b, const pl_net_shape *sh)
{
    pl_graph *g = b->g;
    const int G = densenet121.growth, BN = densenet121.bottleneck, S = densenet121.stem_c;
    int h = sh->in_h, w = sh->in_w;
    g->input = add_tensor(b, "input", 3, h, w, PL_SLOT_B, -1);
    const int stem = add_tensor(b, "stem", S, h / 2, w / 2, PL_SLOT_A, -1);
    if (b->rc < 0) return b->rc;
    pl_gnode *n = add_node(b, PL_NODE_CONV, g->input, 3, stem, 0, S, PL_PROF_STEM);
    if (!n) return b->rc;
    set_name(n->name, "conv0");
    set_window(n, 7, 2, 3);
    n->bias = 1;
    n->relu = 1;

    h /= 4;
    w /= 4;
    int c0 = S;
    int blk = add_tensor(b, "block1", c0 + G * densenet121.layers[0], h, w, PL_SLOT_B, 0);
    if (b->rc < 0) return b->rc;
    if (!(n = add_node(b, PL_NODE_MAXPOOL, stem, S, blk, 0, S, PL_PROF_MAXPOOL))) return b->rc;
    set_name(n->name, "pool0");
    set_window(n, 3, 2, 1);

    for (int bi = 0; bi < densenet121.n_blocks; bi++) {
        const int ctot = c0 + G * densenet121.layers[bi];
        char tn[16];
        snprintf(tn, sizeof tn, "bneck%d", bi + 1);
        const int bneck = add_tensor(b, tn, BN, h, w, PL_SLOT_T, -1);
        if (b->rc < 0) return b->rc;
        for (int l = 0; l < densenet121.layers[bi]; l++) {
            const int cin = c0 + G * l;
            if (!(n = add_node(b, PL_NODE_CONV, blk, cin, bneck, 0, BN, PL_PROF_DENSE1 + 2 * bi)))
                return b->rc;
            set_name(n->unit, "denseblock%d.denselayer%d", bi + 1, l + 1);
            set_name(n->name, "%.30s.conv1", n->unit);
            set_name(n->norm, "%.30s.norm1", n->unit);
            n->bias = 1;
            n->relu = 1;
            if (!(n = add_node(b, PL_NODE_CONV, bneck, BN, blk, cin, G, PL_PROF_DENSE3 + 2 * bi)))
                return b->rc;
            set_name(n->name, "denseblock%d.denselayer%d.conv2", bi + 1, l + 1);
            set_window(n, 3, 1, 1);
        }
        if (bi + 1 < densenet121.n_blocks) {
            h /= 2;
            w /= 2;
            c0 = ctot / 2;
            snprintf(tn, sizeof tn, "block%d", bi + 2);
            const int next = add_tensor(b, tn, c0 + G * densenet121.layers[bi + 1], h, w,
                                        bi % 2 ? PL_SLOT_B : PL_SLOT_A, bi + 1);
            if (b->rc < 0) return b->rc;
            if (!(n = add_node(b, PL_NODE_CONV, blk, ctot, next, 0, ctot / 2, PL_PROF_TRANS + bi)))
                return b->rc;
            set_name(n->unit, "transition%d", bi + 1);
            set_name(n->name, "%.30s.conv", n->unit);
            set_name(n->norm, "%.30s.norm", n->unit);
            n->pool2 = 1;
            blk = next;
        } else {
            g->z = add_tensor(b, "z", ctot * sh->bands, 1, 1, PL_SLOT_VEC, -1);
            if (b->rc < 0) return b->rc;
            if (!(n = add_node(b, PL_NODE_BANDS, blk, ctot, g->z, 0, ctot * sh->bands,
                               PL_PROF_NORM5)))
                return b->rc;
            set_name(n->name, "z");
            set_name(n->unit, "norm5");
            set_name(n->norm, "norm5");
        }
    }
    g->h = add_tensor(b, "h", sh->fc_n, 1, 1, PL_SLOT_VEC, -1);
    if (b->rc < 0) return b->rc;
    const int zl = g->tensors[g->z].c;
    if (!(n = add_node(b, PL_NODE_FC, g->z, zl, g->h, 0, sh->fc_n, PL_PROF_HEADS))) return b->rc;
    set_name(n->name, "fc");
    set_name(n->unit, "fc");
    n->bias = 1;
    n->relu = 1;
    if (!(n = add_node(b, PL_NODE_HEADS, g->z, zl, -1, 0, 0, PL_PROF_HEADS))) return b->rc;
    set_name(n->name, "heads");
    n->in2 = g->h;
    return PL_OK;
}

/* The checks of pl_graph_build (model/graph.h); records each write as a segment. */
static int check(pl_graph *g)
{
    for (int i = 0; i < g->n_nodes; i++) {
        pl_gnode *n = &g->nodes[i];
        const pl_gtensor *in = &g->tensors[n->in];
        if (n->in_c < 1 || n->in_c > in->c)
            return pl_error(PL_E_MODEL, "graph node '%s': reads %d channels of '%s' (%d)", n->name,
                            n->in_c, in->name, in->c);
        /* what it reads was written before: the input, or the segments so far */
        int covered = n->in == g->input ? in->c : 0;
        for (int s = 0; s < in->n_segs && covered < n->in_c; s++)
            if (in->segs[s].c0 == covered) covered += in->segs[s].c;
        if (covered < n->in_c)
            return pl_error(PL_E_MODEL,
                            "graph node '%s': reads channels [0, %d) of '%s', written: [0, %d)",
                            n->name, n->in_c, in->name, covered);
        if (n->op == PL_NODE_CONV || n->op == PL_NODE_MAXPOOL) {
            const int ih = n->pool2 ? n->in_h / 2 : n->in_h, iw = n->pool2 ? n->in_w / 2 : n->in_w;
            const int oh = (ih + 2 * n->pad - n->k) / n->stride + 1;
            const int ow = (iw + 2 * n->pad - n->k) / n->stride + 1;
            if ((n->pool2 && (n->in_h % 2 || n->in_w % 2)) || n->in_h < n->k || n->in_w < n->k ||
                oh != n->out_h || ow != n->out_w)
                return pl_error(PL_E_MODEL,
                                "graph node '%s': a %dx%d map gives %dx%d, its output is %dx%d "
                                "(input size not a multiple of 32?)",
                                n->name, n->in_h, n->in_w, oh, ow, n->out_h, n->out_w);
        }
        if (n->out < 0) continue;
        pl_gtensor *out = &g->tensors[n->out];
        if (n->out_c0 < 0 || n->out_c < 1 || n->out_c0 + n->out_c > out->c)
            return pl_error(PL_E_MODEL, "graph node '%s': writes [%d, %d) of '%s' (%d channels)",
                            n->name, n->out_c0, n->out_c0 + n->out_c, out->name, out->c);
        /* a scratch tensor is rewritten by each producer; a concatenation only appended to */
        if (out->block >= 0) {
            for (int s = 0; s < out->n_segs; s++)
                if (n->out_c0 < out->segs[s].c0 + out->segs[s].c &&
                    out->segs[s].c0 < n->out_c0 + n->out_c)
                    return pl_error(PL_E_MODEL, "graph node '%s' overwrites channels of '%s'",
                                    n->name, g->nodes[out->segs[s].node].name);
            if (out->n_segs == PL_GRAPH_MAX_SEGS)
                return pl_error(PL_E_INTERNAL, "graph: '%s' has more than %d segments", out->name,
                                PL_GRAPH_MAX_SEGS);
        } else {
            out->n_segs = 0;
        }
        out->segs[out->n_segs++] = (pl_gseg){n->out_c0, n->out_c, i};
    }
    return PL_OK;
}

/* pl_gnode.lands: a node writing a concatenation, or one whose output only a max pool into a
 * concatenation reads. */
static void find_lands(pl_graph *g)
{
    for (int i = 0; i < g->n_nodes; i++) {
        pl_gnode *n = &g->nodes[i];
        n->lands = -1;
        if (n->out < 0) continue;
        if (g->tensors[n->out].block >= 0) {
            n->lands = n->out;
            n->lands_c0 = n->out_c0;
            continue;
        }
        for (int j = i + 1; j < g->n_nodes; j++) {
            const pl_gnode *r = &g->nodes[j];
            if (r->in != n->out && r->in2 != n->out) continue;
            if (r->op != PL_NODE_MAXPOOL || g->tensors[r->out].block < 0) {
                n->lands = -1;
                break;
            }
            n->lands = r->out;
            n->lands_c0 = r->out_c0 + n->out_c0;
        }
    }
}

int pl_graph_build(const pl_net_shape *shape, pl_graph *g)
{
    memset(g, 0, sizeof *g);
    g->shape = *shape;
    g->input = g->z = g->h = -1;
    struct builder b = {g, PL_OK};
    int rc = build_densenet(&b, shape);
    if (rc == PL_OK) rc = check(g);
    if (rc == PL_OK) find_lands(g);
    return rc;
}

size_t pl_graph_tensor_size(const pl_graph *g, int t)
{
    const pl_gtensor *x = &g->tensors[t];
    return (size_t)x->c * (size_t)x->h * (size_t)x->w;
}

size_t pl_graph_slot_size(const pl_graph *g, pl_slot slot)
{
    size_t m = 0;
    for (int t = 0; t < g->n_tensors; t++) {
        const size_t s = pl_graph_tensor_size(g, t);
        if (g->tensors[t].slot == slot && s > m) m = s;
    }
    return m;
}

int pl_graph_find(const pl_graph *g, const char *name)
{
    for (int i = 0; i < g->n_nodes; i++)
        if (!strcmp(g->nodes[i].name, name)) return i;
    return -1;
}

int64_t pl_graph_node_macs(const pl_graph *g, const pl_gnode *n)
{
    const pl_net_shape *s = &g->shape;
    const int64_t N = s->n_lights, zl = g->tensors[g->z].c;
    switch (n->op) {
    case PL_NODE_CONV: /* a pooled input's conv counted at the input's size */
        return (int64_t)n->out_c * n->in_c * n->k * n->k * (n->pool2 ? n->in_h : n->out_h) *
               (n->pool2 ? n->in_w : n->out_w);
    case PL_NODE_FC:
        return (int64_t)n->in_c * n->out_c;
    case PL_NODE_HEADS: /* dir, size, rgb, ambient, then the distance head */
        return (int64_t)s->fc_n * (3 * N + N + 3 * N + 3) + (zl + 3 * N) * s->dist_hidden +
               (int64_t)s->dist_hidden * N;
    case PL_NODE_MAXPOOL:
    case PL_NODE_BANDS:
        return 0;
    }
    return 0;
}
