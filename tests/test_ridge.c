/* light/ridge: baseline (d)'s features, outputs and lighting against the numbers of
 * tools/train/fit_ridge.py (tests/data/ridge/golden.json, made by `fit_ridge.py --golden
 * tests/data/ridge` on synthetic images both sides draw the same way), and its loader on broken
 * files: every one refused with PL_E_FORMAT and a message naming the field, none crashing. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "core/json.h"
#include "core/util.h"
#include "light/light.h"
#include "light/ridge.h"
#include "port/json_file.h"

#define GOLDEN_DIR "tests/data/ridge"

/* fit_ridge.py golden_image: v = (37 x + 91 y + 53 c + 11 x y) mod 256, a black 5 x 4 corner and
 * a saturated last row. */
static int golden_image(pl_image_u8 *img, int w, int h)
{
    if (pl_image_u8_alloc(img, w, h) < 0) return -1;
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++)
            for (int c = 0; c < 3; c++) {
                int v = (37 * x + 91 * y + 53 * c + 11 * x * y) % 256;
                if (x < 5 && y < 4) v = 0;
                if (y == h - 1) v = 255;
                img->data[(size_t)y * img->stride + 3 * (size_t)x + (size_t)c] = (uint8_t)v;
            }
    return 0;
}

static double num(const pl_json_value *o, const char *key)
{
    const pl_json_value *v = pl_json_get(o, key);
    return v && v->type == PL_JSON_NUMBER ? v->number : NAN;
}

/* |a - b| <= tol max(1, |b|) */
static int close_to(double a, double b, double tol)
{
    return fabs(a - b) <= tol * (fabs(b) > 1 ? fabs(b) : 1);
}

/* The lighting L against a lights-JSON object of fit_ridge.py's lighting() (float precision). */
static void check_lighting(const pl_lighting *L, const pl_json_value *want, const char *what)
{
    const pl_json_value *lights = pl_json_get(want, "lights"), *amb = pl_json_get(want, "ambient");
    if (!lights || lights->len != 1 || !amb || amb->len != 3) {
        CHECK(0, "%s: golden lighting malformed", what);
        return;
    }
    const pl_json_value *l = &lights->items[0], *dir = pl_json_get(l, "dir"),
                        *rgb = pl_json_get(l, "rgb");
    CHECK(L->n_lights == 1, "%s: %d lights", what, L->n_lights);
    for (int k = 0; k < 3; k++) {
        CHECK(close_to(L->lights[0].dir[k], dir->items[k].number, 1e-6), "%s: dir[%d] %.9g vs %.9g",
              what, k, (double)L->lights[0].dir[k], dir->items[k].number);
        CHECK(close_to(L->lights[0].rgb[k], rgb->items[k].number, 1e-6) ||
                  fabs(L->lights[0].rgb[k] / rgb->items[k].number - 1) < 1e-6,
              "%s: rgb[%d] %.9g vs %.9g", what, k, (double)L->lights[0].rgb[k],
              rgb->items[k].number);
        CHECK(fabs(L->ambient[k] / amb->items[k].number - 1) < 1e-6, "%s: ambient[%d] %.9g vs %.9g",
              what, k, (double)L->ambient[k], amb->items[k].number);
    }
    CHECK(fabs(L->lights[0].solid_angle_sr / num(l, "solid_angle_sr") - 1) < 1e-6,
          "%s: solid angle %.9g vs %.9g", what, (double)L->lights[0].solid_angle_sr,
          num(l, "solid_angle_sr"));
    CHECK(L->lights[0].distance_m == (float)num(l, "distance_m"), "%s: distance %g", what,
          (double)L->lights[0].distance_m);
}

