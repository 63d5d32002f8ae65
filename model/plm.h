/* The .plm model file (docs/FORMAT.md): open, validate, read into memory, look up tensors and
 * metadata.
 *
 * pl_plm_open checks everything the format promises before returning: header fields, metadata
 * text, every table entry (name, dtype, shape, size, alignment, bounds, overlap), the CRC-32 and
 * the finiteness of float data. After it succeeds, tensor data can be used without further
 * checks; what a tensor's shape must be for the architecture is checked by the executors
 * (model/binder.h). The whole file is read into memory the pl_plm owns, and the checksum verified
 * on that copy: what happens to the file afterwards (truncated, overwritten, replaced) cannot
 * change or crash a loaded model. Tensors point into that copy and live until pl_plm_close. */
#ifndef PL_MODEL_PLM_H
#define PL_MODEL_PLM_H

#include <stddef.h>
#include <stdint.h>

#define PL_PLM_MAGIC "PLMODEL"
#define PL_PLM_VERSION 1u
#define PL_PLM_HEADER_SIZE 64u
#define PL_PLM_ENTRY_SIZE 128u
#define PL_PLM_ALIGN 64u
#define PL_PLM_MAX_META 65536u
#define PL_PLM_MAX_TENSORS 4096u
#define PL_PLM_NAME_MAX 64

typedef enum pl_dtype { PL_DT_F32 = 1, PL_DT_S8 = 2, PL_DT_S32 = 3, PL_DT_U8 = 4 } pl_dtype;

typedef struct pl_tensor {
    char name[PL_PLM_NAME_MAX];
    pl_dtype dtype;
    int ndim;            /* 1..4 */
    uint32_t dims[4];    /* dims[ndim..3] = 0 */
    const void *data;    /* into bytes, 64-byte aligned */
    size_t size;         /* bytes */
    size_t count;        /* elements */
    float scale;         /* quantisation scale, 0 for float tensors */
    int32_t zero_point;
} pl_tensor;

typedef struct pl_plm {
    const uint8_t *bytes; /* the whole file, read at open, 64-byte aligned, owned */
    size_t n_bytes;
    char *meta;          /* metadata text, NUL-terminated copy, lines split in place */
    const char **meta_keys, **meta_vals;
    int n_meta;
    pl_tensor *tensors;
    uint32_t n_tensors;
    char path[256];      /* for messages */
} pl_plm;

/* Opens and validates `path`. On failure returns <0 with pl_last_error() naming the file and
 * the problem, and leaves *plm closed. */
int pl_plm_open(const char *path, pl_plm *plm);
/* The same from a file's bytes in memory, copied first (the caller keeps its buffer); messages
 * name the model "<memory>". */
int pl_plm_open_memory(const void *data, size_t size, pl_plm *plm);
void pl_plm_close(pl_plm *plm);

/* Tensor named `name`, or NULL. */
const pl_tensor *pl_plm_tensor(const pl_plm *plm, const char *name);
/* Value of metadata `key`, or NULL. */
const char *pl_plm_meta(const pl_plm *plm, const char *key);

/* CRC-32 (IEEE 802.3, as zlib's crc32()) continuing from `crc` (start with 0). */
uint32_t pl_crc32(uint32_t crc, const void *data, size_t len);

size_t pl_dtype_size(pl_dtype dt);
const char *pl_dtype_name(pl_dtype dt);

#endif
