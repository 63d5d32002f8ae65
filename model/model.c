/* The public model API (include/parlight.h): loading a .plm file, the metadata both precisions
 * share (architecture, N, input size, normalisation, intensity anchor; docs/FORMAT.md), the
 * thread pool, and one estimate: crop to the model's aspect, the executor of the file's
 * precision (model/net_f32.h or model/net_s8.h), the intensity anchor. The network itself is
 * the executors' business. */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/image.h"
#include "core/threads.h"
#include "core/util.h"
#include "light/light.h"
#include "model/graph.h"
#include "model/model.h"
#include "model/net_f32.h"
#include "model/net_s8.h"
#include "model/observer.h"
#include "model/plm.h"
#include "model/profile.h"
#include "model/resize.h"

struct pl_model {
    pl_plm file;
    char arch[64], precision[16];
    int n_lights, in_h, in_w, bands, fc_n, dist_hidden;
    float mean[3], std[3];
    float anchor[3]; /* intensity anchor w, b, gamma (metadata intensity_anchor); w = b = 0: off */
    int64_t n_params;
    size_t memory_bytes; /* int8: the executor's arena (fp32 asks its executor) */
    int have_latent;
    pl_pool *pool;
    pl_f32net *f32; /* one of the two executors, by the file's precision */
    pl_s8 *s8;
    pl_profile *prof; /* pl_model_set_profile, or NULL */
    uint8_t *frame_rgb; /* pl_model_frame_rgb: the RGB of a converted frame (YUYV, NV12) */
    size_t frame_rgb_cap;
};

/* ---- loading ----------------------------------------------------------------------------- */

static int parse_int(const pl_plm *f, const char *key, int lo, int hi, int *out)
{
    const char *v = pl_plm_meta(f, key);
    if (!v) return pl_error(PL_E_MODEL, "%s: metadata '%s' missing", f->path, key);
    char *end;
    errno = 0;
    long x = strtol(v, &end, 10);
    if (errno || end == v || *end || x < lo || x > hi)
        return pl_error(PL_E_MODEL, "%s: metadata %s='%s', expected an integer in %d..%d", f->path,
                        key, v, lo, hi);
    *out = (int)x;
    return PL_OK;
}

static int parse_float3(const pl_plm *f, const char *key, int positive, float out[3])
{
    const char *v = pl_plm_meta(f, key);
    if (!v) return pl_error(PL_E_MODEL, "%s: metadata '%s' missing", f->path, key);
    const char *s = v;
    for (int i = 0; i < 3; i++) {
        char *end;
        errno = 0;
        double x = strtod(s, &end);
        if (errno || end == s || !isfinite(x) || (positive && !(x > 0)) || fabs(x) > 1e6) goto bad;
        out[i] = (float)x;
        s = end;
        if (i < 2) {
            if (*s != ',') goto bad;
            s++;
        }
    }
    if (*s == '\0') return PL_OK;
bad:
    return pl_error(PL_E_MODEL, "%s: metadata %s='%s', expected three %sfloats a,b,c", f->path, key,
                    v, positive ? "positive " : "");
}

/* The optional intensity_anchor=w,b,gamma (docs/FORMAT.md); absent: off (w = b = 0, gamma 2.2). */
static int parse_anchor(const pl_plm *f, float anchor[3])
{
    anchor[0] = anchor[1] = 0, anchor[2] = 2.2f;
    if (!pl_plm_meta(f, "intensity_anchor")) return PL_OK;
    int rc = parse_float3(f, "intensity_anchor", 0, anchor);
    if (rc == PL_OK && pl_anchor_check(anchor[0], anchor[1], anchor[2]) < 0)
        rc = pl_error_prefix(PL_E_MODEL, "%s: metadata intensity_anchor", f->path);
    return rc;
}

