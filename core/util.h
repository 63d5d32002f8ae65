/* Internal helpers shared by every part of the library: error reporting (core/status.h),
 * overflow-checked size arithmetic and the monotonic clock. Not part of the public API. */
#ifndef PL_CORE_UTIL_H
#define PL_CORE_UTIL_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "core/status.h"

/* a*b and a+b into *out; false (and *out untouched) when the result would overflow. */
static inline bool pl_mul_size(size_t a, size_t b, size_t *out)
{
    if (a != 0 && b > SIZE_MAX / a) return false;
    *out = a * b;
    return true;
}
static inline bool pl_add_size(size_t a, size_t b, size_t *out)
{
    if (b > SIZE_MAX - a) return false;
    *out = a + b;
    return true;
}
static inline bool pl_add_u64(uint64_t a, uint64_t b, uint64_t *out)
{
    if (b > UINT64_MAX - a) return false;
    *out = a + b;
    return true;
}

/* Monotonic clock in nanoseconds, and wall-clock (CLOCK_REALTIME) nanoseconds (core/clock.c). */
int64_t pl_now_ns(void);
int64_t pl_wall_ns(void);

#endif
