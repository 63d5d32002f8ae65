/* int8-vs-float accuracy checks (docs/QUANT.md, "Accuracy check"), behind `parlight qcheck`.
 *
 * Per layer: the float model's and the int8 model's observed activations (model/observer.h) on
 * the same frame, accumulated over frames into SQNR = 10 log10(sum f^2 / sum (f - q)^2) in dB
 * and cosine = <f, q> / (|f| |q|).
 * End to end, per frame (pl_qcheck_frame): the int8 lights are matched to the float ones by
 * angle (the permutation with the smallest summed angle), then the direction error of each
 * light in degrees, each light's colour relative error |c_q - c_f| / |c_f|, the ambient
 * relative error, the env-map relative RMSE (RMSE between the two eq.-4 maps at 128 x 64, over
 * the float map's RMS) and the relative L2 of all outputs ([dirs, distances, solid angles,
 * colours, ambient] in float's light order vs the matched int8 lights). */
#ifndef PL_QUANT_QCHECK_H
#define PL_QUANT_QCHECK_H

#include <stddef.h>

#include "parlight.h"

typedef struct pl_qcheck_frame {
    int n_lights;
    double dir_err_deg[PL_MAX_LIGHTS];
    double rgb_rel[PL_MAX_LIGHTS];
    double ambient_rel;
    double envmap_rel_rmse;
    double output_rel_l2;
} pl_qcheck_frame;

/* Compares one frame's lightings (same n_lights, at most 8). */
int pl_qcheck_compare(const pl_lighting *f, const pl_lighting *q, pl_qcheck_frame *r);

/* Layer comparison: pl_qcheck_layers_float() is the float model's observer (it keeps a copy of
 * every layer of the current frame), pl_qcheck_layers_int8() the int8 model's (it accumulates the
 * statistics against that copy). Run the float model first on each frame. */
typedef struct pl_qcheck_layer {
    char name[64];
    size_t n;
    float *ref;                   /* the float layer of the current frame */
    double ss_f, ss_e, ss_q, dot; /* sums over frames */
    int seen;                     /* the int8 model reported it this frame */
} pl_qcheck_layer;

typedef struct pl_qcheck_layers {
    pl_qcheck_layer *l;
    int n, cap;
    int error; /* set when an allocation failed or shapes differed */
} pl_qcheck_layers;

void pl_qcheck_layers_float(void *ctx, const char *layer, const float *chw, int c, int h, int w,
                            const float *floor);
/* With a floor (block-buffer producers), the float values are compared as max(f, floor[c]):
 * clipping below the floor is where every consumer clamps anyway (docs/QUANT.md). */
void pl_qcheck_layers_int8(void *ctx, const char *layer, const float *chw, int c, int h, int w,
                           const float *floor);
void pl_qcheck_layers_free(pl_qcheck_layers *L);
/* SQNR in dB (capped at 200 for an exact match) and cosine of layer i. */
double pl_qcheck_sqnr_db(const pl_qcheck_layer *l);
double pl_qcheck_cosine(const pl_qcheck_layer *l);

/* Quantile q in [0, 1] of v[0..n) (linear interpolation; sorts v). 0 for n == 0. */
double pl_quantile(double *v, size_t n, double q);

#endif
