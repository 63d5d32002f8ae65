/* `--poses FILE` (app/poses.h). */
#include "app/poses.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/file.h"
#include "core/json.h"
#include "core/util.h"
#include "light/pose.h"

#define POSES_MAX 10000000 /* lines: a day of 100 Hz poses */

/* A key as the integer written in the text (a double would round nanosecond timestamps of
 * this century, ~1.7e18 > 2^53): digits only, within int64. */
static int exact_integer(const char *text, size_t len, const pl_json_value *v, int64_t *out)
{
    int64_t x = 0;
    size_t i = v->offset, digits = 0;
    for (; i < len && text[i] >= '0' && text[i] <= '9'; i++, digits++) {
        if (x > (INT64_MAX - (text[i] - '0')) / 10) return 0;
        x = x * 10 + (text[i] - '0');
    }
    if (digits == 0) return 0;
    if (i < len && (text[i] == '.' || text[i] == 'e' || text[i] == 'E')) return 0;
    *out = x;
    return 1;
}

/* One line's key, quaternion and exposure (0 when it has none). */
static int parse_line(const cli_poses *p, const char *text, size_t len, long line_no, int *by_time,
                      int64_t *key, double q[4], double *exposure)
{
    char name[600];
    snprintf(name, sizeof name, "%s:%ld", p->path, line_no);
    pl_json_doc doc;
    if (pl_json_parse(text, len, name, &doc) < 0) return PL_E_FORMAT;
    int rc = 0;
    const pl_json_value *fr = pl_json_get(&doc.root, "frame"), *t = pl_json_get(&doc.root, "t_ns");
    const pl_json_value *jq = pl_json_get(&doc.root, "q"), *k = fr ? fr : t;
    const pl_json_value *ex = pl_json_get(&doc.root, "exposure");
    if (doc.root.type != PL_JSON_OBJECT)
        rc = pl_error(PL_E_FORMAT, "%s: expected an object {\"frame\"|\"t_ns\": N, \"q\": [w, x, "
                                   "y, z]}", name);
    else if (!k || (fr && t))
        rc = pl_error(PL_E_FORMAT, "%s: expected exactly one of \"frame\" and \"t_ns\"", name);
    else if (k->type != PL_JSON_NUMBER || !exact_integer(text, len, k, key))
        rc = pl_error(PL_E_FORMAT, "%s: \"%s\" must be a non-negative integer", name,
                      fr ? "frame" : "t_ns");
    else if (!jq || jq->type != PL_JSON_ARRAY || jq->len != 4)
        rc = pl_error(PL_E_FORMAT, "%s: \"q\" must be an array of 4 numbers [w, x, y, z]", name);
    for (size_t i = 0; rc == 0 && i < 4; i++) {
        if (jq->items[i].type != PL_JSON_NUMBER)
            rc = pl_error(PL_E_FORMAT, "%s: \"q\"[%zu] is a %s, expected a number", name, i,
                          pl_json_type_name(jq->items[i].type));
        else
            q[i] = jq->items[i].number;
    }
    *exposure = 0;
    if (rc == 0 && ex) {
        if (ex->type != PL_JSON_NUMBER || !(ex->number > 0) || !isfinite(ex->number))
            rc = pl_error(PL_E_FORMAT, "%s: \"exposure\" must be a number > 0", name);
        else
            *exposure = ex->number;
    }
    double R[9];
    if (rc == 0 && pl_quat_to_rotation(q, R) < 0) {
        char why[300];
        snprintf(why, sizeof why, "%s", pl_last_error());
        rc = pl_error(PL_E_FORMAT, "%s: %s", name, why);
    }
    if (rc == 0) *by_time = t != NULL;
    pl_json_free(&doc);
    return rc;
}

