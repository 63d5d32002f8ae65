/* The room's key light fused over the views an AR app has seen (`parlight estimate --fuse`,
 * `parlight eval`'s "key light over each room's views"; docs/OUTPUT.md, "Key light over views").
 *
 * One frame says little about where a room's main light is when the light is out of view (the
 * network's lights sit in broad lobes whose relative brightness is what follows the image:
 * models/MODEL_CARD.md, "Where the lights point"). Views that face different ways see the room
 * differently, and their lights, turned into world space by the camera's pose, agree most where
 * the light really is. The fuser keeps the latest view of each heading and finds where their
 * lights add up to the most:
 *
 *   views     A view is one frame's lights (camera frame) and its camera-to-world rotation R.
 *             It goes into a bin by the camera's forward direction R (0, 0, -1) in world space:
 *             PL_FUSE_YAW_BINS sectors of heading (45 degrees, centred on heading 0 = world
 *             -z) times PL_FUSE_PITCH_BINS bands of pitch (below -30, -30..30, above 30
 *             degrees). A new view replaces its bin's, so a camera that dwells on one heading
 *             does not outvote the others: each heading seen counts once.
 *   weights   Each view votes with unit weight: its lights' radiance divided by the view's total
 *             light energy sum_i lum(c_i) I(s_i) (light/light.h's energy; the ambient is not a
 *             direction and is left out). So exposure changes between views (auto exposure,
 *             the anchor) do not matter, and no view needs photometric calibration. A view
 *             with no light energy empties its bin.
 *   map       E(v) = sum over the bins' views and lights of w_i exp((v . l_i - 1) / sigma_i),
 *             sigma_i = s_i / (4 pi): the lights' own spherical Gaussians (eq. 4), in world space.
 *   key       The direction of E's largest value: the best of PL_FUSE_DIRS directions on a
 *             Fibonacci sphere (~6 degrees apart), then refined by the fixed-point iteration
 *             v <- normalise(grad E(v)) (a mean shift on the sphere) until it moves less than
 *             1e-9 rad or PL_FUSE_REFINE steps.
 *   age       With max_age_s > 0 a view older than that (by the t_s given) no longer counts:
 *             walking into another room, the old room's views drop out. 0: views never expire.
 *   level     A view added with its exposure (what the camera multiplied the scene's radiance
 *             by: exposure time x gain, in any unit the stream keeps) also records its level,
 *             log2 of the view's total energy (lights and ambient: 4 pi x the lighting's mean
 *             luminance) over that exposure: the room's brightness as that view saw it. The
 *             room's level is the mean of the kept views' levels (a geometric mean of their
 *             energies), and a frame is brought to it by one factor, 2^level x its exposure
 *             over its own energy (models/MODEL_CARD.md, "Intensity over views"). Views added
 *             without an exposure record no level (and replace their bin's).
 *
 * No allocation; one fuser per stream, not thread-safe. ~PL_FUSE_BINS * N * PL_FUSE_DIRS
 * exponentials per pl_fuser_key call at most (24 x 3 x 1024 for a 3-light model). */
#ifndef PL_LIGHT_FUSE_H
#define PL_LIGHT_FUSE_H

#include "parlight.h"

#define PL_FUSE_YAW_BINS 8
#define PL_FUSE_PITCH_BINS 3
#define PL_FUSE_BINS (PL_FUSE_YAW_BINS * PL_FUSE_PITCH_BINS)
#define PL_FUSE_PITCH_EDGE_DEG 30.0
#define PL_FUSE_DIRS 1024
#define PL_FUSE_REFINE 100

typedef struct pl_fuse_view {
    int n;                        /* lights kept, 0 = empty bin */
    double t_s;                   /* when it was added */
    double dir[PL_MAX_LIGHTS][3]; /* world space, unit */
    double w[PL_MAX_LIGHTS];      /* peak: share of the view's light energy / lobe integral */
    double lambda[PL_MAX_LIGHTS]; /* 1 / sigma_i = 4 pi / s_i */
    int has_level;                /* added with an exposure and some energy */
    double level;                 /* log2(total energy / exposure) */
} pl_fuse_view;

typedef struct pl_fuser {
    double max_age_s; /* 0: views never expire */
    pl_fuse_view bins[PL_FUSE_BINS];
} pl_fuser;

/* max_age_s >= 0 and finite; PL_E_ARG otherwise. Starts empty. */
int pl_fuser_init(pl_fuser *f, double max_age_s);

/* Forgets every view. */
void pl_fuser_reset(pl_fuser *f);

/* Adds one view: cam (camera frame; validated with pl_lighting_check), R the camera-to-world
 * rotation (row-major 3x3, orthonormal within 1e-3), t_s its time in seconds (finite; only
 * compared with other views' times). Replaces the view of the same bin. PL_E_ARG on bad input,
 * the state unchanged. */
int pl_fuser_add(pl_fuser *f, const pl_lighting *cam, const double R[9], double t_s);

/* pl_fuser_add with the view's exposure (> 0 and finite; PL_E_ARG otherwise), recording its
 * level; 0 records none (pl_fuser_add). */
int pl_fuser_add_exposed(pl_fuser *f, const pl_lighting *cam, const double R[9], double t_s,
                         double exposure);

/* The key light's direction (world space, unit) at time t_s, and how many views it rests on
 * (bins holding light, not expired; may be NULL). Returns 0, or PL_E_ARG when no view holds
 * light (dir is then (0, 1, 0), WebXR's default primary direction, and *views 0). */
int pl_fuser_key(const pl_fuser *f, double t_s, float dir[3], int *views);

/* The room's level at time t_s: the mean of the kept views' levels (not expired) into *level, and
 * how many views it rests on (the return value, 0 when none has a level: *level is then 0). */
int pl_fuser_level(const pl_fuser *f, double t_s, double *level);

#endif
