#include "light/lights_json.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>

#include "core/json.h"
#include "core/util.h"

/* Reads a finite number >= lo (or > lo when strict) from v into *out; `what` names the field. */
static int get_number(const char *name, const pl_json_value *v, const char *what, double lo,
                      int strict, float *out)
{
    if (!v) return pl_error(PL_E_FORMAT, "%s: missing field %s", name, what);
    if (v->type != PL_JSON_NUMBER)
        return pl_error(PL_E_FORMAT, "%s: %s: expected a number, found %s", name, what,
                        pl_json_type_name(v->type));
    double x = v->number;
    if (!isfinite(x) || fabs(x) > 3.0e38)
        return pl_error(PL_E_FORMAT, "%s: %s: expected a finite float, found %g", name, what, x);
    /* checked as the float it is kept as: 1e-50 > 0 as a double is 0 as a float */
    const float f = (float)x;
    if (strict ? !(x > lo && f > (float)lo) : !(x >= lo))
        return pl_error(PL_E_FORMAT, "%s: %s: expected a number %s %g, found %g", name, what,
                        strict ? ">" : ">=", lo, x);
    *out = f;
    return 0;
}

static int get_vec3(const char *name, const pl_json_value *v, const char *what, double lo,
                    float out[3])
{
    if (!v) return pl_error(PL_E_FORMAT, "%s: missing field %s", name, what);
    if (v->type != PL_JSON_ARRAY || v->len != 3)
        return pl_error(PL_E_FORMAT, "%s: %s: expected an array of 3 numbers, found %s%s", name,
                        what, v->type == PL_JSON_ARRAY ? "an array of length " : "",
                        v->type == PL_JSON_ARRAY ? (v->len < 3 ? "< 3" : "> 3")
                                                 : pl_json_type_name(v->type));
    char sub[96];
    for (int k = 0; k < 3; k++) {
        snprintf(sub, sizeof sub, "%s[%d]", what, k);
        int rc = get_number(name, &v->items[k], sub, lo, 0, &out[k]);
        if (rc < 0) return rc;
    }
    return 0;
}

int pl_lighting_from_json(const char *name, const pl_json_value *root, pl_lighting *out)
{
    pl_lighting L;
    memset(&L, 0, sizeof L);
    if (root->type != PL_JSON_OBJECT)
        return pl_error(PL_E_FORMAT, "%s: expected a JSON object at the top, found %s", name,
                        pl_json_type_name(root->type));
    const pl_json_value *lights = pl_json_get(root, "lights");
    if (!lights) return pl_error(PL_E_FORMAT, "%s: missing field \"lights\"", name);
    if (lights->type != PL_JSON_ARRAY)
        return pl_error(PL_E_FORMAT, "%s: lights: expected an array, found %s", name,
                        pl_json_type_name(lights->type));
    if (lights->len > PL_MAX_LIGHTS)
        return pl_error(PL_E_FORMAT, "%s: lights: %zu lights, expected at most %d", name,
                        lights->len, PL_MAX_LIGHTS);
    char what[64];
    for (size_t i = 0; i < lights->len; i++) {
        const pl_json_value *o = &lights->items[i];
        pl_light *l = &L.lights[i];
        int rc;
        if (o->type != PL_JSON_OBJECT)
            return pl_error(PL_E_FORMAT, "%s: lights[%zu]: expected an object, found %s", name, i,
                            pl_json_type_name(o->type));
        snprintf(what, sizeof what, "lights[%zu].dir", i);
        if ((rc = get_vec3(name, pl_json_get(o, "dir"), what, -3.0e38, l->dir)) < 0) return rc;
        double n = sqrt((double)l->dir[0] * l->dir[0] + (double)l->dir[1] * l->dir[1] +
                        (double)l->dir[2] * l->dir[2]);
        if (!(n > 1e-6) || !isfinite(n))
            return pl_error(PL_E_FORMAT, "%s: %s: expected a non-zero direction, found length %g",
                            name, what, n);
        for (int k = 0; k < 3; k++)
            l->dir[k] = (float)(l->dir[k] / n);
        snprintf(what, sizeof what, "lights[%zu].distance_m", i);
        if ((rc = get_number(name, pl_json_get(o, "distance_m"), what, 0, 1, &l->distance_m)) < 0)
            return rc;
        snprintf(what, sizeof what, "lights[%zu].solid_angle_sr", i);
        if ((rc = get_number(name, pl_json_get(o, "solid_angle_sr"), what, 0, 1,
                             &l->solid_angle_sr)) < 0)
            return rc;
        snprintf(what, sizeof what, "lights[%zu].rgb", i);
        if ((rc = get_vec3(name, pl_json_get(o, "rgb"), what, 0, l->rgb)) < 0) return rc;
    }
    L.n_lights = (int)lights->len;
    int rc = get_vec3(name, pl_json_get(root, "ambient"), "ambient", 0, L.ambient);
    if (rc < 0) return rc;
    *out = L;
    return 0;
}

