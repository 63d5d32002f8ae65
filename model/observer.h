/* Per-layer observation of a model's activations, for calibration (quant/quantize.c) and for
 * the int8-vs-float accuracy check (parlight qcheck). Not part of the public API.
 *
 * After each observed layer of pl_estimate_rgb8 the executor calls
 *   fn(ctx, layer, chw, c, h, w, floor)
 * with a stable layer name and the layer's output as real values, CHW float planes (c planes of
 * h x w; vectors have h = w = 1). The int8 executor dequantises its NHWC output into a scratch
 * buffer it allocates in pl_model_set_observer, so both precisions report the same quantity under
 * the same name. The data is valid during the call only.
 * floor: NULL, or (int8 block-buffer producers: conv0, conv2, transitions) per channel the value
 * the int8 range starts at: the quantiser clips a producer's range where every consumer's
 * BN + ReLU clamps anyway (docs/QUANT.md), so values below it are equivalent to it.
 *
 * Layer names (in execution order; the graph's node names, model/graph.h):
 *   conv0                              conv0 + ReLU (64 channels, before the max pool)
 *   denseblock{b}.denselayer{l}.conv1  bottleneck 1x1 conv + ReLU (128 channels)
 *   denseblock{b}.denselayer{l}.conv2  the 32 new channels of the dense layer
 *   transition{t}.conv                 BN, ReLU, 2x2 average pool, 1x1 conv (C/2 channels)
 *   z                                  norm5 + ReLU, band pooled (1024 x bands values)
 *   fc                                 FC + ReLU (h, fc values) */
#ifndef PL_MODEL_OBSERVER_H
#define PL_MODEL_OBSERVER_H

#include "parlight.h"

typedef void (*pl_layer_observer)(void *ctx, const char *layer, const float *chw, int c, int h,
                                  int w, const float *floor);

/* Sets (fn non-NULL) or clears (fn NULL) the observer. PL_E_NOMEM when the int8 executor cannot
 * allocate its dequantisation scratch. */
int pl_model_set_observer(pl_model *m, pl_layer_observer fn, void *ctx);

/* "fp32" or "int8"; NULL for a NULL model. */
const char *pl_model_precision(const pl_model *m);

#endif
