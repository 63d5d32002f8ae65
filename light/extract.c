/* Ground-truth light extraction from HDR panoramas (light/extract.h, docs/EXTRACTION.md). */
#include "light/extract.h"

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "core/util.h"
#include "light/equirect.h"
#include "light/light.h"

#define MAX_CANDIDATES 256

static double lum(const float *p)
{
    return pl_luminance(p[0], p[1], p[2]);
}

void pl_extract_default_params(pl_extract_params *p)
{
    p->max_lights = PL_MAX_LIGHTS;
    p->max_candidates = 128;
    p->detect_median = 3.0;
    p->region_frac = 1.0 / 3.0;
    p->ambient_frac = 0.05;
    p->keep_frac = 0.10;
    p->support_frac = 0.01;
    p->refine = 1;
    p->sphere_size = 32;
    p->room.room_height = 2.8;
    p->room.camera_height = 1.6;
    p->room.half_width = 3.0;
    p->room.half_depth = 3.0;
}

int pl_extract_check_params(const pl_extract_params *p)
{
    if (!p) return pl_error(PL_E_ARG, "extract: params is NULL");
    if (p->max_lights < 1 || p->max_lights > PL_MAX_LIGHTS)
        return pl_error(PL_E_ARG, "extract: max_lights %d, expected 1..%d", p->max_lights,
                        PL_MAX_LIGHTS);
    if (p->max_candidates < 1 || p->max_candidates > MAX_CANDIDATES)
        return pl_error(PL_E_ARG, "extract: max_candidates %d, expected 1..%d", p->max_candidates,
                        MAX_CANDIDATES);
    if (!(p->region_frac > 0 && p->region_frac < 1))
        return pl_error(PL_E_ARG, "extract: region_frac %g, expected in (0, 1)", p->region_frac);
    if (!(p->ambient_frac > 0 && p->ambient_frac < 1))
        return pl_error(PL_E_ARG, "extract: ambient_frac %g, expected in (0, 1)", p->ambient_frac);
    if (!(p->detect_median >= 1 && p->detect_median <= 1e6))
        return pl_error(PL_E_ARG, "extract: detect_median %g, expected in [1, 1e6]",
                        p->detect_median);
    if (!(p->keep_frac >= 0 && p->keep_frac <= 1))
        return pl_error(PL_E_ARG, "extract: keep_frac %g, expected in [0, 1]", p->keep_frac);
    if (!(p->support_frac > 0 && p->support_frac <= p->region_frac))
        return pl_error(PL_E_ARG, "extract: support_frac %g, expected in (0, region_frac]",
                        p->support_frac);
    if (p->sphere_size < 16 || p->sphere_size > 512)
        return pl_error(PL_E_ARG, "extract: sphere_size %d, expected 16..512", p->sphere_size);
    const pl_room *r = &p->room;
    if (!(r->camera_height > 0 && r->room_height > r->camera_height && r->room_height < 1e4))
        return pl_error(PL_E_ARG,
                        "extract: room height %g / camera height %g: expected 0 < camera "
                        "< room height",
                        r->room_height, r->camera_height);
    if (!(r->half_width > 0 && r->half_width < 1e4 && r->half_depth > 0 && r->half_depth < 1e4))
        return pl_error(PL_E_ARG, "extract: room half width %g / half depth %g: expected > 0",
                        r->half_width, r->half_depth);
    return PL_OK;
}

double pl_room_distance(const pl_room *room, const float dir[3])
{
    double d = INFINITY;
    double lim[3][2] = {{-room->half_width, room->half_width},
                        {-room->camera_height, room->room_height - room->camera_height},
                        {-room->half_depth, room->half_depth}};
    for (int k = 0; k < 3; k++) {
        if (dir[k] > 1e-9)
            d = fmin(d, lim[k][1] / dir[k]);
        else if (dir[k] < -1e-9)
            d = fmin(d, lim[k][0] / dir[k]);
    }
    return d;
}

