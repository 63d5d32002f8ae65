/* Baseline (d) of `parlight eval`: a linear (ridge) model from a crop's coarse log pixels to one
 * light and an ambient, fit by tools/train/fit_ridge.py on the training crops and stored as a
 * small JSON file (docs/EVAL.md, "(d) ridge"; models/parlight-ridge.json).
 *
 * Features (definition PL_RIDGE_DEFINITION; fit_ridge.py computes the same): the 8-bit RGB image
 * (W x H) linearised per channel as (v / 255)^gamma with the crop's gamma, averaged over a grid
 * of cols x rows cells (16 x 12 in the shipped file; the file says), cell (i, j) being the pixels
 *     x in [floor(i W / cols), floor((i + 1) W / cols)),
 *     y in [floor(j H / rows), floor((j + 1) H / rows))
 * (so any W >= cols, H >= rows works: 640 x 480 eval crops and 256 x 192 training crops alike;
 * a non-4:3 image is cut the same way, stretched), then log(max(mean, floor)) with the file's
 * floor (1e-4). Order: row j (top first), column i (left first), channel R, G, B:
 * f[3 (j cols + i) + c]. n = 3 cols rows features.
 *
 * Outputs y = bias + weights . f, PL_RIDGE_N_OUT of them, in the crop's camera frame (x right,
 * y up, looking along -z) and on the crop's scale, in this order (the file's "outputs" names):
 *   0..2  the primary light's direction (not normalised by the fit)
 *   3..5  log of its peak colour (linear RGB, light/light.h's SG convention)
 *   6     log of its solid angle (sr)
 *   7..9  log of the ambient
 * pl_ridge_predict turns them into a lighting with one light: the direction normalised
 * ((0, 1, 0) when shorter than PL_RIDGE_DIR_EPS), colours and ambient exp of the outputs clamped
 * to [-PL_RIDGE_LOG_MAX, PL_RIDGE_LOG_MAX], the solid angle exp clamped to
 * [PL_RIDGE_SR_MIN, PL_RIDGE_SR_MAX], distance PL_RIDGE_DISTANCE_M (unused by the metrics).
 *
 * The file (JSON, light/ridge.c reads it with port/json.h; fit_ridge.py writes it):
 *   "format": "parlight-ridge", "version": 1,
 *   "features": {"definition": 1, "grid": [cols, rows] (each 1..PL_RIDGE_MAX_GRID),
 *                "floor": f (1e-30..1), "n": 3 cols rows, ...},
 *   "outputs": the 10 names above, in order ("dir_x", ..., "log_ambient_b"),
 *   "bias": [10 numbers], "weights": [10 arrays of n numbers], all finite;
 *   other members ("lambda", "cv", "fit": provenance) are not read.
 * A file that breaks any of these is refused with a message naming the file and the field. */
#ifndef PL_LIGHT_RIDGE_H
#define PL_LIGHT_RIDGE_H

#include <stddef.h>

#include "core/image.h"
#include "core/json.h"
#include "parlight.h"

#define PL_RIDGE_FORMAT "parlight-ridge"
#define PL_RIDGE_VERSION 1
#define PL_RIDGE_DEFINITION 1
#define PL_RIDGE_N_OUT 10
#define PL_RIDGE_MAX_GRID 64
#define PL_RIDGE_DIR_EPS 1e-6
#define PL_RIDGE_LOG_MAX 30.0
#define PL_RIDGE_SR_MIN 1e-6
#define PL_RIDGE_SR_MAX (4.0 * 3.14159265358979323846)
#define PL_RIDGE_DISTANCE_M 2.0

typedef struct pl_ridge {
    int cols, rows, n_features; /* n_features = 3 cols rows */
    double floor;               /* of the cell means before the log */
    double bias[PL_RIDGE_N_OUT];
    double *weights; /* [PL_RIDGE_N_OUT][n_features], owned */
} pl_ridge;

/* Validates a model from len bytes of text; *out is allocated (pl_ridge_free). Errors:
 * PL_E_FORMAT (not JSON, or a field missing or wrong: the message, started by `name`, names the
 * field), PL_E_NOMEM. A file: pl_ridge_load (port/json_file.h), PL_E_IO when it cannot read. */
int pl_ridge_parse(const char *text, size_t len, const char *name, pl_ridge **out);
/* The same from a parsed document, which it frees. */
int pl_ridge_from_json(const char *name, pl_json_doc *doc, pl_ridge **out);
void pl_ridge_free(pl_ridge *r);

/* The features of an 8-bit RGB image (width >= cols, height >= rows) with gamma in 0.2..5 into
 * f[0 .. r->n_features). PL_E_ARG for a bad image or gamma. */
int pl_ridge_features(const pl_ridge *r, const pl_image_u8 *img, double gamma, double *f);
/* y[0 .. PL_RIDGE_N_OUT) = bias + weights . f. */
void pl_ridge_outputs(const pl_ridge *r, const double *f, double y[PL_RIDGE_N_OUT]);
/* The lighting of the outputs (rules above). */
void pl_ridge_lighting(const double y[PL_RIDGE_N_OUT], pl_lighting *out);
/* Features, outputs and lighting of an image: (d)'s estimate. Allocates a temporary feature
 * vector (PL_E_NOMEM); reentrant. */
int pl_ridge_predict(const pl_ridge *r, const pl_image_u8 *img, double gamma, pl_lighting *out);

#endif
