#include "model/plm_write.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "core/util.h"

struct wtensor {
    char name[PL_PLM_NAME_MAX];
    pl_dtype dt;
    int ndim;
    uint32_t dims[4];
    void *data;
    size_t size;
    float scale;
    int32_t zp;
};

struct pl_plm_writer {
    char *meta;
    size_t meta_len, meta_cap;
    struct wtensor *t;
    uint32_t n, cap;
};

int pl_plm_writer_create(pl_plm_writer **out)
{
    *out = calloc(1, sizeof **out);
    return *out ? PL_OK : pl_error(PL_E_NOMEM, "out of memory");
}

void pl_plm_writer_free(pl_plm_writer *w)
{
    if (!w) return;
    for (uint32_t i = 0; i < w->n; i++)
        free(w->t[i].data);
    free(w->t);
    free(w->meta);
    free(w);
}

static int valid_name(const char *s, size_t max)
{
    size_t n = strlen(s);
    if (n == 0 || n >= max) return 0;
    for (size_t i = 0; i < n; i++) {
        const char c = s[i];
        if (!((c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
              c == '_' || c == '.'))
            return 0;
    }
    return 1;
}

int pl_plm_writer_meta(pl_plm_writer *w, const char *key, const char *value)
{
    if (!valid_name(key, 256) || strchr(value, '\n'))
        return pl_error(PL_E_ARG, "metadata '%s': bad key or value with a newline", key);
    size_t kl = strlen(key);
    for (const char *p = w->meta; p && p < w->meta + w->meta_len;) { /* keys unique */
        if (!strncmp(p, key, kl) && p[kl] == '=')
            return pl_error(PL_E_ARG, "metadata key '%s' set twice", key);
        const char *nl = memchr(p, '\n', (size_t)(w->meta + w->meta_len - p));
        p = nl ? nl + 1 : w->meta + w->meta_len;
    }
    const size_t add = kl + 1 + strlen(value) + 1;
    if (w->meta_len + add + 1 > w->meta_cap) {
        size_t cap = (w->meta_len + add + 1) * 2;
        char *m = realloc(w->meta, cap);
        if (!m) return pl_error(PL_E_NOMEM, "out of memory");
        w->meta = m;
        w->meta_cap = cap;
    }
    snprintf(w->meta + w->meta_len, w->meta_cap - w->meta_len, "%s=%s\n", key, value);
    w->meta_len += add;
    if (w->meta_len > PL_PLM_MAX_META) return pl_error(PL_E_ARG, "metadata over 64 KiB");
    return PL_OK;
}

int pl_plm_writer_add(pl_plm_writer *w, const char *name, pl_dtype dt, int ndim,
                      const uint32_t *dims, const void *data, float scale, int32_t zero_point)
{
    if (!valid_name(name, PL_PLM_NAME_MAX))
        return pl_error(PL_E_ARG, "tensor name '%s': expected 1..63 of [A-Za-z0-9_.]", name);
    if (ndim < 1 || ndim > 4) return pl_error(PL_E_ARG, "tensor '%s': ndim %d", name, ndim);
    for (uint32_t i = 0; i < w->n; i++)
        if (!strcmp(w->t[i].name, name)) return pl_error(PL_E_ARG, "tensor '%s' added twice", name);
    if (w->n >= PL_PLM_MAX_TENSORS) return pl_error(PL_E_ARG, "too many tensors");
    size_t count = 1;
    for (int i = 0; i < ndim; i++)
        if (dims[i] == 0 || !pl_mul_size(count, dims[i], &count))
            return pl_error(PL_E_ARG, "tensor '%s': dim %d is 0 or the size overflows", name, i);
    size_t size;
    if (!pl_mul_size(count, pl_dtype_size(dt), &size) || size == 0)
        return pl_error(PL_E_ARG, "tensor '%s': bad dtype or size", name);
    if (w->n == w->cap) {
        uint32_t cap = w->cap ? 2 * w->cap : 64;
        struct wtensor *t = realloc(w->t, cap * sizeof *t);
        if (!t) return pl_error(PL_E_NOMEM, "out of memory");
        w->t = t;
        w->cap = cap;
    }
    struct wtensor *t = &w->t[w->n];
    memset(t, 0, sizeof *t);
    snprintf(t->name, sizeof t->name, "%s", name);
    t->dt = dt;
    t->ndim = ndim;
    memcpy(t->dims, dims, (size_t)ndim * sizeof *dims);
    t->data = malloc(size);
    if (!t->data) return pl_error(PL_E_NOMEM, "out of memory (tensor '%s')", name);
    memcpy(t->data, data, size);
    t->size = size;
    t->scale = scale;
    t->zp = zero_point;
    w->n++;
    return PL_OK;
}

static void wr32(uint8_t *p, uint32_t v)
{
    for (int i = 0; i < 4; i++)
        p[i] = (uint8_t)(v >> (8 * i));
}

static void wr64(uint8_t *p, uint64_t v)
{
    for (int i = 0; i < 8; i++)
        p[i] = (uint8_t)(v >> (8 * i));
}

static size_t align64(size_t n)
{
    return (n + PL_PLM_ALIGN - 1) & ~(size_t)(PL_PLM_ALIGN - 1);
}

int pl_plm_writer_save(const pl_plm_writer *w, const char *path)
{
    if (w->n == 0 || w->meta_len == 0)
        return pl_error(PL_E_ARG, "%s: a model needs metadata and at least one tensor", path);
    const size_t table = align64(PL_PLM_HEADER_SIZE + w->meta_len);
    const size_t data0 = align64(table + (size_t)w->n * PL_PLM_ENTRY_SIZE);
    size_t end = data0;
    for (uint32_t i = 0; i < w->n; i++)
        end = align64(end) + w->t[i].size;
    uint8_t *buf = calloc(1, end);
    if (!buf) return pl_error(PL_E_NOMEM, "out of memory (%zu-byte model)", end);
    memcpy(buf, PL_PLM_MAGIC, 8);
    wr32(buf + 8, PL_PLM_VERSION);
    wr32(buf + 12, PL_PLM_HEADER_SIZE);
    wr64(buf + 16, end);
    wr64(buf + 24, PL_PLM_HEADER_SIZE);
    wr32(buf + 32, (uint32_t)w->meta_len);
    wr32(buf + 36, w->n);
    wr64(buf + 40, table);
    wr64(buf + 48, data0);
    memcpy(buf + PL_PLM_HEADER_SIZE, w->meta, w->meta_len);
    size_t off = data0;
    for (uint32_t i = 0; i < w->n; i++) {
        const struct wtensor *t = &w->t[i];
        uint8_t *e = buf + table + (size_t)i * PL_PLM_ENTRY_SIZE;
        off = align64(off);
        memcpy(e, t->name, strlen(t->name));
        wr32(e + 64, (uint32_t)t->dt);
        wr32(e + 68, (uint32_t)t->ndim);
        for (int d = 0; d < t->ndim; d++)
            wr32(e + 72 + 4 * d, t->dims[d]);
        wr64(e + 88, off);
        wr64(e + 96, t->size);
        uint32_t sbits;
        memcpy(&sbits, &t->scale, 4);
        wr32(e + 104, sbits);
        wr32(e + 108, (uint32_t)t->zp);
        memcpy(buf + off, t->data, t->size);
        off += t->size;
    }
    wr32(buf + 56, pl_crc32(pl_crc32(0, buf, 56), buf + 60, end - 60));

    char tmp[4096];
    if (snprintf(tmp, sizeof tmp, "%s.tmp.%ld", path, (long)getpid()) >= (int)sizeof tmp) {
        free(buf);
        return pl_error(PL_E_ARG, "output path too long");
    }
    FILE *f = fopen(tmp, "wb");
    int rc = PL_OK;
    if (!f) {
        rc = pl_error(PL_E_IO, "%s: cannot write: %s", path, strerror(errno));
    } else {
        const size_t put = fwrite(buf, 1, end, f);
        if (fclose(f) != 0 || put != end) {
            rc = pl_error(PL_E_IO, "%s: write failed: %s", path, strerror(errno));
            remove(tmp);
        } else if (rename(tmp, path) != 0) {
            rc = pl_error(PL_E_IO, "%s: cannot rename %s into place: %s", path, tmp,
                          strerror(errno));
            remove(tmp);
        }
    }
    free(buf);
    return rc;
}