/* Work buffers of one extraction. */
typedef struct work {
    int W, H;
    size_t n;
    float *Y;       /* luminance */
    float *sr;      /* solid angle per row */
    int16_t *lab;   /* 0 free, k+1 candidate region k, -(k+1) its halo */
    int16_t *sup;   /* 0 none, i+1 support of kept light i */
    int32_t *stack; /* flood-fill stack / queue */
    float *lo;      /* halo/support growth: the lowest Y on the path that reached the pixel */
    int32_t *list;  /* the pixels of every candidate region, region after region */
    size_t list_n;
    double floor_y; /* detection floor */
    double left;    /* energy of the free pixels with Y >= floor_y */
} work;

typedef struct region {
    double energy, peak, rgb_sum[3], sr_sum;
    int pixels;
    size_t first; /* its pixels are list[first .. first + pixels) */
} region;

/* 8-connected neighbours of pixel p, wrapping in x; returns their count. */
static int neighbours(const work *w, int32_t p, int32_t nb[8])
{
    int x = (int)(p % w->W), y = (int)(p / w->W), k = 0;
    for (int dy = -1; dy <= 1; dy++) {
        int yy = y + dy;
        if (yy < 0 || yy >= w->H) continue;
        for (int dx = -1; dx <= 1; dx++) {
            if (!dx && !dy) continue;
            int xx = x + dx;
            if (xx < 0) xx += w->W;
            if (xx >= w->W) xx -= w->W;
            nb[k++] = (int32_t)yy * w->W + xx;
        }
    }
    return k;
}

/* Grows candidate region `label` from seed over free pixels with Y >= thr. */
static void grow_region(work *w, const pl_image_f32 *pano, int32_t seed, double thr, int16_t label,
                        region *r)
{
    memset(r, 0, sizeof *r);
    r->first = w->list_n;
    size_t top = 0;
    w->lab[seed] = label;
    w->stack[top++] = seed;
    while (top > 0) {
        int32_t p = w->stack[--top];
        w->list[w->list_n++] = p;
        int y = (int)(p / w->W);
        double dw = w->sr[y];
        if (w->Y[p] >= w->floor_y) w->left -= w->Y[p] * dw;
        const float *px = pano->data + (size_t)p * 3;
        r->energy += w->Y[p] * dw;
        r->sr_sum += dw;
        for (int c = 0; c < 3; c++)
            r->rgb_sum[c] += px[c] * dw;
        if (w->Y[p] > r->peak) r->peak = w->Y[p];
        r->pixels++;
        int32_t nb[8];
        int k = neighbours(w, p, nb);
        for (int i = 0; i < k; i++) {
            int32_t q = nb[i];
            if (w->lab[q] == 0 && w->Y[q] >= thr) {
                w->lab[q] = label;
                w->stack[top++] = q;
            }
        }
    }
}

/* Marks the falloff around region `label`: pixels reached from it along paths that never rise
 * above HALO_TOL x the lowest Y met so far on the path (noise tolerance that cannot compound),
 * with Y >= thr, get -label, so the next peak is not the same light's tail. */
#define HALO_TOL 1.10f
static void grow_halo(work *w, const region *r, int16_t label, double thr)
{
    size_t top = 0;
    for (size_t i = 0; i < (size_t)r->pixels; i++) {
        int32_t p = w->list[r->first + i];
        w->lo[p] = w->Y[p];
        w->stack[top++] = p;
    }
    while (top > 0) {
        int32_t p = w->stack[--top];
        int32_t nb[8];
        int k = neighbours(w, p, nb);
        for (int i = 0; i < k; i++) {
            int32_t q = nb[i];
            if (w->lab[q] == 0 && w->Y[q] >= thr && w->Y[q] <= w->lo[p] * HALO_TOL) {
                w->lab[q] = (int16_t)-label;
                w->lo[q] = fminf(w->lo[p], w->Y[q]);
                if (w->Y[q] >= w->floor_y) w->left -= w->Y[q] * w->sr[q / w->W];
                w->stack[top++] = q;
            }
        }
    }
}

