#include "core/json.h"

#include <errno.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/file.h"
#include "core/util.h"

typedef struct parser {
    const char *s;
    size_t n, i;
    const char *name;
    size_t n_values;
} parser;

static void free_value(pl_json_value *v)
{
    if (v->type == PL_JSON_STRING) free(v->str);
    if (v->type == PL_JSON_ARRAY || v->type == PL_JSON_OBJECT) {
        for (size_t k = 0; k < v->len; k++) {
            free_value(&v->items[k]);
            if (v->keys) free(v->keys[k]);
        }
        free(v->items);
        free(v->keys);
    }
    memset(v, 0, sizeof *v);
}

/* Describes the bytes at p->i for "found ..." */
static void describe_here(const parser *p, char *buf, size_t cap)
{
    if (p->i >= p->n) {
        snprintf(buf, cap, "end of input");
        return;
    }
    unsigned char c = (unsigned char)p->s[p->i];
    if (c >= 0x20 && c < 0x7f)
        snprintf(buf, cap, "'%c'", c);
    else
        snprintf(buf, cap, "byte 0x%02x", c);
}

static int fail_at(const parser *p, size_t at, const char *what)
{
    size_t line = 1, col = 1;
    for (size_t k = 0; k < at && k < p->n; k++) {
        if (p->s[k] == '\n') {
            line++;
            col = 1;
        } else {
            col++;
        }
    }
    char found[32];
    parser q = *p;
    q.i = at;
    describe_here(&q, found, sizeof found);
    return pl_error(PL_E_FORMAT, "%s: byte %zu (line %zu, column %zu): %s, found %s", p->name, at,
                    line, col, what, found);
}

static void skip_ws(parser *p)
{
    while (p->i < p->n) {
        char c = p->s[p->i];
        if (c != ' ' && c != '\t' && c != '\n' && c != '\r') break;
        p->i++;
    }
}

static int hexval(char c)
{
    if (c >= '0' && c <= '9') return c - '0';
    if (c >= 'a' && c <= 'f') return c - 'a' + 10;
    if (c >= 'A' && c <= 'F') return c - 'A' + 10;
    return -1;
}

static int read_hex4(parser *p, unsigned *out)
{
    if (p->n - p->i < 4) return fail_at(p, p->i, "expected 4 hex digits after \\u");
    unsigned v = 0;
    for (int k = 0; k < 4; k++) {
        int h = hexval(p->s[p->i + (size_t)k]);
        if (h < 0) return fail_at(p, p->i + (size_t)k, "expected a hex digit in \\u escape");
        v = v * 16 + (unsigned)h;
    }
    p->i += 4;
    *out = v;
    return 0;
}

static size_t put_utf8(char *d, unsigned cp)
{
    if (cp < 0x80) {
        d[0] = (char)cp;
        return 1;
    }
    if (cp < 0x800) {
        d[0] = (char)(0xc0 | (cp >> 6));
        d[1] = (char)(0x80 | (cp & 0x3f));
        return 2;
    }
    if (cp < 0x10000) {
        d[0] = (char)(0xe0 | (cp >> 12));
        d[1] = (char)(0x80 | ((cp >> 6) & 0x3f));
        d[2] = (char)(0x80 | (cp & 0x3f));
        return 3;
    }
    d[0] = (char)(0xf0 | (cp >> 18));
    d[1] = (char)(0x80 | ((cp >> 12) & 0x3f));
    d[2] = (char)(0x80 | ((cp >> 6) & 0x3f));
    d[3] = (char)(0x80 | (cp & 0x3f));
    return 4;
}

/* Length of a valid UTF-8 sequence starting at s[0] (at most `avail` bytes), or 0 if invalid. */
static size_t utf8_len(const unsigned char *s, size_t avail)
{
    unsigned c = s[0];
    size_t n;
    unsigned cp;
    if (c < 0x80) return 1;
    if (c >= 0xc2 && c <= 0xdf) {
        n = 2;
        cp = c & 0x1f;
    } else if (c >= 0xe0 && c <= 0xef) {
        n = 3;
        cp = c & 0x0f;
    } else if (c >= 0xf0 && c <= 0xf4) {
        n = 4;
        cp = c & 0x07;
    } else {
        return 0;
    }
    if (avail < n) return 0;
    for (size_t k = 1; k < n; k++) {
        if ((s[k] & 0xc0) != 0x80) return 0;
        cp = (cp << 6) | (s[k] & 0x3f);
    }
    if ((n == 3 && cp < 0x800) || (n == 4 && cp < 0x10000) || cp > 0x10ffff ||
        (cp >= 0xd800 && cp <= 0xdfff))
        return 0;
    return n;
}

