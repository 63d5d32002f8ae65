/* Temporal filter for the lights of a frame stream (`parlight estimate --smooth ALPHA`).
 *
 * The network outputs N lights per frame in no particular order, and a light it no longer sees
 * goes dark (its colour goes to ~0) while its direction wanders. The smoother turns that into N
 * TRACKS with stable identities, smoothed parameters and fades:
 *
 *   presence   A light is PRESENT when its energy E_i = lum(c_i) * pl_sg_integral(s_i) (the SG
 *              convention of light/light.h: about lum(c_i) s_i / 2, lum = 0.2126 r + 0.7152 g +
 *              0.0722 b as for the primary light) is at least a fraction of the frame's total
 *              light energy sum_j E_j (ambient excluded). Hysteresis: a light starts or revives a
 *              track at PL_SMOOTH_ENTER (5%) of the total, and keeps a live track down to
 *              PL_SMOOTH_KEEP (2%). Lights under those thresholds are treated as absent: their
 *              (small) energy is not carried to the output.
 *   identity   Present lights are assigned to tracks by angle, optimally (Hungarian algorithm,
 *              N <= PL_MAX_LIGHTS), against each track's PREDICTED direction: the last matched
 *              direction rotated by the track's angular velocity times dt (at most
 *              PL_SMOOTH_PREDICT_MAX_S; the velocity is an EMA, weight PL_SMOOTH_VEL_BETA, of the
 *              observed rotation per second, not updated over steps under 1 ms). So two lights
 *              that cross keep their identities. A pair further apart than PL_SMOOTH_GATE_RAD is
 *              never matched (the light is new, the track fades). Hysteresis: the pairing a track
 *              had in the previous frame (same network output slot) costs PL_SMOOTH_STICKY_RAD
 *              less, so near-ties do not flip back and forth. Among assignments, the one with
 *              the most gated pairs wins, then the smallest total angle.
 *   smoothing  Per matched track, with alpha the weight of the new frame (EMA):
 *                direction: slerp(previous, observed, alpha) along the great circle, renormalised,
 *                  so a light moving at a constant angular speed lags exactly as the scalar EMA
 *                  of its angle does (steady lag = speed * (1 - alpha) / alpha);
 *                colour (and the ambient): linear EMA. Radiance adds linearly, so this is the
 *                  EMA of the environment map the lights stand for, and it is defined at 0;
 *                distance and solid angle: EMA of their logarithms (a geometric mean). Both are
 *                  positive scale quantities spanning orders of magnitude (solid angles from
 *                  1e-4 to several sr): the log domain keeps them positive and treats x2 and /2
 *                  alike, where a linear mean would be dominated by the largest frame.
 *   fades      Each track has a weight w in [0, 1] that multiplies its colour on output. A track
 *              whose light is absent (or unmatched) keeps its direction, size and distance and
 *              fades linearly: w -= dt / fade_s, reaching 0 after ceil(fade_s / dt) updates
 *              (fade_s = PL_SMOOTH_FADE_S = 0.5 s by default: 15 frames at 30 fps), then the
 *              track is empty. A new light takes an empty track (else the faintest fading one)
 *              and fades in the same way: w = dt / fade_s on its first frame, +dt / fade_s per
 *              frame after, its colour starting at the observed one. A light that comes back
 *              to a still-fading track within the gate revives it (same id, w ramps up again).
 *   output     N lights in track order (track i is always out->lights[i]); an empty track
 *              has rgb 0 and keeps its last direction, distance and size. The ambient term is
 *              smoothed linearly. The first frame (and a frame whose N differs from the
 *              previous one, which resets the tracks) is passed through with its present lights
 *              at full weight and its absent ones as empty tracks.
 *
 * alpha = 1 turns the filter off entirely: the output is the input, unchanged and in the
 * network's order (no tracking, no fades). alpha in (0, 1); PL_SMOOTH_DEFAULT_ALPHA is the
 * CLI's default. alpha is per update (per frame), not per second; dt is used for the fades and
 * the angular velocity only.
 *
 * The state lives in the struct (no allocation); one smoother per stream, not thread-safe. */
#ifndef PL_LIGHT_TEMPORAL_H
#define PL_LIGHT_TEMPORAL_H

#include <stdint.h>

#include "parlight.h"

#define PL_SMOOTH_DEFAULT_ALPHA 0.5f
#define PL_SMOOTH_FADE_S 0.5        /* default fade-in / fade-out time, seconds */
#define PL_SMOOTH_ENTER 0.05        /* relative energy to start or revive a track */
#define PL_SMOOTH_KEEP 0.02         /* relative energy for a live track to stay matched */
#define PL_SMOOTH_GATE_RAD 0.6      /* widest match between a prediction and a light (~34 deg) */
#define PL_SMOOTH_STICKY_RAD 0.02   /* bonus for keeping the previous frame's pairing (~1.1 deg) */
#define PL_SMOOTH_VEL_BETA 0.5      /* EMA weight of the newest angular-velocity observation */
#define PL_SMOOTH_VEL_MIN_DT_S 1e-3 /* shorter steps leave the velocity alone (timestamp noise) */
#define PL_SMOOTH_PREDICT_MAX_S 0.5 /* predictions look at most this far ahead (after a stall) */

typedef enum pl_track_state {
    PL_TRACK_EMPTY = 0, /* no light: output rgb 0 */
    PL_TRACK_LIVE,      /* matched in the last update (fading in until weight reaches 1) */
    PL_TRACK_FADING,    /* its light is gone: fading out */
} pl_track_state;

typedef struct pl_track {
    pl_track_state state;
    uint32_t id;            /* identity, new for every light that starts a track (from 1) */
    int last_input;         /* network slot matched in the last update, -1 when none */
    double weight;          /* fade weight in [0, 1], multiplies rgb on output */
    double dir[3];          /* smoothed direction, unit */
    double raw_dir[3];      /* last matched (observed) direction, unit */
    double omega[3];        /* angular velocity, rotation vector in rad/s (camera frame) */
    double log_distance;    /* EMA of ln(distance_m) */
    double log_solid_angle; /* EMA of ln(solid_angle_sr) */
    double rgb[3];          /* EMA of the colour, before the fade weight */
} pl_track;

typedef struct pl_smoother {
    float alpha;   /* weight of the new frame, (0, 1] */
    double fade_s; /* fade time in seconds (>= 0; 0 = cut); PL_SMOOTH_FADE_S after init */
    int n;         /* tracks = N of the stream, 0 before the first update */
    int started;
    uint32_t next_id;
    pl_track tracks[PL_MAX_LIGHTS];
    double ambient[3];
} pl_smoother;

/* alpha in (0, 1] (1 = pass-through). PL_E_ARG otherwise (NaN included). Sets fade_s to
 * PL_SMOOTH_FADE_S; a caller may change fade_s afterwards (>= 0, finite). */
int pl_smoother_init(pl_smoother *s, float alpha);

/* Forgets every track: the next update starts afresh (as the first frame). */
void pl_smoother_reset(pl_smoother *s);

/* Feeds one frame's lighting (validated with pl_lighting_check) taken dt_s seconds after the
 * previous one (finite, >= 0; ignored on the first frame) and writes the smoothed lighting to
 * *out (may be `in`). PL_E_ARG on bad input, leaving the state unchanged. */
int pl_smoother_update(pl_smoother *s, const pl_lighting *in, double dt_s, pl_lighting *out);

#endif
