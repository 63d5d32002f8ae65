/* parlight estimate: lights from image files, videos or directories of frames, one JSON object
 * per frame on stdout (docs/OUTPUT.md). Warnings and the closing summary go to stderr. */
#include <getopt.h>
#include <math.h>
#include <signal.h>
#include <time.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "app/cli.h"
#include "app/commands.h"
#include "core/util.h"
#include "light/light.h"
#include "light/lights_json.h"
#include "light/temporal.h"
#include "parlight.h"
#include "port/capture.h"
#include "port/sink.h"
#include "port/source.h"

static void help(FILE *f)
{
    fprintf(
        f,
        "usage: parlight estimate --model M.plm (--input PATH | --camera SPEC) [--n-frames K]\n"
        "                         [--threads N] [--at X,Y,Z] [--smooth ALPHA] [--out SPEC]...\n"
        "                         [--realtime] [--fps-cap F] [--anchor off|W,B[,GAMMA]]\n\n"
        "Estimates N lights and the ambient term for every frame of PATH: a still image\n"
        "(JPEG, PNG, BMP, TIFF), a video file, or a directory of frames (read in name order;\n"
        "unreadable files are skipped with a warning and counted). Prints one JSON object per\n"
        "frame on stdout (schema: docs/OUTPUT.md).\n\n"
        "  --model M.plm   model file (see parlight info)\n"
        "  --input PATH    image, video or directory\n"
        "  --camera SPEC   a live camera instead: v4l2:/dev/videoN[:WxH[@FPS][:FORMAT]],\n"
        "                  FORMAT yuyv|nv12|rgb24|mjpeg (see parlight cameras, docs/CAMERAS.md)\n"
        "                  or libcamera[:ID|N] (libcamera's first, N-th or named camera)\n"
        "  --n-frames K    stop after K frames (default: all)\n"
        "  --threads N     worker threads, 1..64 (default 1); results do not depend on N\n"
        "  --at X,Y,Z      report the lighting seen from this point (metres, camera frame)\n"
        "                  instead of from the camera\n"
        "  --smooth ALPHA  temporal filter, weight of the newest frame in (0, 1]: lights keep\n"
        "                  their identity across frames and fade in and out; 1 = off.\n"
        "                  Default: 0.5 for --camera, off for --input (files are often unrelated)\n"
        "  --out SPEC      where the JSON lines go, repeatable (up to 8): stdout (default),\n"
        "                  udp://HOST:PORT, tcp://[HOST]:PORT (a server, loopback unless HOST\n"
        "                  is given), unix:PATH (docs/OUTPUT.md, \"Streaming\")\n"
        "  --realtime      replay a video at its own frame rate through the live pipeline:\n"
        "                  frames that arrive while the network is busy are dropped and\n"
        "                  counted in \"dropped\" (cameras always run this way)\n"
        "  --fps-cap F     estimate at most F frames per second (live: the newest frame wins)\n"
        "  --anchor A      intensity anchor instead of the model's own (parlight info):\n"
        "                  scales the lighting by 2^(W ev + B), ev = log2(the frame's mean\n"
        "                  luminance over the lighting's); off: the network's intensity\n"
        "                  (docs/LIGHTING.md, \"Intensity anchor\")\n"
        "  --max-pixels N  images of up to N pixels (default 67108864 = 64 Mi; at most\n"
        "                  268435456): larger files are refused before decoding\n\n"
        "SIGINT or SIGTERM finishes the frame in flight, flushes the outputs and exits 0.\n");
}

static volatile sig_atomic_t stop_requested;

static void on_stop_signal(int sig)
{
    (void)sig;
    stop_requested = 1;
}

/* Sleeps until the monotonic time `until_ns`, waking early on a stop request. */
static void wait_until(int64_t until_ns)
{
    while (!stop_requested) {
        int64_t left = until_ns - pl_now_ns();
        if (left <= 0) return;
        struct timespec ts = {0, (long)(left < 50000000 ? left : 50000000)};
        nanosleep(&ts, NULL);
    }
}

static int finite_lighting(const pl_lighting *L)
{
    for (int i = 0; i < L->n_lights; i++) {
        const pl_light *l = &L->lights[i];
        const float v[8] = {l->dir[0],         l->dir[1], l->dir[2], l->distance_m,
                            l->solid_angle_sr, l->rgb[0], l->rgb[1], l->rgb[2]};
        for (int k = 0; k < 8; k++)
            if (!isfinite(v[k])) return 0;
    }
    return isfinite(L->ambient[0]) && isfinite(L->ambient[1]) && isfinite(L->ambient[2]);
}

