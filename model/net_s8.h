/* The int8 executor of densenet121-parametric (docs/QUANT.md "DenseNet folding", docs/FORMAT.md
 * "int8 models"). Private to model/: pl_model_load (model/model.c) parses the shared metadata and
 * hands an int8 file here; the public API functions delegate to these.
 *
 * pl_s8_load validates every int8 tensor (names, dtypes, shapes, quantisation parameters), turns
 * scales into requantisation (multiplier, shift) pairs, checks every kernel call once with the
 * nn_*_s8_check functions, and plans one arena; pl_s8_estimate then allocates nothing. */
#ifndef PL_MODEL_NET_S8_H
#define PL_MODEL_NET_S8_H

#include <stddef.h>
#include <stdint.h>

#include "core/threads.h"
#include "model/graph.h"
#include "model/observer.h"
#include "model/plm.h"
#include "model/profile.h"
#include "parlight.h"

typedef struct pl_s8 pl_s8;

/* `file` stays open (owned by the caller) while the executor lives. */
int pl_s8_load(const pl_plm *file, const pl_net_shape *shape, pl_s8 **out);
void pl_s8_free(pl_s8 *s);
size_t pl_s8_arena_bytes(const pl_s8 *s);
int64_t pl_s8_params(const pl_s8 *s);
int pl_s8_set_observer(pl_s8 *s, pl_layer_observer fn, void *ctx);
/* Stage times of later estimates add to *p (model/profile.h); NULL stops. */
void pl_s8_set_profile(pl_s8 *s, pl_profile *p);

/* Runs one frame (arguments already validated by pl_estimate_rgb8). */
void pl_s8_estimate(pl_s8 *s, pl_pool *pool, const uint8_t *rgb, int width, int height,
                    size_t stride, pl_lighting *out, int64_t *t_pre_end);
const pl_graph *pl_s8_graph(const pl_s8 *s);
/* The dequantised latent of the last estimate. */
void pl_s8_latent(const pl_s8 *s, const float **z, int *n);

#endif
