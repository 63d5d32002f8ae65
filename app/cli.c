#include "app/cli.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

int cli_int(const char *cmd, const char *flag, const char *s, long lo, long hi, int *out)
{
    char *end;
    errno = 0;
    long v = strtol(s, &end, 10);
    if (errno || end == s || *end || v < lo || v > hi) {
        fprintf(stderr, "parlight %s: %s '%s': expected an integer in %ld..%ld\n", cmd, flag, s,
                lo, hi);
        return -1;
    }
    *out = (int)v;
    return 0;
}

int cli_float3(const char *cmd, const char *flag, const char *s, float out[3])
{
    const char *p = s;
    for (int i = 0; i < 3; i++) {
        char *end;
        errno = 0;
        double v = strtod(p, &end);
        if (errno || end == p || !isfinite(v) || fabs(v) > 1e6) goto bad;
        out[i] = (float)v;
        p = end;
        if (i < 2 && *p++ != ',') goto bad;
    }
    if (*p == '\0') return 0;
bad:
    fprintf(stderr, "parlight %s: %s '%s': expected three finite numbers x,y,z (metres)\n", cmd,
            flag, s);
    return -1;
}
