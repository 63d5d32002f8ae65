#include "kernels/requant.h"

#include <math.h>

#include "core/util.h"

int pl_quantize_multiplier(double real, int32_t *multiplier, int32_t *shift)
{
    if (!multiplier || !shift) return pl_error(PL_E_ARG, "pl_quantize_multiplier: NULL output");
    if (!isfinite(real) || real < 0.0)
        return pl_error(PL_E_ARG, "requantisation multiplier %g: expected a finite value >= 0",
                        real);
    if (real == 0.0) {
        *multiplier = 0;
        *shift = 0;
        return PL_OK;
    }
    int exp = 0;
    const double q = frexp(real, &exp); /* real = q * 2^exp, q in [0.5, 1) */
    int64_t q_fixed = (int64_t)round(q * 2147483648.0);
    if (q_fixed == ((int64_t)1 << 31)) {
        q_fixed /= 2;
        exp++;
    }
    if (exp < PL_REQUANT_SHIFT_MIN) { /* every bit would be shifted out: the result is 0 */
        *multiplier = 0;
        *shift = 0;
        return PL_OK;
    }
    if (exp > PL_REQUANT_SHIFT_MAX)
        return pl_error(PL_E_ARG, "requantisation multiplier %g: expected < 2^30 (shift %d > %d)",
                        real, exp, PL_REQUANT_SHIFT_MAX);
    *multiplier = (int32_t)q_fixed;
    *shift = exp;
    return PL_OK;
}
