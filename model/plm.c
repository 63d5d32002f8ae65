#include "model/plm.h"

#include <errno.h>
#include <math.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "core/file.h"
#include "core/util.h"

static uint32_t crc_table[8][256];

static void crc_init(void)
{
    for (uint32_t i = 0; i < 256; i++) {
        uint32_t c = i;
        for (int k = 0; k < 8; k++) c = (c & 1) ? 0xEDB88320u ^ (c >> 1) : c >> 1;
        crc_table[0][i] = c;
    }
    for (uint32_t i = 0; i < 256; i++)
        for (int t = 1; t < 8; t++)
            crc_table[t][i] = (crc_table[t - 1][i] >> 8) ^ crc_table[0][crc_table[t - 1][i] & 0xff];
}

uint32_t pl_crc32(uint32_t crc, const void *data, size_t len)
{
    static pthread_once_t once = PTHREAD_ONCE_INIT;
    pthread_once(&once, crc_init);
    const uint8_t *p = data;
    crc = ~crc;
    while (len >= 8) { /* slicing-by-8: eight table lookups per 8 bytes */
        uint32_t lo = crc ^ ((uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 |
                             (uint32_t)p[3] << 24);
        uint32_t hi = (uint32_t)p[4] | (uint32_t)p[5] << 8 | (uint32_t)p[6] << 16 |
                      (uint32_t)p[7] << 24;
        crc = crc_table[7][lo & 0xff] ^ crc_table[6][(lo >> 8) & 0xff] ^
              crc_table[5][(lo >> 16) & 0xff] ^ crc_table[4][lo >> 24] ^
              crc_table[3][hi & 0xff] ^ crc_table[2][(hi >> 8) & 0xff] ^
              crc_table[1][(hi >> 16) & 0xff] ^ crc_table[0][hi >> 24];
        p += 8;
        len -= 8;
    }
    while (len--) crc = crc_table[0][(crc ^ *p++) & 0xff] ^ (crc >> 8);
    return ~crc;
}

size_t pl_dtype_size(pl_dtype dt)
{
    switch (dt) {
    case PL_DT_F32: return 4;
    case PL_DT_S8: return 1;
    case PL_DT_S32: return 4;
    case PL_DT_U8: return 1;
    }
    return 0;
}

const char *pl_dtype_name(pl_dtype dt)
{
    switch (dt) {
    case PL_DT_F32: return "f32";
    case PL_DT_S8: return "s8";
    case PL_DT_S32: return "s32";
    case PL_DT_U8: return "u8";
    }
    return "?";
}

static uint32_t rd32(const uint8_t *p)
{
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

static uint64_t rd64(const uint8_t *p)
{
    return (uint64_t)rd32(p) | (uint64_t)rd32(p + 4) << 32;
}

static int cmp_offset(const void *a, const void *b)
{
    const pl_tensor *x = *(const pl_tensor *const *)a, *y = *(const pl_tensor *const *)b;
    const uint8_t *px = x->data, *py = y->data;
    return px < py ? -1 : px > py;
}

/* Splits the metadata text into key/value pairs in place. */
static int parse_meta(pl_plm *plm, const char *path)
{
    int lines = 1;
    for (const char *c = plm->meta; *c; c++) lines += *c == '\n';
    plm->meta_keys = calloc((size_t)lines, sizeof *plm->meta_keys);
    plm->meta_vals = calloc((size_t)lines, sizeof *plm->meta_vals);
    if (!plm->meta_keys || !plm->meta_vals) return pl_error(PL_E_NOMEM, "%s: out of memory", path);
    char *line = plm->meta;
    int lineno = 0;
    while (line && *line) {
        char *next = strchr(line, '\n');
        if (next) *next++ = '\0';
        lineno++;
        if (*line) {
            char *eq = strchr(line, '=');
            if (!eq || eq == line)
                return pl_error(PL_E_FORMAT, "%s: metadata line %d is not key=value: '%.40s'", path,
                                lineno, line);
            *eq = '\0';
            for (int i = 0; i < plm->n_meta; i++)
                if (!strcmp(plm->meta_keys[i], line))
                    return pl_error(PL_E_FORMAT, "%s: metadata key '%s' appears twice", path, line);
            plm->meta_keys[plm->n_meta] = line;
            plm->meta_vals[plm->n_meta] = eq + 1;
            plm->n_meta++;
        }
        line = next;
    }
    return PL_OK;
}

static int check_entry(pl_plm *plm, uint32_t i, const uint8_t *e, uint64_t data_offset)
{
    const char *path = plm->path;
    pl_tensor *t = &plm->tensors[i];
    size_t nlen = strnlen((const char *)e, PL_PLM_NAME_MAX);
    if (nlen == 0 || nlen == PL_PLM_NAME_MAX)
        return pl_error(PL_E_FORMAT, "%s: tensor %u: name is empty or not NUL-terminated", path, i);
    for (size_t k = 0; k < nlen; k++) {
        char c = (char)e[k];
        if (!((c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
              c == '_' || c == '.'))
            return pl_error(PL_E_FORMAT, "%s: tensor %u: name has invalid byte 0x%02x", path, i,
                            (unsigned char)c);
    }
    for (size_t k = nlen; k < PL_PLM_NAME_MAX; k++)
        if (e[k]) return pl_error(PL_E_FORMAT, "%s: tensor %u: name padding not zero", path, i);
    memcpy(t->name, e, nlen + 1);

    uint32_t dtype = rd32(e + 64), ndim = rd32(e + 68);
    if (dtype < PL_DT_F32 || dtype > PL_DT_U8)
        return pl_error(PL_E_FORMAT, "%s: tensor '%s': unknown dtype %u", path, t->name, dtype);
    if (ndim < 1 || ndim > 4)
        return pl_error(PL_E_FORMAT, "%s: tensor '%s': ndim %u not in 1..4", path, t->name, ndim);
    t->dtype = (pl_dtype)dtype;
    t->ndim = (int)ndim;
    size_t count = 1;
    for (uint32_t d = 0; d < 4; d++) {
        t->dims[d] = rd32(e + 72 + 4 * d);
        if (d < ndim) {
            if (t->dims[d] == 0)
                return pl_error(PL_E_FORMAT, "%s: tensor '%s': dim %u is 0", path, t->name, d);
            if (!pl_mul_size(count, t->dims[d], &count))
                return pl_error(PL_E_FORMAT, "%s: tensor '%s': element count overflows", path,
                                t->name);
        } else if (t->dims[d] != 0) {
            return pl_error(PL_E_FORMAT, "%s: tensor '%s': unused dim %u is %u, expected 0", path,
                            t->name, d, t->dims[d]);
        }
    }
    size_t bytes;
    if (!pl_mul_size(count, pl_dtype_size(t->dtype), &bytes))
        return pl_error(PL_E_FORMAT, "%s: tensor '%s': byte size overflows", path, t->name);
    uint64_t off = rd64(e + 88), size = rd64(e + 96), end;
    if (size != bytes)
        return pl_error(PL_E_FORMAT, "%s: tensor '%s': size %llu, expected %zu for its shape", path,
                        t->name, (unsigned long long)size, bytes);
    if (off % PL_PLM_ALIGN || off < data_offset)
        return pl_error(PL_E_FORMAT, "%s: tensor '%s': offset %llu not 64-aligned or before data",
                        path, t->name, (unsigned long long)off);
    if (!pl_add_u64(off, size, &end) || end > plm->n_bytes)
        return pl_error(PL_E_FORMAT, "%s: tensor '%s': data [%llu, +%llu) past end of file (%zu)",
                        path, t->name, (unsigned long long)off, (unsigned long long)size,
                        plm->n_bytes);
    memcpy(&t->scale, e + 104, 4);
    t->zero_point = (int32_t)rd32(e + 108);
    for (int k = 112; k < 128; k++)
        if (e[k]) return pl_error(PL_E_FORMAT, "%s: tensor '%s': reserved bytes not zero", path,
                                  t->name);
    if (!isfinite(t->scale))
        return pl_error(PL_E_FORMAT, "%s: tensor '%s': scale is not finite", path, t->name);
    t->data = plm->bytes + off;
    t->size = (size_t)size;
    t->count = count;
    if (t->dtype == PL_DT_F32) {
        const float *f = t->data;
        for (size_t k = 0; k < count; k++)
            if (!isfinite(f[k]))
                return pl_error(PL_E_FORMAT, "%s: tensor '%s': element %zu is %s", path, t->name,
                                k, isnan(f[k]) ? "NaN" : "Inf");
    }
    return PL_OK;
}

/* The buffer a model's n bytes live in: 64-byte aligned as the tensors need, the tail past n
 * zeroed; *buf is NULL with the error returned when the size does not fit or it cannot be had. */
static int alloc_bytes(const char *path, uint64_t n, uint8_t **buf)
{
    *buf = NULL;
    if (n < PL_PLM_HEADER_SIZE)
        return pl_error(PL_E_FORMAT, "%s: %llu bytes, too short for a .plm header (64)", path,
                        (unsigned long long)n);
    size_t cap;
    if (n > SIZE_MAX || !pl_add_size((size_t)n, PL_PLM_ALIGN - 1, &cap))
        return pl_error(PL_E_NOMEM, "%s: %llu bytes do not fit in memory", path,
                        (unsigned long long)n);
    cap -= cap % PL_PLM_ALIGN; /* aligned_alloc wants a multiple of the alignment */
    *buf = aligned_alloc(PL_PLM_ALIGN, cap);
    if (!*buf)
        return pl_error(PL_E_NOMEM, "%s: cannot allocate %zu bytes for the model", path, cap);
    memset(*buf + n, 0, cap - (size_t)n);
    return PL_OK;
}

/* Reads the whole file into memory this process owns, so that nothing done to the file
 * afterwards (truncated, overwritten, replaced) reaches a loaded model: a mapping of it would
 * fault (SIGBUS) on truncation and show overwritten bytes. A file that changes while it is read
 * fails here or at the checksum. */
static int read_whole(const char *path, pl_plm *plm)
{
    int fd;
    int64_t size;
    int rc = pl_file_open_regular(path, "model", &fd, &size);
    if (rc < 0) return rc;
    uint8_t *buf;
    if ((rc = alloc_bytes(path, (uint64_t)size, &buf)) < 0) {
        close(fd);
        return rc;
    }
    const size_t n = (size_t)size;
    size_t got = 0;
    while (got < n) {
        ssize_t r = read(fd, buf + got, n - got);
        if (r < 0 && errno == EINTR) continue;
        if (r < 0) {
            rc = pl_error(PL_E_IO, "%s: read error at byte %zu: %s", path, got, strerror(errno));
            break;
        }
        if (r == 0) {
            rc = pl_error(PL_E_IO,
                          "%s: file shrank to %zu bytes while being read (%zu expected): "
                          "is it being rewritten?",
                          path, got, n);
            break;
        }
        got += (size_t)r;
    }
    close(fd);
    if (rc < 0) {
        free(buf);
        return rc;
    }
    plm->bytes = buf;
    plm->n_bytes = n;
    return PL_OK;
}

/* The memory twin of read_whole: a copy of the caller's n bytes. */
static int copy_whole(const void *data, size_t n, const char *path, pl_plm *plm)
{
    uint8_t *buf;
    int rc = alloc_bytes(path, n, &buf);
    if (rc < 0) return rc;
    memcpy(buf, data, n);
    plm->bytes = buf;
    plm->n_bytes = n;
    return PL_OK;
}

static int validate(const char *path, pl_plm *plm);

int pl_plm_open(const char *path, pl_plm *plm)
{
    memset(plm, 0, sizeof *plm);
    snprintf(plm->path, sizeof plm->path, "%s", path ? path : "(null)");
    if (!path) return pl_error(PL_E_ARG, "model path is NULL");
    int rc = read_whole(path, plm);
    if (rc < 0) return rc;
    return validate(path, plm);
}

int pl_plm_open_memory(const void *data, size_t size, pl_plm *plm)
{
    static const char name[] = "<memory>";
    memset(plm, 0, sizeof *plm);
    snprintf(plm->path, sizeof plm->path, "%s", name);
    if (!data || size == 0)
        return pl_error(PL_E_ARG, "%s: model buffer is %s", name, data ? "empty" : "NULL");
    int rc = copy_whole(data, size, name, plm);
    if (rc < 0) return rc;
    return validate(name, plm);
}

/* Everything the format promises, checked on the owned copy (plm->bytes); closes plm on failure.
 */
static int validate(const char *path, pl_plm *plm)
{
    int rc;
    const uint8_t *h = plm->bytes;
    if (memcmp(h, PL_PLM_MAGIC "\0", 8)) {
        rc = pl_error(PL_E_FORMAT, "%s: not a parlight model (bad magic)", path);
        goto fail;
    }
    uint32_t version = rd32(h + 8), header_size = rd32(h + 12), meta_size = rd32(h + 32);
    uint32_t n_tensors = rd32(h + 36), crc = rd32(h + 56);
    uint64_t file_size = rd64(h + 16), meta_offset = rd64(h + 24), table_offset = rd64(h + 40);
    uint64_t data_offset = rd64(h + 48), end;
    if (version != PL_PLM_VERSION) {
        rc = pl_error(PL_E_FORMAT, "%s: format version %u, this parlight reads version %u", path,
                      version, PL_PLM_VERSION);
        goto fail;
    }
    if (header_size != PL_PLM_HEADER_SIZE || rd32(h + 60) != 0) {
        rc = pl_error(PL_E_FORMAT, "%s: header size %u (expected 64) or reserved field not 0",
                      path, header_size);
        goto fail;
    }
    if (file_size != plm->n_bytes) {
        rc = pl_error(PL_E_FORMAT, "%s: header says %llu bytes, %s has %zu (truncated?)", path,
                      (unsigned long long)file_size, strcmp(path, "<memory>") ? "file" : "buffer",
                      plm->n_bytes);
        goto fail;
    }
    if (meta_offset != PL_PLM_HEADER_SIZE || meta_size < 1 || meta_size > PL_PLM_MAX_META ||
        meta_offset + meta_size > file_size) {
        rc = pl_error(PL_E_FORMAT, "%s: metadata at %llu size %u out of bounds", path,
                      (unsigned long long)meta_offset, meta_size);
        goto fail;
    }
    if (n_tensors < 1 || n_tensors > PL_PLM_MAX_TENSORS) {
        rc = pl_error(PL_E_FORMAT, "%s: %u tensors, expected 1..%u", path, n_tensors,
                      PL_PLM_MAX_TENSORS);
        goto fail;
    }
    if (table_offset % PL_PLM_ALIGN || table_offset < meta_offset + meta_size ||
        !pl_add_u64(table_offset, (uint64_t)n_tensors * PL_PLM_ENTRY_SIZE, &end) ||
        end > data_offset || data_offset % PL_PLM_ALIGN || data_offset > file_size) {
        rc = pl_error(PL_E_FORMAT, "%s: tensor table at %llu (%u entries) or data at %llu out of "
                      "bounds or misaligned", path, (unsigned long long)table_offset, n_tensors,
                      (unsigned long long)data_offset);
        goto fail;
    }
    uint32_t actual = pl_crc32(pl_crc32(0, plm->bytes, 56), plm->bytes + 60, plm->n_bytes - 60);
    if (actual != crc) {
        rc = pl_error(PL_E_FORMAT, "%s: checksum mismatch (header %08x, data %08x): file corrupted",
                      path, crc, actual);
        goto fail;
    }

    plm->meta = malloc(meta_size + 1u);
    if (!plm->meta) {
        rc = pl_error(PL_E_NOMEM, "%s: out of memory", path);
        goto fail;
    }
    memcpy(plm->meta, plm->bytes + meta_offset, meta_size);
    plm->meta[meta_size] = '\0';
    if (strlen(plm->meta) != meta_size) {
        rc = pl_error(PL_E_FORMAT, "%s: metadata contains a NUL byte", path);
        goto fail;
    }
    if ((rc = parse_meta(plm, path)) < 0) goto fail;

    plm->tensors = calloc(n_tensors, sizeof *plm->tensors);
    const pl_tensor **order = calloc(n_tensors, sizeof *order);
    if (!plm->tensors || !order) {
        free(order);
        rc = pl_error(PL_E_NOMEM, "%s: out of memory", path);
        goto fail;
    }
    plm->n_tensors = n_tensors;
    for (uint32_t i = 0; i < n_tensors; i++) {
        rc = check_entry(plm, i, plm->bytes + table_offset + (size_t)i * PL_PLM_ENTRY_SIZE,
                         data_offset);
        if (rc < 0) break;
        for (uint32_t j = 0; j < i; j++)
            if (!strcmp(plm->tensors[j].name, plm->tensors[i].name)) {
                rc = pl_error(PL_E_FORMAT, "%s: tensor '%s' appears twice", path,
                              plm->tensors[i].name);
                break;
            }
        if (rc < 0) break;
        order[i] = &plm->tensors[i];
    }
    if (rc == PL_OK) {
        qsort(order, n_tensors, sizeof *order, cmp_offset);
        for (uint32_t i = 1; i < n_tensors; i++) {
            const uint8_t *prev_end = (const uint8_t *)order[i - 1]->data + order[i - 1]->size;
            if ((const uint8_t *)order[i]->data < prev_end) {
                rc = pl_error(PL_E_FORMAT, "%s: tensors '%s' and '%s' overlap", path,
                              order[i - 1]->name, order[i]->name);
                break;
            }
        }
    }
    free(order);
    if (rc < 0) goto fail;
    return PL_OK;

fail:
    pl_plm_close(plm);
    return rc;
}

void pl_plm_close(pl_plm *plm)
{
    if (!plm) return;
    free((void *)plm->bytes);
    free(plm->meta);
    free(plm->meta_keys);
    free(plm->meta_vals);
    free(plm->tensors);
    char path[sizeof plm->path];
    memcpy(path, plm->path, sizeof path);
    memset(plm, 0, sizeof *plm);
    memcpy(plm->path, path, sizeof path);
}

const pl_tensor *pl_plm_tensor(const pl_plm *plm, const char *name)
{
    for (uint32_t i = 0; i < plm->n_tensors; i++)
        if (!strcmp(plm->tensors[i].name, name)) return &plm->tensors[i];
    return NULL;
}

const char *pl_plm_meta(const pl_plm *plm, const char *key)
{
    for (int i = 0; i < plm->n_meta; i++)
        if (!strcmp(plm->meta_keys[i], key)) return plm->meta_vals[i];
    return NULL;
}
