/* parlight estimate: lights from image files, videos or directories of frames, one JSON object
 * per frame on stdout (docs/OUTPUT.md). Warnings and the closing summary go to stderr. */
#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "app/cli.h"
#include "app/commands.h"
#include "light/light.h"
#include "light/lights_json.h"
#include "parlight.h"
#include "port/source.h"
#include "port/util.h"

static void help(FILE *f)
{
    fprintf(f,
            "usage: parlight estimate --model M.plm --input PATH [--n-frames K] [--threads N]\n"
            "                         [--at X,Y,Z]\n\n"
            "Estimates N lights and the ambient term for every frame of PATH: a still image\n"
            "(JPEG, PNG, BMP, TIFF), a video file, or a directory of frames (read in name order;\n"
            "unreadable files are skipped with a warning and counted). Prints one JSON object per\n"
            "frame on stdout (schema: docs/OUTPUT.md).\n\n"
            "  --model M.plm   model file (see parlight info)\n"
            "  --input PATH    image, video or directory\n"
            "  --n-frames K    stop after K frames (default: all)\n"
            "  --threads N     worker threads, 1..64 (default 1); results do not depend on N\n"
            "  --at X,Y,Z      report the lighting seen from this point (metres, camera frame)\n"
            "                  instead of from the camera\n");
}

static int finite_lighting(const pl_lighting *L)
{
    for (int i = 0; i < L->n_lights; i++) {
        const pl_light *l = &L->lights[i];
        const float v[8] = {l->dir[0], l->dir[1], l->dir[2], l->distance_m,
                            l->solid_angle_sr, l->rgb[0], l->rgb[1], l->rgb[2]};
        for (int k = 0; k < 8; k++)
            if (!isfinite(v[k])) return 0;
    }
    return isfinite(L->ambient[0]) && isfinite(L->ambient[1]) && isfinite(L->ambient[2]);
}

/* Writes one JSON line for a frame; returns 0, or -1 when the line does not fit (a bug). */
static int format_line(char *buf, size_t cap, int64_t frame, int64_t t_ns, const char *source,
                       const pl_lighting *L, const pl_timing *tm, double total_ms)
{
    size_t n = 0;
    int w;
#define PUT(...)                                                                                   \
    do {                                                                                           \
        w = snprintf(buf + n, cap - n, __VA_ARGS__);                                               \
        if (w < 0 || (size_t)w >= cap - n) return -1;                                              \
        n += (size_t)w;                                                                            \
    } while (0)
    PUT("{\"frame\":%lld,\"t_ns\":%lld,\"source\":\"", (long long)frame, (long long)t_ns);
    for (const char *s = source; *s; s++) { /* JSON string escaping of the path */
        unsigned char ch = (unsigned char)*s;
        if (ch == '"' || ch == '\\') PUT("\\%c", ch);
        else if (ch < 0x20) PUT("\\u%04x", ch);
        else PUT("%c", ch);
    }
    PUT("\",");
    w = pl_lighting_format_json(L, buf + n, cap - n);
    if (w < 0) return -1;
    n += (size_t)w;
    float dir[3], rgb[3], sh[27];
    pl_lighting_primary(L, dir, rgb);
    pl_sh9_from_lights(L, sh);
    PUT(",\"primary\":{\"dir\":[%.6g,%.6g,%.6g],\"rgb\":[%.6g,%.6g,%.6g]},\"sh9\":[", (double)dir[0],
        (double)dir[1], (double)dir[2], (double)rgb[0], (double)rgb[1], (double)rgb[2]);
    for (int k = 0; k < 27; k++) PUT("%s%.6g", k ? "," : "", (double)sh[k]);
    PUT("],\"timing_ms\":{\"preprocess\":%.3f,\"infer\":%.3f,\"total\":%.3f},\"dropped\":0}\n",
        tm->preprocess_ms, tm->infer_ms, total_ms);
#undef PUT
    return 0;
}

