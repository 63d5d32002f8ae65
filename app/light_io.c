#include "app/light_io.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <unistd.h>

#include "core/util.h"
#include "port/hdr_io.h"
#include "port/image.h"

static const char *ext_of(const char *path)
{
    const char *dot = strrchr(path, '.'), *slash = strrchr(path, '/');
    if (!dot || (slash && dot < slash)) return "";
    return dot;
}

int pl_app_output_kind(const char *path)
{
    const char *e = ext_of(path);
    if (!strcasecmp(e, ".exr") || !strcasecmp(e, ".hdr")) return 1;
    if (!strcasecmp(e, ".png")) return 2;
    return 0;
}

int pl_app_input_kind(const char *path)
{
    const char *e = ext_of(path);
    if (!strcasecmp(e, ".json")) return 1;
    if (!strcasecmp(e, ".exr") || !strcasecmp(e, ".hdr")) return 2;
    return 0;
}

int pl_app_write_image(const char *path, const pl_image_f32 *img, int force)
{
    int kind = pl_app_output_kind(path);
    if (kind == 0)
        return pl_error(PL_E_ARG, "%s: unknown output extension (expected .exr, .hdr or .png)",
                        path);
    if (!force && access(path, F_OK) == 0)
        return pl_error(PL_E_IO, "%s: already exists (use --force to overwrite)", path);
    if (kind == 1) return pl_hdr_write(path, img);
    pl_image_u8 u8;
    int rc = pl_tonemap_rgb8(img, &u8);
    if (rc < 0) return rc;
    rc = pl_image_write_rgb8(path, &u8);
    pl_image_u8_free(&u8);
    return rc;
}

int pl_app_parse_point(const char *text, float p[3])
{
    const char *s = text;
    for (int k = 0; k < 3; k++) {
        char *end;
        errno = 0;
        double v = strtod(s, &end);
        if (end == s || errno || !isfinite(v) || fabs(v) > 1e6)
            return pl_error(PL_E_ARG, "--at '%s': expected three finite numbers x,y,z (metres)",
                            text);
        p[k] = (float)v;
        s = end;
        if (k < 2) {
            if (*s != ',')
                return pl_error(PL_E_ARG, "--at '%s': expected three numbers separated by commas",
                                text);
            s++;
        }
    }
    if (*s) return pl_error(PL_E_ARG, "--at '%s': unexpected text after the third number", text);
    return 0;
}

void pl_app_put_json_string(FILE *f, const char *s)
{
    fputc('"', f);
    for (const unsigned char *c = (const unsigned char *)s; *c; c++) {
        if (*c == '"' || *c == '\\')
            fprintf(f, "\\%c", *c);
        else if (*c < 0x20)
            fprintf(f, "\\u%04x", *c);
        else
            fputc(*c, f);
    }
    fputc('"', f);
}