/* p->i at the opening quote. Decoded string is never longer than the raw one. */
static int parse_string(parser *p, char **out, size_t *out_len)
{
    size_t start = p->i;
    p->i++;
    size_t end = p->i;
    /* find the closing quote first, to size the buffer */
    while (end < p->n && p->s[end] != '"')
        end += (p->s[end] == '\\') ? 2 : 1;
    if (end >= p->n) return fail_at(p, start, "unterminated string (expected a closing '\"')");
    char *d = malloc(end - p->i + 1);
    if (!d) return pl_error(PL_E_NOMEM, "%s: out of memory for a string", p->name);
    size_t k = 0;
    while (p->s[p->i] != '"') {
        unsigned char c = (unsigned char)p->s[p->i];
        if (c < 0x20) {
            free(d);
            return fail_at(p, p->i,
                           "expected a string character (control characters must be escaped)");
        }
        if (c == '\\') {
            size_t esc = p->i;
            p->i++;
            char e = p->s[p->i++];
            switch (e) {
            case '"':
                d[k++] = '"';
                break;
            case '\\':
                d[k++] = '\\';
                break;
            case '/':
                d[k++] = '/';
                break;
            case 'b':
                d[k++] = '\b';
                break;
            case 'f':
                d[k++] = '\f';
                break;
            case 'n':
                d[k++] = '\n';
                break;
            case 'r':
                d[k++] = '\r';
                break;
            case 't':
                d[k++] = '\t';
                break;
            case 'u': {
                unsigned cp, lo;
                int rc = read_hex4(p, &cp);
                if (rc < 0) {
                    free(d);
                    return rc;
                }
                if (cp >= 0xdc00 && cp <= 0xdfff) {
                    free(d);
                    return fail_at(p, esc,
                                   "expected a high surrogate before a low one in \\u escape");
                }
                if (cp >= 0xd800 && cp <= 0xdbff) {
                    if (p->n - p->i < 2 || p->s[p->i] != '\\' || p->s[p->i + 1] != 'u') {
                        free(d);
                        return fail_at(p, p->i,
                                       "expected \\u low surrogate after a high surrogate");
                    }
                    p->i += 2;
                    rc = read_hex4(p, &lo);
                    if (rc < 0) {
                        free(d);
                        return rc;
                    }
                    if (lo < 0xdc00 || lo > 0xdfff) {
                        free(d);
                        return fail_at(p, p->i - 6, "expected a low surrogate (\\udc00-\\udfff)");
                    }
                    cp = 0x10000 + ((cp - 0xd800) << 10) + (lo - 0xdc00);
                }
                /* \uXXXX takes 6 raw bytes and at most 3 decoded; a pair 12 raw and 4 decoded */
                k += put_utf8(d + k, cp);
                break;
            }
            default:
                free(d);
                return fail_at(
                    p, esc, "expected a valid escape (\\\" \\\\ \\/ \\b \\f \\n \\r \\t \\uXXXX)");
            }
            continue;
        }
        size_t m = utf8_len((const unsigned char *)p->s + p->i, end - p->i);
        if (m == 0) {
            free(d);
            return fail_at(p, p->i, "expected valid UTF-8 in string");
        }
        memcpy(d + k, p->s + p->i, m);
        k += m;
        p->i += m;
    }
    p->i++;
    d[k] = 0;
    *out = d;
    *out_len = k;
    return 0;
}

