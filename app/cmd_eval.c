/* parlight eval: a model's estimates on the paper's crops of a folder of HDR panoramas, scored
 * against the ground truth with four baselines (light/eval.h, docs/EVAL.md). */
#include <dirent.h>
#include <errno.h>
#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "app/cli.h"
#include "app/commands.h"
#include "app/light_io.h"
#include "core/threads.h"
#include "core/util.h"
#include "light/eval.h"
#include "light/extract.h"
#include "light/fuse.h"
#include "light/lights_json.h"
#include "light/pose.h"
#include "light/ridge.h"
#include "model/resize.h"
#include "parlight.h"
#include "port/hdr_io.h"
#include "port/json_file.h"

static void usage(FILE *f)
{
    fprintf(f,
            "usage: parlight eval --model M.plm --hdr DIR [--crops N] [--size S] [--threads N]\n"
            "                     [--json] [--per-pano] [--anchor off|W,B[,GAMMA]]\n"
            "                     [--ridge FILE|none]\n"
            "\n"
            "Scores a model on the paper's crops of every HDR panorama (.exr/.hdr, 2:1) in DIR:\n"
            "N crops per panorama, yaws 360/N apart at pitch 0, fov 60, 640x480, auto exposure,\n"
            "gamma 2.2 (what `parlight crop --batch N` writes). Per crop, the model's estimate\n"
            "from the crop's 8-bit pixels and four baselines, (a) the crop's mean linear colour\n"
            "as ambient, (b) one light toward the crop's brightest cell plus ambient, (c) the\n"
            "extracted ground-truth lights, (d) a ridge regression from the crop's 16x12 log\n"
            "pixels to one light and ambient, fit on the training crops (--ridge), are each\n"
            "compared with the truth, the diffuse sphere lit by the panorama in the crop's\n"
            "camera frame on the crop's scale:\n"
            "  rmse, si_rmse  render RMSE and scale-invariant RMSE (diffuse sphere, S px)\n"
            "  angle          degrees between the primary light and the ground truth's\n"
            "  scale EV       stops the render is too dark by (log2 of si_rmse's scale)\n"
            "Prints the median and quartiles over all crops per method (docs/EVAL.md).\n"
            "Files that are not panoramas are reported on stderr, counted and skipped.\n"
            "\n"
            "  --model M.plm   the model (fp32 or int8)\n"
            "  --hdr DIR       folder of panoramas (not searched recursively)\n"
            "  --crops N       crops per panorama, 1..64 (default 8)\n"
            "  --size S        sphere render size in pixels, 8..512 (default 64)\n"
            "  --threads N     threads for the model and the metrics, 1..64 (default 1);\n"
            "                  results do not depend on N\n"
            "  --json          one JSON object: per-method statistics and per-panorama rows\n"
            "  --per-pano      the table for every panorama too\n"
            "  --anchor A      the model's intensity anchor replaced (as in parlight estimate);\n"
            "                  off scores the network's own intensity, what\n"
            "                  tools/train/fit_anchor.py fits an anchor to\n"
            "  --ridge FILE    baseline (d)'s model (tools/train/fit_ridge.py); default: the\n"
            "                  --model file's folder's parlight-ridge.json when it exists;\n"
            "                  none: (d) not scored (stderr says when it is not)\n"
            "  --max-pixels N  panoramas of up to N pixels (default 67108864 = 64 Mi; at most "
            "268435456)\n"
            "  -h, --help      this text\n");
}

/* The model's lights after what an AR app that has seen the whole room does with them: aimed at
 * the room's key light (`estimate --aim`), brought to the room's level (`estimate --level`, the
 * crop's exposure scale k as the frame's exposure), both. */
enum { V_AIMED, V_LEVELED, V_AIMED_LEVELED, N_VARIANTS };
static const char *const VARIANT_KEY[N_VARIANTS] = {"key_aimed", "key_leveled",
                                                    "key_aimed_leveled"};
static const char *const VARIANT_STAT[N_VARIANTS] = {"aimed", "leveled", "aimed_leveled"};
static const char *const VARIANT_LABEL[N_VARIANTS] = {
    "aimed at the key light", "at the room's level", "aimed + the room's level"};

/* One crop's work: its image and scale, the estimate, the scores and the status. */
typedef struct crop_job {
    pl_crop_params p;
    pl_image_u8 ldr;
    double k;
    pl_lighting pred, gt, ridge;
    pl_lighting brightest; /* baseline (b)'s lighting, for the JSON */
    double frame_ev; /* log2(frame's mean luminance / the estimate's), pl_anchor_ratio_ev */
    pl_eval_scores s[PL_EVAL_N_METHODS];
    pl_lighting var[N_VARIANTS];      /* pred after the room's views (V_*) */
    int have_var[N_VARIANTS];         /* 0: no key light / level (var_s all NaN) */
    pl_eval_scores var_s[N_VARIANTS]; /* var's scores */
    int rc;
    char err[512];
} crop_job;

typedef struct pano_ctx {
    const pl_image_f32 *pano;
    const pl_lighting *lights;
    const pl_ridge *ridge; /* NULL: (d) not scored */
    crop_job *jobs;
    int size;
} pano_ctx;

static void record_error(crop_job *j, int rc)
{
    j->rc = rc;
    snprintf(j->err, sizeof j->err, "yaw %g: %s", j->p.yaw_deg, pl_last_error());
}

static void make_crops(void *vctx, int begin, int end)
{
    pano_ctx *c = vctx;
    for (int i = begin; i < end; i++) {
        crop_job *j = &c->jobs[i];
        int rc = pl_eval_make_crop(c->pano, &j->p, &j->ldr, &j->k);
        if (rc < 0) record_error(j, rc);
    }
}

