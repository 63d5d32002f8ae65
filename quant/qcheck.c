#include "quant/qcheck.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/util.h"
#include "light/light.h"

#define ENV_W 128

static double angle_deg(const float a[3], const float b[3])
{
    const double na = sqrt((double)a[0] * a[0] + (double)a[1] * a[1] + (double)a[2] * a[2]);
    const double nb = sqrt((double)b[0] * b[0] + (double)b[1] * b[1] + (double)b[2] * b[2]);
    double c = ((double)a[0] * b[0] + (double)a[1] * b[1] + (double)a[2] * b[2]) / (na * nb);
    c = c > 1 ? 1 : c < -1 ? -1 : c;
    return acos(c) * 180.0 / M_PI;
}

/* Best permutation by summed angle (Heap-free recursion; n <= 8). */
static void best_perm(const pl_lighting *f, const pl_lighting *q, int k, int *perm, int *used,
                      double acc, double *best, int *best_perm_out)
{
    const int n = f->n_lights;
    if (acc >= *best) return;
    if (k == n) {
        *best = acc;
        memcpy(best_perm_out, perm, (size_t)n * sizeof *perm);
        return;
    }
    for (int j = 0; j < n; j++) {
        if (used[j]) continue;
        used[j] = 1;
        perm[k] = j;
        best_perm(f, q, k + 1, perm, used, acc + angle_deg(f->lights[k].dir, q->lights[j].dir),
                  best, best_perm_out);
        used[j] = 0;
    }
}

static double norm3(const float v[3])
{
    return sqrt((double)v[0] * v[0] + (double)v[1] * v[1] + (double)v[2] * v[2]);
}

int pl_qcheck_compare(const pl_lighting *f, const pl_lighting *q, pl_qcheck_frame *r)
{
    memset(r, 0, sizeof *r);
    const int n = f->n_lights;
    if (n != q->n_lights || n < 0 || n > 8)
        return pl_error(PL_E_ARG, "lightings with %d and %d lights", n, q->n_lights);
    int perm[8], best_p[8], used[8] = {0};
    double best = INFINITY;
    for (int i = 0; i < n; i++)
        best_p[i] = i;
    best_perm(f, q, 0, perm, used, 0, &best, best_p);
    r->n_lights = n;
    double e2 = 0, f2 = 0;
    for (int i = 0; i < n; i++) {
        const pl_light *a = &f->lights[i], *b = &q->lights[best_p[i]];
        r->dir_err_deg[i] = angle_deg(a->dir, b->dir);
        float d[3] = {b->rgb[0] - a->rgb[0], b->rgb[1] - a->rgb[1], b->rgb[2] - a->rgb[2]};
        const double na = norm3(a->rgb);
        r->rgb_rel[i] = norm3(d) / (na > 1e-12 ? na : 1e-12);
        const float va[8] = {a->dir[0],         a->dir[1], a->dir[2], a->distance_m,
                             a->solid_angle_sr, a->rgb[0], a->rgb[1], a->rgb[2]};
        const float vb[8] = {b->dir[0],         b->dir[1], b->dir[2], b->distance_m,
                             b->solid_angle_sr, b->rgb[0], b->rgb[1], b->rgb[2]};
        for (int k = 0; k < 8; k++) {
            e2 += ((double)vb[k] - va[k]) * ((double)vb[k] - va[k]);
            f2 += (double)va[k] * va[k];
        }
    }
    float da[3];
    for (int c = 0; c < 3; c++) {
        da[c] = q->ambient[c] - f->ambient[c];
        e2 += (double)da[c] * da[c];
        f2 += (double)f->ambient[c] * f->ambient[c];
    }
    const double nam = norm3(f->ambient);
    r->ambient_rel = norm3(da) / (nam > 1e-12 ? nam : 1e-12);
    r->output_rel_l2 = sqrt(e2 / (f2 > 1e-24 ? f2 : 1e-24));

    pl_image_f32 ef = {0}, eq = {0};
    int rc = pl_envmap_from_lights(f, ENV_W, &ef);
    if (rc == PL_OK) rc = pl_envmap_from_lights(q, ENV_W, &eq);
    if (rc == PL_OK) {
        double se = 0, sf = 0;
        const size_t n_px = (size_t)ef.width * ef.height * 3;
        for (size_t i = 0; i < n_px; i++) {
            const double d = (double)eq.data[i] - ef.data[i];
            se += d * d;
            sf += (double)ef.data[i] * ef.data[i];
        }
        r->envmap_rel_rmse = sqrt(se / (sf > 1e-24 ? sf : 1e-24));
    }
    pl_image_f32_free(&ef);
    pl_image_f32_free(&eq);
    return rc;
}