/* Writes one JSON line for a frame; returns 0, or -1 when the line does not fit (a bug). */
static int format_line(char *buf, size_t cap, int64_t frame, int64_t t_ns, const char *source,
                       const pl_lighting *L, const pl_timing *tm, double total_ms,
                       double latency_ms, int64_t dropped)
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
        if (ch == '"' || ch == '\\')
            PUT("\\%c", ch);
        else if (ch < 0x20)
            PUT("\\u%04x", ch);
        else
            PUT("%c", ch);
    }
    PUT("\",");
    w = pl_lighting_format_json(L, buf + n, cap - n);
    if (w < 0) return -1;
    n += (size_t)w;
    float dir[3], rgb[3], sh[27];
    pl_lighting_primary(L, dir, rgb);
    pl_sh9_from_lights(L, sh);
    PUT(",\"primary\":{\"dir\":[%.6g,%.6g,%.6g],\"rgb\":[%.6g,%.6g,%.6g]},\"sh9\":[",
        (double)dir[0], (double)dir[1], (double)dir[2], (double)rgb[0], (double)rgb[1],
        (double)rgb[2]);
    for (int k = 0; k < 27; k++)
        PUT("%s%.6g", k ? "," : "", (double)sh[k]);
    PUT("],\"timing_ms\":{\"preprocess\":%.3f,\"infer\":%.3f,\"total\":%.3f", tm->preprocess_ms,
        tm->infer_ms, total_ms);
    if (latency_ms >= 0) PUT(",\"latency\":%.3f", latency_ms);
    PUT("},\"dropped\":%lld}\n", (long long)dropped);
#undef PUT
    return 0;
}