static void score_crops(void *vctx, int begin, int end)
{
    pano_ctx *c = vctx;
    for (int i = begin; i < end; i++) {
        crop_job *j = &c->jobs[i];
        if (j->rc < 0) continue;
        int rc = 0;
        if (c->ridge && (rc = pl_ridge_predict(c->ridge, &j->ldr, j->p.gamma, &j->ridge)) < 0) {
            pl_error_prefix(rc, "eval: ridge");
            record_error(j, rc);
            continue;
        }
        pl_image_f32 truth = {0, 0, NULL};
        rc = pl_eval_crop(c->pano, c->lights, &j->p, &j->ldr, j->k, &j->pred,
                          c->ridge ? &j->ridge : NULL, c->size, j->s, &j->gt, &j->brightest,
                          &truth);
        for (int v = 0; v < N_VARIANTS && rc == 0; v++)
            if (j->have_var[v] &&
                (rc = pl_eval_score(&j->var[v], &truth, &j->gt, &j->var_s[v])) < 0)
                pl_error_prefix(rc, "eval: %s", VARIANT_LABEL[v]);
        pl_image_f32_free(&truth);
        if (rc < 0) record_error(j, rc);
    }
}

/* What is kept of a panorama once its crops are scored. */
typedef struct pano_row {
    char *file;
    int width, height, n_gt_lights;
    double *yaw, *k;        /* [crops] */
    double *frame_ev;       /* [crops] */
    signed char *in_view;   /* [crops]: primary_in_view() of the ground truth */
    pl_lighting *pred, *gt; /* [crops]: the model's estimates, the ground truths */
    pl_lighting *brightest; /* [crops]: baseline (b)'s lightings */
    pl_lighting *ridge;     /* [crops]: (d)'s estimates (zeros when not scored) */
    pl_eval_scores *s;      /* [crops][PL_EVAL_N_METHODS] */
    pl_eval_scores *var[N_VARIANTS]; /* [crops]: the model after the room's views (V_*) */
    double key_angle[2];    /* key light over the crops' views (model, ridge): angle to the
                               truth's primary in degrees, NAN when undefined (key_angle) */
} pano_row;

#define SKIP_FILE 1

/* Whether the ground truth's primary light (pl_lighting_primary's) projects inside the crop:
 * 1 in view, 0 out of view, -1 no light. Most crops' primary light is outside the 60-degree
 * view (56 of eval/'s 64), where its direction has to be inferred from the room's shading
 * rather than seen; the report splits the angle by this. */
static int primary_in_view(const pl_lighting *gt, const pl_crop_params *p)
{
    float dir[3], rgb[3];
    double x, y;
    if (gt->n_lights <= 0) return -1;
    pl_lighting_primary(gt, dir, rgb);
    return pl_crop_project(p, dir, &x, &y);
}

/* The key light fused over a room's views (light/fuse.h), each crop a view turned into the
 * panorama's frame by its camera's rotation (the model's lights, or (d)'s with ridge): 0, or -1
 * when no view holds light. */
static int room_key(const crop_job *jobs, int crops, int ridge, float key[3])
{
    pl_fuser fu;
    if (pl_fuser_init(&fu, 0) < 0) return -1;
    for (int i = 0; i < crops; i++) {
        double R[9];
        pl_crop_rotation(&jobs[i].p, R);
        if (pl_fuser_add(&fu, ridge ? &jobs[i].ridge : &jobs[i].pred, R, 0) < 0) return -1;
    }
    return pl_fuser_key(&fu, 0, key, NULL) < 0 ? -1 : 0;
}

/* The angle in degrees from a room's key light (NULL: none) to the panorama's primary light;
 * NAN when either is missing. */
static double key_angle(const float *key, const pl_lighting *truth)
{
    float dir[3], rgb[3];
    if (!key || truth->n_lights <= 0) return NAN;
    pl_lighting_primary(truth, dir, rgb);
    return pl_eval_angle_deg(key, dir);
}

/* Each crop's estimate after the room's views (docs/OUTPUT.md): its primary light turned to the
 * room's key light (NULL: none), the key over all its crops, as `parlight estimate --aim` gives
 * once it has seen them; its intensity brought to the room's level over the same crops, each
 * with its exposure scale k as the camera's exposure, as `estimate --level` gives (the public
 * pl_key_fuser_level on a fuser of the crops); and both. */
static void after_views(crop_job *jobs, int crops, const float *key)
{
    pl_key_fuser *fu = NULL;
    int ok = pl_key_fuser_new(0, &fu) == 0;
    for (int i = 0; i < crops && ok; i++) {
        double R[9];
        pl_crop_rotation(&jobs[i].p, R);
        ok = pl_key_fuser_add_exposed(fu, &jobs[i].pred, R, 0, jobs[i].k) == 0;
    }
    for (int i = 0; i < crops; i++) {
        crop_job *j = &jobs[i];
        pl_lighting *var = j->var;
        double R[9];
        float kc[3];
        pl_crop_rotation(&j->p, R);
        if (key) pl_rotate3_inverse(R, key, kc);
        j->have_var[V_AIMED] = key && pl_lighting_aim_primary(&j->pred, kc, &var[V_AIMED]) >= 0;
        j->have_var[V_LEVELED] =
            ok && pl_key_fuser_level(fu, 0, &j->pred, j->k, &var[V_LEVELED]) > 0;
        j->have_var[V_AIMED_LEVELED] =
            j->have_var[V_AIMED] && j->have_var[V_LEVELED] &&
            pl_key_fuser_level(fu, 0, &var[V_AIMED], j->k, &var[V_AIMED_LEVELED]) > 0;
        for (int v = 0; v < N_VARIANTS; v++)
            if (!j->have_var[v])
                j->var_s[v].rmse = j->var_s[v].si_rmse = j->var_s[v].scale_ev =
                    j->var_s[v].render_rms = j->var_s[v].angle_deg = NAN;
    }
    pl_key_fuser_free(fu);
}

static void free_row(pano_row *r)
{
    free(r->yaw);
    free(r->k);
    free(r->frame_ev);
    free(r->in_view);
    free(r->s);
    free(r->pred);
    free(r->gt);
    free(r->ridge);
    free(r->brightest);
    for (int v = 0; v < N_VARIANTS; v++)
        free(r->var[v]);
    memset(r, 0, sizeof *r);
}