int cli_poses_load(const char *path, cli_poses *p)
{
    memset(p, 0, sizeof *p);
    snprintf(p->path, sizeof p->path, "%s", path);
    FILE *f = NULL;
    int rc = pl_file_fopen_regular(path, "poses file", &f);
    if (rc < 0) return rc;
    char *line = NULL;
    size_t cap = 0, n_cap = 0;
    ssize_t len;
    long line_no = 0;
    while (rc == 0 && (len = getline(&line, &cap, f)) >= 0) {
        line_no++;
        while (len > 0 && (line[len - 1] == '\n' || line[len - 1] == '\r' || line[len - 1] == ' '))
            len--;
        if (len == 0) continue;
        cli_pose e;
        int by_time;
        rc = parse_line(p, line, (size_t)len, line_no, &by_time, &e.key, e.q, &e.exposure);
        if (rc < 0) break;
        if (p->n == 0) {
            p->by_time = by_time;
        } else if (by_time != p->by_time) {
            rc = pl_error(PL_E_FORMAT, "%s:%ld: keyed by %s, the lines before by %s", path,
                          line_no, by_time ? "t_ns" : "frame", p->by_time ? "t_ns" : "frame");
        } else if (e.key <= p->pose[p->n - 1].key) {
            rc = pl_error(PL_E_FORMAT, "%s:%ld: %s %lld comes after %lld: keys must increase",
                          path, line_no, by_time ? "t_ns" : "frame", (long long)e.key,
                          (long long)p->pose[p->n - 1].key);
        }
        if (rc == 0 && p->n == POSES_MAX)
            rc = pl_error(PL_E_FORMAT, "%s: more than %d poses", path, POSES_MAX);
        if (rc == 0 && p->n == n_cap) {
            n_cap = n_cap ? 2 * n_cap : 1024;
            cli_pose *g = realloc(p->pose, n_cap * sizeof *g);
            if (!g)
                rc = pl_error(PL_E_NOMEM, "%s: out of memory for %zu poses", path, n_cap);
            else
                p->pose = g;
        }
        if (rc == 0) p->pose[p->n++] = e;
    }
    if (rc == 0 && ferror(f)) rc = pl_error(PL_E_IO, "%s: read error", path);
    if (rc == 0 && p->n == 0) rc = pl_error(PL_E_FORMAT, "%s: no poses", path);
    free(line);
    fclose(f);
    if (rc < 0) cli_poses_free(p);
    return rc;
}

int cli_poses_lookup(const cli_poses *p, int64_t frame, int64_t t_ns, double q[4], double *exposure)
{
    double unused;
    if (!exposure) exposure = &unused;
    *exposure = 0;
    int64_t key = p->by_time ? t_ns : frame;
    size_t lo = 0, hi = p->n; /* first pose with key >= the frame's */
    while (lo < hi) {
        size_t mid = lo + (hi - lo) / 2;
        if (p->pose[mid].key < key)
            lo = mid + 1;
        else
            hi = mid;
    }
    if (lo < p->n && p->pose[lo].key == key) {
        memcpy(q, p->pose[lo].q, 4 * sizeof *q);
        *exposure = p->pose[lo].exposure;
        return 0;
    }
    if (!p->by_time)
        return pl_error(PL_E_ARG, "%s: no pose for frame %lld", p->path, (long long)frame);
    if (lo == 0 || lo == p->n)
        return pl_error(PL_E_ARG,
                        "%s: frame %lld at t_ns %lld is outside the poses' span (%lld..%lld)",
                        p->path, (long long)frame, (long long)t_ns, (long long)p->pose[0].key,
                        (long long)p->pose[p->n - 1].key);
    const cli_pose *a = &p->pose[lo - 1], *b = &p->pose[lo];
    double qa[4], qb[4], na = 0, nb = 0;
    for (int k = 0; k < 4; k++) {
        na += a->q[k] * a->q[k];
        nb += b->q[k] * b->q[k];
    }
    for (int k = 0; k < 4; k++) {
        qa[k] = a->q[k] / sqrt(na);
        qb[k] = b->q[k] / sqrt(nb);
    }
    const double u = (double)(key - a->key) / (double)(b->key - a->key);
    pl_quat_slerp(qa, qb, u, q);
    if (a->exposure > 0 && b->exposure > 0)
        *exposure = exp2((1 - u) * log2(a->exposure) + u * log2(b->exposure));
    return 0;
}

void cli_poses_free(cli_poses *p)
{
    free(p->pose);
    p->pose = NULL;
    p->n = 0;
}
