/* The densenet121-parametric architecture constants (tools/model.py, docs/FORMAT.md), shared by
 * the fp32 executor (model/net_f32.c), the int8 executor (model/net_s8.c) and the quantiser
 * (quant/quantize.c), so that the graph is written down once. */
#ifndef PL_MODEL_ARCH_H
#define PL_MODEL_ARCH_H

#define PL_ARCH_NAME "densenet121-parametric"
#define GROWTH 32      /* channels each dense layer appends */
#define BOTTLENECK 128 /* a dense layer's 1x1 conv width */
#define N_BLOCKS 4
#define MAX_LAYERS 58
#define FEATURES 1024 /* channels of the last block (norm5) */

/* Layers per dense block and channels entering each block. */
static const int block_layers[N_BLOCKS] = {6, 12, 24, 16};
static const int block_c0[N_BLOCKS] = {64, 128, 256, 512};

/* Shape parameters read from a model's metadata (both precisions). */
typedef struct pl_net_shape {
    int n_lights, in_h, in_w, bands, fc_n, dist_hidden;
    float mean[3], std[3];
} pl_net_shape;

#endif
