/* JSON files (port/json_file.h). */
#include "port/json_file.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/file.h"
#include "core/util.h"
#include "light/lights_json.h"

int pl_json_read_file(const char *path, pl_json_doc *doc)
{
    if (!doc || !path) return pl_error(PL_E_ARG, "pl_json_read_file: NULL argument");
    memset(doc, 0, sizeof *doc);
    FILE *f;
    int rc = pl_file_fopen_regular(path, NULL, &f); /* a FIFO is refused, never waited on */
    if (rc < 0) return rc;
    size_t cap = 4096, n = 0;
    char *buf = malloc(cap);
    if (!buf) {
        fclose(f);
        return pl_error(PL_E_NOMEM, "%s: out of memory", path);
    }
    for (;;) {
        if (n == cap) {
            if (cap > PL_JSON_MAX_BYTES) {
                rc = pl_error(PL_E_FORMAT, "%s: larger than %zu bytes", path,
                              (size_t)PL_JSON_MAX_BYTES);
                goto out;
            }
            char *nb = realloc(buf, cap * 2);
            if (!nb) {
                rc = pl_error(PL_E_NOMEM, "%s: out of memory", path);
                goto out;
            }
            buf = nb;
            cap *= 2;
        }
        size_t got = fread(buf + n, 1, cap - n, f);
        n += got;
        if (got == 0) {
            if (ferror(f)) {
                rc = pl_error(PL_E_IO, "%s: cannot read: %s", path, strerror(errno));
                goto out;
            }
            break;
        }
    }
    rc = pl_json_parse(buf, n, path, doc);
out:
    free(buf);
    fclose(f);
    return rc;
}

int pl_lighting_read_json(const char *path, pl_lighting *out)
{
    if (!out || !path) return pl_error(PL_E_ARG, "pl_lighting_read_json: NULL argument");
    pl_json_doc doc;
    int rc = pl_json_read_file(path, &doc);
    if (rc < 0) return rc;
    rc = pl_lighting_from_json(path, &doc.root, out);
    pl_json_free(&doc);
    return rc;
}

int pl_ridge_load(const char *path, pl_ridge **out)
{
    if (!path || !out) return pl_error(PL_E_ARG, "pl_ridge_load: NULL argument");
    *out = NULL;
    pl_json_doc doc;
    int rc = pl_json_read_file(path, &doc);
    if (rc < 0) return rc;
    return pl_ridge_from_json(path, &doc, out);
}
