#include "quant/calib.h"

#include <math.h>
#include <string.h>

#include "core/util.h"

#define B PL_HIST_BINS

void pl_hist_init(pl_hist *h)
{
    memset(h, 0, sizeof *h);
    h->min = INFINITY;
    h->max = -INFINITY;
}

/* Doubles R: new bin k covers old bins 2k - B/2 and 2k - B/2 + 1. */
static void grow(pl_hist *h)
{
    uint32_t nb[B];
    memset(nb, 0, sizeof nb);
    for (int j = 0; j < B; j++)
        nb[B / 4 + j / 2] += h->bins[j];
    memcpy(h->bins, nb, sizeof nb);
    h->R *= 2;
}

void pl_hist_add(pl_hist *h, const float *x, size_t n)
{
    double mx = 0;
    for (size_t i = 0; i < n; i++) {
        const double v = x[i];
        if (v < h->min) h->min = v;
        if (v > h->max) h->max = v;
        if (fabs(v) > mx) mx = fabs(v);
    }
    if (mx > 0 && h->R == 0) {
        h->R = pow(2.0, ceil(log2(mx)));
        if (h->R < mx) h->R *= 2;
    }
    while (h->R > 0 && mx >= h->R)
        grow(h);
    const double k = h->R > 0 ? B / (2 * h->R) : 0;
    for (size_t i = 0; i < n; i++) {
        int bin = h->R > 0 ? (int)floor((x[i] + h->R) * k) : B / 2;
        if (bin < 0) bin = 0;
        if (bin >= B) bin = B - 1;
        h->bins[bin]++;
    }
    h->total += n;
}

int pl_calib_method_parse(const char *name, pl_calib_method *m)
{
    static const char *names[] = {"minmax", "percentile", "entropy", "mse"};
    for (int i = 0; i < 4; i++)
        if (!strcmp(name, names[i])) {
            *m = (pl_calib_method)i;
            return PL_OK;
        }
    return pl_error(PL_E_ARG,
                    "calibration method '%s': expected minmax, percentile, entropy or mse", name);
}

const char *pl_calib_method_name(pl_calib_method m)
{
    switch (m) {
    case PL_CALIB_MINMAX:
        return "minmax";
    case PL_CALIB_PERCENTILE:
        return "percentile";
    case PL_CALIB_ENTROPY:
        return "entropy";
    case PL_CALIB_MSE:
        return "mse";
    }
    return "?";
}

static double bin_lo(const pl_hist *h, int i)
{
    return -h->R + 2 * h->R * i / B;
}

/* Value below which a fraction p of the samples lie (linear within the bin). */
static double quantile(const pl_hist *h, double p)
{
    const double target = p * (double)h->total;
    double acc = 0;
    for (int i = 0; i < B; i++) {
        const double c = (double)h->bins[i];
        if (acc + c >= target && c > 0) {
            const double f = (target - acc) / c;
            return bin_lo(h, i) + f * 2 * h->R / B;
        }
        acc += c;
    }
    return h->max;
}

/* TensorRT-style entropy calibration on the magnitude histogram (bins of width R/(B/2)). */
static double kl_threshold(const pl_hist *h)
{
    enum { HALF = B / 2, LEVELS = 128 };
    double mag[HALF];
    for (int i = 0; i < HALF; i++)
        mag[i] = (double)h->bins[HALF + i] + (double)h->bins[HALF - 1 - i];
    int last = HALF - 1;
    while (last > 0 && mag[last] == 0)
        last--;
    if (last < LEVELS) return (last + 1) * h->R / HALF;
    double best_kl = INFINITY;
    int best = last + 1;
    double p[HALF], q[HALF];
    for (int i = LEVELS; i <= last + 1; i += (last + 1 - LEVELS) / 64 + 1) {
        double outliers = 0;
        for (int k = i; k < HALF; k++)
            outliers += mag[k];
        for (int k = 0; k < i; k++)
            p[k] = mag[k];
        p[i - 1] += outliers;
        /* quantise [0, i) into LEVELS groups, spread each group's mass over its non-empty bins */
        for (int g = 0; g < LEVELS; g++) {
            const int a = g * i / LEVELS, b = (g + 1) * i / LEVELS;
            double sum = 0;
            int nz = 0;
            for (int k = a; k < b; k++) {
                sum += mag[k];
                nz += mag[k] > 0;
            }
            for (int k = a; k < b; k++)
                q[k] = mag[k] > 0 ? sum / nz : 0;
        }
        double ps = 0, qs = 0;
        for (int k = 0; k < i; k++) {
            ps += p[k];
            qs += q[k];
        }
        if (ps <= 0 || qs <= 0) continue;
        double kl = 0;
        for (int k = 0; k < i; k++) {
            if (p[k] <= 0) continue;
            const double pk = p[k] / ps, qk = q[k] > 0 ? q[k] / qs : 1e-12;
            kl += pk * log(pk / qk);
        }
        if (kl < best_kl) {
            best_kl = kl;
            best = i;
        }
    }
    return best * h->R / HALF;
}

/* Expected squared error of quantising the histogram to 256 levels over [lo, hi]. */
static double range_mse(const pl_hist *h, double lo, double hi)
{
    const double step = (hi - lo) / 255.0, w = 2 * h->R / B;
    double err = 0;
    for (int i = 0; i < B; i++) {
        if (!h->bins[i]) continue;
        const double c = bin_lo(h, i) + w / 2;
        double e;
        if (c < lo)
            e = (lo - c) * (lo - c);
        else if (c > hi)
            e = (c - hi) * (c - hi);
        else
            e = step * step / 12.0;
        err += (double)h->bins[i] * e;
    }
    return err;
}

int pl_hist_range(const pl_hist *h, pl_calib_method m, double percentile, int relu, double *lo,
                  double *hi)
{
    if (h->total == 0) return pl_error(PL_E_ARG, "no calibration data for this activation");
    double l = h->min < 0 ? h->min : 0, u = h->max > 0 ? h->max : 0;
    if (relu) l = 0;
    if (h->R > 0) switch (m) {
        case PL_CALIB_MINMAX:
            break;
        case PL_CALIB_PERCENTILE: {
            const double ql = quantile(h, 1.0 - percentile / 100.0),
                         qh = quantile(h, percentile / 100.0);
            if (l < 0 && ql < 0) l = ql > l ? ql : l;
            if (u > 0 && qh > 0) u = qh < u ? qh : u;
            break;
        }
        case PL_CALIB_ENTROPY: {
            const double t = kl_threshold(h);
            if (l < -t) l = -t;
            if (u > t) u = t;
            break;
        }
        case PL_CALIB_MSE: {
            double best = INFINITY, bf = 1;
            for (int k = 0; k < 100; k++) {
                const double f = 1.0 - k * 0.0099;
                const double e = range_mse(h, l * f, u * f);
                if (e < best) {
                    best = e;
                    bf = f;
                }
            }
            l *= bf;
            u *= bf;
            break;
        }
        }
    *lo = l;
    *hi = u;
    return PL_OK;
}
