/* The fp32 executor of densenet121-parametric (model/net_f32.c). Private to model/: pl_model_load
 * (model/model.c) parses the metadata both precisions share and hands a float file here; the
 * public API functions delegate to these, as they do to the int8 executor (model/net_s8.h).
 *
 * pl_f32net_load validates every tensor (names, dtypes, shapes), packs the weights for the
 * dispatched kernels and plans one arena; pl_f32net_estimate then allocates nothing. */
#ifndef PL_MODEL_NET_F32_H
#define PL_MODEL_NET_F32_H

#include <stddef.h>
#include <stdint.h>

#include "core/threads.h"
#include "model/graph.h"
#include "model/observer.h"
#include "model/plm.h"
#include "model/profile.h"
#include "parlight.h"

typedef struct pl_f32net pl_f32net;

/* `file` stays open (owned by the caller) while the executor lives. */
int pl_f32net_load(const pl_plm *file, const pl_net_shape *shape, pl_f32net **out);
void pl_f32net_free(pl_f32net *m);
int64_t pl_f32net_params(const pl_f32net *m);
/* Working memory: the arena, the GEMM scratch of every thread and the packed weights. */
size_t pl_f32net_memory_bytes(const pl_f32net *m);
/* Grows the per-thread GEMM scratch for n threads (packed paths). */
int pl_f32net_set_threads(pl_f32net *m, int n);
void pl_f32net_set_observer(pl_f32net *m, pl_layer_observer fn, void *ctx);
/* Stage times of later estimates add to *p (model/profile.h); NULL stops. */
void pl_f32net_set_profile(pl_f32net *m, pl_profile *p);

/* Runs the network on the frame's region (x0, y0, cw, ch), already cropped to the model's
 * aspect and validated by pl_estimate_rgb8, into *out; *t_pre: the end of the preprocessing. */
void pl_f32net_estimate(pl_f32net *m, pl_pool *pool, const uint8_t *rgb, size_t stride, int x0,
                        int y0, int cw, int ch, pl_lighting *out, int64_t *t_pre);
const pl_graph *pl_f32net_graph(const pl_f32net *m);
/* The latent z of the last estimate. */
void pl_f32net_latent(const pl_f32net *m, const float **z, int *n);

#endif
