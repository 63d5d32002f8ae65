/* light/temporal.c on synthetic sequences: a moving light followed with the closed-form EMA lag,
 * a light that disappears (fades over the documented number of frames) and reappears (fades
 * in), two lights crossing (colours stay with their tracks, with the network's output order
 * shuffled every frame), presence hysteresis, alpha = 1 as the identity, bad arguments. */
#include <stdlib.h>
#include <string.h>

#include "core/util.h"
#include "light/light.h"
#include "light/temporal.h"
#include "light_test.h"

static pl_light light_at(double phi, double elev, float r, float g, float b)
{
    pl_light l;
    l.dir[0] = (float)(sin(phi) * cos(elev));
    l.dir[1] = (float)sin(elev);
    l.dir[2] = (float)(-cos(phi) * cos(elev));
    l.distance_m = 3.0f;
    l.solid_angle_sr = 0.2f;
    l.rgb[0] = r, l.rgb[1] = g, l.rgb[2] = b;
    return l;
}

/* Azimuth of a direction on the equator (angle from -z toward +x). */
static double azimuth(const float d[3])
{
    return atan2((double)d[0], -(double)d[2]);
}

static double angle_f(const float a[3], const float b[3])
{
    double d = (double)a[0] * b[0] + (double)a[1] * b[1] + (double)a[2] * b[2];
    double c0 = (double)a[1] * b[2] - (double)a[2] * b[1],
           c1 = (double)a[2] * b[0] - (double)a[0] * b[2],
           c2 = (double)a[0] * b[1] - (double)a[1] * b[0];
    return atan2(sqrt(c0 * c0 + c1 * c1 + c2 * c2), d);
}

static unsigned lcg = 12345;
static unsigned next_rand(void)
{
    lcg = lcg * 1103515245u + 12345u;
    return (lcg >> 16) & 0x7fff;
}

/* A light moving along the equator at a constant angular speed, plus two static ones: the
 * output's azimuth must follow the scalar EMA y_t = a phi_t + (1 - a) y_{t-1}, y_0 = phi_0. */
static void test_moving_light(void)
{
    const float alpha = 0.3f;
    const double w = 0.02, phi0 = -0.4; /* rad per frame */
    pl_smoother s;
    CHECK(pl_smoother_init(&s, alpha) == 0, "init: %s", pl_last_error());
    double y = phi0;
    int track = -1;
    for (int t = 0; t < 60; t++) {
        pl_lighting in, out;
        memset(&in, 0, sizeof in);
        in.n_lights = 3;
        double phi = phi0 + w * t;
        in.lights[0] = light_at(1.5, 0.8, 1, 1, 1);
        in.lights[1] = light_at(phi, 0, 5, 4, 3);
        in.lights[2] = light_at(2.5, -0.5, 1, 2, 1);
        in.ambient[0] = in.ambient[1] = in.ambient[2] = 0.1f;
        int rc = pl_smoother_update(&s, &in, 1.0 / 30, &out);
        CHECK(rc == 0, "update %d: %s", t, pl_last_error());
        CHECK(out.n_lights == 3, "n_lights %d", out.n_lights);
        if (t > 0) y = alpha * phi + (1 - alpha) * y;
        int k = -1;
        for (int i = 0; i < 3; i++)
            if (out.lights[i].rgb[0] > 4.5f) k = i;
        if (t == 0) track = k;
        CHECK(k >= 0 && k == track, "frame %d: moving light in track %d, was %d", t, k, track);
        if (k < 0) continue;
        double got = azimuth(out.lights[k].dir);
        CHECK(fabs(got - y) < 2e-5, "frame %d: azimuth %.7f, EMA %.7f", t, got, y);
        CHECK(fabs(out.lights[k].dir[1]) < 1e-5, "frame %d: left the equator", t);
        if (t == 59) {
            double lag = phi - got, expect = w * (1 - alpha) / alpha;
            CHECK(fabs(lag - expect) < 1e-4, "steady lag %.6f, closed form %.6f", lag, expect);
        }
        CHECK(pl_lighting_check(&out) == 0, "output invalid: %s", pl_last_error());
    }
}

/* Light 1 goes dark at frame 10 (the network keeps emitting it with rgb ~0 and a wandering
 * direction) and comes back at frame 30: its track fades out linearly over fade_s / dt = 10
 * frames holding its direction, is empty, then fades in over 10 frames. */
