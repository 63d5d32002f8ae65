/* Temporal filter: tracks with stable identities, EMA smoothing and fades (light/temporal.h). */
#include "light/temporal.h"

#include <math.h>
#include <string.h>

#include "core/util.h"
#include "light/light.h"

/* Cost of a forbidden pair: larger than any sum of real costs (N * pi), so the assignment first
 * maximises the number of allowed pairs, then minimises their total angle. */
#define FORBIDDEN 1.0e6

static double dot3(const double a[3], const double b[3])
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

static void cross3(const double a[3], const double b[3], double c[3])
{
    c[0] = a[1] * b[2] - a[2] * b[1];
    c[1] = a[2] * b[0] - a[0] * b[2];
    c[2] = a[0] * b[1] - a[1] * b[0];
}

static void normalize3(double v[3])
{
    double n = sqrt(dot3(v, v));
    if (n > 0)
        for (int k = 0; k < 3; k++)
            v[k] /= n;
}

/* Angle between unit vectors, accurate near 0 and pi. */
static double angle3(const double a[3], const double b[3])
{
    double c[3];
    cross3(a, b, c);
    return atan2(sqrt(dot3(c, c)), dot3(a, b));
}

/* A unit vector perpendicular to unit a. */
static void perpendicular3(const double a[3], double p[3])
{
    double e[3] = {0, 0, 0};
    e[fabs(a[0]) < 0.9 ? 0 : 1] = 1;
    cross3(a, e, p);
    normalize3(p);
}

/* Rotates v by the rotation vector r (axis * angle, Rodrigues). */
static void rotate3(const double v[3], const double r[3], double out[3])
{
    double th = sqrt(dot3(r, r));
    if (th < 1e-15) {
        memcpy(out, v, 3 * sizeof *v);
        return;
    }
    double k[3] = {r[0] / th, r[1] / th, r[2] / th}, kxv[3];
    cross3(k, v, kxv);
    double c = cos(th), s = sin(th), kv = dot3(k, v) * (1 - c);
    for (int i = 0; i < 3; i++)
        out[i] = v[i] * c + kxv[i] * s + k[i] * kv;
    normalize3(out);
}

/* Rotation vector taking unit a to unit b along the great circle (antipodes: about any axis). */
static void rotation_between(const double a[3], const double b[3], double r[3])
{
    double c[3];
    cross3(a, b, c);
    double sn = sqrt(dot3(c, c)), th = atan2(sn, dot3(a, b));
    if (sn < 1e-12) {
        if (th < 1.0) {
            r[0] = r[1] = r[2] = 0;
            return;
        }
        perpendicular3(a, c);
        sn = 1;
    }
    for (int k = 0; k < 3; k++)
        r[k] = c[k] / sn * th;
}

/* Moves unit a toward unit b by the fraction t of the angle between them, in place. */
static void slerp3(double a[3], const double b[3], double t)
{
    double r[3], out[3];
    rotation_between(a, b, r);
    for (int k = 0; k < 3; k++)
        r[k] *= t;
    rotate3(a, r, out);
    memcpy(a, out, sizeof out);
}

/* Minimum-cost perfect assignment on an n x n matrix (row-major), Hungarian algorithm with
 * potentials, O(n^3). row_to_col[i] = the column of row i. n <= PL_MAX_LIGHTS. */
static void hungarian(int n, const double *cost, int *row_to_col)
{
    double u[PL_MAX_LIGHTS + 1] = {0}, v[PL_MAX_LIGHTS + 1] = {0};
    int p[PL_MAX_LIGHTS + 1] = {0}, way[PL_MAX_LIGHTS + 1] = {0};
    for (int i = 1; i <= n; i++) {
        p[0] = i;
        int j0 = 0;
        double minv[PL_MAX_LIGHTS + 1];
        int used[PL_MAX_LIGHTS + 1];
        for (int j = 0; j <= n; j++)
            minv[j] = INFINITY, used[j] = 0;
        do {
            used[j0] = 1;
            int i0 = p[j0], j1 = 0;
            double delta = INFINITY;
            for (int j = 1; j <= n; j++) {
                if (used[j]) continue;
                double cur = cost[(i0 - 1) * n + (j - 1)] - u[i0] - v[j];
                if (cur < minv[j]) minv[j] = cur, way[j] = j0;
                if (minv[j] < delta) delta = minv[j], j1 = j;
            }
            for (int j = 0; j <= n; j++) {
                if (used[j])
                    u[p[j]] += delta, v[j] -= delta;
                else
                    minv[j] -= delta;
            }
            j0 = j1;
        } while (p[j0] != 0);
        do {
            int j1 = way[j0];
            p[j0] = p[j1];
            j0 = j1;
        } while (j0);
    }
    for (int j = 1; j <= n; j++)
        if (p[j] > 0) row_to_col[p[j] - 1] = j - 1;
}

static double light_energy(const pl_light *l)
{
    double e = pl_light_energy(l);
    return e > 0 ? e : 0;
}

