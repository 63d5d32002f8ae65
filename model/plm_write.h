/* Writing .plm files (docs/FORMAT.md) from C, for `parlight quantize`. The Python writer is
 * tools/plm.py; both produce the same layout.
 *
 *     pl_plm_writer *w;
 *     pl_plm_writer_create(&w);
 *     pl_plm_writer_meta(w, "arch", "densenet121-parametric");
 *     pl_plm_writer_add(w, "conv0.weight", PL_DT_S8, 4, dims, data, 0.0f, 0);
 *     ...
 *     pl_plm_writer_save(w, "out.plm");      (temporary file + rename: never a half file)
 *     pl_plm_writer_free(w);
 *
 * Tensors are copied when added (the caller's buffers may go). Metadata keys and tensor names are
 * checked as the loader checks them; errors are PL_E_ARG (bad name, dims, duplicate), PL_E_NOMEM,
 * PL_E_IO (naming the path). */
#ifndef PL_MODEL_PLM_WRITE_H
#define PL_MODEL_PLM_WRITE_H

#include <stdint.h>

#include "model/plm.h"

typedef struct pl_plm_writer pl_plm_writer;

int pl_plm_writer_create(pl_plm_writer **out);
void pl_plm_writer_free(pl_plm_writer *w);
/* key: [A-Za-z0-9_.]+, unique; value: no newline or NUL. */
int pl_plm_writer_meta(pl_plm_writer *w, const char *key, const char *value);
/* dims: ndim (1..4) positive values; data: product(dims) elements of dt. */
int pl_plm_writer_add(pl_plm_writer *w, const char *name, pl_dtype dt, int ndim,
                      const uint32_t *dims, const void *data, float scale, int32_t zero_point);
int pl_plm_writer_save(const pl_plm_writer *w, const char *path);

#endif
