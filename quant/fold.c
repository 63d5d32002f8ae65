#include "quant/fold.h"

#include <math.h>

#include "core/util.h"

int pl_qparams_from_range(double lo, double hi, int relu, pl_qparams *q)
{
    if (!isfinite(lo) || !isfinite(hi) || lo > hi)
        return pl_error(PL_E_ARG, "activation range [%g, %g]: expected finite lo <= hi", lo, hi);
    if (lo > 0) lo = 0;
    if (hi < 0) hi = 0;
    if (relu || lo >= 0) {
        double s = hi / 255.0;
        q->scale = (float)(s > 1e-12 ? s : 1e-12);
        q->zero_point = -128;
        return PL_OK;
    }
    double s = (hi - lo) / 255.0;
    if (!(s > 1e-12)) s = 1e-12;
    double z = round(-128.0 - lo / s);
    q->scale = (float)s;
    q->zero_point = (int32_t)(z < -128 ? -128 : z > 127 ? 127 : z);
    return PL_OK;
}

int pl_qparams_clipped(double lo, double hi, pl_qparams *q)
{
    if (!isfinite(lo) || !isfinite(hi) || lo > hi)
        return pl_error(PL_E_ARG, "activation range [%g, %g]: expected finite lo <= hi", lo, hi);
    double s = (hi - lo) / 254.0;
    const double mag = fmax(fabs(lo), fabs(hi));
    if (!(s > 1e-12) || s < mag / 32000.0) s = fmax(1e-12, mag / 32000.0); /* zero point bound */
    const double z = ceil(-128.0 - lo / s - 1e-9);
    q->scale = (float)s;
    q->zero_point = (int32_t)(z < -32767 ? -32767 : z > 32767 ? 32767 : z);
    return PL_OK;
}

void pl_fold_plain(pl_qparams in, pl_preact *f)
{
    f->A = in.scale;
    f->B = -(double)in.scale * in.zero_point;
    f->lo = -128;
    f->hi = 127;
    f->center = in.zero_point;
    f->active = 1;
    f->constant = 0;
}

void pl_fold_preact(double a, double b, pl_qparams in, pl_preact *f)
{
    const double A = a * in.scale, B = b - a * in.scale * in.zero_point;
    f->A = A;
    f->B = B;
    f->lo = -128;
    f->hi = 127;
    f->center = a > 0 ? -128 : 127;
    f->active = 1;
    f->constant = 0;
    if (A == 0) { /* relu(B) whatever q is */
        f->active = 0;
        f->constant = B > 0 ? B : 0;
        return;
    }
    const double t = -B / A;
    if (A > 0 ? t > 127.5 : t < -128.5) { /* relu is 0 for every representable q */
        f->active = 0;
        return;
    }
    if (A > 0 ? t <= -128 : t >= 127) return; /* relu never clips: exact, no clamp */
    const double tq = t < -128 ? -128 : t > 127 ? 127 : round(t);
    if (A > 0)
        f->lo = (int8_t)tq;
    else
        f->hi = (int8_t)tq;
    f->center = (int32_t)tq;
    /* The integer threshold tq is off the real one by up to half a step: A*clamp(q) + B is then
     * off by d = A*(tq - t) on the clipped side. Sharing it half and half between the two sides
     * bounds the error by |A|/4 everywhere and makes it zero-mean when half the values clip. */
    f->B = B + 0.5 * A * (t - tq);
}

double pl_preact_value(const pl_preact *f, int q)
{
    if (!f->active) return f->constant;
    if (q < f->lo) q = f->lo;
    if (q > f->hi) q = f->hi;
    return f->A * q + f->B;
}

int pl_quantize_layer(const char *what, const float *w, const float *bias, int out_c, int depth,
                      const pl_preact *fold, int ch_div, int ch_mod, int32_t input_offset,
                      int8_t *wq, int32_t *bias_q, float *wscale)
{
    for (int o = 0; o < out_c; o++) {
        const float *wo = w + (size_t)o * depth;
        double mx = 0, b = bias ? bias[o] : 0.0;
        for (int d = 0; d < depth; d++) {
            const pl_preact *f = &fold[(d / ch_div) % ch_mod];
            if (f->active) {
                const double v = fabs(wo[d] * f->A);
                if (v > mx) mx = v;
                b += wo[d] * (f->A * f->center + f->B);
            } else {
                b += wo[d] * f->constant;
            }
        }
        double s = mx / 127.0;
        if (!(s > 1e-30)) s = 1e-30; /* all weights 0: any positive scale */
        s = (double)(float)s;        /* the scale the file stores */
        int8_t *qo = wq + (size_t)o * depth;
        double corr = 0; /* sum_d wq[d]*(center + input_offset), exactly */
        for (int d = 0; d < depth; d++) {
            const pl_preact *f = &fold[(d / ch_div) % ch_mod];
            const double v = f->active ? round(wo[d] * f->A / s) : 0.0;
            qo[d] = (int8_t)(v > 127 ? 127 : v < -127 ? -127 : v);
            corr += (double)qo[d] * (f->center + input_offset);
        }
        const double bq = round(b / s - corr);
        if (!(fabs(bq) < 2147483647.0))
            return pl_error(PL_E_ARG,
                            "%s: output channel %d: folded bias %g is %g weight steps, beyond "
                            "int32 (the activation ranges are far too wide for the weights)",
                            what, o, b, bq);
        bias_q[o] = (int32_t)bq;
        wscale[o] = (float)s;
    }
    return PL_OK;
}
