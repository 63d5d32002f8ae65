#include "app/cli.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "core/file.h"
#include "core/image.h"
#include "core/util.h"
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

int cli_read_token(const char *cmd, const char *path, char *out, size_t cap)
{
    int fd = -1;
    struct stat st;
    const char *why = NULL;
    char buf[1024];
    ssize_t n = 0;
    if (pl_file_open_regular(path, "token file", &fd, NULL) < 0) {
        fprintf(stderr, "parlight %s: --token-file %s\n", cmd, pl_last_error());
        return -1;
    }
    if (fstat(fd, &st) != 0)
        why = strerror(errno);
    else if (st.st_mode & S_IROTH)
        why = "readable by every user: a secret must not be (chmod o-r)";
    else if ((n = read(fd, buf, sizeof buf - 1)) < 0)
        why = strerror(errno);
    close(fd);
    if (!why) {
        buf[n] = '\0';
        size_t len = strcspn(buf, "\n");
        if (len > 0 && buf[len - 1] == '\r') len--;
        buf[len] = '\0';
        if (len == 0)
            why = "the first line is empty";
        else if (len >= cap)
            why = "the token is too long";
        for (size_t i = 0; i < len && !why; i++)
            if ((unsigned char)buf[i] < 0x20 || buf[i] == 0x7f)
                why = "the token holds a control character";
        if (!why) memcpy(out, buf, len + 1);
    }
    if (why) {
        fprintf(stderr, "parlight %s: --token-file %s: %s\n", cmd, path, why);
        return -1;
    }
    return 0;
}

int cli_quat(const char *cmd, const char *s, double q[4])
{
    const char *p = s;
    for (int i = 0; i < 4; i++) {
        char *end;
        errno = 0;
        q[i] = strtod(p, &end);
        if (errno || end == p || !isfinite(q[i])) goto bad;
        p = end;
        if (i < 3 && *p++ != ',') goto bad;
    }
    if (*p == '\0') return 0;
bad:
    fprintf(stderr,
            "parlight %s: --orientation '%s': expected a unit quaternion W,X,Y,Z (camera to "
            "world)\n",
            cmd, s);
    return -1;
}