/* The model of an opened file (path, or data/size when path is NULL). */
static int load(const char *path, const void *data, size_t size, pl_model **out)
{
    if (!out)
        return pl_error(PL_E_ARG, "%s: out is NULL",
                        path ? "pl_model_load" : "pl_model_load_memory");
    *out = NULL;
    pl_model *m = calloc(1, sizeof *m);
    if (!m) return pl_error(PL_E_NOMEM, "out of memory");
    int rc = path ? pl_plm_open(path, &m->file) : pl_plm_open_memory(data, size, &m->file);
    if (rc < 0) {
        free(m);
        return rc;
    }
    const pl_plm *f = &m->file;
    const char *arch = pl_plm_meta(f, "arch"), *prec = pl_plm_meta(f, "precision");
    if (!arch || strcmp(arch, PL_ARCH_NAME)) {
        rc = pl_error(PL_E_MODEL, "%s: architecture '%s', expected '" PL_ARCH_NAME "'", f->path,
                      arch ? arch : "(missing)");
        goto fail;
    }
    if (!prec || (strcmp(prec, "fp32") && strcmp(prec, "int8"))) {
        rc = pl_error(PL_E_UNSUPPORTED, "%s: precision '%s', expected 'fp32' or 'int8'", f->path,
                      prec ? prec : "(missing)");
        goto fail;
    }
    snprintf(m->arch, sizeof m->arch, "%s", arch);
    snprintf(m->precision, sizeof m->precision, "%s", prec);
    if ((rc = parse_int(f, "n_lights", 1, PL_MAX_LIGHTS, &m->n_lights)) < 0 ||
        (rc = parse_int(f, "input_h", 96, 1024, &m->in_h)) < 0 ||
        (rc = parse_int(f, "input_w", 64, 1024, &m->in_w)) < 0 ||
        (rc = parse_int(f, "bands", 1, 3, &m->bands)) < 0 ||
        (rc = parse_int(f, "fc", 1, 4096, &m->fc_n)) < 0 ||
        (rc = parse_int(f, "dist_hidden", 1, 4096, &m->dist_hidden)) < 0 ||
        (rc = parse_float3(f, "mean", 0, m->mean)) < 0 ||
        (rc = parse_float3(f, "std", 1, m->std)) < 0 || (rc = parse_anchor(f, m->anchor)) < 0)
        goto fail;
    if (m->n_lights != 2 && m->n_lights != 3 && m->n_lights != 5) {
        rc = pl_error(PL_E_MODEL, "%s: n_lights=%d, expected 2, 3 or 5", f->path, m->n_lights);
        goto fail;
    }
    if (m->in_h % 32 || m->in_w % 32) {
        rc = pl_error(PL_E_MODEL, "%s: input %dx%d (h x w) must be multiples of 32", f->path,
                      m->in_h, m->in_w);
        goto fail;
    }
    const pl_net_shape shape = {m->n_lights,
                                m->in_h,
                                m->in_w,
                                m->bands,
                                m->fc_n,
                                m->dist_hidden,
                                {m->mean[0], m->mean[1], m->mean[2]},
                                {m->std[0], m->std[1], m->std[2]}};
    if (!strcmp(prec, "int8")) {
        if ((rc = pl_s8_load(&m->file, &shape, &m->s8)) < 0) goto fail;
        m->n_params = pl_s8_params(m->s8);
        /* in whole floats, as the fp32 executor counts */
        m->memory_bytes =
            (pl_s8_arena_bytes(m->s8) + sizeof(float) - 1) / sizeof(float) * sizeof(float);
    } else {
        if ((rc = pl_f32net_load(&m->file, &shape, &m->f32)) < 0) goto fail;
        m->n_params = pl_f32net_params(m->f32);
    }
    if ((rc = pl_pool_create(1, &m->pool)) < 0) goto fail;
    *out = m;
    return PL_OK;
fail:
    pl_model_free(m);
    return rc;
}

int pl_model_load(const char *path, pl_model **out)
{
    if (!path) {
        if (out) *out = NULL;
        return pl_error(PL_E_ARG, "model path is NULL");
    }
    return load(path, NULL, 0, out);
}

int pl_model_load_memory(const void *data, size_t size, pl_model **out)
{
    return load(NULL, data, size, out);
}

void pl_model_free(pl_model *m)
{
    if (!m) return;
    free(m->frame_rgb);
    pl_s8_free(m->s8);
    pl_f32net_free(m->f32);
    pl_pool_destroy(m->pool);
    pl_plm_close(&m->file);
    free(m);
}

int pl_model_get_info(const pl_model *m, pl_model_info *info)
{
    if (!m || !info) return pl_error(PL_E_ARG, "pl_model_get_info: NULL argument");
    const char *prov = pl_plm_meta(&m->file, "provenance");
    info->arch = m->arch;
    info->precision = m->precision;
    info->provenance = prov ? prov : "";
    info->n_lights = m->n_lights;
    info->input_h = m->in_h;
    info->input_w = m->in_w;
    info->n_params = m->n_params;
    info->file_size = (int64_t)m->file.n_bytes;
    for (int k = 0; k < 3; k++)
        info->anchor[k] = m->anchor[k];
    /* fp32 on a packed path: the arena, the GEMM scratch and the packed weights */
    info->arena_bytes = m->f32 ? pl_f32net_memory_bytes(m->f32) : m->memory_bytes;
    return PL_OK;
}

