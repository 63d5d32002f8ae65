/* The architecture's name and the shape parameters a model's metadata gives it (docs/FORMAT.md),
 * shared by model/model.c, which parses them, and the graph (model/graph.h), which is built
 * from them; the architecture's own constants (blocks, growth rate) live in model/graph.c. */
#ifndef PL_MODEL_ARCH_H
#define PL_MODEL_ARCH_H

#define PL_ARCH_NAME "densenet121-parametric"

/* Shape parameters read from a model's metadata (both precisions). */
typedef struct pl_net_shape {
    int n_lights, in_h, in_w, bands, fc_n, dist_hidden;
    float mean[3], std[3];
} pl_net_shape;

#endif