static void test_golden(void)
{
    pl_ridge *r = NULL;
    pl_json_doc doc;
    if (pl_ridge_load(GOLDEN_DIR "/model.json", &r) < 0) {
        CHECK(0, "load the golden model: %s", pl_last_error());
        return;
    }
    if (pl_json_read_file(GOLDEN_DIR "/golden.json", &doc) < 0) {
        CHECK(0, "golden.json: %s", pl_last_error());
        pl_ridge_free(r);
        return;
    }
    CHECK(r->cols == 16 && r->rows == 12 && r->n_features == 576 && r->floor == 1e-4,
          "model: grid %dx%d n %d floor %g", r->cols, r->rows, r->n_features, r->floor);
    const pl_json_value *cases = pl_json_get(&doc.root, "cases");
    CHECK(cases && cases->type == PL_JSON_ARRAY && cases->len == 3, "golden.json: 3 cases");
    double *f = calloc((size_t)r->n_features, sizeof *f);
    int n_floor = 0;
    for (size_t c = 0; cases && f && c < cases->len; c++) {
        const pl_json_value *cs = &cases->items[c], *fw = pl_json_get(cs, "features"),
                            *yw = pl_json_get(cs, "outputs");
        int w = (int)num(cs, "width"), h = (int)num(cs, "height");
        double gamma = num(cs, "gamma");
        char what[64];
        snprintf(what, sizeof what, "%dx%d gamma %g", w, h, gamma);
        pl_image_u8 img = {0, 0, 0, NULL};
        if (golden_image(&img, w, h) < 0 || !fw || fw->len != (size_t)r->n_features || !yw ||
            yw->len != PL_RIDGE_N_OUT) {
            CHECK(0, "%s: cannot make the image or malformed case", what);
            pl_image_u8_free(&img);
            continue;
        }
        CHECK(pl_ridge_features(r, &img, gamma, f) == 0, "%s: %s", what, pl_last_error());
        double worst = 0;
        for (int i = 0; i < r->n_features; i++) {
            double d = fabs(f[i] - fw->items[i].number);
            if (d > worst) worst = d;
            if (f[i] == log(1e-4)) n_floor++;
        }
        CHECK(worst < 1e-12, "%s: features differ from fit_ridge.py's by up to %g", what, worst);
        double y[PL_RIDGE_N_OUT];
        pl_ridge_outputs(r, f, y);
        for (int k = 0; k < PL_RIDGE_N_OUT; k++)
            CHECK(close_to(y[k], yw->items[k].number, 1e-11), "%s: output %d %.17g vs %.17g", what,
                  k, y[k], yw->items[k].number);
        pl_lighting L;
        CHECK(pl_ridge_predict(r, &img, gamma, &L) == 0, "%s: predict: %s", what, pl_last_error());
        check_lighting(&L, pl_json_get(cs, "lighting"), what);
        CHECK(pl_lighting_check(&L) == 0, "%s: not a valid lighting: %s", what, pl_last_error());
        pl_image_u8_free(&img);
    }
    CHECK(n_floor > 0, "no feature at the floor: the black corner is not tested");

    const pl_json_value *lc = pl_json_get(&doc.root, "lighting_cases");
    CHECK(lc && lc->type == PL_JSON_ARRAY && lc->len >= 4, "golden.json: lighting_cases");
    for (size_t c = 0; lc && c < lc->len; c++) {
        const pl_json_value *yw = pl_json_get(&lc->items[c], "outputs");
        double y[PL_RIDGE_N_OUT];
        for (int k = 0; k < PL_RIDGE_N_OUT; k++)
            y[k] = yw->items[k].number;
        pl_lighting L;
        pl_ridge_lighting(y, &L);
        char what[64];
        snprintf(what, sizeof what, "lighting case %zu", c);
        check_lighting(&L, pl_json_get(&lc->items[c], "lighting"), what);
        CHECK(pl_lighting_check(&L) == 0, "%s: not a valid lighting: %s", what, pl_last_error());
    }

    /* bad images and gammas are the caller's errors */
    pl_image_u8 small = {0, 0, 0, NULL};
    if (golden_image(&small, 15, 12) == 0) {
        CHECK(pl_ridge_features(r, &small, 2.2, f) == PL_E_ARG, "15x12 image accepted");
        pl_image_u8_free(&small);
    }
    if (golden_image(&small, 16, 12) == 0) {
        CHECK(pl_ridge_features(r, &small, 0.1, f) == PL_E_ARG, "gamma 0.1 accepted");
        CHECK(pl_ridge_features(r, &small, NAN, f) == PL_E_ARG, "gamma NaN accepted");
        pl_image_u8_free(&small);
    }
    free(f);
    pl_json_free(&doc);
    pl_ridge_free(r);
}

/* A valid model with a 1 x 1 grid (3 features), printed with one member replaced: `key`
 * (a top-level or "features." name) gets the raw JSON `value`, or is left out when value is
 * NULL. */