static void test_disappear_reappear(void)
{
    const double dt = 0.05; /* fade 0.5 s = 10 frames */
    pl_smoother s;
    CHECK(pl_smoother_init(&s, 0.5f) == 0, "init");
    CHECK(s.fade_s == PL_SMOOTH_FADE_S && fabs(PL_SMOOTH_FADE_S / dt - 10) < 1e-9, "fade time");
    const pl_light a = light_at(0.3, 0.2, 4, 4, 4), b = light_at(-1.2, 0.4, 0, 0, 6);
    int track_b = -1;
    uint32_t id_b = 0;
    float dir_b[3] = {0, 0, 0};
    for (int t = 0; t < 45; t++) {
        pl_lighting in, out;
        memset(&in, 0, sizeof in);
        in.n_lights = 2;
        in.lights[0] = a;
        in.lights[1] = b;
        int gone = t >= 10 && t < 30;
        if (gone) {
            in.lights[1] = light_at(0.1 * (double)(next_rand() % 60), 0.1, 1e-6f, 0, 1e-6f);
        }
        CHECK(pl_smoother_update(&s, &in, dt, &out) == 0, "update %d: %s", t, pl_last_error());
        if (t == 0) {
            track_b = out.lights[0].rgb[2] > 5 ? 0 : 1;
            id_b = s.tracks[track_b].id;
            memcpy(dir_b, out.lights[track_b].dir, sizeof dir_b);
            CHECK(fabs(out.lights[track_b].rgb[2] - 6) < 1e-6, "first frame passes through");
        }
        if (track_b < 0) return;
        const pl_light *ob = &out.lights[track_b], *oa = &out.lights[1 - track_b];
        CHECK(fabs(oa->rgb[0] - 4) < 1e-5, "frame %d: steady light changed (%g)", t, oa->rgb[0]);
        double expect;
        if (t < 10)
            expect = 6;
        else if (t < 30)
            expect = 6 * fmax(0, 1 - (t - 9) * 0.1);
        else
            expect = 6 * fmin(1, (t - 29) * 0.1);
        CHECK(fabs(ob->rgb[2] - expect) < 1e-4, "frame %d: faded light blue %.6f, expected %.6f", t,
              ob->rgb[2], expect);
        if (gone) {
            CHECK(angle_f(ob->dir, dir_b) < 1e-6, "frame %d: fading light moved", t);
            if (t >= 19)
                CHECK(s.tracks[track_b].state == PL_TRACK_EMPTY, "frame %d: not empty", t);
            else
                CHECK(s.tracks[track_b].state == PL_TRACK_FADING, "frame %d: not fading", t);
        }
        if (t >= 30) {
            CHECK(s.tracks[track_b].state == PL_TRACK_LIVE, "frame %d: did not come back", t);
            CHECK(s.tracks[track_b].id != id_b, "frame %d: a new light gets a new id", t);
            CHECK(angle_f(ob->dir, b.dir) < 1e-5, "frame %d: reappeared elsewhere", t);
        }
        CHECK(pl_lighting_check(&out) == 0, "output invalid: %s", pl_last_error());
    }

    /* Coming back while still fading revives the same track (same id), ramping up from where
     * the fade had got to. */
    CHECK(pl_smoother_init(&s, 0.5f) == 0, "init");
    for (int t = 0; t < 12; t++) {
        pl_lighting in, out;
        memset(&in, 0, sizeof in);
        in.n_lights = 2;
        in.lights[0] = a;
        in.lights[1] = b;
        if (t >= 5 && t < 8) in.lights[1].rgb[2] = 0;
        CHECK(pl_smoother_update(&s, &in, dt, &out) == 0, "update: %s", pl_last_error());
        if (t == 0) id_b = s.tracks[1].id;
        double expect = t < 5   ? 6
                        : t < 8 ? 6 * (1 - (t - 4) * 0.1)
                                : 6 * fmin(1, 0.7 + (t - 7) * 0.1);
        CHECK(fabs(out.lights[1].rgb[2] - expect) < 1e-4, "revive frame %d: %.6f vs %.6f", t,
              out.lights[1].rgb[2], expect);
        CHECK(s.tracks[1].id == id_b, "revive frame %d: id changed", t);
    }
}