static void obs_dir(const pl_light *l, double d[3])
{
    for (int k = 0; k < 3; k++)
        d[k] = l->dir[k];
    normalize3(d);
}

/* Starts track t on light l with fade weight w. */
static void track_start(pl_smoother *s, pl_track *t, const pl_light *l, int slot, double w)
{
    t->state = PL_TRACK_LIVE;
    t->id = s->next_id++;
    if (s->next_id == 0) s->next_id = 1;
    t->last_input = slot;
    t->weight = w;
    obs_dir(l, t->dir);
    memcpy(t->raw_dir, t->dir, sizeof t->dir);
    t->omega[0] = t->omega[1] = t->omega[2] = 0;
    t->log_distance = log(l->distance_m);
    t->log_solid_angle = log(l->solid_angle_sr);
    for (int k = 0; k < 3; k++)
        t->rgb[k] = l->rgb[k];
}

static void track_empty(pl_track *t)
{
    t->state = PL_TRACK_EMPTY;
    t->last_input = -1;
    t->weight = 0;
    t->omega[0] = t->omega[1] = t->omega[2] = 0;
    t->rgb[0] = t->rgb[1] = t->rgb[2] = 0;
}

int pl_smoother_init(pl_smoother *s, float alpha)
{
    if (!s) return pl_error(PL_E_ARG, "smoother is NULL");
    if (!(alpha > 0.0f && alpha <= 1.0f))
        return pl_error(PL_E_ARG, "smoothing alpha %g: expected a number in (0, 1] (1 = off)",
                        (double)alpha);
    memset(s, 0, sizeof *s);
    s->alpha = alpha;
    s->fade_s = PL_SMOOTH_FADE_S;
    s->next_id = 1;
    return 0;
}

void pl_smoother_reset(pl_smoother *s)
{
    if (!s) return;
    s->n = 0;
    s->started = 0;
    memset(s->tracks, 0, sizeof s->tracks);
    memset(s->ambient, 0, sizeof s->ambient);
}

static void write_output(const pl_smoother *s, pl_lighting *out)
{
    pl_lighting o;
    memset(&o, 0, sizeof o);
    o.n_lights = s->n;
    for (int i = 0; i < s->n; i++) {
        const pl_track *t = &s->tracks[i];
        pl_light *l = &o.lights[i];
        for (int k = 0; k < 3; k++) {
            l->dir[k] = (float)t->dir[k];
            l->rgb[k] = t->state == PL_TRACK_EMPTY ? 0.0f : (float)(t->rgb[k] * t->weight);
        }
        l->distance_m = (float)exp(t->log_distance);
        l->solid_angle_sr = (float)exp(t->log_solid_angle);
        if (!(l->distance_m > 0)) l->distance_m = 1e-30f;
        if (!(l->solid_angle_sr > 0)) l->solid_angle_sr = 1e-30f;
    }
    for (int k = 0; k < 3; k++)
        o.ambient[k] = (float)s->ambient[k];
    *out = o;
}

/* First frame, or N changed: tracks straight from the input. */
static void start_stream(pl_smoother *s, const pl_lighting *in, const double *energy, double total)
{
    s->n = in->n_lights;
    s->started = 1;
    for (int i = 0; i < s->n; i++) {
        pl_track *t = &s->tracks[i];
        track_start(s, t, &in->lights[i], i, 1.0);
        if (!(total > 0 && energy[i] >= PL_SMOOTH_ENTER * total)) track_empty(t);
    }
    for (int k = 0; k < 3; k++)
        s->ambient[k] = in->ambient[k];
}