/* Median of n floats (n >= 1), by quickselect on scratch (overwritten). */
static float median(float *a, size_t n)
{
    size_t lo = 0, hi = n - 1, k = n / 2;
    while (lo < hi) {
        float piv = a[lo + (hi - lo) / 2];
        size_t i = lo, j = hi;
        while (i <= j) {
            while (a[i] < piv)
                i++;
            while (a[j] > piv)
                j--;
            if (i <= j) {
                float t = a[i];
                a[i] = a[j];
                a[j] = t;
                i++;
                if (j == 0) break;
                j--;
            }
        }
        if (k <= j)
            hi = j;
        else if (k >= i)
            lo = i;
        else
            break;
    }
    return a[k];
}

/* Direction (solid-angle-weighted centre of mass) and size (fitted ellipse) of region `label`. */
static void region_geometry(const work *w, const region *reg, double dir[3], double *solid_angle)
{
    double s[3] = {0, 0, 0}, wsum = 0;
    for (size_t i = 0; i < (size_t)reg->pixels; i++) {
        size_t p = (size_t)w->list[reg->first + i];
        int y = (int)(p / (size_t)w->W), x = (int)(p % (size_t)w->W);
        double d[3], dw = w->sr[y];
        pl_equirect_dir(w->W, w->H, x, y, d);
        for (int k = 0; k < 3; k++)
            s[k] += d[k] * dw;
        wsum += dw;
    }
    double nrm = sqrt(s[0] * s[0] + s[1] * s[1] + s[2] * s[2]);
    if (nrm < 1e-12) { /* a region symmetric around the camera: take +y */
        s[0] = 0, s[1] = 1, s[2] = 0;
        nrm = 1;
    }
    for (int k = 0; k < 3; k++)
        dir[k] = s[k] / nrm;
    /* tangent basis at dir */
    double a[3] = {0, 1, 0};
    if (fabs(dir[1]) > 0.9) a[0] = 1, a[1] = 0;
    double e1[3] = {a[1] * dir[2] - a[2] * dir[1], a[2] * dir[0] - a[0] * dir[2],
                    a[0] * dir[1] - a[1] * dir[0]};
    double n1 = sqrt(e1[0] * e1[0] + e1[1] * e1[1] + e1[2] * e1[2]);
    for (int k = 0; k < 3; k++)
        e1[k] /= n1;
    double e2[3] = {dir[1] * e1[2] - dir[2] * e1[1], dir[2] * e1[0] - dir[0] * e1[2],
                    dir[0] * e1[1] - dir[1] * e1[0]};
    /* second moments of the azimuthal-equidistant coordinates, plus each pixel's own extent */
    double m1 = 0, m2 = 0, c11 = 0, c22 = 0, c12 = 0;
    for (size_t i = 0; i < (size_t)reg->pixels; i++) {
        size_t p = (size_t)w->list[reg->first + i];
        int y = (int)(p / (size_t)w->W), x = (int)(p % (size_t)w->W);
        double d[3], dw = w->sr[y];
        pl_equirect_dir(w->W, w->H, x, y, d);
        double c = d[0] * dir[0] + d[1] * dir[1] + d[2] * dir[2];
        double t1 = d[0] * e1[0] + d[1] * e1[1] + d[2] * e1[2];
        double t2 = d[0] * e2[0] + d[1] * e2[1] + d[2] * e2[2];
        double st = sqrt(t1 * t1 + t2 * t2), th = atan2(st, c);
        double u = st > 1e-12 ? th * t1 / st : 0, v = st > 1e-12 ? th * t2 / st : 0;
        m1 += u * dw, m2 += v * dw;
        c11 += (u * u + dw / 12.0) * dw;
        c22 += (v * v + dw / 12.0) * dw;
        c12 += u * v * dw;
    }
    m1 /= wsum, m2 /= wsum;
    c11 = c11 / wsum - m1 * m1;
    c22 = c22 / wsum - m2 * m2;
    c12 = c12 / wsum - m1 * m2;
    double tr = c11 + c22, det = c11 * c22 - c12 * c12;
    double disc = sqrt(fmax(0.0, tr * tr / 4 - det));
    double l1 = fmax(0.0, tr / 2 + disc), l2 = fmax(0.0, tr / 2 - disc);
    /* a uniform ellipse with semi-axes A, B has variances A^2/4, B^2/4 */
    double r = fmin(M_PI, (2.0 * sqrt(l1) + 2.0 * sqrt(l2)) / 2.0);
    double sa = 2.0 * M_PI * (1.0 - cos(r));
    *solid_angle = fmax(sa, 1e-6);
}