static void make_model(char *buf, size_t cap, const char *key, const char *value)
{
    static const char *const keys[] = {"format", "version", "features", "outputs",
                                       "bias",   "weights", "lambda"};
    static const char *const vals[] = {
        "\"parlight-ridge\"",
        "1",
        NULL,
        "[\"dir_x\",\"dir_y\",\"dir_z\",\"log_rgb_r\",\"log_rgb_g\",\"log_rgb_b\","
        "\"log_solid_angle_sr\",\"log_ambient_r\",\"log_ambient_g\",\"log_ambient_b\"]",
        "[0,1,0,0,0,0,-2,-1,-1,-1]",
        "[[0,0,0],[0,0,0],[0,0,0],[1,0,0],[0,1,0],[0,0,1],[0,0,0],[1,0,0],[0,1,0],[0,0,1]]",
        "{\"dir\":1}"};
    static const char *const fkeys[] = {"definition", "grid", "floor", "n"};
    static const char *const fvals[] = {"1", "[1,1]", "1e-4", "3"};
    size_t n = 0;
    n += (size_t)snprintf(buf + n, cap - n, "{");
    int first = 1;
    for (size_t i = 0; i < sizeof keys / sizeof *keys; i++) {
        const char *v = vals[i];
        if (strcmp(key, keys[i]) == 0) {
            if (!value) continue;
            v = value;
        }
        n += (size_t)snprintf(buf + n, cap - n, "%s\"%s\":", first ? "" : ",", keys[i]);
        first = 0;
        if (v) {
            n += (size_t)snprintf(buf + n, cap - n, "%s", v);
            continue;
        }
        n += (size_t)snprintf(buf + n, cap - n, "{");
        int ff = 1;
        for (size_t j = 0; j < sizeof fkeys / sizeof *fkeys; j++) {
            char full[64];
            snprintf(full, sizeof full, "features.%s", fkeys[j]);
            const char *fv = fvals[j];
            if (strcmp(key, full) == 0) {
                if (!value) continue;
                fv = value;
            }
            n += (size_t)snprintf(buf + n, cap - n, "%s\"%s\":%s", ff ? "" : ",", fkeys[j], fv);
            ff = 0;
        }
        n += (size_t)snprintf(buf + n, cap - n, "}");
    }
    snprintf(buf + n, cap - n, "}");
}

static void expect_bad(const char *key, const char *value, const char *in_message)
{
    char text[4096];
    make_model(text, sizeof text, key, value);
    pl_ridge *r = (pl_ridge *)1;
    int rc = pl_ridge_parse(text, strlen(text), "bad.json", &r);
    CHECK(rc == PL_E_FORMAT && r == NULL, "%s = %s: rc %d (%s)", key, value ? value : "(missing)",
          rc, text);
    CHECK(strstr(pl_last_error(), "bad.json") && strstr(pl_last_error(), in_message),
          "%s = %s: message '%s' lacks '%s'", key, value ? value : "(missing)", pl_last_error(),
          in_message);
    pl_ridge_free(rc == 0 ? r : NULL);
}

