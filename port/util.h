/* Internal helpers shared by every part of the library: error reporting, overflow-checked size
 * arithmetic and the monotonic clock. Not part of the public API. */
#ifndef PL_PORT_UTIL_H
#define PL_PORT_UTIL_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "parlight.h"

/* Records a message for pl_last_error() and returns `status` (negative), so failures read
 * `return pl_error(PL_E_FORMAT, "%s: tensor '%s' offset %llu past end", ...)`. */
int pl_error(int status, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
/* Prefixes the current message with "<prefix>: " (context added by a caller) and returns status. */
int pl_error_prefix(int status, const char *fmt, ...) __attribute__((format(printf, 2, 3)));

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

/* Monotonic clock in nanoseconds, and wall-clock (CLOCK_REALTIME) nanoseconds. */
int64_t pl_now_ns(void);
int64_t pl_wall_ns(void);

#endif