static pl_qcheck_layer *find_layer(pl_qcheck_layers *L, const char *name)
{
    for (int i = 0; i < L->n; i++)
        if (!strcmp(L->l[i].name, name)) return &L->l[i];
    return NULL;
}

void pl_qcheck_layers_float(void *ctx, const char *layer, const float *chw, int c, int h, int w,
                            const float *floor)
{
    (void)floor;
    pl_qcheck_layers *L = ctx;
    const size_t n = (size_t)c * h * w;
    pl_qcheck_layer *l = find_layer(L, layer);
    if (!l) {
        if (L->n == L->cap) {
            const int cap = L->cap ? 2 * L->cap : 128;
            pl_qcheck_layer *p = realloc(L->l, (size_t)cap * sizeof *p);
            if (!p) {
                L->error = 1;
                return;
            }
            L->l = p;
            L->cap = cap;
        }
        l = &L->l[L->n];
        memset(l, 0, sizeof *l);
        strncpy(l->name, layer, sizeof l->name - 1);
        l->ref = malloc(n * sizeof *l->ref);
        if (!l->ref) {
            L->error = 1;
            return;
        }
        l->n = n;
        L->n++;
    }
    if (l->n != n) {
        L->error = 1;
        return;
    }
    memcpy(l->ref, chw, n * sizeof *chw);
    l->seen = 0;
}

void pl_qcheck_layers_int8(void *ctx, const char *layer, const float *chw, int c, int h, int w,
                           const float *floor)
{
    pl_qcheck_layers *L = ctx;
    pl_qcheck_layer *l = find_layer(L, layer);
    const size_t n = (size_t)c * h * w;
    if (!l || l->n != n) {
        L->error = 1;
        return;
    }
    const size_t hw = (size_t)h * (size_t)w;
    for (size_t i = 0; i < n; i++) {
        double f = l->ref[i];
        const double q = chw[i];
        if (floor && f < floor[i / hw]) f = floor[i / hw];
        l->ss_f += f * f;
        l->ss_q += q * q;
        l->ss_e += (f - q) * (f - q);
        l->dot += f * q;
    }
    l->seen = 1;
}

void pl_qcheck_layers_free(pl_qcheck_layers *L)
{
    for (int i = 0; i < L->n; i++)
        free(L->l[i].ref);
    free(L->l);
    memset(L, 0, sizeof *L);
}

double pl_qcheck_sqnr_db(const pl_qcheck_layer *l)
{
    if (l->ss_e <= 0) return 200.0;
    if (l->ss_f <= 0) return -200.0;
    const double v = 10.0 * log10(l->ss_f / l->ss_e);
    return v > 200 ? 200 : v;
}

double pl_qcheck_cosine(const pl_qcheck_layer *l)
{
    if (l->ss_f <= 0 || l->ss_q <= 0) return l->ss_f == l->ss_q ? 1.0 : 0.0;
    return l->dot / sqrt(l->ss_f * l->ss_q);
}

static int cmp_double(const void *a, const void *b)
{
    const double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

double pl_quantile(double *v, size_t n, double q)
{
    if (n == 0) return 0;
    qsort(v, n, sizeof *v, cmp_double);
    const double pos = q * (double)(n - 1);
    const size_t i = (size_t)floor(pos);
    if (i + 1 >= n) return v[n - 1];
    return v[i] + (pos - (double)i) * (v[i + 1] - v[i]);
}