int pl_smoother_update(pl_smoother *s, const pl_lighting *in, double dt_s, pl_lighting *out)
{
    if (!s || !out) return pl_error(PL_E_ARG, "smoother update: NULL smoother or output");
    if (!(s->alpha > 0.0f && s->alpha <= 1.0f))
        return pl_error(PL_E_ARG, "smoother: not initialised (alpha %g)", (double)s->alpha);
    if (!(s->fade_s >= 0 && isfinite(s->fade_s)))
        return pl_error(PL_E_ARG, "smoother: fade time %g s, expected a finite value >= 0",
                        s->fade_s);
    int rc = pl_lighting_check(in);
    if (rc < 0) return pl_error_prefix(rc, "smoother input");
    if (!(dt_s >= 0 && isfinite(dt_s)))
        return pl_error(PL_E_ARG, "smoother: dt %g s, expected a finite value >= 0", dt_s);
    if (s->alpha == 1.0f) {
        *out = *in;
        return 0;
    }

    const int n = in->n_lights;
    double energy[PL_MAX_LIGHTS], total = 0;
    for (int i = 0; i < n; i++)
        total += energy[i] = light_energy(&in->lights[i]);
    if (!s->started || n != s->n) {
        start_stream(s, in, energy, total);
        write_output(s, out);
        return 0;
    }

    const double a = s->alpha;
    const double step = s->fade_s > 0 ? dt_s / s->fade_s : (double)INFINITY;
    double obs[PL_MAX_LIGHTS][3];
    for (int i = 0; i < n; i++)
        obs_dir(&in->lights[i], obs[i]);

    /* Cost of track t (row) taking input i (column). */
    double cost[PL_MAX_LIGHTS * PL_MAX_LIGHTS];
    for (int t = 0; t < n; t++) {
        const pl_track *tr = &s->tracks[t];
        double pred[3];
        if (tr->state == PL_TRACK_LIVE) {
            double h = fmin(dt_s, PL_SMOOTH_PREDICT_MAX_S);
            double r[3] = {tr->omega[0] * h, tr->omega[1] * h, tr->omega[2] * h};
            rotate3(tr->raw_dir, r, pred);
        } else {
            memcpy(pred, tr->raw_dir, sizeof pred);
        }
        for (int i = 0; i < n; i++) {
            double c = FORBIDDEN;
            double need = tr->state == PL_TRACK_LIVE ? PL_SMOOTH_KEEP : PL_SMOOTH_ENTER;
            if (tr->state != PL_TRACK_EMPTY && total > 0 && energy[i] > 0 &&
                energy[i] >= need * total) {
                double ang = angle3(pred, obs[i]);
                if (ang <= PL_SMOOTH_GATE_RAD) {
                    c = ang;
                    if (tr->state == PL_TRACK_LIVE && tr->last_input == i)
                        c -= PL_SMOOTH_STICKY_RAD;
                }
            }
            cost[t * n + i] = c;
        }
    }
    int match[PL_MAX_LIGHTS];
    hungarian(n, cost, match);

    int input_used[PL_MAX_LIGHTS] = {0};
    for (int t = 0; t < n; t++) {
        pl_track *tr = &s->tracks[t];
        int i = match[t];
        if (i >= 0 && i < n && cost[t * n + i] < FORBIDDEN / 2) {
            const pl_light *l = &in->lights[i];
            input_used[i] = 1;
            double r[3] = {0, 0, 0};
            if (tr->state == PL_TRACK_LIVE && dt_s >= PL_SMOOTH_VEL_MIN_DT_S) {
                rotation_between(tr->raw_dir, obs[i], r);
                for (int k = 0; k < 3; k++)
                    tr->omega[k] =
                        PL_SMOOTH_VEL_BETA * r[k] / dt_s + (1 - PL_SMOOTH_VEL_BETA) * tr->omega[k];
            } else if (tr->state != PL_TRACK_LIVE) {
                tr->omega[0] = tr->omega[1] = tr->omega[2] = 0;
            }
            memcpy(tr->raw_dir, obs[i], sizeof tr->raw_dir);
            slerp3(tr->dir, obs[i], a);
            tr->log_distance = a * log(l->distance_m) + (1 - a) * tr->log_distance;
            tr->log_solid_angle = a * log(l->solid_angle_sr) + (1 - a) * tr->log_solid_angle;
            for (int k = 0; k < 3; k++)
                tr->rgb[k] = a * (double)l->rgb[k] + (1 - a) * tr->rgb[k];
            tr->state = PL_TRACK_LIVE;
            tr->weight = fmin(1.0, tr->weight + step);
            tr->last_input = i;
        } else if (tr->state != PL_TRACK_EMPTY) {
            tr->state = PL_TRACK_FADING;
            tr->last_input = -1;
            tr->omega[0] = tr->omega[1] = tr->omega[2] = 0;
            tr->weight -= step;
            if (!(tr->weight > 1e-9)) track_empty(tr);
        }
    }

    /* Unmatched present lights start tracks, brightest first: in an empty track, else in the
     * faintest fading one. There is always one: the n - m tracks not matched this frame are at
     * least as many as the unmatched inputs. */
    for (;;) {
        int best = -1;
        for (int i = 0; i < n; i++)
            if (!input_used[i] && total > 0 && energy[i] >= PL_SMOOTH_ENTER * total &&
                (best < 0 || energy[i] > energy[best]))
                best = i;
        if (best < 0) break;
        input_used[best] = 1;
        int slot = -1;
        for (int t = 0; t < n && slot < 0; t++)
            if (s->tracks[t].state == PL_TRACK_EMPTY) slot = t;
        for (int t = 0; t < n; t++)
            if (s->tracks[t].state == PL_TRACK_FADING &&
                (slot < 0 || (s->tracks[slot].state == PL_TRACK_FADING &&
                              s->tracks[t].weight < s->tracks[slot].weight)))
                slot = t;
        if (slot < 0) continue; /* every track matched this frame: cannot happen, see above */
        track_start(s, &s->tracks[slot], &in->lights[best], best, fmin(1.0, step));
    }

    for (int k = 0; k < 3; k++)
        s->ambient[k] = a * (double)in->ambient[k] + (1 - a) * s->ambient[k];
    write_output(s, out);
    return 0;
}
