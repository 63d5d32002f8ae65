/* Status codes and error messages: the ground floor every part of the library reports through.
 * Library code returns a negative PL_E_* status (include/parlight.h) and records a message that
 * names the thing (file, offset, field, expected vs found); pl_last_error() hands it to the app.
 * The message buffer is per thread. Not part of the public API (pl_last_error and
 * pl_status_name are, and are defined in core/status.c). */
#ifndef PL_CORE_STATUS_H
#define PL_CORE_STATUS_H

#include "parlight.h"

/* Records a message for pl_last_error() and returns `status` (negative), so failures read
 * `return pl_error(PL_E_FORMAT, "%s: tensor '%s' offset %llu past end", ...)`. */
int pl_error(int status, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
/* Prefixes the current message with "<prefix>: " (context added by a caller) and returns status. */
int pl_error_prefix(int status, const char *fmt, ...) __attribute__((format(printf, 2, 3)));

#endif
