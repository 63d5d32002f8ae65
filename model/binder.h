/* The tensor binder both executors load through: looks a tensor up by name in a model file
 * (model/plm.h), checks its dtype and exact shape, and marks what was bound, so that a file
 * with a tensor the graph (model/graph.h) does not name can be refused (pl_bind_finish). The
 * first error sticks: later calls return NULL and leave the message alone, so a loader binds
 * everything and checks rc once. */
#ifndef PL_MODEL_BINDER_H
#define PL_MODEL_BINDER_H

#include <stdint.h>

#include "model/plm.h"

typedef struct pl_binder {
    const pl_plm *file;
    const char *missing_note; /* appended to "tensor 'x' missing" (e.g. " (int8 model)"), or "" */
    int rc;                   /* PL_OK, or the first error */
    int64_t params;           /* elements of the tensors bound with pl_bind_f32 */
    uint8_t bound[PL_PLM_MAX_TENSORS / 8]; /* a bit per table entry */
} pl_binder;

/* The tensor `name` with dtype `dt` and exactly `ndim` dims d0..d3 (the unused ones 0), or NULL
 * with b->rc set (PL_E_MODEL naming the file, the tensor, what was expected and what was found). */
const pl_tensor *pl_bind(pl_binder *b, const char *name, pl_dtype dt, int ndim, int d0, int d1,
                         int d2, int d3);
/* The same for an f32 parameter tensor: its data, its elements counted in b->params. */
const float *pl_bind_f32(pl_binder *b, const char *name, int ndim, int d0, int d1, int d2, int d3);

/* After the last bind: b->rc, or PL_E_MODEL naming the first tensor of the file that was never
 * bound ("unexpected tensor 'x' for <what>"). */
int pl_bind_finish(pl_binder *b, const char *what);

#endif