/* Reads and extracts one panorama, then crops (on the pool), estimates (one at a time, the
 * model's own threads) and scores (on the pool) its crops into *r (file left unset). Returns 0,
 * SKIP_FILE when the file is not a usable panorama, or a negative status on any other failure
 * (the message in pl_last_error). ms[0..2] accumulate the wall time of the three phases. */
static int eval_panorama(const char *path, const pl_extract_params *ep, pl_model *model,
                         const pl_model_info *mi, const pl_ridge *ridge, pl_pool *pool, int crops,
                         int size, crop_job *jobs, pano_row *r, double ms[3])
{
    pl_image_f32 pano = {0, 0, NULL};
    pl_lighting lights;
    if (pl_hdr_read_panorama(path, &pano) < 0) return SKIP_FILE;
    if (pl_extract_lights(&pano, ep, &lights, NULL) < 0) {
        pl_image_f32_free(&pano);
        return SKIP_FILE;
    }
    memset(jobs, 0, (size_t)crops * sizeof *jobs);
    for (int i = 0; i < crops; i++) {
        pl_crop_default_params(&jobs[i].p); /* 640x480, fov 60, pitch 0, ev 0, gamma 2.2 */
        jobs[i].p.yaw_deg = 360.0 * i / crops;
    }
    pano_ctx ctx = {&pano, &lights, ridge, jobs, size};
    const int64_t t0 = pl_now_ns();
    pl_pool_for(pool, crops, make_crops, &ctx);
    const int64_t t1 = pl_now_ns();
    for (int i = 0; i < crops; i++) {
        crop_job *j = &jobs[i];
        if (j->rc < 0) continue;
        pl_timing tm;
        int rc = pl_estimate_rgb8(model, j->ldr.data, j->ldr.width, j->ldr.height, j->ldr.stride,
                                  &j->pred, &tm);
        if (rc == 0 && (rc = pl_lighting_check(&j->pred)) < 0)
            pl_error_prefix(rc, "the model's estimate is not a valid lighting");
        if (rc < 0) {
            record_error(j, rc);
            continue;
        }
        int x0, y0, cw, ch; /* the region the model saw */
        pl_crop_to_aspect(j->ldr.width, j->ldr.height, mi->input_w, mi->input_h, &x0, &y0, &cw,
                          &ch);
        j->frame_ev = pl_anchor_ratio_ev(
            pl_frame_mean_luminance(j->ldr.data, j->ldr.stride, x0, y0, cw, ch, mi->anchor[2]),
            &j->pred);
    }
    const int64_t t2 = pl_now_ns();
    float key[3];
    const int have_key = room_key(jobs, crops, 0, key) == 0;
    after_views(jobs, crops, have_key ? key : NULL);
    pl_pool_for(pool, crops, score_crops, &ctx);
    ms[0] += (double)(t1 - t0) / 1e6;
    ms[1] += (double)(t2 - t1) / 1e6;
    ms[2] += (double)(pl_now_ns() - t2) / 1e6;

    int rc = 0;
    for (int i = 0; i < crops && rc == 0; i++)
        if (jobs[i].rc < 0) rc = pl_error(jobs[i].rc, "%s", jobs[i].err);
    for (int i = 0; i < crops; i++)
        pl_image_u8_free(&jobs[i].ldr);
    r->width = pano.width;
    r->height = pano.height;
    r->n_gt_lights = lights.n_lights;
    pl_image_f32_free(&pano);
    if (rc < 0) return rc;
    r->yaw = malloc((size_t)crops * sizeof *r->yaw);
    r->k = malloc((size_t)crops * sizeof *r->k);
    r->frame_ev = malloc((size_t)crops * sizeof *r->frame_ev);
    r->in_view = malloc((size_t)crops * sizeof *r->in_view);
    r->s = malloc((size_t)crops * PL_EVAL_N_METHODS * sizeof *r->s);
    r->pred = malloc((size_t)crops * sizeof *r->pred);
    r->gt = malloc((size_t)crops * sizeof *r->gt);
    r->ridge = malloc((size_t)crops * sizeof *r->ridge);
    r->brightest = malloc((size_t)crops * sizeof *r->brightest);
    int have_all = 1;
    for (int v = 0; v < N_VARIANTS; v++)
        have_all &= (r->var[v] = malloc((size_t)crops * sizeof *r->var[v])) != NULL;
    if (!r->yaw || !r->k || !r->frame_ev || !r->in_view || !r->s || !r->pred || !r->gt ||
        !r->ridge || !r->brightest || !have_all) {
        free_row(r);
        return pl_error(PL_E_NOMEM, "out of memory");
    }
    for (int i = 0; i < crops; i++) {
        r->yaw[i] = jobs[i].p.yaw_deg;
        r->k[i] = jobs[i].k;
        r->frame_ev[i] = jobs[i].frame_ev;
        r->in_view[i] = (signed char)primary_in_view(&jobs[i].gt, &jobs[i].p);
        r->pred[i] = jobs[i].pred;
        r->gt[i] = jobs[i].gt;
        r->ridge[i] = jobs[i].ridge;
        r->brightest[i] = jobs[i].brightest;
        for (int v = 0; v < N_VARIANTS; v++)
            r->var[v][i] = jobs[i].var_s[v];
        memcpy(&r->s[(size_t)i * PL_EVAL_N_METHODS], jobs[i].s, sizeof jobs[i].s);
    }
    float ridge_key[3];
    r->key_angle[0] = key_angle(have_key ? key : NULL, &lights);
    const int have_ridge_key = ridge && room_key(jobs, crops, 1, ridge_key) == 0;
    r->key_angle[1] = key_angle(have_ridge_key ? ridge_key : NULL, &lights);
    return 0;
}

typedef struct skipped_file {
    char *file, *why;
} skipped_file;

static int cmp_str(const void *a, const void *b)
{
    return strcmp(*(char *const *)a, *(char *const *)b);
}

