/* What the rest of parlight (not apps) may ask of a pl_model beyond include/parlight.h;
 * model/observer.h and model/graph.h have the tools' hooks. */
#ifndef PL_MODEL_MODEL_H
#define PL_MODEL_MODEL_H

#include <stddef.h>
#include <stdint.h>

#include "parlight.h"

/* A buffer of at least `bytes` the model owns, for a frame converted to RGB before
 * pl_estimate_rgb8 (port/frame_api.c: YUYV, NV12): grown when a frame is larger, never shrunk,
 * freed with the model, so nothing is allocated per frame once sizes settle. Used by the thread
 * that estimates on this model. NULL with pl_last_error set when the allocation fails. */
uint8_t *pl_model_frame_rgb(pl_model *m, size_t bytes);

#endif
