/* kernels/requant: the gemmlowp primitives and TFLite's MultiplyByQuantizedMultiplier at the
 * boundaries (every power of two of the accumulator and its neighbours, both signs, INT32_MIN /
 * INT32_MAX, rounding ties, multipliers 2^30 .. 2^31-1, every shift in [-31, 30]) against a
 * reference written from the definition in exact long-double arithmetic (not by calling the
 * functions under test); the int8 output stage; and pl_quantize_multiplier round trips. */
#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "core/util.h"
#include "kernels/requant.h"
#include "tests/check.h"

/* --- Reference, from the definition ---------------------------------------------------------
 * Long double has a 64-bit (x86) or 113-bit (aarch64) significand: a*b (< 2^62 in magnitude),
 * a*b / 2^31 + 1/2 and h / 2^e are all exact, so floorl/roundl apply the rounding rules to the
 * exact values. */
static const long double TWO31 = 2147483648.0L;

/* high mul: 2*a*b / 2^32 rounded to nearest, ties toward +infinity; INT32_MIN^2 saturates. */
static int32_t ref_high_mul(int32_t a, int32_t b)
{
    if (a == INT32_MIN && b == INT32_MIN) return INT32_MAX;
    return (int32_t)floorl((long double)a * (long double)b / TWO31 + 0.5L);
}

/* x / 2^e rounded to nearest, ties away from zero (roundl). */
static int32_t ref_div_pot(int32_t x, int e)
{
    return (int32_t)roundl((long double)x / ldexpl(1.0L, e));
}

/* acc * 2^max(shift,0) saturated to int32, high mul, then divide by 2^max(-shift,0). */
static int32_t ref_requant(int32_t acc, int32_t m, int32_t shift)
{
    long double x = (long double)acc * ldexpl(1.0L, shift > 0 ? shift : 0);
    if (x > (long double)INT32_MAX) x = INT32_MAX;
    if (x < (long double)INT32_MIN) x = INT32_MIN;
    const int32_t h = ref_high_mul((int32_t)x, m);
    return shift < 0 ? ref_div_pot(h, -shift) : h;
}

/* --- Test values ----------------------------------------------------------------------------- */

static int32_t accs[1024];
static int n_accs;

static void add_acc(long long v)
{
    if (v >= INT32_MIN && v <= INT32_MAX) accs[n_accs++] = (int32_t)v;
}

/* 0, +-1, +-2^k and +-(2^k +- 1) for every k, INT32_MIN/MAX and their neighbours. */
static void make_accs(void)
{
    add_acc(0);
    for (int k = 0; k <= 31; k++) {
        const long long p = 1LL << k;
        for (int sgn = -1; sgn <= 1; sgn += 2) {
            add_acc(sgn * p);
            add_acc(sgn * (p - 1));
            add_acc(sgn * (p + 1));
            add_acc(sgn * (p + p / 2)); /* 1.5 * 2^k: ties when divided by 2^k */
        }
    }
    add_acc(INT32_MIN + 1);
    add_acc(INT32_MAX - 1);
}


static void test_high_mul(void)
{
    const int32_t specials[] = {
        INT32_MIN, INT32_MIN + 1, -(1 << 30) - 1, -(1 << 30),    -3,       -2, -1, 0, 1, 2,
        3,         1 << 30,       (1 << 30) + 1,  INT32_MAX - 1, INT32_MAX};
    const int ns = (int)(sizeof specials / sizeof specials[0]);
    for (int i = 0; i < n_accs; i++)
        for (int j = 0; j < ns; j++) {
            const int32_t a = accs[i], b = specials[j];
            CHECK(pl_sat_rounding_doubling_high_mul(a, b) == ref_high_mul(a, b),
                  "high_mul(%ld, %ld) = %ld, want %ld", (long)a, (long)b,
                  (long)pl_sat_rounding_doubling_high_mul(a, b), (long)ref_high_mul(a, b));
            CHECK(pl_sat_rounding_doubling_high_mul(b, a) == ref_high_mul(b, a),
                  "high_mul(%ld, %ld) symmetric", (long)b, (long)a);
        }
    CHECK(pl_sat_rounding_doubling_high_mul(INT32_MIN, INT32_MIN) == INT32_MAX, "saturating case");
    /* ties: a*b an odd multiple of 2^30 -> +0.5 rounds up, -0.5 rounds toward zero (to +inf) */
    CHECK(pl_sat_rounding_doubling_high_mul(1, 1 << 30) == 1, "+0.5 -> 1");
    CHECK(pl_sat_rounding_doubling_high_mul(-1, 1 << 30) == 0, "-0.5 -> 0");
    CHECK(pl_sat_rounding_doubling_high_mul(-3, 1 << 30) == -1, "-1.5 -> -1");
    CHECK(pl_sat_rounding_doubling_high_mul(3, 1 << 30) == 2, "+1.5 -> 2");
    for (int i = 0; i < 200000; i++) {
        const int32_t a = (int32_t)rnd(), b = (int32_t)rnd();
        CHECK(pl_sat_rounding_doubling_high_mul(a, b) == ref_high_mul(a, b),
              "high_mul(%ld, %ld) random", (long)a, (long)b);
    }
}