/* The regular, non-hidden files of dir, sorted by name. */
static int list_dir(const char *dir, char ***names, int *n)
{
    DIR *d = opendir(dir);
    if (!d) return pl_error(PL_E_IO, "%s: cannot open the folder: %s", dir, strerror(errno));
    char **v = NULL;
    int cnt = 0, cap = 0, rc = 0;
    struct dirent *e;
    while ((e = readdir(d))) {
        if (e->d_name[0] == '.') continue;
        char path[4096];
        struct stat st;
        if ((size_t)snprintf(path, sizeof path, "%s/%s", dir, e->d_name) >= sizeof path ||
            stat(path, &st) != 0 || !S_ISREG(st.st_mode))
            continue;
        if (cnt == cap) {
            cap = cap ? 2 * cap : 16;
            char **nv = realloc(v, (size_t)cap * sizeof *nv);
            if (!nv) {
                rc = pl_error(PL_E_NOMEM, "%s: out of memory", dir);
                break;
            }
            v = nv;
        }
        if (!(v[cnt] = strdup(e->d_name))) {
            rc = pl_error(PL_E_NOMEM, "%s: out of memory", dir);
            break;
        }
        cnt++;
    }
    closedir(d);
    if (rc == 0 && cnt == 0) rc = pl_error(PL_E_IO, "%s: no files in the folder", dir);
    if (rc < 0) {
        for (int i = 0; i < cnt; i++)
            free(v[i]);
        free(v);
        return rc;
    }
    qsort(v, (size_t)cnt, sizeof *v, cmp_str);
    *names = v;
    *n = cnt;
    return 0;
}

static void put_num(FILE *f, double v)
{
    if (isfinite(v))
        fprintf(f, "%.6g", v);
    else
        fputs("null", f);
}

/* Statistics of metric `metric` (0 rmse, 1 si_rmse, 2 angle, 3 scale EV) of method m over the n
 * crops, or over those whose in_view flag is `want` when in_view is not NULL. */
static int stats_of(const pl_eval_scores *s, int n, int m, int metric, const signed char *in_view,
                    int want, double *buf, pl_eval_stats *out)
{
    int k = 0;
    for (int i = 0; i < n; i++) {
        if (in_view && in_view[i] != want) continue;
        const pl_eval_scores *x = &s[(size_t)i * PL_EVAL_N_METHODS + (size_t)m];
        buf[k++] = metric == 0   ? x->rmse
                   : metric == 1 ? x->si_rmse
                   : metric == 2 ? x->angle_deg
                                 : x->scale_ev;
    }
    return pl_eval_quartiles(buf, k, out);
}

static void put_stats_json(FILE *f, const char *key, const pl_eval_stats *st, int quartiles)
{
    fprintf(f, "\"%s\":{\"median\":", key);
    put_num(f, st->median);
    if (quartiles) {
        fputs(",\"q1\":", f);
        put_num(f, st->q1);
        fputs(",\"q3\":", f);
        put_num(f, st->q3);
    }
    fprintf(f, ",\"n\":%d}", st->n);
}

#define N_METRICS 4
static const char *const metric_keys[N_METRICS] = {"rmse", "si_rmse", "angle_deg", "scale_ev"};

/* {"model":{"rmse":{...},"si_rmse":{...},"angle_deg":{...},"scale_ev":{...}},...} over n
 * crops; "ridge" only when (d) is scored. */
static int put_methods_json(FILE *f, const pl_eval_scores *s, int n, int have_ridge, double *buf)
{
    fputc('{', f);
    for (int m = 0; m < PL_EVAL_N_METHODS; m++) {
        if (m == PL_EVAL_RIDGE && !have_ridge) continue;
        fprintf(f, "%s\"%s\":{", m ? "," : "", pl_eval_method_key(m));
        for (int q = 0; q < N_METRICS; q++) {
            pl_eval_stats st;
            int rc = stats_of(s, n, m, q, NULL, 0, buf, &st);
            if (rc < 0) return rc;
            if (q) fputc(',', f);
            put_stats_json(f, metric_keys[q], &st, 1);
        }
        fputc('}', f);
    }
    fputc('}', f);
    return 0;
}

/* One crop's scores of one lighting: {"rmse":..,"si_rmse":..,"angle_deg":..,...}. */
static void put_scores_json(FILE *f, const pl_eval_scores *x)
{
    fputs("{\"rmse\":", f);
    put_num(f, x->rmse);
    fputs(",\"si_rmse\":", f);
    put_num(f, x->si_rmse);
    fputs(",\"angle_deg\":", f);
    put_num(f, x->angle_deg);
    fputs(",\"scale_ev\":", f);
    put_num(f, x->scale_ev);
    fputs(",\"render_rms\":", f);
    put_num(f, x->render_rms);
    fputc('}', f);
}

/* A panorama's "key_aimed" (or another variant's) statistics (no braces): rmse and si-RMSE over
 * its crops. */
static int put_variant_json(FILE *f, const pl_eval_scores *aimed, int crops, double *buf)
{
    for (int q = 0; q < 2; q++) {
        pl_eval_stats st;
        for (int i = 0; i < crops; i++)
            buf[i] = q ? aimed[i].si_rmse : aimed[i].rmse;
        int rc = pl_eval_quartiles(buf, crops, &st);
        if (rc < 0) return rc;
        if (q) fputc(',', f);
        put_stats_json(f, q ? "si_rmse" : "rmse", &st, 1);
    }
    return 0;
}

/* One crop's JSON object: yaw, exposure scale, the scores of every method and of the model after
 * the room's views ("key_aimed", "key_leveled", "key_aimed_leveled"), the model's estimate, the
 * ground truth and (d)'s estimate when scored (lights JSON members, light/lights_json.h). */