/* Two lights crossing on the equator, the network's output order shuffled every frame: each
 * track keeps its colour throughout and ends where its light ends. They never coincide (the
 * crossing falls between frames 12 and 13), so a matcher without prediction swaps them. */
static void test_crossing(void)
{
    const double w = 0.04;
    for (int variant = 0; variant < 2; variant++) {
        pl_smoother s;
        CHECK(pl_smoother_init(&s, 0.4f) == 0, "init");
        int red = -1;
        uint32_t red_id = 0;
        for (int t = 0; t < 26; t++) {
            pl_lighting in, out;
            memset(&in, 0, sizeof in);
            in.n_lights = 3;
            pl_light A = light_at(-0.5 + w * t, 0, 5, 0.2f, 0.2f);
            pl_light B = light_at(0.5 - w * t, variant ? 0.03 : 0, 0.2f, 0.2f, 5);
            pl_light C = light_at(2.5, 0.9, 0.3f, 3, 0.3f);
            int perm = (int)(next_rand() % 6);
            const pl_light *order[6][3] = {{&A, &B, &C}, {&A, &C, &B}, {&B, &A, &C},
                                           {&B, &C, &A}, {&C, &A, &B}, {&C, &B, &A}};
            for (int i = 0; i < 3; i++)
                in.lights[i] = *order[perm][i];
            CHECK(pl_smoother_update(&s, &in, 1.0 / 30, &out) == 0, "update: %s", pl_last_error());
            if (t == 0) {
                for (int i = 0; i < 3; i++)
                    if (out.lights[i].rgb[0] > 4) red = i;
                if (red < 0) return;
                red_id = s.tracks[red].id;
            }
            for (int i = 0; i < 3; i++) {
                const float *c = out.lights[i].rgb;
                if (i == red)
                    CHECK(c[0] > 4.5f && c[2] < 0.7f,
                          "variant %d frame %d: red track is (%g %g %g)", variant, t, c[0], c[1],
                          c[2]);
                else
                    CHECK(c[0] < 0.7f, "variant %d frame %d: track %d turned red (%g %g %g)",
                          variant, t, i, c[0], c[1], c[2]);
            }
            CHECK(s.tracks[red].id == red_id, "variant %d frame %d: red track's id changed",
                  variant, t);
            if (t == 25)
                CHECK(angle_f(out.lights[red].dir, A.dir) < 0.1,
                      "red track ends at %.3f, its light at %.3f", azimuth(out.lights[red].dir),
                      azimuth(A.dir));
        }
    }
}

/* Presence by relative energy with hysteresis: a live light stays at 3% of the total (above
 * KEEP), a new light at 3% (under ENTER) starts no track, at 10% it does. */
static void test_presence(void)
{
    pl_smoother s;
    CHECK(pl_smoother_init(&s, 0.5f) == 0, "init");
    const double dt = 0.1;
    for (int t = 0; t < 8; t++) {
        pl_lighting in, out;
        memset(&in, 0, sizeof in);
        in.n_lights = 3;
        in.lights[0] = light_at(0, 0, 10, 10, 10);
        /* light 1: 10% at t=0, then 3% of the total: stays */
        float l1 = t == 0 ? 10 / 9.0f : 0.31f;
        in.lights[1] = light_at(1.0, 0.3, l1, l1, l1);
        /* light 2: dark at t=0, 3% at t=1..3 (no track), 12% from t=4 (starts one) */
        float l2 = t == 0 ? 0 : t < 4 ? 0.31f : 1.4f;
        in.lights[2] = light_at(-1.5, -0.2, l2, l2, l2);
        CHECK(pl_smoother_update(&s, &in, dt, &out) == 0, "update: %s", pl_last_error());
        CHECK(s.tracks[1].state == PL_TRACK_LIVE, "t=%d: a live light at 3%% was dropped", t);
        if (t < 4)
            CHECK(s.tracks[2].state == PL_TRACK_EMPTY && out.lights[2].rgb[0] == 0,
                  "t=%d: a new light at 3%% started a track", t);
        else
            CHECK(s.tracks[2].state == PL_TRACK_LIVE && out.lights[2].rgb[0] > 0,
                  "t=%d: a new light at 12%% did not start a track", t);
    }
}

