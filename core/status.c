/* Error messages and status names (core/status.h). */
#include "core/status.h"

#include <stdarg.h>
#include <stdio.h>
#include <string.h>

static _Thread_local char last_error[512];

int pl_error(int status, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(last_error, sizeof last_error, fmt, ap);
    va_end(ap);
    return status;
}

int pl_error_prefix(int status, const char *fmt, ...)
{
    char msg[sizeof last_error];
    va_list ap;
    va_start(ap, fmt);
    int n = vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    size_t len = n < 0 ? 0 : (size_t)n < sizeof msg - 3 ? (size_t)n : sizeof msg - 3;
    memcpy(msg + len, ": ", 2);
    len += 2;
    size_t rest = strnlen(last_error, sizeof last_error - 1);
    if (rest > sizeof msg - 1 - len) rest = sizeof msg - 1 - len;
    memcpy(msg + len, last_error, rest);
    msg[len + rest] = '\0';
    memcpy(last_error, msg, len + rest + 1);
    return status;
}

const char *pl_last_error(void)
{
    return last_error;
}

const char *pl_status_name(int status)
{
    switch (status) {
    case PL_OK: return "PL_OK";
    case PL_E_ARG: return "PL_E_ARG";
    case PL_E_IO: return "PL_E_IO";
    case PL_E_FORMAT: return "PL_E_FORMAT";
    case PL_E_MODEL: return "PL_E_MODEL";
    case PL_E_NOMEM: return "PL_E_NOMEM";
    case PL_E_UNSUPPORTED: return "PL_E_UNSUPPORTED";
    case PL_E_EOF: return "PL_E_EOF";
    case PL_E_DEVICE: return "PL_E_DEVICE";
    case PL_E_INTERNAL: return "PL_E_INTERNAL";
    default: return "PL_E_UNKNOWN";
    }
}

const char *pl_version(void)
{
    return PARLIGHT_VERSION;
}
