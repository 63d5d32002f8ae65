/* Calibration observers: what range of real values an activation gets, from the values it took
 * on calibration frames (docs/QUANT.md, "Calibration").
 *
 * pl_hist collects, in one pass, the exact minimum and maximum and a histogram of PL_HIST_BINS
 * equal bins over [-R, R]. R starts as the first batch's largest magnitude rounded up to a power
 * of two and doubles when a later value falls outside (neighbouring bins merge, exactly), so the
 * bins stay between R/PL_HIST_BINS*2 wide and never lose a count. pl_hist_range then picks the
 * clipping range [lo, hi] that the activation's int8 scale will cover:
 *   minmax      [min, max]
 *   percentile  the `percentile` and 100 - `percentile` quantiles (within the bins, linear)
 *   entropy     TensorRT's KL calibration on the magnitudes: the threshold T whose 128-level
 *               quantised distribution is closest (Kullback-Leibler) to the clipped one
 *   mse         the range [min, max] scaled by the factor in (0, 1] that minimises the expected
 *               squared error (clipping + uniform rounding, step^2/12) over the histogram
 * Every method returns a range inside [min, max] containing 0 when the data does. */
#ifndef PL_QUANT_CALIB_H
#define PL_QUANT_CALIB_H

#include <stddef.h>
#include <stdint.h>

#define PL_HIST_BINS 1024

typedef enum pl_calib_method {
    PL_CALIB_MINMAX,
    PL_CALIB_PERCENTILE,
    PL_CALIB_ENTROPY,
    PL_CALIB_MSE
} pl_calib_method;

typedef struct pl_hist {
    double min, max, R; /* R = 0 until the first non-zero value */
    uint64_t total;
    uint32_t bins[PL_HIST_BINS]; /* per-channel histograms: ~10k of them in a model */
} pl_hist;

void pl_hist_init(pl_hist *h);
void pl_hist_add(pl_hist *h, const float *x, size_t n);

/* "minmax" ... -> method; PL_E_ARG for an unknown name. */
int pl_calib_method_parse(const char *name, pl_calib_method *m);
const char *pl_calib_method_name(pl_calib_method m);

/* The clipping range (see above). relu: the values are >= 0 (ReLU outputs), only hi matters.
 * PL_E_ARG when the histogram is empty. */
int pl_hist_range(const pl_hist *h, pl_calib_method m, double percentile, int relu, double *lo,
                  double *hi);

#endif