/* alpha = 1: the output is the input, exactly, whatever the sequence. */
static void test_identity(void)
{
    pl_smoother s;
    CHECK(pl_smoother_init(&s, 1.0f) == 0, "init alpha 1");
    for (int t = 0; t < 20; t++) {
        pl_lighting in, out;
        memset(&in, 0, sizeof in);
        in.n_lights = 1 + t % 5;
        for (int i = 0; i < in.n_lights; i++)
            in.lights[i] =
                light_at(0.1 * (double)(next_rand() % 60), 0.01 * (double)(next_rand() % 100),
                         (float)(next_rand() % 100) * 0.1f, 0, (t & 1) ? 0 : 2);
        in.ambient[1] = (float)t;
        CHECK(pl_smoother_update(&s, &in, 0.02 * t, &out) == 0, "update: %s", pl_last_error());
        CHECK(memcmp(&in, &out, sizeof in) == 0, "frame %d: alpha 1 changed the lighting", t);
    }
}

static void test_bad_args(void)
{
    pl_smoother s;
    const float bad[] = {0.0f, -0.5f, 1.0001f, 2.0f, NAN, INFINITY};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        CHECK(pl_smoother_init(&s, bad[i]) == PL_E_ARG, "alpha %g accepted", (double)bad[i]);
        CHECK(strstr(pl_last_error(), "alpha") != NULL, "message: %s", pl_last_error());
    }
    CHECK(pl_smoother_init(NULL, 0.5f) == PL_E_ARG, "NULL smoother");
    CHECK(pl_smoother_init(&s, 1e-6f) == 0, "tiny alpha rejected");
    CHECK(pl_smoother_init(&s, 0.5f) == 0, "init");
    pl_lighting in, out;
    memset(&in, 0, sizeof in);
    in.n_lights = 2;
    in.lights[0] = light_at(0, 0, 1, 1, 1);
    in.lights[1] = light_at(1, 0, 1, 1, 1);
    CHECK(pl_smoother_update(&s, &in, -0.1, &out) == PL_E_ARG, "negative dt");
    CHECK(pl_smoother_update(&s, &in, NAN, &out) == PL_E_ARG, "NaN dt");
    CHECK(pl_smoother_update(&s, &in, INFINITY, &out) == PL_E_ARG, "infinite dt");
    CHECK(pl_smoother_update(&s, NULL, 0.1, &out) == PL_E_ARG, "NULL input");
    CHECK(pl_smoother_update(&s, &in, 0.1, NULL) == PL_E_ARG, "NULL output");
    CHECK(s.started == 0, "a rejected update changed the state");
    in.n_lights = PL_MAX_LIGHTS + 1;
    CHECK(pl_smoother_update(&s, &in, 0.1, &out) == PL_E_ARG, "n_lights 17");
    in.n_lights = 2;
    in.lights[1].rgb[0] = NAN;
    CHECK(pl_smoother_update(&s, &in, 0.1, &out) == PL_E_ARG, "NaN colour");
    in.lights[1].rgb[0] = 1;
    in.lights[1].distance_m = 0;
    CHECK(pl_smoother_update(&s, &in, 0.1, &out) == PL_E_ARG, "zero distance");
    in.lights[1].distance_m = 2;
    s.fade_s = -1;
    CHECK(pl_smoother_update(&s, &in, 0.1, &out) == PL_E_ARG, "negative fade time");
    s.fade_s = 0;
    CHECK(pl_smoother_update(&s, &in, 0.1, &out) == 0, "fade 0: %s", pl_last_error());

    /* N changes mid-stream: the tracks restart from the new frame. All-dark frames and
     * dt = 0 are fine. */
    in.n_lights = 3;
    in.lights[2] = light_at(2, 0, 1, 0, 0);
    CHECK(pl_smoother_update(&s, &in, 0.1, &out) == 0 && out.n_lights == 3, "N 2 -> 3");
    CHECK(memcmp(&in, &out, sizeof in) == 0 || fabs(out.lights[2].rgb[0] - 1) < 1e-6,
          "restart passes the frame through");
    memset(in.lights[0].rgb, 0, sizeof in.lights[0].rgb);
    memset(in.lights[1].rgb, 0, sizeof in.lights[1].rgb);
    memset(in.lights[2].rgb, 0, sizeof in.lights[2].rgb);
    for (int t = 0; t < 3; t++)
        CHECK(pl_smoother_update(&s, &in, 0, &out) == 0 && pl_lighting_check(&out) == 0,
              "dark frame: %s", pl_last_error());
    in.n_lights = 0;
    CHECK(pl_smoother_update(&s, &in, 0.1, &out) == 0 && out.n_lights == 0, "no lights");
}

