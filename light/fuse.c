/* The room's key light fused over views (light/fuse.h). */
#include "light/fuse.h"

#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/status.h"
#include "light/light.h"

/* The narrowest lobe the map uses: sigma such that exp((cos t - 1) / sigma) falls to 1/e at
 * t = 6 degrees, the grid's spacing. A narrower light (a small, bright source) is spread to
 * this width with its energy kept, so that the grid cannot step over it. Lights as wide as the
 * network's (2-4 sr, sigma 0.16-0.3) are unchanged. */
#define SIGMA_MIN 0.00548 /* 1 - cos(6 deg) */

int pl_fuser_init(pl_fuser *f, double max_age_s)
{
    if (!f) return pl_error(PL_E_ARG, "fuse: no fuser");
    if (!(max_age_s >= 0) || !isfinite(max_age_s))
        return pl_error(PL_E_ARG, "fuse: max age %g s: expected a finite number >= 0", max_age_s);
    memset(f, 0, sizeof *f);
    f->max_age_s = max_age_s;
    return 0;
}

void pl_fuser_reset(pl_fuser *f)
{
    for (int b = 0; b < PL_FUSE_BINS; b++)
        f->bins[b].n = f->bins[b].has_level = 0;
}

static int rotation_ok(const double R[9])
{
    for (int i = 0; i < 9; i++)
        if (!isfinite(R[i])) return 0;
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) {
            double d = R[i] * R[j] + R[3 + i] * R[3 + j] + R[6 + i] * R[6 + j]; /* (R^T R)_ij */
            if (fabs(d - (i == j)) > 1e-3) return 0;
        }
    return 1;
}

/* The bin of a camera whose forward direction in world space is f (unit). */
static int bin_of(const double fw[3])
{
    double heading = atan2(fw[0], -fw[2]) * (180.0 / M_PI); /* 0 along world -z */
    double pitch = asin(fw[1] > 1 ? 1 : fw[1] < -1 ? -1 : fw[1]) * (180.0 / M_PI);
    int yaw = (int)floor(heading / (360.0 / PL_FUSE_YAW_BINS) + 0.5);
    yaw = ((yaw % PL_FUSE_YAW_BINS) + PL_FUSE_YAW_BINS) % PL_FUSE_YAW_BINS;
    int band = pitch < -PL_FUSE_PITCH_EDGE_DEG ? 0 : pitch > PL_FUSE_PITCH_EDGE_DEG ? 2 : 1;
    return band * PL_FUSE_YAW_BINS + yaw;
}

int pl_fuser_add(pl_fuser *f, const pl_lighting *cam, const double R[9], double t_s)
{
    return pl_fuser_add_exposed(f, cam, R, t_s, 0);
}

int pl_fuser_add_exposed(pl_fuser *f, const pl_lighting *cam, const double R[9], double t_s,
                         double exposure)
{
    if (!f || !cam || !R) return pl_error(PL_E_ARG, "fuse: NULL argument");
    int rc = pl_lighting_check(cam);
    if (rc < 0) return pl_error_prefix(rc, "fuse");
    if (!rotation_ok(R))
        return pl_error(PL_E_ARG, "fuse: the camera-to-world matrix is not a rotation");
    if (!isfinite(t_s)) return pl_error(PL_E_ARG, "fuse: time %g s is not finite", t_s);
    if (exposure != 0 && !(exposure > 0 && isfinite(exposure)))
        return pl_error(PL_E_ARG, "fuse: exposure %g: expected a finite number > 0", exposure);

    double fw[3] = {-R[2], -R[5], -R[8]}; /* R (0, 0, -1) */
    pl_fuse_view *v = &f->bins[bin_of(fw)];
    double energy = 4 * M_PI * pl_lighting_mean_luminance(cam);
    v->has_level = exposure > 0 && energy > 0 && isfinite(energy);
    v->level = v->has_level ? log2(energy / exposure) : 0;
    double total = 0;
    for (int i = 0; i < cam->n_lights; i++)
        total += pl_light_energy(&cam->lights[i]);
    v->n = 0;
    v->t_s = t_s;
    if (!(total > 0) || !isfinite(total)) return 0; /* no light: the bin is empty */
    for (int i = 0; i < cam->n_lights; i++) {
        const pl_light *l = &cam->lights[i];
        double e = pl_light_energy(l);
        if (!(e > 0)) continue;
        double sigma = l->solid_angle_sr / (4 * M_PI);
        if (sigma < SIGMA_MIN) sigma = SIGMA_MIN;
        double *d = v->dir[v->n], len;
        for (int k = 0; k < 3; k++)
            d[k] = R[3 * k] * l->dir[0] + R[3 * k + 1] * l->dir[1] + R[3 * k + 2] * l->dir[2];
        len = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
        for (int k = 0; k < 3; k++)
            d[k] /= len;
        /* the lobe's share of the view's energy, per unit integral of the (widened) lobe */
        v->w[v->n] = e / total / pl_sg_integral(4 * M_PI * sigma);
        v->lambda[v->n] = 1 / sigma;
        v->n++;
    }
    return 0;
}