static int parse_number(parser *p, double *out)
{
    size_t start = p->i, i = p->i;
    const char *s = p->s;
    if (i < p->n && s[i] == '-') i++;
    if (i >= p->n || s[i] < '0' || s[i] > '9') return fail_at(p, i, "expected a digit in number");
    if (s[i] == '0') {
        i++;
        if (i < p->n && s[i] >= '0' && s[i] <= '9')
            return fail_at(p, i, "expected no leading zeros in number");
    } else {
        while (i < p->n && s[i] >= '0' && s[i] <= '9')
            i++;
    }
    if (i < p->n && s[i] == '.') {
        i++;
        if (i >= p->n || s[i] < '0' || s[i] > '9')
            return fail_at(p, i, "expected a digit after the decimal point");
        while (i < p->n && s[i] >= '0' && s[i] <= '9')
            i++;
    }
    if (i < p->n && (s[i] == 'e' || s[i] == 'E')) {
        i++;
        if (i < p->n && (s[i] == '+' || s[i] == '-')) i++;
        if (i >= p->n || s[i] < '0' || s[i] > '9')
            return fail_at(p, i, "expected a digit in exponent");
        while (i < p->n && s[i] >= '0' && s[i] <= '9')
            i++;
    }
    size_t len = i - start;
    char small[64], *buf = small;
    if (len >= sizeof small) {
        buf = malloc(len + 1);
        if (!buf) return pl_error(PL_E_NOMEM, "%s: out of memory for a number", p->name);
    }
    memcpy(buf, s + start, len);
    buf[len] = 0;
    errno = 0;
    double v = strtod(buf, NULL);
    int range = errno == ERANGE;
    if (buf != small) free(buf);
    if (range && isinf(v)) return fail_at(p, start, "expected a number within double range");
    if (!isfinite(v)) return fail_at(p, start, "expected a finite number");
    p->i = i;
    *out = v;
    return 0;
}

static int cmp_keys(const void *a, const void *b)
{
    return strcmp(*(char *const *)a, *(char *const *)b);
}

static int parse_value(parser *p, pl_json_value *v, int depth);

static int grow(parser *p, pl_json_value *v, size_t *cap, int with_keys)
{
    if (v->len < *cap) return 0;
    size_t nc = *cap ? *cap * 2 : 4, bytes;
    if (!pl_mul_size(nc, sizeof *v->items, &bytes))
        return pl_error(PL_E_NOMEM, "%s: too many items", p->name);
    pl_json_value *ni = realloc(v->items, bytes);
    if (!ni) return pl_error(PL_E_NOMEM, "%s: out of memory", p->name);
    v->items = ni;
    if (with_keys) {
        char **nk = realloc(v->keys, nc * sizeof *nk);
        if (!nk) return pl_error(PL_E_NOMEM, "%s: out of memory", p->name);
        v->keys = nk;
    }
    *cap = nc;
    return 0;
}

static int parse_container(parser *p, pl_json_value *v, int depth)
{
    int obj = p->s[p->i] == '{';
    char close = obj ? '}' : ']';
    size_t cap = 0;
    v->type = obj ? PL_JSON_OBJECT : PL_JSON_ARRAY;
    if (depth >= PL_JSON_MAX_DEPTH) return fail_at(p, p->i, "expected nesting depth <= 64");
    p->i++;
    skip_ws(p);
    if (p->i < p->n && p->s[p->i] == close) {
        p->i++;
        return 0;
    }
    for (;;) {
        int rc = grow(p, v, &cap, obj);
        if (rc < 0) return rc;
        pl_json_value *item = &v->items[v->len];
        memset(item, 0, sizeof *item);
        skip_ws(p);
        if (obj) {
            char *key;
            size_t klen;
            if (p->i >= p->n || p->s[p->i] != '"')
                return fail_at(p, p->i, "expected '\"' to start a member name");
            rc = parse_string(p, &key, &klen);
            if (rc < 0) return rc;
            if (strlen(key) != klen) {
                free(key);
                return fail_at(p, p->i, "expected a member name without \\u0000");
            }
            v->keys[v->len] = key;
            v->len++; /* owned from here on, even if the value fails */
            skip_ws(p);
            if (p->i >= p->n || p->s[p->i] != ':')
                return fail_at(p, p->i, "expected ':' after member name");
            p->i++;
            skip_ws(p);
            rc = parse_value(p, item, depth + 1);
            if (rc < 0) return rc;
        } else {
            v->len++;
            rc = parse_value(p, item, depth + 1);
            if (rc < 0) return rc;
        }
        skip_ws(p);
        if (p->i < p->n && p->s[p->i] == ',') {
            p->i++;
            skip_ws(p);
            if (p->i < p->n && p->s[p->i] == close)
                return fail_at(p, p->i,
                               obj ? "expected a member after ',' (no trailing commas)"
                                   : "expected a value after ',' (no trailing commas)");
            continue;
        }
        if (p->i < p->n && p->s[p->i] == close) {
            p->i++;
            break;
        }
        return fail_at(p, p->i,
                       obj ? "expected ',' or '}' in object" : "expected ',' or ']' in array");
    }
    if (obj && v->len > 1) {
        char **sorted = malloc(v->len * sizeof *sorted);
        if (!sorted) return pl_error(PL_E_NOMEM, "%s: out of memory", p->name);
        memcpy(sorted, v->keys, v->len * sizeof *sorted);
        qsort(sorted, v->len, sizeof *sorted, cmp_keys);
        for (size_t k = 1; k < v->len; k++) {
            if (!strcmp(sorted[k - 1], sorted[k])) {
                int rc =
                    pl_error(PL_E_FORMAT, "%s: object at byte %zu: duplicate member name \"%.64s\"",
                             p->name, v->offset, sorted[k]);
                free(sorted);
                return rc;
            }
        }
        free(sorted);
    }
    return 0;
}

