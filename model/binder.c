/* The tensor binder (model/binder.h). */
#include "model/binder.h"

#include <stdio.h>

#include "core/util.h"

const pl_tensor *pl_bind(pl_binder *b, const char *name, pl_dtype dt, int ndim, int d0, int d1,
                         int d2, int d3)
{
    if (b->rc < 0) return NULL;
    const pl_plm *f = b->file;
    const pl_tensor *t = pl_plm_tensor(f, name);
    const int want[4] = {d0, d1, d2, d3};
    if (!t) {
        b->rc = pl_error(PL_E_MODEL, "%s: tensor '%s' missing%s", f->path, name, b->missing_note);
        return NULL;
    }
    if (t->dtype != dt) {
        b->rc = pl_error(PL_E_MODEL, "%s: tensor '%s' is %s, expected %s", f->path, name,
                         pl_dtype_name(t->dtype), pl_dtype_name(dt));
        return NULL;
    }
    int ok = t->ndim == ndim;
    for (int i = 0; ok && i < ndim; i++)
        ok = t->dims[i] == (uint32_t)want[i];
    if (!ok) {
        char got[64], exp[64];
        int n = 0, k = 0;
        for (int i = 0; i < t->ndim; i++)
            n += snprintf(got + n, sizeof got - (size_t)n, "%s%u", i ? "," : "", t->dims[i]);
        for (int i = 0; i < ndim; i++)
            k += snprintf(exp + k, sizeof exp - (size_t)k, "%s%d", i ? "," : "", want[i]);
        b->rc = pl_error(PL_E_MODEL, "%s: tensor '%s' has shape [%s], expected [%s]", f->path, name,
                         got, exp);
        return NULL;
    }
    const size_t i = (size_t)(t - f->tensors);
    b->bound[i / 8] |= (uint8_t)(1u << (i % 8));
    return t;
}

const float *pl_bind_f32(pl_binder *b, const char *name, int ndim, int d0, int d1, int d2, int d3)
{
    const pl_tensor *t = pl_bind(b, name, PL_DT_F32, ndim, d0, d1, d2, d3);
    if (!t) return NULL;
    b->params += (int64_t)t->count;
    return t->data;
}

int pl_bind_finish(pl_binder *b, const char *what)
{
    if (b->rc < 0) return b->rc;
    const pl_plm *f = b->file;
    for (uint32_t i = 0; i < f->n_tensors; i++)
        if (!(b->bound[i / 8] >> (i % 8) & 1))
            return b->rc = pl_error(PL_E_MODEL, "%s: unexpected tensor '%s' for %s", f->path,
                                    f->tensors[i].name, what);
    return PL_OK;
}