int pl_lighting_parse_json(const char *text, size_t len, pl_lighting *out)
{
    if (!out) return pl_error(PL_E_ARG, "pl_lighting_parse_json: out is NULL");
    pl_json_doc doc;
    int rc = pl_json_parse(text, len, "lights json", &doc);
    if (rc < 0) return rc;
    rc = pl_lighting_from_json("lights json", &doc.root, out);
    pl_json_free(&doc);
    return rc;
}

typedef struct sbuf {
    char *p;
    size_t cap, n;
    int overflow;
} sbuf;

static void put(sbuf *b, const char *fmt, ...) __attribute__((format(printf, 2, 3)));

static void put(sbuf *b, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    size_t room = b->cap > b->n ? b->cap - b->n : 0;
    int w = vsnprintf(room ? b->p + b->n : NULL, room, fmt, ap);
    va_end(ap);
    if (w < 0 || (size_t)w >= room) {
        b->overflow = 1;
        b->n = b->cap;
        return;
    }
    b->n += (size_t)w;
}

/* JSON has no NaN/Inf: such values (which a valid lighting never has) are written as 0. */
static double fin(float x)
{
    return isfinite(x) ? (double)x : 0.0;
}

int pl_lighting_format_json(const pl_lighting *L, char *buf, size_t cap)
{
    if (!L || !buf || cap == 0)
        return pl_error(PL_E_ARG, "pl_lighting_format_json: NULL or empty buffer");
    if (L->n_lights < 0 || L->n_lights > PL_MAX_LIGHTS)
        return pl_error(PL_E_ARG, "pl_lighting_format_json: n_lights %d, expected 0..%d",
                        L->n_lights, PL_MAX_LIGHTS);
    sbuf b = {buf, cap, 0, 0};
    put(&b, "\"lights\":[");
    for (int i = 0; i < L->n_lights; i++) {
        const pl_light *l = &L->lights[i];
        put(&b,
            "%s{\"dir\":[%.9g,%.9g,%.9g],\"distance_m\":%.9g,\"solid_angle_sr\":%.9g,"
            "\"rgb\":[%.9g,%.9g,%.9g]}",
            i ? "," : "", fin(l->dir[0]), fin(l->dir[1]), fin(l->dir[2]), fin(l->distance_m),
            fin(l->solid_angle_sr), fin(l->rgb[0]), fin(l->rgb[1]), fin(l->rgb[2]));
    }
    put(&b, "],\"ambient\":[%.9g,%.9g,%.9g]", fin(L->ambient[0]), fin(L->ambient[1]),
        fin(L->ambient[2]));
    if (b.overflow) {
        buf[0] = 0;
        return pl_error(PL_E_ARG, "pl_lighting_format_json: buffer of %zu bytes too small", cap);
    }
    return (int)b.n;
}
