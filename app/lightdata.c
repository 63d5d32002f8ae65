#include "app/lightdata.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>

#include "app/light_io.h"
#include "light/lights_json.h"

int pl_app_double(const char *cmd, const char *flag, const char *s, double lo, double hi,
                  double *out)
{
    char *end;
    errno = 0;
    double v = strtod(s, &end);
    if (errno || end == s || *end || !isfinite(v) || v < lo || v > hi) {
        fprintf(stderr, "parlight %s: %s '%s': expected a number in [%g, %g]\n", cmd, flag, s, lo,
                hi);
        return -1;
    }
    *out = v;
    return 0;
}

int pl_app_put_extract_json(FILE *f, const char *source, int width, int height,
                            const pl_lighting *L, const pl_extract_params *p,
                            const pl_extract_info *info, int timing)
{
    char buf[8192];
    int n = pl_lighting_format_json(L, buf, sizeof buf);
    if (n < 0) return n;
    fprintf(f, "\"source\":");
    pl_app_put_json_string(f, source);
    fprintf(f, ",\"panorama_size\":[%d,%d],%s,\"distance_assumed\":true", width, height, buf);
    fprintf(f,
            ",\"room\":{\"room_height_m\":%g,\"camera_height_m\":%g,\"half_width_m\":%g,"
            "\"half_depth_m\":%g}",
            p->room.room_height, p->room.camera_height, p->room.half_width, p->room.half_depth);
    fprintf(f,
            ",\"extract\":{\"peak\":%.6g,\"total_energy\":%.6g,\"candidates\":%d,"
            "\"energy_measure\":\"region sum of luminance x solid angle; fitted = lum(rgb) x "
            "2 pi sigma (1 - exp(-2/sigma)), sigma = s / 4pi\",\"lights\":[",
            info->peak, info->total_energy, info->n_candidates);
    for (int i = 0; i < L->n_lights; i++) {
        const pl_extract_light_info *li = &info->light[i];
        fprintf(f,
                "%s{\"region_energy\":%.6g,\"fitted_energy\":%.6g,\"peak\":%.6g,"
                "\"region_pixels\":%d,\"support_pixels\":%d}",
                i ? "," : "", li->region_energy, li->fitted_energy, li->peak, li->region_pixels,
                li->support_pixels);
    }
    fputc(']', f);
    if (timing)
        fprintf(f, ",\"timing_ms\":{\"detect\":%.3f,\"refine\":%.3f,\"total\":%.3f}",
                info->ms_detect, info->ms_refine, info->ms_total);
    fputc('}', f);
    return 0;
}
