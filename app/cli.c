#include "app/cli.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "core/image.h"
#include "light/light.h"

int cli_int(const char *cmd, const char *flag, const char *s, long lo, long hi, int *out)
{
    char *end;
    errno = 0;
    long v = strtol(s, &end, 10);
    if (errno || end == s || *end || v < lo || v > hi) {
        fprintf(stderr, "parlight %s: %s '%s': expected an integer in %ld..%ld\n", cmd, flag, s, lo,
                hi);
        return -1;
    }
    *out = (int)v;
    return 0;
}

int cli_max_pixels(const char *cmd, const char *s)
{
    int n;
    if (cli_int(cmd, "--max-pixels", s, 1, PL_IMAGE_MAX_PIXELS, &n) < 0) return -1;
    return pl_image_set_max_pixels(n, "--max-pixels") < 0 ? -1 : 0;
}

int cli_double(const char *cmd, const char *flag, const char *s, double lo, double hi, int lo_open,
               double *out)
{
    char *end;
    errno = 0;
    const double v = strtod(s, &end);
    if (errno || end == s || *end || !(lo_open ? v > lo : v >= lo) || !(v <= hi)) {
        fprintf(stderr, "parlight %s: %s '%s': expected a number in %s%g, %g]\n", cmd, flag, s,
                lo_open ? "(" : "[", lo, hi);
        return -1;
    }
    *out = v;
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

int cli_anchor(const char *cmd, const char *s, double out[3])
{
    out[0] = out[1] = 0, out[2] = 2.2;
    if (!strcmp(s, "off")) return 0;
    const char *p = s;
    int n = 0;
    for (;;) {
        char *end;
        errno = 0;
        double v = strtod(p, &end);
        if (errno || end == p || !isfinite(v)) goto bad;
        out[n++] = v;
        p = end;
        if (*p != ',' || n == 3) break;
        p++;
    }
    if (n >= 2 && *p == '\0' && pl_anchor_check(out[0], out[1], out[2]) == 0) return 0;
bad:
    fprintf(stderr,
            "parlight %s: --anchor '%s': expected off, or W,B or W,B,GAMMA with W in "
            "0..1, B in -8..8 (stops), GAMMA in 1..3\n",
            cmd, s);
    return -1;
}

int cli_getopt_error(const char *cmd, int c, char *const argv[])
{
    /* getopt_long has moved optind past the option it is reporting, except after an unknown
     * short option inside a cluster such as -jx, where optopt names it */
    const char *arg = argv[optind - 1];
    if (c == ':')
        fprintf(stderr, "parlight %s: %s needs a value\n", cmd, arg);
    else if (strncmp(arg, "--", 2) == 0 && strchr(arg, '='))
        fprintf(stderr,
                "parlight %s: '%s': unknown option, or a value for one that takes none "
                "(see --help)\n",
                cmd, arg);
    else if (strncmp(arg, "--", 2) == 0)
        fprintf(stderr, "parlight %s: unknown option '%s' (see --help)\n", cmd, arg);
    else
        fprintf(stderr, "parlight %s: unknown option '-%c' (see --help)\n", cmd,
                optopt > 32 && optopt < 127 ? optopt : '?');
    return 2;
}