int pl_model_set_anchor(pl_model *m, double w, double b, double gamma)
{
    if (!m) return pl_error(PL_E_ARG, "pl_model_set_anchor: model is NULL");
    int rc = pl_anchor_check(w, b, gamma);
    if (rc < 0) return rc;
    m->anchor[0] = (float)w, m->anchor[1] = (float)b, m->anchor[2] = (float)gamma;
    return PL_OK;
}

int pl_model_set_threads(pl_model *m, int n)
{
    if (!m) return pl_error(PL_E_ARG, "pl_model_set_threads: model is NULL");
    if (n == pl_pool_threads(m->pool)) return PL_OK;
    pl_pool *p;
    int rc = pl_pool_create(n, &p);
    if (rc < 0) return rc;
    if (m->f32 && (rc = pl_f32net_set_threads(m->f32, n)) < 0) {
        pl_pool_destroy(p);
        return rc;
    }
    pl_pool_destroy(m->pool);
    m->pool = p;
    return PL_OK;
}

int pl_model_last_latent(const pl_model *m, const float **z, int *n)
{
    if (!m || !z || !n) return pl_error(PL_E_ARG, "pl_model_last_latent: NULL argument");
    if (!m->have_latent) return pl_error(PL_E_ARG, "no estimate has run on this model yet");
    if (m->s8) {
        pl_s8_latent(m->s8, z, n);
        return PL_OK;
    }
    pl_f32net_latent(m->f32, z, n);
    return PL_OK;
}

int pl_model_set_observer(pl_model *m, pl_layer_observer fn, void *ctx)
{
    if (!m) return pl_error(PL_E_ARG, "pl_model_set_observer: model is NULL");
    if (m->s8) return pl_s8_set_observer(m->s8, fn, ctx);
    pl_f32net_set_observer(m->f32, fn, ctx);
    return PL_OK;
}

int pl_model_set_profile(pl_model *m, pl_profile *p)
{
    if (!m) return pl_error(PL_E_ARG, "pl_model_set_profile: model is NULL");
    m->prof = p;
    if (m->s8) pl_s8_set_profile(m->s8, p);
    if (m->f32) pl_f32net_set_profile(m->f32, p);
    return PL_OK;
}

const pl_graph *pl_model_graph(const pl_model *m)
{
    return m->f32 ? pl_f32net_graph(m->f32) : pl_s8_graph(m->s8);
}

const char *pl_model_precision(const pl_model *m)
{
    return m ? m->precision : NULL;
}

uint8_t *pl_model_frame_rgb(pl_model *m, size_t bytes)
{
    if (bytes > m->frame_rgb_cap) {
        uint8_t *p = realloc(m->frame_rgb, bytes);
        if (!p) {
            pl_error(PL_E_NOMEM, "cannot allocate %zu bytes for a frame's RGB", bytes);
            return NULL;
        }
        m->frame_rgb = p;
        m->frame_rgb_cap = bytes;
    }
    return m->frame_rgb;
}

/* ---- estimating ---------------------------------------------------------------------------- */

int pl_estimate_rgb8(pl_model *m, const uint8_t *rgb, int width, int height, size_t stride,
                     pl_lighting *out, pl_timing *timing)
{
    if (!m || !rgb || !out) return pl_error(PL_E_ARG, "pl_estimate_rgb8: NULL argument");
    if (width < 8 || height < 8 || width > PL_IMAGE_MAX_SIDE || height > PL_IMAGE_MAX_SIDE)
        return pl_error(PL_E_ARG, "frame %dx%d: each side must be in 8..%d", width, height,
                        PL_IMAGE_MAX_SIDE);
    if (stride < (size_t)width * 3)
        return pl_error(PL_E_ARG, "frame stride %zu smaller than 3 x width (%d)", stride, width);
    const int64_t t0 = pl_now_ns();
    int64_t t1;
    if (m->prof) m->prof->frames++;
    /* the region the network sees: both executors crop the frame to the model's aspect */
    int x0, y0, cw, ch;
    pl_crop_to_aspect(width, height, m->in_w, m->in_h, &x0, &y0, &cw, &ch);
    if (m->s8)
        pl_s8_estimate(m->s8, m->pool, rgb, width, height, stride, out, &t1);
    else
        pl_f32net_estimate(m->f32, m->pool, rgb, stride, x0, y0, cw, ch, out, &t1);
    m->have_latent = 1;
    if (m->anchor[0] != 0 || m->anchor[1] != 0)
        pl_anchor_apply(out, pl_frame_mean_luminance(rgb, stride, x0, y0, cw, ch, m->anchor[2]),
                        m->anchor[0], m->anchor[1]);
    if (timing) {
        timing->preprocess_ms = (double)(t1 - t0) / 1e6;
        timing->infer_ms = (double)(pl_now_ns() - t1) / 1e6;
    }
    return PL_OK;
}
