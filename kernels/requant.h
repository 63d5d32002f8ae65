/* Requantisation: the fixed-point maths of TFLite's int8 scheme, written once. It sits at the
 * bottom of kernels/, beside the kernels that use it (as CMSIS-NN keeps arm_nn_requantize in its
 * support functions), so no kernel reaches up into quant/, the offline tools.
 *
 * Every int8 kernel (reference and SIMD) turns its int32 accumulator into an int8 output with
 * pl_requantize_s8(), which is pl_requantize() (TFLite's MultiplyByQuantizedMultiplier, the
 * gemmlowp primitives with TFLite's default "double rounding") followed by the output zero point
 * and the activation clamp. There is one rounding mode in the project: this one. The semantics
 * are spelled out in docs/QUANT.md ("Kernels and rounding") and tested at every power of two and
 * at INT32_MIN/INT32_MAX by tests/test_requant.c.
 *
 * A real multiplier r > 0 is represented as r = multiplier * 2^(shift - 31), with multiplier a
 * Q31 value in [2^30, 2^31) (or 0 for r = 0) and shift in [-31, 30]; pl_quantize_multiplier()
 * makes that pair from r. A positive shift is a left shift (r >= 1), a negative one a rounding
 * right shift. */
#ifndef PL_KERNELS_REQUANT_H
#define PL_KERNELS_REQUANT_H

#include <stdint.h>

/* Valid ranges of a (multiplier, shift) pair, checked where the pair enters (model loader,
 * quantiser, the golden-vector runner); the functions below assume them. */
#define PL_REQUANT_MULT_MIN ((int32_t)1 << 30) /* or exactly 0 */
#define PL_REQUANT_SHIFT_MIN (-31)
#define PL_REQUANT_SHIFT_MAX 30

/* gemmlowp SaturatingRoundingDoublingHighMul: the high 32 bits of 2*a*b, rounded to nearest with
 * ties toward +infinity, i.e. floor((a*b + 2^30) / 2^31). The one product that does not fit,
 * INT32_MIN * INT32_MIN, saturates to INT32_MAX. Defined for every a, b. */
static inline int32_t pl_sat_rounding_doubling_high_mul(int32_t a, int32_t b)
{
    if (a == INT32_MIN && b == INT32_MIN) return INT32_MAX;
    const int64_t ab = (int64_t)a * b;
    const int64_t nudge = ab >= 0 ? ((int64_t)1 << 30) : 1 - ((int64_t)1 << 30);
    return (int32_t)((ab + nudge) / ((int64_t)1 << 31)); /* '/' truncates toward zero */
}

/* gemmlowp RoundingDivideByPOT: x / 2^exp rounded to nearest, ties away from zero.
 * exp in [0, 31]. */
static inline int32_t pl_rounding_divide_by_pot(int32_t x, int exp)
{
    const int32_t mask = (int32_t)(((int64_t)1 << exp) - 1);
    const int32_t remainder = x & mask;
    const int32_t threshold = (mask >> 1) + (x < 0 ? 1 : 0);
    return (x >> exp) + (remainder > threshold ? 1 : 0); /* '>>' of a negative is arithmetic */
}

/* TFLite MultiplyByQuantizedMultiplier(acc, multiplier, shift): approximately
 * acc * multiplier * 2^(shift - 31), as
 *   RoundingDivideByPOT(SaturatingRoundingDoublingHighMul(acc << max(shift, 0), multiplier),
 *                       max(-shift, 0)).
 * multiplier in [2^30, 2^31) or 0, shift in [-31, 30]. One deliberate difference: where
 * acc << shift overflows int32 (undefined behaviour in TFLite's C++), the shifted value saturates
 * to INT32_MIN/INT32_MAX, so the result keeps its sign and its magnitude stays >= 2^29, which
 * every int8 output stage clamps to -128/127 exactly as exact arithmetic would. */
static inline int32_t pl_requantize(int32_t acc, int32_t multiplier, int32_t shift)
{
    int32_t x = acc;
    if (shift > 0) {
        const int64_t wide = (int64_t)acc * ((int64_t)1 << shift);
        x = wide > INT32_MAX ? INT32_MAX : wide < INT32_MIN ? INT32_MIN : (int32_t)wide;
    }
    const int32_t high = pl_sat_rounding_doubling_high_mul(x, multiplier);
    return shift < 0 ? pl_rounding_divide_by_pot(high, (int)-shift) : high;
}

/* The int8 output stage of every conv / fully connected kernel: requantise, add the output zero
 * point (`output_offset` = +output_zero_point, in [-128, 127]), clamp to [act_min, act_max]
 * (-128 <= act_min <= act_max <= 127). The sum is taken in 64 bits so it cannot overflow. */
static inline int8_t pl_requantize_s8(int32_t acc, int32_t multiplier, int32_t shift,
                                      int32_t output_offset, int32_t act_min, int32_t act_max)
{
    int64_t v = (int64_t)pl_requantize(acc, multiplier, shift) + output_offset;
    if (v < act_min) v = act_min;
    if (v > act_max) v = act_max;
    return (int8_t)v;
}

/* TFLite QuantizeMultiplier: splits real >= 0 into (multiplier, shift) with
 * real ~= multiplier * 2^(shift - 31): frexp gives real = q * 2^shift with q in [0.5, 1), then
 * multiplier = round(q * 2^31) (half away from zero); when that rounds up to 2^31 it becomes
 * 2^30 with shift + 1. real == 0, or so small that shift < -31, gives (0, 0) (every result is 0).
 * Returns PL_OK, or PL_E_ARG with a message when real is negative, not finite or >= 2^30
 * (shift would exceed 30). Relative error of the pair: at most 2^-31. */
int pl_quantize_multiplier(double real, int32_t *multiplier, int32_t *shift);

#endif