/* Solves the k x k system G x = h restricted to the indices with free[i] (Gaussian elimination
 * with partial pivoting); x[i] = 0 elsewhere. Returns 0, or -1 when singular. */
static int solve_free(int k, const double *G, const double *h, const int *freev, double *x)
{
    double A[PL_MAX_LIGHTS][PL_MAX_LIGHTS + 1];
    int idx[PL_MAX_LIGHTS], m = 0;
    for (int i = 0; i < k; i++)
        if (freev[i]) idx[m++] = i;
    for (int i = 0; i < k; i++)
        x[i] = 0;
    if (m == 0) return 0;
    double tr = 0;
    for (int i = 0; i < m; i++)
        tr += G[idx[i] * k + idx[i]];
    for (int i = 0; i < m; i++) {
        for (int j = 0; j < m; j++)
            A[i][j] = G[idx[i] * k + idx[j]];
        A[i][i] += 1e-10 * tr / m; /* a whisper of ridge for near-duplicate lights */
        A[i][m] = h[idx[i]];
    }
    for (int c = 0; c < m; c++) {
        int piv = c;
        for (int r = c + 1; r < m; r++)
            if (fabs(A[r][c]) > fabs(A[piv][c])) piv = r;
        if (fabs(A[piv][c]) < 1e-300) return -1;
        if (piv != c)
            for (int j = 0; j <= m; j++) {
                double t = A[c][j];
                A[c][j] = A[piv][j];
                A[piv][j] = t;
            }
        for (int r = c + 1; r < m; r++) {
            double f = A[r][c] / A[c][c];
            for (int j = c; j <= m; j++)
                A[r][j] -= f * A[c][j];
        }
    }
    for (int r = m - 1; r >= 0; r--) {
        double s = A[r][m];
        for (int j = r + 1; j < m; j++)
            s -= A[r][j] * x[idx[j]];
        x[idx[r]] = s / A[r][r];
    }
    return 0;
}

/* Non-negative least squares by clamping: solve on the free set, drop the most negative, repeat. */
static void nnls_clamp(int k, const double *G, const double *h, double *x)
{
    int freev[PL_MAX_LIGHTS];
    for (int i = 0; i < k; i++)
        freev[i] = 1;
    for (int it = 0; it <= k; it++) {
        if (solve_free(k, G, h, freev, x) < 0) {
            for (int i = 0; i < k; i++)
                x[i] = 0;
            return;
        }
        int worst = -1;
        for (int i = 0; i < k; i++)
            if (freev[i] && x[i] < 0 && (worst < 0 || x[i] < x[worst])) worst = i;
        if (worst < 0) return;
        freev[worst] = 0;
    }
}

/* Supports for the colour fit: every detected region (kept or not) with its halo, grown further
 * (multi-source, breadth first) over pixels reached by non-rising paths (as grow_halo) with
 * Y >= max(peak * frac, floor_y). w->sup[p] = the candidate's label (1..nc) or 0. */
static void grow_supports(work *w, const region *cand, double frac, double floor_y)
{
    size_t head = 0, tail = 0;
    for (size_t p = 0; p < w->n; p++) {
        int lb = w->lab[p] < 0 ? -w->lab[p] : w->lab[p];
        w->sup[p] = (int16_t)lb;
        if (!lb) continue;
        w->lo[p] = w->Y[p];
        w->stack[tail++] = (int32_t)p;
    }
    while (head < tail) {
        int32_t p = w->stack[head++];
        int lb = w->sup[p];
        double thr = fmax(cand[lb - 1].peak * frac, floor_y);
        int32_t nb[8];
        int m = neighbours(w, p, nb);
        for (int j = 0; j < m; j++) {
            int32_t q = nb[j];
            if (w->sup[q] == 0 && w->Y[q] >= thr && w->Y[q] <= w->lo[p] * HALO_TOL) {
                w->sup[q] = (int16_t)lb;
                w->lo[q] = fminf(w->lo[p], w->Y[q]);
                w->stack[tail++] = q;
            }
        }
    }
}