int cmd_estimate(int argc, char **argv)
{
    static const struct option opts[] = {{"model", required_argument, 0, 'm'},
                                         {"input", required_argument, 0, 'i'},
                                         {"n-frames", required_argument, 0, 'n'},
                                         {"threads", required_argument, 0, 't'},
                                         {"at", required_argument, 0, 'a'},
                                         {"help", no_argument, 0, 'h'},
                                         {0, 0, 0, 0}};
    const char *model_path = NULL, *input = NULL;
    int n_frames = 0, threads = 1, have_at = 0, c;
    float at[3] = {0, 0, 0};
    opterr = 0;
    while ((c = getopt_long(argc, argv, ":m:i:n:t:a:h", opts, NULL)) != -1) {
        switch (c) {
        case 'm': model_path = optarg; break;
        case 'i': input = optarg; break;
        case 'n':
            if (cli_int("estimate", "--n-frames", optarg, 1, 1000000000, &n_frames) < 0) return 2;
            break;
        case 't':
            if (cli_int("estimate", "--threads", optarg, 1, 64, &threads) < 0) return 2;
            break;
        case 'a':
            if (cli_float3("estimate", "--at", optarg, at) < 0) return 2;
            have_at = 1;
            break;
        case 'h': help(stdout); return 0;
        case ':':
            fprintf(stderr, "parlight estimate: %s needs a value\n", argv[optind - 1]);
            return 2;
        default:
            fprintf(stderr, "parlight estimate: unknown option '%s' (see --help)\n",
                    argv[optind - 1]);
            return 2;
        }
    }
    if (optind < argc) {
        fprintf(stderr, "parlight estimate: unexpected argument '%s'\n", argv[optind]);
        return 2;
    }
    if (!model_path || !input) {
        fprintf(stderr, "parlight estimate: %s is required (see --help)\n",
                !model_path ? "--model" : "--input");
        return 2;
    }

    pl_model *model = NULL;
    pl_source *src = NULL;
    int rc = 1;
    if (pl_model_load(model_path, &model) < 0 || pl_model_set_threads(model, threads) < 0) {
        fprintf(stderr, "parlight estimate: %s\n", pl_last_error());
        goto out;
    }
    if (pl_source_open_path(input, &src) < 0) {
        fprintf(stderr, "parlight estimate: %s\n", pl_last_error());
        goto out;
    }
    long long done = 0, skipped = 0;
    char line[16384], source[4096];
    for (;;) {
        if (n_frames && done >= n_frames) break;
        pl_frame fr;
        const int64_t t0 = pl_now_ns();
        int st = pl_source_read(src, &fr);
        if (st == PL_E_EOF) break;
        if (st < 0) { /* one bad frame (a corrupt file in a directory): skipped and counted */
            fprintf(stderr, "parlight estimate: warning: skipping frame: %s\n", pl_last_error());
            skipped++;
            continue;
        }
        pl_lighting L;
        pl_timing tm;
        if (pl_estimate_rgb8(model, fr.image.data, fr.image.width, fr.image.height,
                             fr.image.stride, &L, &tm) < 0 ||
            (have_at && pl_lighting_at_point(&L, at, &L) < 0)) {
            fprintf(stderr, "parlight estimate: %s: %s\n", fr.name, pl_last_error());
            goto out;
        }
        if (!finite_lighting(&L)) {
            fprintf(stderr, "parlight estimate: %s: the model produced a non-finite value\n",
                    fr.name);
            goto out;
        }
        const double total_ms = (double)(pl_now_ns() - t0) / 1e6;
        const char *desc = pl_source_describe(src);
        if (!strncmp(desc, "dir:", 4))
            snprintf(source, sizeof source, "%s/%s", desc, fr.name);
        else
            snprintf(source, sizeof source, "%s", desc);
        if (format_line(line, sizeof line, fr.index, fr.t_ns, source, &L, &tm, total_ms) < 0) {
            fprintf(stderr, "parlight estimate: internal error: JSON line too long\n");
            goto out;
        }
        if (fputs(line, stdout) == EOF || fflush(stdout) == EOF) {
            fprintf(stderr, "parlight estimate: cannot write to stdout\n");
            goto out;
        }
        done++;
    }
    if (skipped || done == 0)
        fprintf(stderr, "parlight estimate: %lld frame%s estimated, %lld skipped\n", done,
                done == 1 ? "" : "s", skipped);
    if (done == 0) {
        fprintf(stderr, "parlight estimate: no usable frame in %s\n", input);
        goto out;
    }
    rc = 0;
out:
    pl_source_close(src);
    pl_model_free(model);
    return rc;
}