static int put_crop_json(FILE *f, const pano_row *pr, int i, int have_ridge)
{
    fprintf(f, "{\"yaw_deg\":%.9g,\"exposure_scale\":%.9g,\"frame_ev\":", pr->yaw[i], pr->k[i]);
    put_num(f, pr->frame_ev[i]);
    fprintf(f, ",\"primary_in_view\":%s",
            pr->in_view[i] < 0 ? "null"
            : pr->in_view[i]   ? "true"
                               : "false");
    for (int m = 0; m < PL_EVAL_N_METHODS; m++) {
        if (m == PL_EVAL_RIDGE && !have_ridge) continue;
        fprintf(f, ",\"%s\":", pl_eval_method_key(m));
        put_scores_json(f, &pr->s[(size_t)i * PL_EVAL_N_METHODS + (size_t)m]);
    }
    for (int v = 0; v < N_VARIANTS; v++) {
        fprintf(f, ",\"%s\":", VARIANT_KEY[v]);
        put_scores_json(f, &pr->var[v][i]);
    }
    char lj[PL_MAX_LIGHTS * 256 + 128];
    const pl_lighting *L[4] = {&pr->pred[i], &pr->gt[i], &pr->brightest[i], &pr->ridge[i]};
    const char *key[4] = {"estimate", "ground_truth", "brightest_estimate", "ridge_estimate"};
    for (int t = 0; t < (have_ridge ? 4 : 3); t++) {
        if (pl_lighting_format_json(L[t], lj, sizeof lj) < 0)
            return pl_error(PL_E_INTERNAL, "eval: %s JSON longer than %zu bytes", key[t],
                            sizeof lj);
        fprintf(f, ",\"%s\":{%s}", key[t], lj);
    }
    fputc('}', f);
    return 0;
}

static int count_where(const signed char *in_view, int n, int want)
{
    int k = 0;
    for (int i = 0; i < n; i++)
        k += in_view[i] == want;
    return k;
}

/* "angle_by_view":{"in_view":{"crops":N,"model":{median,q1,q3,n},...},"out_of_view":{...}} */
static int put_angle_by_view_json(FILE *f, const pl_eval_scores *s, const signed char *in_view,
                                  int n, int have_ridge, double *buf)
{
    fputs("{", f);
    for (int want = 1; want >= 0; want--) {
        fprintf(f, "%s\"%s\":{\"crops\":%d", want ? "" : ",", want ? "in_view" : "out_of_view",
                count_where(in_view, n, want));
        for (int m = 0; m < PL_EVAL_N_METHODS; m++) {
            if (m == PL_EVAL_RIDGE && !have_ridge) continue;
            pl_eval_stats st;
            int rc = stats_of(s, n, m, 2, in_view, want, buf, &st);
            if (rc < 0) return rc;
            fputc(',', f);
            put_stats_json(f, pl_eval_method_key(m), &st, 1);
        }
        fputc('}', f);
    }
    fputc('}', f);
    return 0;
}

static void put_cell(FILE *f, const pl_eval_stats *st, int width)
{
    char b[96];
    if (st->n == 0)
        snprintf(b, sizeof b, "-");
    else
        snprintf(b, sizeof b, "%.4g [%.4g, %.4g]", st->median, st->q1, st->q3);
    fprintf(f, "  %-*s", width, b);
}

static int put_table(FILE *f, const pl_eval_scores *s, int n, int have_ridge, double *buf)
{
    fprintf(f, "  %-24s  %-28s  %-28s  %-28s  %s\n", "method", "rmse median [q1, q3]",
            "si-rmse median [q1, q3]", "angle deg median [q1, q3]", "scale EV median [q1, q3]");
    for (int m = 0; m < PL_EVAL_N_METHODS; m++) {
        if (m == PL_EVAL_RIDGE && !have_ridge) continue;
        fprintf(f, "  %-24s", pl_eval_method_label(m));
        for (int q = 0; q < N_METRICS; q++) {
            pl_eval_stats st;
            int rc = stats_of(s, n, m, q, NULL, 0, buf, &st);
            if (rc < 0) return rc;
            put_cell(f, &st, q < N_METRICS - 1 ? 28 : 0);
        }
        fputc('\n', f);
    }
    return 0;
}

/* Key light over each room's views, for one method (model, or ridge when `ridge`): the
 * statistics over rooms of the fused key light's angle (st[0]) and of each room's median
 * single-crop angle (st[1]). buf: crops + 2 n_rows values. */
static int key_stats(const pano_row *rows, int n_rows, int crops, int ridge, double *buf,
                     pl_eval_stats st[2])
{
    double *fused = buf + crops, *single = fused + n_rows;
    for (int r = 0; r < n_rows; r++) {
        pl_eval_stats room;
        int rc = stats_of(rows[r].s, crops, ridge ? PL_EVAL_RIDGE : PL_EVAL_MODEL, 2, NULL, 0, buf,
                          &room);
        if (rc < 0) return rc;
        fused[r] = rows[r].key_angle[ridge];
        single[r] = room.median;
    }
    int rc = pl_eval_quartiles(fused, n_rows, &st[0]);
    return rc < 0 ? rc : pl_eval_quartiles(single, n_rows, &st[1]);
}

/* The model's lights after the room's views (variant v, V_*): rmse (st[0]) and si-RMSE (st[1])
 * over every crop, the same for its own lights (st[2], st[3]), and in how many rooms the variant
 * lowers the median rmse (rooms_lower[0]) and the median si-RMSE (rooms_lower[1]). */
static int variant_stats(const pano_row *rows, int n_rows, int crops, int v, double *buf,
                         pl_eval_stats st[4], int rooms_lower[2])
{
    for (int q = 0; q < 4; q++) {
        for (int r = 0; r < n_rows; r++)
            for (int i = 0; i < crops; i++) {
                const pl_eval_scores *x =
                    q < 2 ? &rows[r].var[v][i] : &rows[r].s[(size_t)i * PL_EVAL_N_METHODS];
                buf[r * crops + i] = q % 2 ? x->si_rmse : x->rmse;
            }
        int rc = pl_eval_quartiles(buf, n_rows * crops, &st[q]);
        if (rc < 0) return rc;
    }
    rooms_lower[0] = rooms_lower[1] = 0;
    for (int r = 0; r < n_rows; r++)
        for (int q = 0; q < 2; q++) {
            pl_eval_stats own, after;
            for (int i = 0; i < crops; i++)
                buf[i] = q ? rows[r].var[v][i].si_rmse : rows[r].var[v][i].rmse;
            int rc = pl_eval_quartiles(buf, crops, &after);
            if (rc == 0) rc = stats_of(rows[r].s, crops, PL_EVAL_MODEL, q, NULL, 0, buf, &own);
            if (rc < 0) return rc;
            /* lower by more than rounding: a variant that keeps the shape (the level) renders
             * the same si-RMSE to within float noise */
            rooms_lower[q] += after.median < own.median * (1 - 1e-6);
        }
    return 0;
}