static int fresh(const pl_fuser *f, const pl_fuse_view *v, double t_s)
{
    return f->max_age_s <= 0 || t_s - v->t_s <= f->max_age_s;
}

static int live(const pl_fuser *f, const pl_fuse_view *v, double t_s)
{
    return v->n > 0 && fresh(f, v, t_s);
}

int pl_fuser_level(const pl_fuser *f, double t_s, double *level)
{
    double sum = 0;
    int n = 0;
    for (int b = 0; b < PL_FUSE_BINS; b++)
        if (f->bins[b].has_level && fresh(f, &f->bins[b], t_s)) sum += f->bins[b].level, n++;
    *level = n ? sum / n : 0;
    return n;
}

static int live_views(const pl_fuser *f, double t_s)
{
    int n = 0;
    for (int b = 0; b < PL_FUSE_BINS; b++)
        n += live(f, &f->bins[b], t_s);
    return n;
}

/* E(u), and its gradient in R^3 into g when g is not NULL. */
static double map_at(const pl_fuser *f, double t_s, const double u[3], double g[3])
{
    double e = 0;
    if (g) g[0] = g[1] = g[2] = 0;
    for (int b = 0; b < PL_FUSE_BINS; b++) {
        const pl_fuse_view *v = &f->bins[b];
        if (!live(f, v, t_s)) continue;
        for (int i = 0; i < v->n; i++) {
            const double *d = v->dir[i];
            double c = v->w[i] * exp(v->lambda[i] * (u[0] * d[0] + u[1] * d[1] + u[2] * d[2] - 1));
            e += c;
            if (g)
                for (int k = 0; k < 3; k++)
                    g[k] += c * v->lambda[i] * d[k];
        }
    }
    return e;
}

int pl_fuser_key(const pl_fuser *f, double t_s, float dir[3], int *views)
{
    dir[0] = 0, dir[1] = 1, dir[2] = 0;
    if (views) *views = 0;
    if (!f || !isfinite(t_s))
        return pl_error(PL_E_ARG, "fuse: no fuser or a time that is not finite");
    int n = live_views(f, t_s);
    if (n == 0) return pl_error(PL_E_ARG, "fuse: no view with light yet");

    /* the best grid direction: a Fibonacci sphere (golden-angle spiral, equal areas) */
    double best[3] = {0, 1, 0}, best_e = -1;
    for (int j = 0; j < PL_FUSE_DIRS; j++) {
        double y = 1 - 2 * (j + 0.5) / PL_FUSE_DIRS, r = sqrt(1 - y * y);
        double a = j * M_PI * (3 - sqrt(5.0));
        double u[3] = {r * cos(a), y, r * sin(a)};
        double e = map_at(f, t_s, u, NULL);
        if (e > best_e) best_e = e, memcpy(best, u, sizeof best);
    }
    /* mean shift: the fixed point of u = grad E(u) / |grad E(u)| is a maximum of E on the sphere */
    for (int it = 0; it < PL_FUSE_REFINE; it++) {
        double g[3];
        map_at(f, t_s, best, g);
        double len = sqrt(g[0] * g[0] + g[1] * g[1] + g[2] * g[2]);
        if (!(len > 0)) break;
        double moved = 0;
        for (int k = 0; k < 3; k++) {
            double nk = g[k] / len;
            moved += (nk - best[k]) * (nk - best[k]);
            best[k] = nk;
        }
        if (moved < 1e-18) break;
    }
    for (int k = 0; k < 3; k++)
        dir[k] = (float)best[k];
    if (views) *views = n;
    return 0;
}

/* ---- the public face (include/parlight.h): the same fuser behind an opaque handle ---------- */