static void test_div_pot(void)
{
    for (int e = 0; e <= 31; e++)
        for (int i = 0; i < n_accs; i++) {
            const int32_t x = accs[i];
            CHECK(pl_rounding_divide_by_pot(x, e) == ref_div_pot(x, e),
                  "divide_by_pot(%ld, %d) = %ld, want %ld", (long)x, e,
                  (long)pl_rounding_divide_by_pot(x, e), (long)ref_div_pot(x, e));
        }
    CHECK(pl_rounding_divide_by_pot(3, 1) == 2 && pl_rounding_divide_by_pot(-3, 1) == -2,
          "ties away from zero: +-1.5 -> +-2");
    CHECK(pl_rounding_divide_by_pot(5, 1) == 3 && pl_rounding_divide_by_pot(-5, 1) == -3,
          "ties away from zero: +-2.5 -> +-3");
    CHECK(pl_rounding_divide_by_pot(INT32_MIN, 31) == -1 &&
              pl_rounding_divide_by_pot(INT32_MAX, 31) == 1 &&
              pl_rounding_divide_by_pot(-(1 << 30), 31) == -1 &&
              pl_rounding_divide_by_pot((1 << 30) - 1, 31) == 0,
          "exponent 31");
}

static void test_requantize(void)
{
    const int32_t mults[] = {0,
                             1 << 30,
                             (1 << 30) + 1,
                             1518500250 /* sqrt(2) 2^30 */,
                             1932735283 /* 0.9 2^31 */,
                             INT32_MAX - 1,
                             INT32_MAX};
    const int nm = (int)(sizeof mults / sizeof mults[0]);
    long long cases = 0;
    for (int32_t s = PL_REQUANT_SHIFT_MIN; s <= PL_REQUANT_SHIFT_MAX; s++)
        for (int j = 0; j < nm; j++)
            for (int i = 0; i < n_accs; i++, cases++) {
                const int32_t a = accs[i], m = mults[j];
                const int32_t got = pl_requantize(a, m, s), want = ref_requant(a, m, s);
                CHECK(got == want, "requantize(%ld, %ld, %ld) = %ld, want %ld", (long)a, (long)m,
                      (long)s, (long)got, (long)want);
            }
    for (int i = 0; i < 300000; i++, cases++) {
        const int32_t a = (int32_t)rnd() >> (rnd() % 32);
        const int32_t m = (int32_t)((1u << 30) | (rnd() & 0x3fffffffu));
        const int32_t s = (int32_t)(rnd() % 62) - 31;
        CHECK(pl_requantize(a, m, s) == ref_requant(a, m, s), "requantize(%ld, %ld, %ld) random",
              (long)a, (long)m, (long)s);
    }
    /* Double rounding, as TFLite requires: acc 5, m 2^30 (0.5), shift -1: the high mul rounds
     * 2.5 up to 3, then 3 / 2 = 1.5 rounds to 2, where rounding 5 * 0.25 = 1.25 once gives 1. */
    CHECK(pl_requantize(5, 1 << 30, -1) == 2, "double rounding: 5 * 0.25 -> 2");
    printf("requantize: %lld cases against the long-double reference\n", cases);
}

/* The int8 output stage, and the documented left-shift saturation: where acc << shift overflows,
 * the int8 result equals clamping the exact product acc * m * 2^(shift-31). */
static void test_output_stage(void)
{
    CHECK(pl_requantize_s8(INT32_MAX, INT32_MAX, 0, 127, -128, 127) == 127, "no overflow at max");
    CHECK(pl_requantize_s8(INT32_MIN, INT32_MAX, 0, -128, -128, 127) == -128, "no overflow at min");
    CHECK(pl_requantize_s8(0, 1 << 30, 0, 5, -128, 127) == 5, "offset added");
    CHECK(pl_requantize_s8(1000, 1 << 30, -2, 0, -10, 100) == 100, "act_max: 125 -> 100");
    CHECK(pl_requantize_s8(-1000, 1 << 30, -2, 0, -10, 100) == -10, "act_min: -125 -> -10");
    for (int32_t s = 1; s <= PL_REQUANT_SHIFT_MAX; s++)
        for (int i = 0; i < n_accs; i++)
            for (int mi = 0; mi < 2; mi++) {
                const int32_t a = accs[i], m = mi ? INT32_MAX : 1 << 30;
                const long double exact = (long double)a * m * ldexpl(1.0L, s - 31);
                const long double wide = (long double)a * ldexpl(1.0L, s);
                if (wide <= (long double)INT32_MAX && wide >= (long double)INT32_MIN) continue;
                const int want = exact > 127.0L ? 127 : exact < -128.0L ? -128 : 0;
                CHECK(want != 0 && pl_requantize_s8(a, m, s, 0, -128, 127) == want,
                      "saturated left shift: acc %ld m %ld shift %ld", (long)a, (long)m, (long)s);
            }
}