/* The key-light table (text), or its "key_light_over_views" object (json). */
static int put_key_lights(FILE *f, int json, const pano_row *rows, int n_rows, int crops,
                          int have_ridge, double *buf)
{
    if (json) {
        fprintf(f, "{\"rooms\":%d,\"views\":%d", n_rows, crops);
    } else {
        char h[2][96];
        snprintf(h[0], sizeof h[0], "key light, %d room%s", n_rows, n_rows == 1 ? "" : "s");
        snprintf(h[1], sizeof h[1], "fused over %d views, deg", crops);
        fprintf(f, "  %-24s  %-28s  %s\n", h[0], h[1], "single crops, room medians, deg");
    }
    for (int m = 0; m <= have_ridge; m++) {
        const int method = m ? PL_EVAL_RIDGE : PL_EVAL_MODEL;
        pl_eval_stats st[2];
        int rc = key_stats(rows, n_rows, crops, m, buf, st);
        if (rc < 0) return rc;
        if (json) {
            fprintf(f, ",\"%s\":{", pl_eval_method_key(method));
            put_stats_json(f, "fused_angle_deg", &st[0], 1);
            fputc(',', f);
            put_stats_json(f, "room_median_angle_deg", &st[1], 1);
            for (int v = 0; !m && v < N_VARIANTS; v++) {
                pl_eval_stats a[4];
                int lower[2];
                char key[64];
                if ((rc = variant_stats(rows, n_rows, crops, v, buf, a, lower)) < 0) return rc;
                for (int q = 0; q < 2; q++) {
                    snprintf(key, sizeof key, "%s_%s", VARIANT_STAT[v], q ? "si_rmse" : "rmse");
                    fputc(',', f);
                    put_stats_json(f, key, &a[q], 1);
                }
                fprintf(f, ",\"rooms_%s_rmse_lower\":%d,\"rooms_%s_si_rmse_lower\":%d",
                        VARIANT_STAT[v], lower[0], VARIANT_STAT[v], lower[1]);
            }
            fputc('}', f);
        } else {
            fprintf(f, "  %-24s", pl_eval_method_label(method));
            put_cell(f, &st[0], 28);
            put_cell(f, &st[1], 0);
            fputc('\n', f);
        }
    }
    if (json) {
        fputc('}', f);
        return 0;
    }
    fprintf(f, "  %-24s  %-28s  %-28s  %s\n", "model's lights", "rmse median [q1, q3]",
            "si-rmse median [q1, q3]", "rooms where lower: rmse, si-rmse");
    for (int v = 0; v < N_VARIANTS; v++) {
        pl_eval_stats a[4];
        int lower[2];
        int rc = variant_stats(rows, n_rows, crops, v, buf, a, lower);
        if (rc < 0) return rc;
        if (v == 0) {
            fprintf(f, "  %-24s", "own");
            put_cell(f, &a[2], 28);
            put_cell(f, &a[3], 0);
            fputc('\n', f);
        }
        fprintf(f, "  %-24s", VARIANT_LABEL[v]);
        put_cell(f, &a[0], 28);
        put_cell(f, &a[1], 28);
        fprintf(f, "%d, %d of %d\n", lower[0], lower[1], n_rows);
    }
    return 0;
}

/* The angle column again, split by where the ground truth's primary light is. */
static int put_angle_by_view(FILE *f, const pl_eval_scores *s, const signed char *in_view, int n,
                             int have_ridge, double *buf)
{
    char h[2][64];
    for (int want = 1; want >= 0; want--) {
        const int k = count_where(in_view, n, want);
        snprintf(h[1 - want], sizeof h[0], "%s (%d crop%s)", want ? "in view" : "out of view", k,
                 k == 1 ? "" : "s");
    }
    fprintf(f, "  %-24s  %-28s  %s\n", "angle deg, primary light", h[0], h[1]);
    for (int m = 0; m < PL_EVAL_N_METHODS; m++) {
        if (m == PL_EVAL_RIDGE && !have_ridge) continue;
        fprintf(f, "  %-24s", pl_eval_method_label(m));
        for (int want = 1; want >= 0; want--) {
            pl_eval_stats st;
            int rc = stats_of(s, n, m, 2, in_view, want, buf, &st);
            if (rc < 0) return rc;
            put_cell(f, &st, want ? 28 : 0);
        }
        fputc('\n', f);
    }
    return 0;
}