struct pl_key_fuser {
    pl_fuser f;
};

int pl_key_fuser_new(double max_age_s, pl_key_fuser **out)
{
    if (!out) return pl_error(PL_E_ARG, "pl_key_fuser_new: NULL out");
    *out = NULL;
    pl_fuser f;
    int rc = pl_fuser_init(&f, max_age_s);
    if (rc < 0) return rc;
    pl_key_fuser *k = malloc(sizeof *k);
    if (!k) return pl_error(PL_E_NOMEM, "pl_key_fuser_new: out of memory (%zu bytes)", sizeof *k);
    k->f = f;
    *out = k;
    return 0;
}

void pl_key_fuser_free(pl_key_fuser *fuser)
{
    free(fuser);
}

void pl_key_fuser_reset(pl_key_fuser *fuser)
{
    if (fuser) pl_fuser_reset(&fuser->f);
}

int pl_key_fuser_add(pl_key_fuser *fuser, const pl_lighting *cam, const double R[9], double t_s)
{
    if (!fuser) return pl_error(PL_E_ARG, "pl_key_fuser_add: NULL fuser");
    return pl_fuser_add(&fuser->f, cam, R, t_s);
}

int pl_key_fuser_get(const pl_key_fuser *fuser, double t_s, pl_key_light *out)
{
    if (!fuser || !out) return pl_error(PL_E_ARG, "pl_key_fuser_get: NULL argument");
    if (!isfinite(t_s)) return pl_error(PL_E_ARG, "pl_key_fuser_get: time %g s is not finite", t_s);
    if (live_views(&fuser->f, t_s) == 0) { /* not an error for an app: nothing seen yet */
        out->dir[0] = 0, out->dir[1] = 1, out->dir[2] = 0;
        out->views = 0;
        return 0;
    }
    return pl_fuser_key(&fuser->f, t_s, out->dir, &out->views);
}

int pl_key_fuser_add_exposed(pl_key_fuser *fuser, const pl_lighting *cam, const double R[9],
                             double t_s, double exposure)
{
    if (!fuser) return pl_error(PL_E_ARG, "pl_key_fuser_add_exposed: NULL fuser");
    if (!(exposure > 0 && isfinite(exposure)))
        return pl_error(PL_E_ARG,
                        "pl_key_fuser_add_exposed: exposure %g: expected a finite "
                        "number > 0",
                        exposure);
    return pl_fuser_add_exposed(&fuser->f, cam, R, t_s, exposure);
}

int pl_key_fuser_level(const pl_key_fuser *fuser, double t_s, const pl_lighting *L, double exposure,
                       pl_lighting *out)
{
    if (!fuser || !L || !out) return pl_error(PL_E_ARG, "pl_key_fuser_level: NULL argument");
    if (!isfinite(t_s))
        return pl_error(PL_E_ARG, "pl_key_fuser_level: time %g s is not finite", t_s);
    if (!(exposure > 0 && isfinite(exposure)))
        return pl_error(PL_E_ARG, "pl_key_fuser_level: exposure %g: expected a finite number > 0",
                        exposure);
    int rc = pl_lighting_check(L);
    if (rc < 0) return pl_error_prefix(rc, "pl_key_fuser_level");
    double level;
    const int n = pl_fuser_level(&fuser->f, t_s, &level);
    const double energy = 4 * M_PI * pl_lighting_mean_luminance(L);
    if (out != L) *out = *L;
    if (n == 0 || !(energy > 0) || !isfinite(energy)) return n;
    const double c = exp2(level) * exposure / energy;
    /* a level beyond float's range (exposures that disagree by ~2^128): leave the frame as it is
     * rather than hand out infinite colours */
    double peak = 0;
    for (int i = 0; i < out->n_lights; i++)
        for (int k = 0; k < 3; k++)
            peak = fmax(peak, out->lights[i].rgb[k]);
    for (int k = 0; k < 3; k++)
        peak = fmax(peak, out->ambient[k]);
    if (!(peak * c <= FLT_MAX)) return n;
    for (int i = 0; i < out->n_lights; i++)
        for (int k = 0; k < 3; k++)
            out->lights[i].rgb[k] = (float)(out->lights[i].rgb[k] * c);
    for (int k = 0; k < 3; k++)
        out->ambient[k] = (float)(out->ambient[k] * c);
    return n;
}
