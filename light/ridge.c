/* Baseline (d): the ridge model file, its features and its lighting (light/ridge.h). */
#include "light/ridge.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/json.h"
#include "core/util.h"

static const char *const output_names[PL_RIDGE_N_OUT] = {"dir_x",
                                                         "dir_y",
                                                         "dir_z",
                                                         "log_rgb_r",
                                                         "log_rgb_g",
                                                         "log_rgb_b",
                                                         "log_solid_angle_sr",
                                                         "log_ambient_r",
                                                         "log_ambient_g",
                                                         "log_ambient_b"};

/* The member `key` of object o, which must have type t; `what` names o in messages. */
static int member(const char *name, const pl_json_value *o, const char *what, const char *key,
                  pl_json_type t, const pl_json_value **out)
{
    const pl_json_value *v = pl_json_get(o, key);
    if (!v) return pl_error(PL_E_FORMAT, "%s: missing field %s%s", name, what, key);
    if (v->type != t)
        return pl_error(PL_E_FORMAT, "%s: field %s%s: expected %s, found %s", name, what, key,
                        pl_json_type_name(t), pl_json_type_name(v->type));
    *out = v;
    return 0;
}

/* A finite number of v into *out; `field` names it. */
static int finite_number(const char *name, const pl_json_value *v, const char *field, double *out)
{
    if (v->type != PL_JSON_NUMBER)
        return pl_error(PL_E_FORMAT, "%s: field %s: expected a number, found %s", name, field,
                        pl_json_type_name(v->type));
    if (!isfinite(v->number))
        return pl_error(PL_E_FORMAT, "%s: field %s: expected a finite number", name, field);
    *out = v->number;
    return 0;
}

/* An array of exactly n finite numbers into out[0..n). */
static int number_array(const char *name, const pl_json_value *v, const char *field, size_t n,
                        double *out)
{
    if (v->type != PL_JSON_ARRAY)
        return pl_error(PL_E_FORMAT, "%s: field %s: expected an array, found %s", name, field,
                        pl_json_type_name(v->type));
    if (v->len != n)
        return pl_error(PL_E_FORMAT, "%s: field %s: expected %zu numbers, found %zu", name, field,
                        n, v->len);
    for (size_t i = 0; i < n; i++) {
        char sub[96];
        snprintf(sub, sizeof sub, "%s[%zu]", field, i);
        int rc = finite_number(name, &v->items[i], sub, &out[i]);
        if (rc < 0) return rc;
    }
    return 0;
}

/* An integer in lo..hi. */
static int int_field(const char *name, const pl_json_value *v, const char *field, int lo, int hi,
                     int *out)
{
    double x;
    int rc = finite_number(name, v, field, &x);
    if (rc < 0) return rc;
    if (!(x == floor(x) && x >= lo && x <= hi))
        return pl_error(PL_E_FORMAT, "%s: field %s: expected an integer in %d..%d, found %g", name,
                        field, lo, hi, x);
    *out = (int)x;
    return 0;
}

