/* The one description of the network (DESIGN.md "The network"): a flat list of nodes in
 * execution order over a list of tensors, built once from the model's metadata (pl_net_shape)
 * and the architecture's constants, and checked once when built. The fp32 executor
 * (model/net_f32.c), the int8 executor (model/net_s8.c), the quantiser (quant/quantize.c) and
 * `parlight bench`'s MAC count iterate it; none of them spells out the DenseNet. A new
 * architecture (another growth rate, block count or stem) is a new builder in model/graph.c,
 * not new walks (docs/ARCHITECTURE.md, "The graph").
 *
 * Tensors are activations, CHW in the fp32 executor and NHWC in the int8 one. A concatenation
 * is a tensor that several nodes write at channel offsets (its segments, in the order written):
 * a DenseNet block buffer, to which each dense layer appends its growth channels and from which
 * each consumer reads the channels [0, in_c) written so far. Concatenation copies nothing.
 *
 * A node names its layer once: `name` is the observer's name (model/observer.h) and the prefix
 * of its weight tensors in the model file (name.weight, name.bias; int8 also name.wscale,
 * name.out); `norm` the prefix of the pre-activation batch norm on its input (norm.scale,
 * norm.shift), `unit` the prefix of the int8 per-input-channel clamp (unit.clamp) and the name
 * `--keep-float` knows it by. */
#ifndef PL_MODEL_GRAPH_H
#define PL_MODEL_GRAPH_H

#include <stddef.h>
#include <stdint.h>

#include "model/arch.h"
#include "parlight.h"

#define PL_GRAPH_MAX_NODES 160
#define PL_GRAPH_MAX_TENSORS 16
#define PL_GRAPH_MAX_SEGS 64
#define PL_GRAPH_NAME_MAX 48

typedef enum pl_node_op {
    PL_NODE_CONV,    /* [BN + ReLU of the input (norm)] [2x2/2 average pool (pool2)] k x k conv,
                        [bias], [ReLU]: out[out_c0 + o] for o < out_c */
    PL_NODE_MAXPOOL, /* k x k / stride max pool (pad) of in_c channels */
    PL_NODE_BANDS,   /* BN + ReLU (norm), then the average of each of `bands` horizontal bands:
                        z[c * bands + k] (the latent) */
    PL_NODE_FC,      /* fully connected on a vector, bias, [ReLU] */
    PL_NODE_HEADS    /* the float parametric heads (model/heads.h) on z (in) and h (in2) */
} pl_node_op;

/* Where an executor keeps a tensor: two ping-pong buffers, a scratch one, or small vectors. */
typedef enum pl_slot { PL_SLOT_A, PL_SLOT_B, PL_SLOT_T, PL_SLOT_VEC } pl_slot;

typedef struct pl_gseg {
    int c0, c; /* channels [c0, c0 + c) */
    int node;  /* written by nodes[node] */
} pl_gseg;

typedef struct pl_gtensor {
    char name[16]; /* "input", "stem", "block1", "bneck1", "z", "h" */
    int c, h, w;
    pl_slot slot;
    int block; /* a dense block buffer: its index from 0 (consumers clamp it); else -1 */
    int n_segs;
    pl_gseg segs[PL_GRAPH_MAX_SEGS];
} pl_gtensor;

typedef struct pl_gnode {
    pl_node_op op;
    char name[PL_GRAPH_NAME_MAX]; /* "conv0", "denseblock1.denselayer1.conv1", "transition1.conv",
                                     "z", "fc"; "pool0" and "heads" have no tensors of their own */
    char norm[PL_GRAPH_NAME_MAX]; /* pre-activation BN prefix ("transition1.norm"), or "" */
    char unit[PL_GRAPH_NAME_MAX]; /* int8 clamp prefix and --keep-float name ("transition1"), or
                                     "" */
    int in, in2, out;             /* tensor ids (in2: HEADS only, else -1; out -1 for HEADS) */
    int in_c;                     /* channels read: [0, in_c) of `in` */
    int out_c0, out_c;            /* channels written: [out_c0, out_c0 + out_c) of `out` */
    int in_h, in_w;               /* the input map (1 x 1 for vectors) */
    int out_h, out_w;             /* the output map (CONV: after pool2's halving) */
    int k, stride, pad;           /* CONV and MAXPOOL window */
    int pool2, bias, relu;
    int stage;           /* the profile stage its time adds to (model/profile.h) */
    int lands, lands_c0; /* the concatenation its output values end in, directly or through a
                            max pool (which keeps values): tensor id and channel offset; -1 */
} pl_gnode;

typedef struct pl_graph {
    pl_net_shape shape;
    int n_nodes, n_tensors;
    /* tensor ids: the network's input (3 x in_h x in_w), the latent, the fc's output */
    int input, z, h;
    pl_gnode nodes[PL_GRAPH_MAX_NODES];
    pl_gtensor tensors[PL_GRAPH_MAX_TENSORS];
} pl_graph;

/* Builds the densenet121-parametric graph for `shape` into *g and checks it: every map halves
 * exactly, every node reads channels already written and writes inside its tensor, without
 * overlapping an earlier segment. PL_E_MODEL (naming the node) when the shape does not fit. */
int pl_graph_build(const pl_net_shape *shape, pl_graph *g);

/* The graph of a loaded model (either precision), for the quantiser and the bench. */
const pl_graph *pl_model_graph(const pl_model *m);

/* The elements of tensor t (c * h * w). */
size_t pl_graph_tensor_size(const pl_graph *g, int t);

/* The most elements of any tensor kept in `slot`. */
size_t pl_graph_slot_size(const pl_graph *g, pl_slot slot);

/* Node index of `name` ("transition2.conv"), or -1. */
int pl_graph_find(const pl_graph *g, const char *name);

/* Multiply-accumulates of one node as tools/model.py writes it (a transition's 1x1 conv at the
 * block's size, before its pool; pooling, BN, ReLU and additions not counted), for
 * `parlight bench`. */
int64_t pl_graph_node_macs(const pl_graph *g, const pl_gnode *n);

#endif
