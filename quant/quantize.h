/* The float -> int8 model quantiser behind `parlight quantize` (docs/QUANT.md).
 *
 * Runs the float model over calibration frames with an observer on every activation the int8
 * graph quantises, picks each activation's range with the chosen method (quant/calib.h), folds
 * the pre-activation batch norms, the input normalisation and the per-segment scales into int8
 * weights and int32 biases (quant/fold.h), and writes an int8 .plm (docs/FORMAT.md, "int8 models").
 * Library code: no printing; progress goes through an optional callback. */
#ifndef PL_QUANT_QUANTIZE_H
#define PL_QUANT_QUANTIZE_H

#include <stdint.h>

#include "quant/calib.h"

typedef struct pl_quantize_opts {
    const char *float_path; /* fp32 .plm */
    const char *calib;      /* image, video or directory of frames (port/source.h) */
    const char *out_path;   /* int8 .plm to write (replaced atomically) */
    pl_calib_method method;
    double percentile;      /* for PL_CALIB_PERCENTILE, in (50, 100]; e.g. 99.99 */
    const char *keep_float; /* comma-separated layers kept float ("fc", "transition1" ..
                               "transition3"), or NULL */
    int max_frames;         /* 0: all */
    double headroom;        /* every calibrated range is widened by this factor, in [1, 16];
                               0 means 1 (docs/QUANT.md: trades resolution for frames that go
                               beyond the calibration frames) */
    double block_floor;     /* with block_floor_set, in [0, 1]: a dense-block channel's step is
                               at least this times its layer's widest step (default 0.25) */
    int block_floor_set;
    /* called after each calibration frame (good or bad); may be NULL */
    void (*progress)(void *ctx, int64_t good, int64_t bad, const char *frame, const char *error);
    void *progress_ctx;
} pl_quantize_opts;

typedef struct pl_quantize_report {
    int64_t frames_good, frames_bad;
    int n_activations; /* activations calibrated */
} pl_quantize_report;

/* PL_E_ARG: bad options (unknown method / keep-float layer); PL_E_MODEL: the input model is not
 * a float densenet121-parametric; PL_E_FORMAT: the calibration input gave no usable frame;
 * plus the loader's, the frame source's and the writer's errors. */
int pl_quantize_model(const pl_quantize_opts *o, pl_quantize_report *rep);

#endif