/* Odd timing: repeated timestamps (dt ~ 0) and a 10 s stall keep the light on its track (the
 * velocity ignores tiny steps, predictions look at most PL_SMOOTH_PREDICT_MAX_S ahead). */
static void test_odd_timing(void)
{
    pl_smoother s;
    CHECK(pl_smoother_init(&s, 0.5f) == 0, "init");
    const double dts[] = {0.033, 0.033, 0.033, 1e-6, 0, 1e-6, 0.033, 10.0, 0.033, 0.033};
    uint32_t id = 0;
    double phi = 0;
    for (size_t t = 0; t < sizeof dts / sizeof dts[0]; t++) {
        phi += 0.6 * dts[t] > 0.05 ? 0.05 : 0.6 * dts[t]; /* 0.6 rad/s, a stall moves it 0.05 */
        if (dts[t] < 1e-3) phi += 0.003;                  /* network jitter between repeats */
        pl_lighting in, out;
        memset(&in, 0, sizeof in);
        in.n_lights = 2;
        in.lights[0] = light_at(phi, 0, 3, 3, 3);
        in.lights[1] = light_at(2.0, 1.0, 1, 1, 1);
        CHECK(pl_smoother_update(&s, &in, dts[t], &out) == 0, "update: %s", pl_last_error());
        CHECK(pl_lighting_check(&out) == 0, "output invalid: %s", pl_last_error());
        if (t == 0) id = s.tracks[0].id;
        CHECK(s.tracks[0].id == id && s.tracks[0].state == PL_TRACK_LIVE,
              "step %zu (dt %g): the light lost its track", t, dts[t]);
        double w = sqrt(s.tracks[0].omega[0] * s.tracks[0].omega[0] +
                        s.tracks[0].omega[1] * s.tracks[0].omega[1] +
                        s.tracks[0].omega[2] * s.tracks[0].omega[2]);
        CHECK(w < 2.0, "step %zu: angular velocity %g rad/s from timestamp noise", t, w);
    }
}

/* The optimal assignment over 16 lights: a random permutation of 16 well-separated lights,
 * jittered, is undone exactly. */
static void test_many_lights(void)
{
    pl_smoother s;
    CHECK(pl_smoother_init(&s, 0.5f) == 0, "init");
    pl_light base[PL_MAX_LIGHTS];
    for (int i = 0; i < PL_MAX_LIGHTS; i++)
        base[i] = light_at(i * 2 * M_PI / 8, i < 8 ? 0.5 : -0.5, (float)(10 + i), 10, 10);
    pl_lighting in, out;
    memset(&in, 0, sizeof in);
    in.n_lights = PL_MAX_LIGHTS;
    memcpy(in.lights, base, sizeof base);
    CHECK(pl_smoother_update(&s, &in, 0.1, &out) == 0, "update");
    for (int t = 0; t < 10; t++) {
        int perm[PL_MAX_LIGHTS];
        for (int i = 0; i < PL_MAX_LIGHTS; i++)
            perm[i] = i;
        for (int i = PL_MAX_LIGHTS - 1; i > 0; i--) {
            int j = (int)(next_rand() % (unsigned)(i + 1)), x = perm[i];
            perm[i] = perm[j], perm[j] = x;
        }
        for (int i = 0; i < PL_MAX_LIGHTS; i++) {
            in.lights[i] = base[perm[i]];
            in.lights[i].dir[0] += 0.01f * (float)((int)(next_rand() % 21) - 10) / 10;
        }
        CHECK(pl_smoother_update(&s, &in, 0.1, &out) == 0, "update");
        for (int i = 0; i < PL_MAX_LIGHTS; i++)
            CHECK(fabs(out.lights[i].rgb[0] - (float)(10 + i)) < 1e-4, "t=%d: track %d has %g", t,
                  i, out.lights[i].rgb[0]);
    }
}

int main(void)
{
    test_moving_light();
    test_disappear_reappear();
    test_crossing();
    test_presence();
    test_identity();
    test_bad_args();
    test_odd_timing();
    test_many_lights();
    if (failures) {
        printf("%d failure(s)\n", failures);
        return 1;
    }
    printf("temporal: all passed\n");
    return 0;
}