int cmd_estimate(int argc, char **argv)
{
    static const struct option opts[] = {{"model", required_argument, 0, 'm'},
                                         {"input", required_argument, 0, 'i'},
                                         {"camera", required_argument, 0, 'C'},
                                         {"n-frames", required_argument, 0, 'n'},
                                         {"threads", required_argument, 0, 't'},
                                         {"at", required_argument, 0, 'a'},
                                         {"smooth", required_argument, 0, 's'},
                                         {"out", required_argument, 0, 'o'},
                                         {"realtime", no_argument, 0, 'r'},
                                         {"fps-cap", required_argument, 0, 'f'},
                                         {"anchor", required_argument, 0, 'A'},
                                         {"max-pixels", required_argument, 0, CLI_OPT_MAX_PIXELS},
                                         {"help", no_argument, 0, 'h'},
                                         {0, 0, 0, 0}};
    const char *model_path = NULL, *input = NULL, *camera = NULL;
    int n_frames = 0, threads = 1, have_at = 0, c;
    float at[3] = {0, 0, 0}, alpha = -1.0f;
    double fps_cap = 0.0;
    int realtime = 0, have_anchor = 0;
    double anchor[3];
    const char *outs[PL_SINKS_MAX];
    int n_outs = 0;
    opterr = 0;
    while ((c = getopt_long(argc, argv, ":m:i:C:n:t:a:s:o:rf:A:h", opts, NULL)) != -1) {
        switch (c) {
        case 'm':
            model_path = optarg;
            break;
        case 'i':
            input = optarg;
            break;
        case 'C':
            camera = optarg;
            break;
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
        case 's': {
            double v;
            if (cli_double("estimate", "--smooth", optarg, 0, 1, 1, &v) < 0) return 2;
            alpha = (float)v;
            break;
        }
        case 'r':
            realtime = 1;
            break;
        case 'A':
            if (cli_anchor("estimate", optarg, anchor) < 0) return 2;
            have_anchor = 1;
            break;
        case 'f': {
            char *end;
            fps_cap = strtod(optarg, &end);
            if (end == optarg || *end || !(fps_cap > 0.0 && fps_cap <= 1000.0)) {
                fprintf(stderr,
                        "parlight estimate: --fps-cap '%s': expected frames per second "
                        "in (0, 1000]\n",
                        optarg);
                return 2;
            }
            break;
        }
        case 'o':
            if (n_outs == PL_SINKS_MAX) {
                fprintf(stderr, "parlight estimate: at most %d --out\n", PL_SINKS_MAX);
                return 2;
            }
            outs[n_outs++] = optarg;
            break;
        case CLI_OPT_MAX_PIXELS:
            if (cli_max_pixels("estimate", optarg) < 0) return 2;
            break;
        case 'h':
            help(stdout);
            return 0;
        default:
            return cli_getopt_error("estimate", c, argv);
        }
    }
    if (optind < argc) {
        fprintf(stderr, "parlight estimate: unexpected argument '%s'\n", argv[optind]);
        return 2;
    }
    if (!model_path || (!input && !camera)) {
        fprintf(stderr, "parlight estimate: %s is required (see --help)\n",
                !model_path ? "--model" : "--input or --camera");
        return 2;
    }
    if (input && camera) {
        fprintf(stderr, "parlight estimate: --input and --camera exclude each other\n");
        return 2;
    }

    pl_model *model = NULL;
    pl_source *src = NULL;
    pl_sinks *sinks = NULL;
    pl_capture *cap = NULL;
    pl_smoother smoother;
    int rc = 1;
    if (alpha < 0) alpha = camera ? PL_SMOOTH_DEFAULT_ALPHA : 1.0f;
    if (pl_smoother_init(&smoother, alpha) < 0) {
        fprintf(stderr, "parlight estimate: --smooth: %s\n", pl_last_error());
        return 2;
    }
    int st_open = pl_sinks_open(outs, n_outs, &sinks);
    if (st_open < 0) {
        fprintf(stderr, "parlight estimate: %s\n", pl_last_error());
        return st_open == PL_E_ARG ? 2 : 1;
    }
    if (pl_model_load(model_path, &model) < 0 || pl_model_set_threads(model, threads) < 0 ||
        (have_anchor && pl_model_set_anchor(model, anchor[0], anchor[1], anchor[2]) < 0)) {
        fprintf(stderr, "parlight estimate: %s\n", pl_last_error());
        goto out;
    }
    if ((camera ? pl_source_open_camera(camera, &src) : pl_source_open_path(input, &src)) < 0) {
        fprintf(stderr, "parlight estimate: %s\n", pl_last_error());
        goto out;
    }
    /* cameras and --realtime replays run capture on its own thread (port/capture.h): the
     * newest frame wins and the ones replaced unseen are counted in "dropped" */
    if ((camera || realtime) && pl_capture_start(src, realtime, &cap) < 0) {
        fprintf(stderr, "parlight estimate: %s\n", pl_last_error());
        goto out;
    }
    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_stop_signal; /* no SA_RESTART: a blocking read returns EINTR */
    sigemptyset(&sa.sa_mask);
    sigaction(SIGINT, &sa, NULL);
    sigaction(SIGTERM, &sa, NULL);

    long long done = 0, skipped = 0;
    int64_t prev_t_ns = 0, last_start = 0;
    char line[16384], source[4096], event[512];
    for (;;) {
        if (n_frames && done >= n_frames) break;
        if (fps_cap > 0 && done) wait_until(last_start + (int64_t)(1e9 / fps_cap));
        if (stop_requested) break;
        pl_frame fr;
        int64_t dropped = 0;
        int st;
        if (cap) {
            st = pl_capture_take(cap, &fr, &dropped, 100);
            if (st == PL_CAPTURE_AGAIN) continue;
        } else {
            st = pl_source_read(src, &fr);
        }
        const int64_t t0 = pl_now_ns();
        last_start = t0;
        if (st == PL_E_EOF && camera) { /* a camera only ends when it is lost for good */
            fprintf(stderr, "parlight estimate: %s\n", pl_last_error());
            goto out;
        }
        if (st == PL_E_EOF) break;
        if (st < 0) { /* one bad frame (a corrupt file in a directory): skipped and counted */
            fprintf(stderr, "parlight estimate: warning: skipping frame: %s\n", pl_last_error());
            skipped++;
            continue;
        }
        pl_lighting L;
        pl_timing tm;
        /* the filter's clock: the frames' own timestamps when they advance sensibly, else a
         * nominal 30 fps (files: modification times say nothing about the frame interval) */
        double dt_s = done ? (double)(fr.t_ns - prev_t_ns) / 1e9 : 0.0;
        if (done && !(dt_s > 0.0 && dt_s <= 10.0)) dt_s = 1.0 / 30.0;
        prev_t_ns = fr.t_ns;
        if (pl_estimate_rgb8(model, fr.image.data, fr.image.width, fr.image.height, fr.image.stride,
                             &L, &tm) < 0 ||
            pl_smoother_update(&smoother, &L, dt_s, &L) < 0 ||
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
        /* cameras stamp frames with CLOCK_MONOTONIC, pl_now_ns's clock: capture to this line */
        const double latency_ms = camera ? (double)(pl_now_ns() - fr.t_ns) / 1e6 : -1.0;
        if (format_line(line, sizeof line, fr.index, fr.t_ns, source, &L, &tm, total_ms, latency_ms,
                        dropped) < 0) {
            fprintf(stderr, "parlight estimate: internal error: JSON line too long\n");
            goto out;
        }
        if (pl_sinks_write(sinks, line, strlen(line)) < 0) {
            if (n_outs == 0) { /* stdout alone: its reader is gone, nobody is listening */
                fprintf(stderr, "parlight estimate: %s\n", pl_last_error());
                goto out;
            }
            fprintf(stderr, "parlight estimate: warning: %s\n", pl_last_error());
        }
        while (pl_sinks_next_event(sinks, event, sizeof event))
            fprintf(stderr, "parlight estimate: %s\n", event);
        done++;
    }
    if (cap) {
        char last[512];
        const int64_t bad = pl_capture_bad_frames(cap, last, sizeof last);
        if (bad)
            fprintf(stderr, "parlight estimate: warning: %lld bad frame%s skipped, the last: %s\n",
                    (long long)bad, bad == 1 ? "" : "s", last);
        skipped += bad;
    }
    if (stop_requested) {
        fprintf(stderr, "parlight estimate: stopped by a signal after %lld frame%s\n", done,
                done == 1 ? "" : "s");
        rc = 0;
        goto out;
    }
    if (skipped || done == 0)
        fprintf(stderr, "parlight estimate: %lld frame%s estimated, %lld skipped\n", done,
                done == 1 ? "" : "s", skipped);
    if (done == 0) {
        fprintf(stderr, "parlight estimate: no usable frame in %s\n", camera ? camera : input);
        goto out;
    }
    rc = 0;
out:
    pl_capture_stop(cap);
    pl_sinks_close(sinks);
    pl_source_close(src);
    pl_model_free(model);
    return rc;
}