static void test_loader(void)
{
    char text[4096];
    pl_ridge *r = NULL;
    make_model(text, sizeof text, "", NULL);
    CHECK(pl_ridge_parse(text, strlen(text), "ok.json", &r) == 0, "valid 1x1 model: %s (%s)",
          pl_last_error(), text);
    if (r) {
        CHECK(r->cols == 1 && r->rows == 1 && r->n_features == 3 && r->weights[3 * 3] == 1,
              "1x1 model read wrongly");
        /* the 1x1 model's lighting: direction (0, 1, 0) from the bias, colour = the mean */
        pl_image_u8 img = {0, 0, 0, NULL};
        if (pl_image_u8_alloc(&img, 2, 2) == 0) {
            memset(img.data, 255, img.stride * 2);
            img.data[0] = 0;
            pl_lighting L;
            CHECK(pl_ridge_predict(r, &img, 2.0, &L) == 0, "predict: %s", pl_last_error());
            CHECK(L.lights[0].dir[1] == 1 && fabs(L.lights[0].rgb[0] - 0.75f) < 1e-6 &&
                      L.lights[0].rgb[1] == 1 && fabs(L.ambient[0] - 0.75f / (float)M_E) < 1e-6,
                  "1x1 model: dir y %g rgb %g %g ambient %g", (double)L.lights[0].dir[1],
                  (double)L.lights[0].rgb[0], (double)L.lights[0].rgb[1], (double)L.ambient[0]);
            pl_image_u8_free(&img);
        }
        pl_ridge_free(r);
    }

    static const char *const required[] = {"format",
                                           "version",
                                           "features",
                                           "outputs",
                                           "bias",
                                           "weights",
                                           "features.definition",
                                           "features.grid",
                                           "features.floor",
                                           "features.n"};
    for (size_t i = 0; i < sizeof required / sizeof *required; i++) {
        const char *dot = strchr(required[i], '.');
        expect_bad(required[i], NULL, dot ? dot + 1 : required[i]);
    }
    expect_bad("format", "\"parlight-model\"", "format");
    expect_bad("format", "3", "format");
    expect_bad("version", "2", "version");
    expect_bad("version", "1.5", "version");
    expect_bad("features", "[]", "features");
    expect_bad("features.definition", "2", "definition");
    expect_bad("features.grid", "[1]", "grid");
    expect_bad("features.grid", "[0,1]", "grid[0]");
    expect_bad("features.grid", "[1,65]", "grid[1]");
    expect_bad("features.grid", "[1.5,1]", "grid[0]");
    expect_bad("features.grid", "[2,1]", "features.n"); /* 6 features, n says 3 */
    expect_bad("features.floor", "0", "floor");
    expect_bad("features.floor", "\"1e-4\"", "floor");
    expect_bad("features.n", "4", "features.n");
    expect_bad("outputs", "[\"dir_x\"]", "outputs");
    expect_bad("outputs",
               "[\"dir_x\",\"dir_y\",\"dir_z\",\"log_rgb_r\",\"log_rgb_g\",\"log_rgb_b\","
               "\"log_solid_angle\",\"log_ambient_r\",\"log_ambient_g\",\"log_ambient_b\"]",
               "outputs[6]");
    expect_bad("bias", "[0,1,0,0,0,0,-2,-1,-1]", "bias");
    expect_bad("bias", "[0,1,0,0,0,0,-2,-1,-1,\"x\"]", "bias[9]");
    expect_bad("bias", "[0,1,0,0,0,0,-2,-1,-1,null]", "bias[9]");
    expect_bad("weights", "[[0,0,0]]", "weights");
    expect_bad("weights",
               "[[0,0,0],[0,0,0],[0,0,0],[1,0,0],[0,1,0],[0,0,1],[0,0],[1,0,0],[0,1,0],[0,0,1]]",
               "weights[6]");
    expect_bad("weights",
               "[[0,0,0],[0,0,0],[0,0,0],[1,0,0],[0,1,0],[0,0,1],[0,0,0],[1,0,0],[0,1,0],[0,0,{}]]",
               "weights[9][2]");
    expect_bad("weights", "{}", "weights");
    /* NaN and infinities are not JSON: the parser refuses them, naming the file */
    expect_bad("bias", "[0,1,0,0,0,0,-2,-1,-1,NaN]", "byte");
    expect_bad("bias", "[0,1,0,0,0,0,-2,-1,-1,1e999]", "byte");

    static const char *const not_models[] = {"", "not json", "[1,2,3]", "{\"format\":", "null"};
    for (size_t i = 0; i < sizeof not_models / sizeof *not_models; i++) {
        r = (pl_ridge *)1;
        int rc = pl_ridge_parse(not_models[i], strlen(not_models[i]), "junk.json", &r);
        CHECK(rc == PL_E_FORMAT && r == NULL && strstr(pl_last_error(), "junk.json"),
              "'%s': rc %d, message '%s'", not_models[i], rc, pl_last_error());
    }
    /* truncations of a valid file at every byte: all refused, none crash */
    make_model(text, sizeof text, "", NULL);
    int accepted = 0;
    for (size_t n = 0; n < strlen(text); n++) {
        r = NULL;
        if (pl_ridge_parse(text, n, "cut.json", &r) == 0) accepted++;
        pl_ridge_free(r);
    }
    CHECK(accepted == 0, "%d truncated files accepted", accepted);
    /* random byte changes: each either refused or a model whose numbers are all finite */
    int bad = 0;
    for (int t = 0; t < 3000; t++) {
        char m[4096];
        size_t n = strlen(text);
        memcpy(m, text, n + 1);
        for (int k = rint_in(1, 3); k > 0; k--)
            m[rnd() % n] = "0123456789.,:-+eE[]{}\"x \\"[rnd() % 25];
        r = NULL;
        if (pl_ridge_parse(m, n, "fuzz.json", &r) == 0) {
            for (int i = 0; i < PL_RIDGE_N_OUT * r->n_features; i++)
                bad += !isfinite(r->weights[i]);
            for (int i = 0; i < PL_RIDGE_N_OUT; i++)
                bad += !isfinite(r->bias[i]);
            bad += r->n_features != 3 * r->cols * r->rows;
        }
        pl_ridge_free(r);
    }
    CHECK(bad == 0, "fuzzed files accepted with %d bad values", bad);
    CHECK(pl_ridge_load("tests/data/ridge/no-such-file.json", &r) == PL_E_IO &&
              strstr(pl_last_error(), "no-such-file.json"),
          "missing file: %s", pl_last_error());
}

int main(void)
{
    test_golden();
    test_loader();
    printf("%s\n", failures ? "FAILED" : "ok");
    return failures ? 1 : 0;
}