static int literal(parser *p, const char *word)
{
    size_t m = strlen(word);
    if (p->n - p->i < m || memcmp(p->s + p->i, word, m) != 0) return -1;
    p->i += m;
    return 0;
}

static int parse_value(parser *p, pl_json_value *v, int depth)
{
    memset(v, 0, sizeof *v);
    v->offset = p->i;
    if (++p->n_values > PL_JSON_MAX_VALUES)
        return fail_at(p, p->i, "expected at most 4194304 values in the document");
    if (p->i >= p->n) return fail_at(p, p->i, "expected a value");
    char c = p->s[p->i];
    switch (c) {
    case '{':
    case '[':
        return parse_container(p, v, depth);
    case '"':
        v->type = PL_JSON_STRING;
        return parse_string(p, &v->str, &v->len);
    case 't':
        v->type = PL_JSON_TRUE;
        if (literal(p, "true") == 0) return 0;
        break;
    case 'f':
        v->type = PL_JSON_FALSE;
        if (literal(p, "false") == 0) return 0;
        break;
    case 'n':
        v->type = PL_JSON_NULL;
        if (literal(p, "null") == 0) return 0;
        break;
    default:
        if (c == '-' || (c >= '0' && c <= '9')) {
            v->type = PL_JSON_NUMBER;
            return parse_number(p, &v->number);
        }
        break;
    }
    v->type = PL_JSON_NULL;
    return fail_at(p, v->offset,
                   "expected a value (object, array, string, number, true, false or null)");
}

int pl_json_parse(const char *text, size_t len, const char *name, pl_json_doc *doc)
{
    if (!doc) return pl_error(PL_E_ARG, "pl_json_parse: doc is NULL");
    memset(doc, 0, sizeof *doc);
    if (!name) name = "json";
    if (!text && len) return pl_error(PL_E_ARG, "%s: text is NULL", name);
    if (len > PL_JSON_MAX_BYTES)
        return pl_error(PL_E_FORMAT, "%s: %zu bytes, expected at most %zu", name, len,
                        (size_t)PL_JSON_MAX_BYTES);
    parser p = {text ? text : "", len, 0, name, 0};
    skip_ws(&p);
    int rc = parse_value(&p, &doc->root, 0);
    if (rc == 0) {
        skip_ws(&p);
        if (p.i != p.n) rc = fail_at(&p, p.i, "expected end of input after the value");
    }
    if (rc < 0) free_value(&doc->root);
    return rc;
}

int pl_json_read_file(const char *path, pl_json_doc *doc)
{
    if (!doc || !path) return pl_error(PL_E_ARG, "pl_json_read_file: NULL argument");
    memset(doc, 0, sizeof *doc);
    FILE *f;
    int rc = pl_file_fopen_regular(path, NULL, &f);
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

void pl_json_free(pl_json_doc *doc)
{
    if (doc) free_value(&doc->root);
}

const pl_json_value *pl_json_get(const pl_json_value *v, const char *key)
{
    if (!v || v->type != PL_JSON_OBJECT || !key) return NULL;
    for (size_t k = 0; k < v->len; k++)
        if (!strcmp(v->keys[k], key)) return &v->items[k];
    return NULL;
}

const char *pl_json_type_name(pl_json_type t)
{
    switch (t) {
    case PL_JSON_NULL:
        return "null";
    case PL_JSON_FALSE:
        return "false";
    case PL_JSON_TRUE:
        return "true";
    case PL_JSON_NUMBER:
        return "number";
    case PL_JSON_STRING:
        return "string";
    case PL_JSON_ARRAY:
        return "array";
    case PL_JSON_OBJECT:
        return "object";
    }
    return "?";
}