int cmd_eval(int argc, char **argv)
{
    static const struct option opts[] = {{"model", required_argument, 0, 'm'},
                                         {"hdr", required_argument, 0, 'i'},
                                         {"crops", required_argument, 0, 'c'},
                                         {"size", required_argument, 0, 's'},
                                         {"threads", required_argument, 0, 't'},
                                         {"json", no_argument, 0, 'j'},
                                         {"per-pano", no_argument, 0, 'p'},
                                         {"anchor", required_argument, 0, 'A'},
                                         {"ridge", required_argument, 0, 'R'},
                                         {"max-pixels", required_argument, 0, CLI_OPT_MAX_PIXELS},
                                         {"help", no_argument, 0, 'h'},
                                         {0, 0, 0, 0}};
    const char *model_path = NULL, *dir = NULL, *ridge_arg = NULL;
    int crops = 8, size = 64, threads = 1, json = 0, per_pano = 0, have_anchor = 0, c;
    double anchor[3];
    optind = 1;
    opterr = 0;
    while ((c = getopt_long(argc, argv, ":h", opts, NULL)) != -1) {
        switch (c) {
        case 'm':
            model_path = optarg;
            break;
        case 'i':
            dir = optarg;
            break;
        case 'c':
            if (cli_int("eval", "--crops", optarg, 1, 64, &crops) < 0) return 2;
            break;
        case 's':
            if (cli_int("eval", "--size", optarg, 8, 512, &size) < 0) return 2;
            break;
        case 't':
            if (cli_int("eval", "--threads", optarg, 1, PL_MAX_THREADS, &threads) < 0) return 2;
            break;
        case 'j':
            json = 1;
            break;
        case 'p':
            per_pano = 1;
            break;
        case 'A':
            if (cli_anchor("eval", optarg, anchor) < 0) return 2;
            have_anchor = 1;
            break;
        case 'R':
            ridge_arg = optarg;
            break;
        case CLI_OPT_MAX_PIXELS:
            if (cli_max_pixels("eval", optarg) < 0) return 2;
            break;
        case 'h':
            usage(stdout);
            return 0;
        default:
            return cli_getopt_error("eval", c, argv);
        }
    }
    if (optind < argc) {
        fprintf(stderr, "parlight eval: unexpected argument '%s'\n", argv[optind]);
        return 2;
    }
    if (!model_path || !dir) {
        fprintf(stderr, "parlight eval: %s is required (see --help)\n",
                !model_path ? "--model M.plm" : "--hdr DIR");
        return 2;
    }

    int ret = 1, n_files = 0, n_rows = 0, n_skipped = 0;
    char **files = NULL;
    pano_row *rows = NULL;
    skipped_file *skipped = NULL;
    crop_job *jobs = NULL;
    pl_model *model = NULL;
    pl_ridge *ridge = NULL;
    char ridge_path[4096] = "";
    pl_pool *pool = NULL;
    double *buf = NULL;
    pl_model_info mi;
    double ms[3] = {0, 0, 0}; /* wall time making crops, estimating, scoring */
    const int64_t t_start = pl_now_ns();

    if (list_dir(dir, &files, &n_files) < 0 || pl_model_load(model_path, &model) < 0 ||
        pl_model_set_threads(model, threads) < 0 ||
        (have_anchor && pl_model_set_anchor(model, anchor[0], anchor[1], anchor[2]) < 0) ||
        pl_model_get_info(model, &mi) < 0 || pl_pool_create(threads, &pool) < 0) {
        fprintf(stderr, "parlight eval: %s\n", pl_last_error());
        goto out;
    }
    if (ridge_arg && strcmp(ridge_arg, "none") != 0) {
        snprintf(ridge_path, sizeof ridge_path, "%s", ridge_arg);
    } else if (!ridge_arg) { /* beside the model, when it is there */
        const char *slash = strrchr(model_path, '/');
        int len = slash ? (int)(slash - model_path) + 1 : 0;
        struct stat st;
        if ((size_t)snprintf(ridge_path, sizeof ridge_path, "%.*sparlight-ridge.json", len,
                             model_path) >= sizeof ridge_path ||
            stat(ridge_path, &st) != 0)
            ridge_path[0] = '\0';
    }
    if (ridge_path[0] && pl_ridge_load(ridge_path, &ridge) < 0) {
        fprintf(stderr, "parlight eval: (d) ridge model: %s\n", pl_last_error());
        goto out;
    }
    if (!ridge)
        fprintf(stderr, "parlight eval: baseline (d) ridge not scored: %s\n",
                ridge_arg ? "--ridge none"
                          : "no parlight-ridge.json beside the model and no --ridge FILE");
    rows = calloc((size_t)n_files, sizeof *rows);
    skipped = calloc((size_t)n_files, sizeof *skipped);
    jobs = calloc((size_t)crops, sizeof *jobs);
    if (!rows || !skipped || !jobs) {
        fprintf(stderr, "parlight eval: out of memory\n");
        goto out;
    }
    pl_extract_params ep;
    pl_extract_default_params(&ep);

    for (int f = 0; f < n_files; f++) {
        char path[4096];
        snprintf(path, sizeof path, "%s/%s", dir, files[f]);
        int st =
            eval_panorama(path, &ep, model, &mi, ridge, pool, crops, size, jobs, &rows[n_rows], ms);
        if (st == SKIP_FILE) {
            fprintf(stderr, "parlight eval: skipping %s: %s\n", files[f], pl_last_error());
            skipped[n_skipped].file = files[f];
            skipped[n_skipped].why = strdup(pl_last_error());
            n_skipped++;
            continue;
        }
        if (st < 0) { /* an error in our own maths or the model: not a file to skip */
            fprintf(stderr, "parlight eval: %s: %s\n", files[f], pl_last_error());
            goto out;
        }
        rows[n_rows++].file = files[f];
    }
    if (n_rows == 0) {
        fprintf(stderr, "parlight eval: no usable panorama in %s (%d file%s skipped)\n", dir,
                n_skipped, n_skipped == 1 ? "" : "s");
        goto out;
    }

    /* all crops of all panoramas, in one array */
    const int n_crops = n_rows * crops;
    pl_eval_scores *all = malloc((size_t)n_crops * PL_EVAL_N_METHODS * sizeof *all);
    signed char *all_in_view = malloc((size_t)n_crops);
    buf = malloc(((size_t)n_crops + (size_t)crops + 2 * (size_t)n_rows) * sizeof *buf);
    if (!all || !all_in_view || !buf) {
        free(all);
        free(all_in_view);
        fprintf(stderr, "parlight eval: out of memory\n");
        goto out;
    }
    for (int r = 0; r < n_rows; r++) {
        memcpy(&all[(size_t)r * crops * PL_EVAL_N_METHODS], rows[r].s,
               (size_t)crops * PL_EVAL_N_METHODS * sizeof *all);
        memcpy(&all_in_view[(size_t)r * crops], rows[r].in_view, (size_t)crops);
    }
    int rc = 0;
    if (json) {
        printf("{\"model\":");
        pl_app_put_json_string(stdout, model_path);
        printf(",\"precision\":\"%s\",\"n_lights\":%d,\"intensity_anchor\":{\"w\":%.6g,\"b\":%.6g,"
               "\"gamma\":%.6g},\"hdr\":",
               mi.precision, mi.n_lights, mi.anchor[0], mi.anchor[1], mi.anchor[2]);
        pl_app_put_json_string(stdout, dir);
        pl_crop_params cp;
        pl_crop_default_params(&cp);
        printf(",\"crops_per_panorama\":%d,\"crop\":{\"width\":%d,\"height\":%d,\"fov_deg\":%g,"
               "\"pitch_deg\":%g,\"exposure_ev\":%g,\"gamma\":%g,\"yaw_step_deg\":%.9g},"
               "\"sphere\":{\"material\":\"diffuse\",\"size\":%d,\"truth_map_width\":%d},"
               "\"n_panoramas\":%d,\"n_crops\":%d,\"n_skipped\":%d,\"skipped\":[",
               crops, cp.width, cp.height, cp.fov_deg, cp.pitch_deg, cp.exposure_ev, cp.gamma,
               360.0 / crops, size, PL_EVAL_TRUTH_MAP_WIDTH, n_rows, n_crops, n_skipped);
        for (int i = 0; i < n_skipped; i++) {
            printf("%s{\"file\":", i ? "," : "");
            pl_app_put_json_string(stdout, skipped[i].file);
            printf(",\"error\":");
            pl_app_put_json_string(stdout, skipped[i].why ? skipped[i].why : "");
            printf("}");
        }
        printf("],\"ridge\":");
        if (ridge) {
            printf("{\"file\":");
            pl_app_put_json_string(stdout, ridge_path);
            printf(",\"grid\":[%d,%d]}", ridge->cols, ridge->rows);
        } else {
            printf("null");
        }
        printf(",\"methods\":");
        rc = put_methods_json(stdout, all, n_crops, ridge != NULL, buf);
        printf(",\"angle_by_view\":");
        if (rc == 0)
            rc = put_angle_by_view_json(stdout, all, all_in_view, n_crops, ridge != NULL, buf);
        printf(",\"key_light_over_views\":");
        if (rc == 0) rc = put_key_lights(stdout, 1, rows, n_rows, crops, ridge != NULL, buf);
        printf(",\"panoramas\":[");
        for (int r = 0; r < n_rows && rc == 0; r++) {
            const pano_row *pr = &rows[r];
            printf("%s{\"file\":", r ? "," : "");
            pl_app_put_json_string(stdout, pr->file);
            printf(",\"width\":%d,\"height\":%d,\"gt_lights\":%d,\"methods\":", pr->width,
                   pr->height, pr->n_gt_lights);
            rc = put_methods_json(stdout, pr->s, crops, ridge != NULL, buf);
            printf(",\"key_light_angle_deg\":{\"model\":");
            put_num(stdout, pr->key_angle[0]);
            if (ridge) {
                printf(",\"ridge\":");
                put_num(stdout, pr->key_angle[1]);
            }
            for (int v = 0; v < N_VARIANTS; v++) {
                printf("},\"%s\":{", VARIANT_KEY[v]);
                if (rc == 0) rc = put_variant_json(stdout, pr->var[v], crops, buf);
            }
            printf("},\"crops\":[");
            for (int i = 0; i < crops && rc == 0; i++) {
                if (i) putchar(',');
                rc = put_crop_json(stdout, pr, i, ridge != NULL);
            }
            printf("]}");
        }
        printf("]}\n");
    } else {
        char an[96] = "";
        if (mi.anchor[0] != 0 || mi.anchor[1] != 0)
            snprintf(an, sizeof an, ", intensity anchor w %g b %g gamma %g", mi.anchor[0],
                     mi.anchor[1], mi.anchor[2]);
        printf("parlight eval: %s (%s, %d lights%s) on %s: %d panorama%s x %d crops (yaw 360/%d "
               "apart, pitch 0, fov 60, 640x480, gamma 2.2), diffuse sphere %d px\n",
               model_path, mi.precision, mi.n_lights, an, dir, n_rows, n_rows == 1 ? "" : "s",
               crops, crops, size);
        if (ridge) printf("  (d) ridge: %s\n", ridge_path);
        rc = put_table(stdout, all, n_crops, ridge != NULL, buf);
        if (rc == 0) rc = put_angle_by_view(stdout, all, all_in_view, n_crops, ridge != NULL, buf);
        if (rc == 0) rc = put_key_lights(stdout, 0, rows, n_rows, crops, ridge != NULL, buf);
        for (int r = 0; r < n_rows && per_pano && rc == 0; r++) {
            printf("\n%s (%dx%d, %d ground-truth light%s)\n", rows[r].file, rows[r].width,
                   rows[r].height, rows[r].n_gt_lights, rows[r].n_gt_lights == 1 ? "" : "s");
            rc = put_table(stdout, rows[r].s, crops, ridge != NULL, buf);
        }
    }
    free(all);
    free(all_in_view);
    if (rc < 0) {
        fprintf(stderr, "parlight eval: %s\n", pl_last_error());
        goto out;
    }
    if (fflush(stdout) != 0 || ferror(stdout)) {
        fprintf(stderr, "parlight eval: cannot write the output\n");
        goto out;
    }
    fprintf(stderr,
            "parlight eval: %d panorama%s, %d crop%s in %.1f s (crops %.1f s, estimates %.1f s, "
            "metrics %.1f s, %d thread%s)",
            n_rows, n_rows == 1 ? "" : "s", n_crops, n_crops == 1 ? "" : "s",
            (double)(pl_now_ns() - t_start) / 1e9, ms[0] / 1e3, ms[1] / 1e3, ms[2] / 1e3, threads,
            threads == 1 ? "" : "s");
    if (n_skipped)
        fprintf(stderr, "; %d file%s skipped (not panoramas)", n_skipped,
                n_skipped == 1 ? "" : "s");
    fputc('\n', stderr);
    ret = 0;
out:
    for (int r = 0; r < n_rows; r++)
        free_row(&rows[r]);
    for (int i = 0; i < n_skipped; i++)
        free(skipped[i].why);
    for (int i = 0; i < n_files; i++)
        free(files[i]);
    if (jobs)
        for (int i = 0; i < crops; i++)
            pl_image_u8_free(&jobs[i].ldr);
    free(files);
    free(rows);
    free(skipped);
    free(jobs);
    free(buf);
    pl_pool_destroy(pool);
    pl_model_free(model);
    pl_ridge_free(ridge);
    return ret;
}