/* Least-squares colours (see the header, step 5); w->sup holds the supports. */
static int refine_colours(work *w, const pl_image_f32 *pano, const pl_extract_params *prm,
                          pl_lighting *L, const double amb[3])
{
    int k = L->n_lights, st = PL_OK;
    if (k == 0) return PL_OK;
    pl_image_f32 masked = {0, 0, NULL}, target = {0, 0, NULL}, basis[PL_MAX_LIGHTS];
    memset(basis, 0, sizeof basis);
    if ((st = pl_image_f32_alloc(&masked, w->W, w->H)) < 0) goto out;
    for (size_t p = 0; p < w->n; p++) {
        float *o = masked.data + p * 3;
        const float *s = pano->data + p * 3;
        if (w->sup[p]) {
            for (int c = 0; c < 3; c++)
                o[c] = (float)fmax(0.0, s[c] - amb[c]);
        } else {
            o[0] = o[1] = o[2] = 0;
        }
    }
    int S = prm->sphere_size;
    if ((st = pl_render_sphere_envmap(&masked, PL_MATERIAL_DIFFUSE, S, &target)) < 0) goto out;
    for (int i = 0; i < k; i++) {
        pl_lighting one;
        memset(&one, 0, sizeof one);
        one.n_lights = 1;
        one.lights[0] = L->lights[i];
        one.lights[0].rgb[0] = one.lights[0].rgb[1] = one.lights[0].rgb[2] = 1.0f;
        if ((st = pl_render_sphere_lights(&one, PL_MATERIAL_DIFFUSE, S, &basis[i])) < 0) goto out;
    }
    double G[PL_MAX_LIGHTS * PL_MAX_LIGHTS] = {0}, h[3][PL_MAX_LIGHTS] = {{0}};
    for (int y = 0; y < S; y++) {
        for (int x = 0; x < S; x++) {
            if (!pl_sphere_mask(S, x, y)) continue;
            size_t o = ((size_t)y * S + x) * 3;
            for (int i = 0; i < k; i++) {
                double bi = basis[i].data[o]; /* grey: all channels equal */
                for (int j = 0; j < k; j++)
                    G[i * k + j] += bi * basis[j].data[o];
                for (int c = 0; c < 3; c++)
                    h[c][i] += bi * target.data[o + c];
            }
        }
    }
    for (int c = 0; c < 3; c++) {
        double x[PL_MAX_LIGHTS];
        nnls_clamp(k, G, h[c], x);
        for (int i = 0; i < k; i++)
            L->lights[i].rgb[c] = (float)fmax(0.0, x[i]);
    }
out:
    pl_image_f32_free(&masked);
    pl_image_f32_free(&target);
    for (int i = 0; i < k; i++)
        pl_image_f32_free(&basis[i]);
    return st;
}

typedef struct peak_px {
    float y;
    int32_t p;
} peak_px;

static int cmp_peak(const void *a, const void *b)
{
    const peak_px *x = a, *y = b;
    if (x->y != y->y) return x->y < y->y ? 1 : -1; /* brightest first */
    return (x->p > y->p) - (x->p < y->p);          /* then in raster order: deterministic */
}