static void test_quantize_multiplier(void)
{
    int32_t m = -1, s = -1;
    CHECK(pl_quantize_multiplier(0.0, &m, &s) == PL_OK && m == 0 && s == 0, "0 -> (0, 0)");
    CHECK(pl_quantize_multiplier(1.0, &m, &s) == PL_OK && m == (1 << 30) && s == 1, "1.0");
    CHECK(pl_quantize_multiplier(0.5, &m, &s) == PL_OK && m == (1 << 30) && s == 0, "0.5");
    CHECK(pl_quantize_multiplier(0.75, &m, &s) == PL_OK && m == 1610612736 && s == 0, "0.75");
    /* q * 2^31 rounds up to 2^31: becomes 2^30 with shift + 1 */
    CHECK(pl_quantize_multiplier(1.0 - 1e-12, &m, &s) == PL_OK && m == (1 << 30) && s == 1,
          "1 - 1e-12 -> (2^30, 1), got (%ld, %ld)", (long)m, (long)s);
    CHECK(pl_quantize_multiplier(ldexp(1.0, -32), &m, &s) == PL_OK && m == (1 << 30) && s == -31,
          "2^-32 -> (2^30, -31), got (%ld, %ld)", (long)m, (long)s);
    CHECK(pl_quantize_multiplier(ldexp(1.0, -33), &m, &s) == PL_OK && m == 0 && s == 0,
          "2^-33 -> (0, 0): shift would be < -31");
    CHECK(pl_quantize_multiplier(ldexp(1.0, 29), &m, &s) == PL_OK && m == (1 << 30) && s == 30,
          "2^29 -> (2^30, 30)");
    CHECK(pl_quantize_multiplier(ldexp(1.0, 30), &m, &s) == PL_E_ARG, "2^30 rejected");
    CHECK(pl_quantize_multiplier(-0.5, &m, &s) == PL_E_ARG, "negative rejected");
    CHECK(pl_quantize_multiplier(NAN, &m, &s) == PL_E_ARG, "NaN rejected");
    CHECK(pl_quantize_multiplier(INFINITY, &m, &s) == PL_E_ARG, "inf rejected");
    for (int i = 0; i < 100000; i++) {
        /* log-uniform in [2^-31, 2^29] */
        const double real =
            ldexp(1.0 + (double)rnd() / 4294967296.0, (int)(rnd() % 60) - 31);
        if (pl_quantize_multiplier(real, &m, &s) != PL_OK) {
            CHECK(0, "quantize_multiplier(%.17g): %s", real, pl_last_error());
            continue;
        }
        const double back = ldexp((double)m, s - 31);
        CHECK(m >= (1 << 30) && s >= PL_REQUANT_SHIFT_MIN && s <= PL_REQUANT_SHIFT_MAX,
              "range: %.17g -> (%ld, %ld)", real, (long)m, (long)s);
        CHECK(fabs(back - real) <= real * ldexp(1.0, -31), "round trip %.17g -> %.17g", real, back);
        /* and requantising with it approximates acc * real (to within 1 plus the Q31 error) */
        const int32_t acc = (int32_t)(rnd() >> 12) - (1 << 19);
        const double want = (double)acc * real;
        if (fabs(want) < 1e9) {
            const int32_t got = pl_requantize(acc, m, s);
            CHECK(fabs((double)got - want) <= 1.0 + fabs(want) * ldexp(1.0, -30),
                  "requantize(%ld, %.17g) = %ld, want ~%.3f", (long)acc, real, (long)got, want);
        }
    }
}

int main(void)
{
    if (LDBL_MANT_DIG < 64) {
        printf("long double has %d significand bits here; the exact reference needs 64\n",
               LDBL_MANT_DIG);
        return 77;
    }
    make_accs();
    test_high_mul();
    test_div_pot();
    test_requantize();
    test_output_stage();
    test_quantize_multiplier();
    if (failures) {
        printf("%d checks failed\n", failures);
        return 1;
    }
    printf("all requantisation checks passed\n");
    return 0;
}