static int from_doc(const char *name, const pl_json_value *root, pl_ridge *r)
{
    const pl_json_value *v, *feat, *arr;
    int rc, version;
    if (root->type != PL_JSON_OBJECT)
        return pl_error(PL_E_FORMAT, "%s: expected a JSON object at the top, found %s", name,
                        pl_json_type_name(root->type));
    if ((rc = member(name, root, "", "format", PL_JSON_STRING, &v)) < 0) return rc;
    if (strcmp(v->str, PL_RIDGE_FORMAT) != 0 || strlen(v->str) != v->len)
        return pl_error(PL_E_FORMAT, "%s: field format: expected \"%s\", found \"%.40s\"", name,
                        PL_RIDGE_FORMAT, v->str);
    if ((rc = member(name, root, "", "version", PL_JSON_NUMBER, &v)) < 0 ||
        (rc = int_field(name, v, "version", 0, 1000000, &version)) < 0)
        return rc;
    if (version != PL_RIDGE_VERSION)
        return pl_error(PL_E_FORMAT, "%s: field version: %d, this build reads version %d", name,
                        version, PL_RIDGE_VERSION);

    if ((rc = member(name, root, "", "features", PL_JSON_OBJECT, &feat)) < 0) return rc;
    int def, n;
    double grid[2];
    if ((rc = member(name, feat, "features.", "definition", PL_JSON_NUMBER, &v)) < 0 ||
        (rc = int_field(name, v, "features.definition", 0, 1000000, &def)) < 0)
        return rc;
    if (def != PL_RIDGE_DEFINITION)
        return pl_error(PL_E_FORMAT,
                        "%s: field features.definition: %d, this build computes definition %d",
                        name, def, PL_RIDGE_DEFINITION);
    if ((rc = member(name, feat, "features.", "grid", PL_JSON_ARRAY, &v)) < 0 ||
        (rc = number_array(name, v, "features.grid", 2, grid)) < 0)
        return rc;
    for (int k = 0; k < 2; k++)
        if (!(grid[k] == floor(grid[k]) && grid[k] >= 1 && grid[k] <= PL_RIDGE_MAX_GRID))
            return pl_error(PL_E_FORMAT,
                            "%s: field features.grid[%d]: expected an integer in "
                            "1..%d, found %g",
                            name, k, PL_RIDGE_MAX_GRID, grid[k]);
    r->cols = (int)grid[0];
    r->rows = (int)grid[1];
    r->n_features = 3 * r->cols * r->rows;
    if ((rc = member(name, feat, "features.", "floor", PL_JSON_NUMBER, &v)) < 0 ||
        (rc = finite_number(name, v, "features.floor", &r->floor)) < 0)
        return rc;
    if (!(r->floor >= 1e-30 && r->floor <= 1))
        return pl_error(PL_E_FORMAT, "%s: field features.floor: expected 1e-30..1, found %g", name,
                        r->floor);
    if ((rc = member(name, feat, "features.", "n", PL_JSON_NUMBER, &v)) < 0 ||
        (rc = int_field(name, v, "features.n", 1, 3 * PL_RIDGE_MAX_GRID * PL_RIDGE_MAX_GRID, &n)) <
            0)
        return rc;
    if (n != r->n_features)
        return pl_error(PL_E_FORMAT, "%s: field features.n: %d, the %dx%d grid has %d", name, n,
                        r->cols, r->rows, r->n_features);

    if ((rc = member(name, root, "", "outputs", PL_JSON_ARRAY, &arr)) < 0) return rc;
    if (arr->len != PL_RIDGE_N_OUT)
        return pl_error(PL_E_FORMAT, "%s: field outputs: expected %d names, found %zu", name,
                        PL_RIDGE_N_OUT, arr->len);
    for (int k = 0; k < PL_RIDGE_N_OUT; k++) {
        const pl_json_value *s = &arr->items[k];
        if (s->type != PL_JSON_STRING || strcmp(s->str, output_names[k]) != 0 ||
            strlen(s->str) != s->len)
            return pl_error(PL_E_FORMAT, "%s: field outputs[%d]: expected \"%s\"", name, k,
                            output_names[k]);
    }
    if ((rc = member(name, root, "", "bias", PL_JSON_ARRAY, &v)) < 0 ||
        (rc = number_array(name, v, "bias", PL_RIDGE_N_OUT, r->bias)) < 0)
        return rc;
    if ((rc = member(name, root, "", "weights", PL_JSON_ARRAY, &arr)) < 0) return rc;
    if (arr->len != PL_RIDGE_N_OUT)
        return pl_error(PL_E_FORMAT, "%s: field weights: expected %d rows, found %zu", name,
                        PL_RIDGE_N_OUT, arr->len);
    r->weights = malloc((size_t)PL_RIDGE_N_OUT * (size_t)r->n_features * sizeof *r->weights);
    if (!r->weights) return pl_error(PL_E_NOMEM, "%s: out of memory", name);
    for (int k = 0; k < PL_RIDGE_N_OUT; k++) {
        char field[32];
        snprintf(field, sizeof field, "weights[%d]", k);
        if ((rc = number_array(name, &arr->items[k], field, (size_t)r->n_features,
                               r->weights + (size_t)k * (size_t)r->n_features)) < 0)
            return rc;
    }
    return 0;
}

int pl_ridge_from_json(const char *name, pl_json_doc *doc, pl_ridge **out)
{
    pl_ridge *r = calloc(1, sizeof *r);
    int rc = r ? from_doc(name, &doc->root, r) : pl_error(PL_E_NOMEM, "%s: out of memory", name);
    pl_json_free(doc);
    if (rc < 0) {
        pl_ridge_free(r);
        return rc;
    }
    *out = r;
    return 0;
}

int pl_ridge_parse(const char *text, size_t len, const char *name, pl_ridge **out)
{
    if (!out || (!text && len)) return pl_error(PL_E_ARG, "pl_ridge_parse: NULL argument");
    *out = NULL;
    if (!name) name = "ridge model";
    pl_json_doc doc;
    int rc = pl_json_parse(text ? text : "", len, name, &doc);
    if (rc < 0) return rc;
    return pl_ridge_from_json(name, &doc, out);
}

