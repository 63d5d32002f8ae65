/* Folding float layers into int8 ones (docs/QUANT.md, "DenseNet folding").
 *
 * Activations: real = scale * (q - zero_point), q in [-128, 127] (pl_qparams).
 *
 * Every int8 conv / FC reads input values q and sees, per input channel c, the real value
 *     f_c(q) = A_c * clamp(q, lo_c, hi_c) + B_c          (pl_preact, "active")
 * or a constant (a channel whose ReLU is always off, or whose BN scale is 0). Two cases:
 *  - pre-activation BN + ReLU on a quantised input, relu(a*x + b) with x = s*(q - z): with
 *    A = a*s, B = b - a*s*z and t = -B/A,
 *        a > 0:  relu(A q + B) = A*max(q, t) + B     -> lo = round(t), hi = 127
 *        a < 0:  relu(A q + B) = A*min(q, t) + B     -> lo = -128, hi = round(t)
 *    t is rounded to the nearest integer t_q and B moved by A*(t - t_q)/2, which splits the
 *    rounding error d = A*(t_q - t) between the clipped and the linear side: |error| <= |A|/4
 *    for every q (a quarter of an input step), zero-mean when half the values clip; a t beyond
 *    the int8 range makes the channel constant 0 or leaves it unclamped and exact;
 *  - a plain quantised input (no BN): A = s, B = -s*z, no clamp.
 * pl_quantize_layer then folds A into the weights (W'[o][d] = W[o][d]*A_c) and B into the bias,
 * quantises W' per output channel symmetrically (scale = max|W'|/127) and the bias at the same
 * scale, computed with the ROUNDED weights around each channel's `center` (bias correction):
 *     bias_q = round((b + sum_d W[d]*(A_c*center_c + B_c)) / wscale - sum_d wq[d]*(center_c + off))
 * so that weight rounding errors multiply clamp(q) - center (the signal) rather than clamp(q)
 * itself (which for a ReLU producer sits near -128, for the u8 input near the mean pixel), and
 *     real_out[o] = wscale[o] * (bias_q[o] + sum_d wq[o][d] * (clamp(q_d) + input_offset)).
 * The clamp and the input offset are what the int8 kernels apply (kernels/ref/nn_ref_s8_clamp.h).
 */
#ifndef PL_QUANT_FOLD_H
#define PL_QUANT_FOLD_H

#include <stdint.h>

typedef struct pl_qparams {
    float scale;        /* > 0, finite */
    int32_t zero_point; /* [-128, 127] */
} pl_qparams;

typedef struct pl_preact {
    double A, B;    /* f(q) = A*clamp(q, lo, hi) + B when active */
    int8_t lo, hi;  /* lo <= hi */
    int32_t center; /* a typical clamp(q): the threshold (clamped channels) or the zero point */
    int active;     /* 0: f(q) = constant for every q (A = 0 in the folded weights) */
    double constant;
} pl_preact;

/* int8 quantisation of the real range [lo, hi] (widened to contain 0): scale = (hi - lo)/255,
 * zero point so that lo maps to -128. relu != 0 (or lo >= 0): zero point -128, scale hi/255.
 * A zero-width range gets a tiny positive scale. PL_E_ARG for non-finite bounds. */
int pl_qparams_from_range(double lo, double hi, int relu, pl_qparams *q);

/* int8 quantisation of [lo, hi] (not widened to 0): scale = (hi - lo)/254, zero point
 * ceil(-128 - lo/scale), so the first level scale*(-128 - zero point) is at or below lo and the
 * last at or above hi: a range that starts at its consumers' clamp point t never reads as a value
 * above t (a rounded zero point could put the first level up to half a step above it, and every
 * clipped value then reached the consumers as a(level - t) > 0). The zero point may lie outside
 * the int8 range (|zero point| <= 32767; the scale is coarsened to keep it there): it only
 * enters the producer's bias and the consumers' folds (docs/QUANT.md). */
int pl_qparams_clipped(double lo, double hi, pl_qparams *q);

/* relu(a*x + b) on input quantised with `in` (see above). */
void pl_fold_preact(double a, double b, pl_qparams in, pl_preact *f);
/* A plain quantised input: f(q) = s*(q - z). */
void pl_fold_plain(pl_qparams in, pl_preact *f);
/* f(q) as the int8 layer sees it: A*clamp(q) + B, or the constant. */
double pl_preact_value(const pl_preact *f, int q);

/* Quantises a layer: w [out_c][depth] (convs in OHWI order: depth = k_h*k_w*in_c), bias [out_c]
 * or NULL; input element d belongs to channel (d / ch_div) % ch_mod, whose fold is fold[...].
 * Writes wq [out_c][depth], bias_q [out_c], wscale [out_c] (> 0). PL_E_ARG when a folded bias
 * does not fit in int32 (message names `what`). */
int pl_quantize_layer(const char *what, const float *w, const float *bias, int out_c, int depth,
                      const pl_preact *fold, int ch_div, int ch_mod, int32_t input_offset,
                      int8_t *wq, int32_t *bias_q, float *wscale);

#endif
