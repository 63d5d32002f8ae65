/* The per-frame JSON line (docs/OUTPUT.md), the one the CLI prints (include/parlight.h). */
#include <math.h>
#include <stdio.h>

#include "core/util.h"
#include "light/light.h"
#include "light/lights_json.h"

int pl_frame_format_json(const pl_frame_meta *m, const pl_lighting *L, char *buf, size_t cap)
{
    if (!m || !L || !buf || cap == 0)
        return pl_error(PL_E_ARG, "pl_frame_format_json: NULL argument");
    const char *source = m->source ? m->source : "";
    size_t n = 0;
    int w;
#define PUT(...)                                                                                   \
    do {                                                                                           \
        w = snprintf(buf + n, cap - n, __VA_ARGS__);                                               \
        if (w < 0 || (size_t)w >= cap - n) goto too_small;                                         \
        n += (size_t)w;                                                                            \
    } while (0)
    PUT("{\"frame\":%lld,\"t_ns\":%lld,\"source\":\"", (long long)m->frame, (long long)m->t_ns);
    for (const char *s = source; *s; s++) { /* JSON string escaping of the path */
        unsigned char ch = (unsigned char)*s;
        if (ch == '"' || ch == '\\')
            PUT("\\%c", ch);
        else if (ch < 0x20)
            PUT("\\u%04x", ch);
        else
            PUT("%c", ch);
    }
    if (m->orientation)
        PUT("\",\"space\":\"world\",\"orientation\":[%.6g,%.6g,%.6g,%.6g],", m->orientation[0],
            m->orientation[1], m->orientation[2], m->orientation[3]);
    else
        PUT("\",\"space\":\"camera\",");
    w = pl_lighting_format_json(L, buf + n, cap - n);
    if (w < 0) goto too_small;
    n += (size_t)w;
    float dir[3], rgb[3], sh[27];
    pl_lighting_primary(L, dir, rgb);
    pl_sh9_from_lights(L, sh);
    PUT(",\"primary\":{\"dir\":[%.6g,%.6g,%.6g],\"rgb\":[%.6g,%.6g,%.6g]},\"sh9\":[",
        (double)dir[0], (double)dir[1], (double)dir[2], (double)rgb[0], (double)rgb[1],
        (double)rgb[2]);
    for (int k = 0; k < 27; k++)
        PUT("%s%.6g", k ? "," : "", (double)sh[k]);
    pl_engine_lighting E;
    pl_lighting_engine(L, &E);
    PUT("],\"engine\":{\"dir\":[%.6g,%.6g,%.6g],\"intensity\":[%.6g,%.6g,%.6g],\"sh9\":[",
        (double)E.dir[0], (double)E.dir[1], (double)E.dir[2], (double)E.intensity[0],
        (double)E.intensity[1], (double)E.intensity[2]);
    for (int k = 0; k < 27; k++)
        PUT("%s%.6g", k ? "," : "", (double)E.sh9[k]);
    PUT("]},\"timing_ms\":{\"preprocess\":%.3f,\"infer\":%.3f,\"total\":%.3f",
        m->timing.preprocess_ms, m->timing.infer_ms, m->total_ms);
    if (m->latency_ms >= 0) PUT(",\"latency\":%.3f", m->latency_ms);
    PUT("},\"dropped\":%lld}\n", (long long)m->dropped);
#undef PUT
    return (int)n;
too_small:
    return pl_error(PL_E_ARG, "pl_frame_format_json: the line does not fit in %zu bytes", cap);
}

int pl_frame_format_json_key(const pl_frame_meta *m, const pl_lighting *L, const pl_key_light *key,
                             char *buf, size_t cap)
{
    if (!key) return pl_error(PL_E_ARG, "pl_frame_format_json_key: NULL key");
    if (key->views < 0 || !isfinite(key->dir[0]) || !isfinite(key->dir[1]) ||
        !isfinite(key->dir[2]))
        return pl_error(PL_E_ARG, "pl_frame_format_json_key: the key light is not finite or its "
                                  "views are negative");
    int len = pl_frame_format_json(m, L, buf, cap);
    if (len < 0) return len;
    /* "key_light" goes last: over the closing "}\n" */
    size_t at = (size_t)len - 2, room = cap - at;
    int w;
    if (key->views > 0)
        w = snprintf(buf + at, room, ",\"key_light\":{\"dir\":[%.6g,%.6g,%.6g],\"views\":%d}}\n",
                     (double)key->dir[0], (double)key->dir[1], (double)key->dir[2], key->views);
    else
        w = snprintf(buf + at, room, ",\"key_light\":null}\n");
    if (w < 0 || (size_t)w >= room)
        return pl_error(PL_E_ARG, "pl_frame_format_json_key: the line does not fit in %zu bytes",
                        cap);
    return (int)(at + (size_t)w);
}