void pl_ridge_free(pl_ridge *r)
{
    if (!r) return;
    free(r->weights);
    free(r);
}

int pl_ridge_features(const pl_ridge *r, const pl_image_u8 *img, double gamma, double *f)
{
    if (!r || !img || !f) return pl_error(PL_E_ARG, "ridge: NULL argument");
    if (!img->data || img->stride < (size_t)img->width * 3 || img->width < r->cols ||
        img->height < r->rows)
        return pl_error(PL_E_ARG, "ridge: image %dx%d: expected at least the %dx%d grid",
                        img->width, img->height, r->cols, r->rows);
    if (!(gamma >= 0.2 && gamma <= 5))
        return pl_error(PL_E_ARG, "ridge: gamma %g: expected 0.2..5", gamma);
    double lut[256];
    for (int v = 0; v < 256; v++)
        lut[v] = pow(v / 255.0, gamma);
    const int W = img->width, H = img->height;
    for (int j = 0; j < r->rows; j++) {
        /* 64-bit products: W, H and the grid are ints, their product may not be */
        const int y0 = (int)((long long)j * H / r->rows),
                  y1 = (int)((long long)(j + 1) * H / r->rows);
        for (int i = 0; i < r->cols; i++) {
            const int x0 = (int)((long long)i * W / r->cols),
                      x1 = (int)((long long)(i + 1) * W / r->cols);
            double s[3] = {0, 0, 0};
            for (int y = y0; y < y1; y++) {
                const uint8_t *row = img->data + (size_t)y * img->stride;
                for (int x = x0; x < x1; x++)
                    for (int c = 0; c < 3; c++)
                        s[c] += lut[row[3 * x + c]];
            }
            const double n = (double)(x1 - x0) * (double)(y1 - y0);
            for (int c = 0; c < 3; c++) {
                const double m = s[c] / n;
                f[3 * (j * r->cols + i) + c] = log(m > r->floor ? m : r->floor);
            }
        }
    }
    return 0;
}

void pl_ridge_outputs(const pl_ridge *r, const double *f, double y[PL_RIDGE_N_OUT])
{
    for (int k = 0; k < PL_RIDGE_N_OUT; k++) {
        const double *w = r->weights + (size_t)k * (size_t)r->n_features;
        double s = r->bias[k];
        for (int i = 0; i < r->n_features; i++)
            s += w[i] * f[i];
        y[k] = s;
    }
}

static double clamp(double v, double lo, double hi)
{
    return v < lo ? lo : v > hi ? hi : v;
}

void pl_ridge_lighting(const double y[PL_RIDGE_N_OUT], pl_lighting *out)
{
    memset(out, 0, sizeof *out);
    out->n_lights = 1;
    pl_light *l = &out->lights[0];
    const double n = sqrt(y[0] * y[0] + y[1] * y[1] + y[2] * y[2]);
    for (int k = 0; k < 3; k++) {
        l->dir[k] = n > PL_RIDGE_DIR_EPS ? (float)(y[k] / n) : (k == 1 ? 1.0f : 0.0f);
        l->rgb[k] = (float)exp(clamp(y[3 + k], -PL_RIDGE_LOG_MAX, PL_RIDGE_LOG_MAX));
        out->ambient[k] = (float)exp(clamp(y[7 + k], -PL_RIDGE_LOG_MAX, PL_RIDGE_LOG_MAX));
    }
    l->solid_angle_sr = (float)clamp(exp(clamp(y[6], -PL_RIDGE_LOG_MAX, PL_RIDGE_LOG_MAX)),
                                     PL_RIDGE_SR_MIN, PL_RIDGE_SR_MAX);
    l->distance_m = (float)PL_RIDGE_DISTANCE_M;
}

int pl_ridge_predict(const pl_ridge *r, const pl_image_u8 *img, double gamma, pl_lighting *out)
{
    if (!r || !out) return pl_error(PL_E_ARG, "ridge: NULL argument");
    double *f = malloc((size_t)r->n_features * sizeof *f);
    if (!f) return pl_error(PL_E_NOMEM, "ridge: out of memory");
    int rc = pl_ridge_features(r, img, gamma, f);
    if (rc == 0) {
        double y[PL_RIDGE_N_OUT];
        pl_ridge_outputs(r, f, y);
        pl_ridge_lighting(y, out);
    }
    free(f);
    return rc;
}
