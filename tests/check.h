/* What the C unit tests share: CHECK, which counts and reports a failed condition and goes on,
 * and a small deterministic random generator for test data.
 *
 * Include it once, in the test's .c file. A test that wants another random sequence defines
 * CHECK_RNG_SEED first. main() ends with `return failures ? 1 : 0;` (tests/run.sh reads the exit
 * status; 77 means skipped). */
#ifndef PL_TESTS_CHECK_H
#define PL_TESTS_CHECK_H

#include <stdint.h>
#include <stdio.h>

static int failures;

/* Only the first CHECK_MAX_PRINTED failures are printed; all are counted. */
#define CHECK_MAX_PRINTED 20

#define CHECK(cond, ...)                                                                           \
    do {                                                                                           \
        if (!(cond) && failures++ < CHECK_MAX_PRINTED) {                                           \
            printf("FAIL %s:%d: ", __FILE__, __LINE__);                                            \
            printf(__VA_ARGS__);                                                                   \
            printf("\n");                                                                          \
            fflush(stdout);                                                                        \
        }                                                                                          \
    } while (0)

#ifndef CHECK_RNG_SEED
#define CHECK_RNG_SEED 0x9e3779b97f4a7c15ULL
#endif

/* xorshift64 (13, 7, 17), upper bits: the same sequence on every platform and run. */
static inline uint32_t rnd(void)
{
    static uint64_t s = CHECK_RNG_SEED;
    s ^= s << 13;
    s ^= s >> 7;
    s ^= s << 17;
    return (uint32_t)(s >> 16);
}

/* Uniform in [lo, hi] (hi - lo < 2^32; the modulo bias does not matter for test data). */
static inline int rint_in(int lo, int hi)
{
    return lo + (int)(rnd() % (uint32_t)(hi - lo + 1));
}

#endif
