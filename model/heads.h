/* The parametric heads (tools/model.py, DESIGN.md "The network"), in float for both executors:
 * from the latent z (z_len = 1024 x bands) and the FC output h (fc_n), the direction (3N,
 * normalised per light as F.normalize(eps=1e-12)), angular size (N), colour (3N) and ambient (3),
 * each through PyTorch's softplus where positive, and the distance (N) from [z, directions]
 * through a hidden layer of dist_hidden. The executor that runs them passes its own FC (how it
 * splits the work over threads decides nothing: each output's sum has a fixed order, but the two
 * executors' FC kernels differ, so each keeps its own). */
#ifndef PL_MODEL_HEADS_H
#define PL_MODEL_HEADS_H

#include <stddef.h>

#include "model/binder.h"
#include "parlight.h"

typedef struct pl_heads {
    int n_lights, fc_n, dist_hidden, z_len;
    /* weights [out][in] and biases, f32; d1_w may be the executor's own (dequantised) copy */
    const float *dir_w, *dir_b, *size_w, *size_b, *rgb_w, *rgb_b, *amb_w, *amb_b;
    const float *d1_w, *d1_b, *d2_w, *d2_b;
    /* outputs and working vectors, in the executor's arena (pl_heads_place) */
    float *out_dir, *out_size, *out_rgb, *out_amb, *dist_in, *dist_h, *out_dist;
} pl_heads;

/* out[o] = (relu?) b[o] + w[o] . in over n_in inputs, for o in [0, n_out). */
typedef void (*pl_heads_fc_fn)(void *ctx, const float *in, int n_in, const float *w, const float *b,
                               int n_out, int relu, float *out);

/* Binds the f32 head tensors (head_dir, head_size, head_rgb, head_ambient) of a model with
 * hd's sizes. The distance head's first layer differs by precision: the caller binds
 * head_dist.fc1.weight, then calls pl_heads_bind_dist for the rest. */
void pl_heads_bind(pl_binder *b, pl_heads *hd);
void pl_heads_bind_dist(pl_binder *b, pl_heads *hd);

/* Floats the outputs and working vectors take, and their placement from p (returns the end). */
size_t pl_heads_floats(const pl_heads *hd);
float *pl_heads_place(pl_heads *hd, float *p);

/* Runs the heads on z and h with the executor's fc. */
void pl_heads_run(const pl_heads *hd, const float *z, const float *h, pl_heads_fc_fn fc, void *ctx);

/* The lights and ambient of the last run into *out (zeroed first). */
void pl_heads_lighting(const pl_heads *hd, pl_lighting *out);

#endif