int pl_extract_lights(const pl_image_f32 *pano, const pl_extract_params *prm, pl_lighting *out,
                      pl_extract_info *info_out)
{
    if (!pano || !pano->data || !out) return pl_error(PL_E_ARG, "extract: NULL argument");
    int st = pl_extract_check_params(prm);
    if (st < 0) return st;
    if (pano->height < 4 || pano->width != 2 * pano->height || pano->width > PL_IMAGE_MAX_SIDE)
        return pl_error(PL_E_ARG, "extract: %d x %d is not a 2:1 panorama of at least 8 x 4",
                        pano->width, pano->height);
    int64_t t0 = pl_now_ns();
    pl_extract_info info;
    memset(&info, 0, sizeof info);
    work w;
    memset(&w, 0, sizeof w);
    w.W = pano->width;
    w.H = pano->height;
    w.n = (size_t)w.W * (size_t)w.H;
    w.Y = malloc(w.n * sizeof *w.Y);
    w.sr = malloc((size_t)w.H * sizeof *w.sr);
    w.lab = calloc(w.n, sizeof *w.lab);
    w.sup = calloc(w.n, sizeof *w.sup);
    w.stack = malloc(w.n * sizeof *w.stack);
    w.lo = malloc(w.n * sizeof *w.lo);
    w.list = malloc(w.n * sizeof *w.list);
    pl_lighting L;
    memset(&L, 0, sizeof L);
    peak_px *peaks = NULL;
    if (!w.Y || !w.sr || !w.lab || !w.sup || !w.stack || !w.lo || !w.list) {
        st = pl_error(PL_E_NOMEM, "extract: out of memory for a %d x %d panorama", w.W, w.H);
        goto out;
    }
    for (int y = 0; y < w.H; y++)
        w.sr[y] = (float)pl_equirect_pixel_sr(w.W, w.H, y);
    double P0 = 0, total = 0;
    for (size_t p = 0; p < w.n; p++) {
        const float *px = pano->data + p * 3;
        if (!(isfinite(px[0]) && isfinite(px[1]) && isfinite(px[2]) && px[0] >= 0 && px[1] >= 0 &&
              px[2] >= 0)) {
            st = pl_error(PL_E_ARG, "extract: pixel (%zu, %zu) is negative or not finite",
                          p % (size_t)w.W, p / (size_t)w.W);
            goto out;
        }
        w.Y[p] = (float)lum(px);
        if (w.Y[p] > P0) P0 = w.Y[p];
        total += w.Y[p] * w.sr[p / (size_t)w.W];
    }
    info.peak = P0;
    info.total_energy = total;

    /* the background level: the median pixel luminance */
    float *scratch = malloc(w.n * sizeof *scratch);
    if (!scratch) {
        st = pl_error(PL_E_NOMEM, "extract: out of memory");
        goto out;
    }
    memcpy(scratch, w.Y, w.n * sizeof *scratch);
    info.median = median(scratch, w.n);
    free(scratch);

    /* 1. detection: peaks down to floor_y = detect_median x the median, so that a region (down to
     * region_frac of its peak) never spreads over the background */
    region cand[MAX_CANDIDATES];
    int nc = 0;
    double amb_thr = prm->ambient_frac * P0, strongest = 0;
    double floor_y = fmax(prm->detect_median * info.median, 1e-6 * P0);
    info.floor = floor_y;
    w.floor_y = floor_y;
    /* the pixels at or above the floor, brightest first: the peaks are taken in this order */
    size_t np = 0;
    w.left = 0;
    for (size_t p = 0; p < w.n; p++)
        if (w.Y[p] >= floor_y && P0 > 0) {
            np++;
            w.left += w.Y[p] * w.sr[p / (size_t)w.W];
        }
    peaks = malloc((np ? np : 1) * sizeof *peaks);
    if (!peaks) {
        st = pl_error(PL_E_NOMEM, "extract: out of memory");
        goto out;
    }
    np = 0;
    for (size_t p = 0; p < w.n; p++)
        if (w.Y[p] >= floor_y && P0 > 0) peaks[np].y = w.Y[p], peaks[np++].p = (int32_t)p;
    qsort(peaks, np, sizeof *peaks, cmp_peak);
    size_t next = 0;
    while (nc < prm->max_candidates) {
        while (next < np && w.lab[peaks[next].p])
            next++;
        if (next == np) break;
        if (nc > 0 && w.left < prm->keep_frac * strongest) break;
        int32_t best = peaks[next].p;
        grow_region(&w, pano, best, w.Y[best] * prm->region_frac, (int16_t)(nc + 1), &cand[nc]);
        grow_halo(&w, &cand[nc], (int16_t)(nc + 1), floor_y);
        if (cand[nc].energy > strongest) strongest = cand[nc].energy;
        nc++;
    }
    info.n_candidates = nc;

    /* 2. keep >= keep_frac of the strongest, then the max_lights strongest */
    int order[MAX_CANDIDATES], nk = 0;
    for (int i = 0; i < nc; i++)
        if (cand[i].energy >= prm->keep_frac * strongest) order[nk++] = i;
    for (int i = 1; i < nk; i++) /* insertion sort by energy, descending */
        for (int j = i; j > 0 && cand[order[j]].energy > cand[order[j - 1]].energy; j--) {
            int t = order[j];
            order[j] = order[j - 1];
            order[j - 1] = t;
        }
    if (nk > prm->max_lights) nk = prm->max_lights;

    /* 3. geometry and mean colour */
    int labels[PL_MAX_LIGHTS];
    for (int i = 0; i < nk; i++) {
        const region *r = &cand[order[i]];
        pl_light *l = &L.lights[i];
        double dir[3], sa;
        region_geometry(&w, r, dir, &sa);
        for (int k = 0; k < 3; k++)
            l->dir[k] = (float)dir[k];
        l->solid_angle_sr = (float)sa;
        for (int c = 0; c < 3; c++)
            l->rgb[c] = (float)(r->rgb_sum[c] / r->sr_sum);
        l->distance_m = (float)pl_room_distance(&prm->room, l->dir);
        info.light[i].region_energy = r->energy;
        info.light[i].peak = r->peak;
        info.light[i].region_pixels = r->pixels;
        labels[i] = order[i] + 1;
    }
    L.n_lights = nk;

    /* supports (down to 1.5 x the median luminance, just above the background) */
    grow_supports(&w, cand, prm->support_frac, 1.5 * info.median);
    for (size_t p = 0; p < w.n; p++)
        for (int i = 0; i < nk && w.sup[p]; i++)
            if (w.sup[p] == labels[i]) info.light[i].support_pixels++;

    /* 4. ambient: mean of the pixels under ambient_frac * P0 outside the supports; when there are
     * none, of all the pixels outside the supports (what is left); when none, of all pixels */
    double amb[3] = {0, 0, 0}, asr = 0;
    for (int pass = 0; pass < 3 && asr == 0; pass++) {
        for (size_t p = 0; p < w.n; p++) {
            if ((pass == 0 && w.Y[p] >= amb_thr) || (pass < 2 && w.sup[p])) continue;
            double dw = w.sr[p / (size_t)w.W];
            const float *px = pano->data + p * 3;
            for (int c = 0; c < 3; c++)
                amb[c] += px[c] * dw;
            asr += dw;
        }
    }
    for (int c = 0; c < 3; c++)
        amb[c] = asr > 0 ? amb[c] / asr : 0.0;
    for (int c = 0; c < 3; c++)
        L.ambient[c] = (float)amb[c];
    info.ms_detect = (double)(pl_now_ns() - t0) / 1e6;

    /* 5. colour refinement */
    int64_t t1 = pl_now_ns();
    if (prm->refine && nk > 0) {
        if ((st = refine_colours(&w, pano, prm, &L, amb)) < 0) goto out;
        int m = 0;
        for (int i = 0; i < nk; i++) {
            const pl_light *l = &L.lights[i];
            if (l->rgb[0] <= 0 && l->rgb[1] <= 0 && l->rgb[2] <= 0) {
                info.n_dropped_fit++;
                continue;
            }
            L.lights[m] = L.lights[i];
            info.light[m] = info.light[i];
            m++;
        }
        L.n_lights = nk = m;
    }
    info.ms_refine = (double)(pl_now_ns() - t1) / 1e6;
    for (int i = 0; i < nk; i++)
        info.light[i].fitted_energy =
            lum(L.lights[i].rgb) * pl_sg_integral(L.lights[i].solid_angle_sr);
    for (int i = 1; i < nk; i++) /* sort by fitted energy, descending */
        for (int j = i; j > 0 && info.light[j].fitted_energy > info.light[j - 1].fitted_energy;
             j--) {
            pl_light tl = L.lights[j];
            L.lights[j] = L.lights[j - 1];
            L.lights[j - 1] = tl;
            pl_extract_light_info ti = info.light[j];
            info.light[j] = info.light[j - 1];
            info.light[j - 1] = ti;
        }
    info.ms_total = (double)(pl_now_ns() - t0) / 1e6;
    *out = L;
    if (info_out) *info_out = info;
out:
    free(w.Y);
    free(w.sr);
    free(w.lab);
    free(w.sup);
    free(w.stack);
    free(w.lo);
    free(w.list);
    free(peaks);
    return st;
}
