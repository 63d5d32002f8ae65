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
#include "app/poses.h"
#include "app/thumb.h"
#include "core/ratelimit.h"
#include "core/util.h"
#include "light/fuse.h"
#include "light/light.h"
#include "light/lights_json.h"
#include "light/pose.h"
#include "light/temporal.h"
#include "parlight.h"
#include "port/capture.h"
#include "port/sink.h"
#include "port/source.h"

static void help(FILE *f)
{
    fprintf(f,
            "usage: parlight estimate --model M.plm (--input PATH | --camera SPEC) [--n-frames K]\n"
            "                         [--threads N] [--at X,Y,Z] [--smooth ALPHA] [--out SPEC]...\n"
            "                         [--realtime [--frame-interval MS]] [--fps-cap F]\n"
            "                         [--anchor off|W,B[,GAMMA]] [--www DIR] [--thumb W]\n"
            "                         [--loop] [--wait-clients N] [--max-clients N]\n"
            "                         [--unix-mode MODE] [--token-file F] [--max-pixels N]\n"
            "                         [--orientation W,X,Y,Z | --gravity X,Y,Z | --poses FILE]\n"
            "                         [--mqtt-qos 0|1] [--mqtt-id ID] [--mqtt-user U]\n"
            "                         [--mqtt-password-file F] [--mqtt-ca F [--mqtt-cert F --mqtt-key F]]\n\n"
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
            "                  is given), unix:PATH, ws://[HOST]:PORT[/PATH] (a WebSocket server\n"
            "                  for browsers: one text message per frame), mqtt://HOST:PORT/TOPIC\n"
            "                  (publishes each frame, retained, to TOPIC on a broker)\n"
            "                  (docs/OUTPUT.md, \"Streaming\")\n"
            "  --max-clients N readers at once per tcp/unix/ws server, 1..1024 (default 16);\n"
            "                  one more is told why and closed\n"
            "  --unix-mode MODE permission bits of unix: sockets, octal (default 600: owner only;\n"
            "                  660 adds the file's group)\n"
            "  --token-file F  tcp/unix readers must first send the token in F (its first line)\n"
            "                  and a newline, ws readers as their first message; F must not be\n"
            "                  readable by every user\n"
            "  --mqtt-qos Q    0 (default: at most once) or 1 (at least once, acknowledged)\n"
            "  --mqtt-id ID    MQTT client id (default parlight-PID)\n"
            "  --mqtt-user U   log in to the broker as U\n"
            "  --mqtt-password-file F  with --mqtt-user: the password, F's first line (F must\n"
            "                  not be readable by every user; a password never goes in argv)\n"
            "  --mqtt-ca F     TLS to the broker, whose certificate must chain to the CA(s) in F\n"
            "                  and name HOST; --mqtt-cert F --mqtt-key F: a client certificate\n"
            "  --realtime      replay a video at its own frame rate through the live pipeline:\n"
            "                  frames that arrive while the network is busy are dropped and\n"
            "                  counted in \"dropped\" (cameras always run this way); a\n"
            "                  directory or still image at one frame per --frame-interval\n"
            "  --frame-interval MS  with --realtime: milliseconds between the frames of a\n"
            "                  directory or still image, like a camera (default 33.3: 30 fps;\n"
            "                  up to 3600000); not for videos, which have their own rate\n"
            "  --fps-cap F     estimate at most F frames per second (live: the newest frame wins)\n"
            "  --orientation W,X,Y,Z  camera-to-world rotation (unit quaternion) of a fixed camera:\n"
            "                  lights, primary, sh9, engine and --at in world space\n"
            "  --gravity X,Y,Z gravity measured in the camera frame (an IMU): world space with y\n"
            "                  up, yaw following the camera\n"
            "  --poses FILE    a camera-to-world quaternion per frame, JSON lines keyed by \"frame\"\n"
            "                  or \"t_ns\" (docs/OUTPUT.md, \"World space\")\n"
            "  --fuse MAX_AGE  with --poses: add \"key_light\", the room's main light direction fused\n"
            "                  over the headings seen (world space), forgetting views older than\n"
            "                  MAX_AGE seconds (0: never) (docs/OUTPUT.md, \"Key light over views\")\n"
            "  --aim N         with --fuse: once the key light rests on N headings or more (1..24;\n"
            "                  3 or more measured to help), turn each frame's primary light to it;\n"
            "                  lights, primary, sh9 and engine follow (docs/OUTPUT.md, \"Aiming at\n"
            "                  the key light\")\n"
            "  --level N       with --fuse and an \"exposure\" on the --poses lines: once the room's\n"
            "                  level rests on N headings or more (1..24; 8 measured), bring each\n"
            "                  frame's intensity to it (docs/OUTPUT.md, \"Intensity over views\")\n"
            "  --loop          --input only: start again at the end (frame numbers go on), until\n"
            "                  --n-frames or a signal\n"
            "  --wait-clients N before the first frame, wait until N readers are connected to the\n"
            "                  tcp/unix/ws servers (a replay is not over before a viewer connects)\n"
            "  --www DIR       ws:// servers also serve the files under DIR over HTTP on the\n"
            "                  same port (the live viewer: parlight view, docs/VIEWER.md)\n"
            "  --thumb W       add the frame as a W-pixel-wide JPEG (16..320) to each line:\n"
            "                  \"thumb\":\"data:image/jpeg;base64,...\" (the viewer shows it)\n"
            "  --anchor A      intensity anchor instead of the model's own (parlight info):\n"
            "                  scales the lighting by 2^(W ev + B), ev = log2(the frame's mean\n"
            "                  luminance over the lighting's); off: the network's intensity\n"
            "                  (docs/LIGHTING.md, \"Intensity anchor\")\n"
            "  --max-pixels N  images of up to N pixels (default 67108864 = 64 Mi; at most\n"
            "                  268435456): larger files are refused before decoding\n\n"
            "SIGINT or SIGTERM finishes the frame in flight (if any), flushes the outputs,\n"
            "removes a unix: socket and exits 0, also when it comes during start-up.\n"
            "SIGHUP reloads the model from the same path between two frames; a file that does\n"
            "not load leaves the current model running (docs/OUTPUT.md, \"Signals\").\n");
}

static volatile sig_atomic_t stop_requested, reload_requested;

static void on_signal(int sig)
{
    if (sig == SIGHUP)
        reload_requested = 1;
    else
        stop_requested = 1;
}

/* SIGINT and SIGTERM ask the loop to stop, SIGHUP to reload the model; the handlers only set a
 * flag, so they can be installed before anything else and the work happens between frames. */
static void install_signals(void)
{
    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_signal; /* no SA_RESTART: a blocking read returns EINTR */
    sigemptyset(&sa.sa_mask);
    sigaction(SIGINT, &sa, NULL);
    sigaction(SIGTERM, &sa, NULL);
    sigaction(SIGHUP, &sa, NULL);
}

/* Loads the model at `path` with the run's settings; on failure pl_last_error() says why and
 * *out is NULL. */
static int load_model(const char *path, int threads, const double *anchor, pl_model **out)
{
    int rc = pl_model_load(path, out);
    if (rc == PL_OK) rc = pl_model_set_threads(*out, threads);
    if (rc == PL_OK && anchor) rc = pl_model_set_anchor(*out, anchor[0], anchor[1], anchor[2]);
    if (rc < 0) {
        pl_model_free(*out);
        *out = NULL;
    }
    return rc;
}

/* SIGHUP: the model is loaded anew from `path` (a new file renamed over it, or the same file),
 * verified, and replaces *model; the temporal filter starts again, as the new model's lights
 * have nothing to do with the old ones. A file that does not load leaves *model as it was. */
static void reload_model(const char *path, int threads, const double *anchor, float alpha,
                         pl_model **model, pl_smoother *smoother)
{
    pl_model *fresh;
    if (load_model(path, threads, anchor, &fresh) < 0) {
        fprintf(stderr, "parlight estimate: SIGHUP: keeping the current model: %s\n",
                pl_last_error());
        return;
    }
    pl_model_free(*model);
    *model = fresh;
    pl_smoother_init(smoother, alpha);
    fprintf(stderr, "parlight estimate: SIGHUP: model reloaded from %s\n", path);
}

/* Sleeps until the monotonic time `until_ns`, waking early on a stop request, and services the
 * servers every 20 ms meanwhile (a viewer page loading from --www, readers connecting). */
static void wait_until(int64_t until_ns, pl_sinks *sinks)
{
    while (!stop_requested) {
        pl_sinks_service(sinks);
        int64_t left = until_ns - pl_now_ns();
        if (left <= 0) return;
        struct timespec ts = {0, (long)(left < 20000000 ? left : 20000000)};
        nanosleep(&ts, NULL);
    }
}

/* Sink warnings and events: LOG_BURST lines per LOG_WINDOW_NS of each kind, then a count. */
#define LOG_BURST 5
#define LOG_WINDOW_NS 10000000000LL

static void log_held(pl_ratelimit *r, const char *what)
{
    long long held = pl_ratelimit_take_held(r);
    if (held)
        fprintf(stderr, "parlight estimate: %lld more %s like the above not shown\n", held, what);
}

static void log_limited(pl_ratelimit *r, const char *prefix, const char *msg)
{
    long long held;
    int show = pl_ratelimit_allow(r, pl_now_ns(), &held);
    if (held)
        fprintf(stderr, "parlight estimate: %lld more like the above in the last %lld s not shown\n",
                held, (long long)(r->window_ns / 1000000000LL));
    if (show) fprintf(stderr, "parlight estimate: %s%s\n", prefix, msg);
}

/* --wait-clients: services the servers until n readers are admitted. -1 if a signal came. */
static int wait_for_readers(pl_sinks *sinks, int n, pl_ratelimit *event_limit)
{
    fprintf(stderr, "parlight estimate: waiting for %d reader%s before the first frame\n", n,
            n == 1 ? "" : "s");
    char event[512];
    for (;;) {
        int have = pl_sinks_service(sinks);
        while (pl_sinks_next_event(sinks, event, sizeof event))
            log_limited(event_limit, "", event);
        if (have >= n) return 0;
        if (stop_requested) return -1;
        struct timespec ts = {0, 20000000};
        nanosleep(&ts, NULL);
    }
}

/* --thumb: the frame's line with "thumb" added before its closing brace; *out grows to
 * THUMB_LINE_MAX once. A line that would be longer (a very detailed frame) goes without it. */
#define THUMB_LINE_MAX 60000
static int add_thumb(app_thumb *t, const pl_image_u8 *frame, int width, const char *line,
                     char **out)
{
    const char *url;
    int rc = app_thumb_make(t, frame, width, &url);
    if (rc < 0) return rc;
    size_t n = strlen(line), u = strlen(url);
    if (n < 2 || line[n - 2] != '}' || line[n - 1] != '\n')
        return pl_error(PL_E_ARG, "internal error: a line that does not end in \"}\\n\"");
    if (n + u + 16 > THUMB_LINE_MAX)
        return pl_error(PL_E_ARG, "the line would be %zu bytes, more than %d", n + u + 12,
                        THUMB_LINE_MAX);
    if (!*out && !(*out = malloc(THUMB_LINE_MAX)))
        return pl_error(PL_E_NOMEM, "out of memory for the thumbnail line");
    snprintf(*out, THUMB_LINE_MAX, "%.*s,\"thumb\":\"%s\"}\n", (int)(n - 2), line, url);
    return 0;
}

/* --realtime without --frame-interval on a directory or still image: 30 fps, a camera's rate. */
#define PL_DEFAULT_FRAME_INTERVAL_NS 33333333LL

static int start_capture(pl_source *src, int realtime, int64_t interval_ns, pl_capture **cap)
{
    return interval_ns ? pl_capture_start_paced(src, interval_ns, cap)
                       : pl_capture_start(src, realtime, cap);
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
                                         {"max-clients", required_argument, 0, 'M'},
                                         {"unix-mode", required_argument, 0, 'U'},
                                         {"token-file", required_argument, 0, 'T'},
                                         {"loop", no_argument, 0, 'L'},
                                         {"orientation", required_argument, 0, 'O'},
                                         {"gravity", required_argument, 0, 'G'},
                                         {"poses", required_argument, 0, 'P'},
                                         {"wait-clients", required_argument, 0, 'W'},
                                         {"frame-interval", required_argument, 0, 1008},
                                         {"www", required_argument, 0, 1009},
                                         {"thumb", required_argument, 0, 1010},
                                         {"fuse", required_argument, 0, 1011},
                                         {"aim", required_argument, 0, 1012},
                                         {"level", required_argument, 0, 1013},
                                         {"max-pixels", required_argument, 0, CLI_OPT_MAX_PIXELS},
                                         {"mqtt-qos", required_argument, 0, 1001},
                                         {"mqtt-id", required_argument, 0, 1002},
                                         {"mqtt-user", required_argument, 0, 1003},
                                         {"mqtt-password-file", required_argument, 0, 1004},
                                         {"mqtt-ca", required_argument, 0, 1005},
                                         {"mqtt-cert", required_argument, 0, 1006},
                                         {"mqtt-key", required_argument, 0, 1007},
                                         {"help", no_argument, 0, 'h'},
                                         {0, 0, 0, 0}};
    const char *model_path = NULL, *input = NULL, *camera = NULL;
    int n_frames = 0, threads = 1, have_at = 0, c;
    float at[3] = {0, 0, 0}, alpha = -1.0f;
    double fps_cap = 0.0;
    int realtime = 0, have_anchor = 0, loop = 0, wait_clients = 0;
    int64_t interval_ns = 0; /* --frame-interval; 0: not given */
    int thumb_w = 0;         /* --thumb; 0: none */
    app_thumb thumb = {0};
    char *thumb_line = NULL; /* the line with its "thumb" field */
    int have_orient = 0, n_pose_flags = 0;
    double fuse_age = -1; /* --fuse MAX_AGE; < 0: not given */
    int aim_views = 0;    /* --aim N; 0: not given */
    int level_views = 0;  /* --level N; 0: not given */
    double fixed_q[4], fixed_R[9];
    const char *poses_path = NULL;
    cli_poses poses = {0};
    double anchor[3];
    const char *outs[PL_SINKS_MAX];
    int n_outs = 0;
    pl_sink_options sink_opts = {0};
    const char *token_file = NULL, *password_file = NULL;
    char token[PL_SINK_TOKEN_MAX + 1], password[PL_SINK_TOKEN_MAX + 1];
    install_signals(); /* first: a service may be stopped while it loads (issue 25) */
    opterr = 0;
    while ((c = getopt_long(argc, argv, ":m:i:C:n:t:a:s:o:rf:A:M:U:T:LW:O:G:P:h", opts, NULL)) != -1) {
        switch (c) {
        case 'm': model_path = optarg; break;
        case 'i': input = optarg; break;
        case 'C': camera = optarg; break;
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
        case 'r': realtime = 1; break;
        case 'A':
            if (cli_anchor("estimate", optarg, anchor) < 0) return 2;
            have_anchor = 1;
            break;
        case 'f': {
            char *end;
            fps_cap = strtod(optarg, &end);
            if (end == optarg || *end || !(fps_cap > 0.0 && fps_cap <= 1000.0)) {
                fprintf(stderr, "parlight estimate: --fps-cap '%s': expected frames per second "
                                "in (0, 1000]\n", optarg);
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
        case 'M':
            if (cli_int("estimate", "--max-clients", optarg, 1, PL_SINK_CLIENTS_LIMIT,
                        &sink_opts.max_clients) < 0)
                return 2;
            break;
        case 'U': {
            char *end;
            unsigned long m = strtoul(optarg, &end, 8);
            if (end == optarg || *end || m > 0777 || !(m & 0200)) {
                fprintf(stderr, "parlight estimate: --unix-mode '%s': expected octal permission "
                                "bits with the owner's write bit (600, 660, 666)\n", optarg);
                return 2;
            }
            sink_opts.unix_mode = (unsigned)m;
            break;
        }
        case 'T': token_file = optarg; break;
        case 'L': loop = 1; break;
        case 'O':
            if (cli_quat("estimate", optarg, fixed_q) < 0) return 2;
            have_orient = 1;
            n_pose_flags++;
            break;
        case 'G': {
            float g[3];
            if (cli_float3("estimate", "--gravity", optarg, g) < 0) return 2;
            if (pl_rotation_from_gravity(g, fixed_R, fixed_q) < 0) {
                fprintf(stderr, "parlight estimate: --gravity: %s\n", pl_last_error());
                return 2;
            }
            have_orient = 1;
            n_pose_flags++;
            break;
        }
        case 'P':
            poses_path = optarg;
            n_pose_flags++;
            break;
        case 1011:
            if (cli_double("estimate", "--fuse", optarg, 0, 1e9, 0, &fuse_age) < 0) return 2;
            break;
        case 1012:
            if (cli_int("estimate", "--aim", optarg, 1, PL_FUSE_BINS, &aim_views) < 0) return 2;
            break;
        case 1013:
            if (cli_int("estimate", "--level", optarg, 1, PL_FUSE_BINS, &level_views) < 0)
                return 2;
            break;
        case 'W':
            if (cli_int("estimate", "--wait-clients", optarg, 1, PL_SINK_CLIENTS_LIMIT,
                        &wait_clients) < 0)
                return 2;
            break;
        case CLI_OPT_MAX_PIXELS:
            if (cli_max_pixels("estimate", optarg) < 0) return 2;
            break;
        case 1001:
            if (cli_int("estimate", "--mqtt-qos", optarg, 0, 1, &sink_opts.mqtt_qos) < 0) return 2;
            break;
        case 1002:
            sink_opts.mqtt_client_id = optarg;
            break;
        case 1003:
            sink_opts.mqtt_username = optarg;
            break;
        case 1004:
            password_file = optarg;
            break;
        case 1005:
            sink_opts.mqtt_ca_file = optarg;
            break;
        case 1006:
            sink_opts.mqtt_cert_file = optarg;
            break;
        case 1007:
            sink_opts.mqtt_key_file = optarg;
            break;
        case 1008: {
            double ms;
            if (cli_double("estimate", "--frame-interval", optarg, 0, 3600000, 1, &ms) < 0)
                return 2;
            interval_ns = (int64_t)(ms * 1e6 + 0.5);
            if (interval_ns <= 0) {
                fprintf(stderr, "parlight estimate: --frame-interval '%s': expected milliseconds "
                                "in (0, 3600000]\n", optarg);
                return 2;
            }
            break;
        }
        case 1009:
            sink_opts.www_dir = optarg;
            break;
        case 1010:
            if (cli_int("estimate", "--thumb", optarg, APP_THUMB_MIN_WIDTH, APP_THUMB_MAX_WIDTH,
                        &thumb_w) < 0)
                return 2;
            break;
        case 'h': help(stdout); return 0;
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
    if (n_pose_flags > 1) {
        fprintf(stderr, "parlight estimate: --orientation, --gravity and --poses exclude each "
                        "other\n");
        return 2;
    }
    if (fuse_age >= 0 && !poses_path) {
        fprintf(stderr, "parlight estimate: --fuse needs the camera's heading in every frame: "
                        "--poses FILE (--orientation is one heading, --gravity has none)\n");
        return 2;
    }
    if (aim_views && fuse_age < 0) {
        fprintf(stderr, "parlight estimate: --aim turns the lights to the fused key light: it "
                        "needs --fuse MAX_AGE (and --poses)\n");
        return 2;
    }
    if (level_views && fuse_age < 0) {
        fprintf(stderr, "parlight estimate: --level brings the lights to the room's level over "
                        "views: it needs --fuse MAX_AGE (and --poses with \"exposure\")\n");
        return 2;
    }
    if (have_orient && pl_quat_to_rotation(fixed_q, fixed_R) < 0) {
        fprintf(stderr, "parlight estimate: --orientation: %s\n", pl_last_error());
        return 2;
    }
    if (loop && camera) {
        fprintf(stderr, "parlight estimate: --loop replays files; a camera does not end\n");
        return 2;
    }
    if (interval_ns && (!realtime || camera)) {
        fprintf(stderr, "parlight estimate: --frame-interval paces a --realtime replay of "
                        "--input (a directory or a still image)\n");
        return 2;
    }
    int n_servers = 0;
    for (int i = 0; i < n_outs; i++)
        n_servers += !strncmp(outs[i], "tcp:", 4) || !strncmp(outs[i], "unix:", 5) ||
                     !strncmp(outs[i], "ws:", 3);
    if (wait_clients && !n_servers) {
        fprintf(stderr, "parlight estimate: --wait-clients needs a server to connect to: --out "
                        "tcp://HOST:PORT, ws://HOST:PORT or unix:PATH\n");
        return 2;
    }
    int n_ws = 0;
    for (int i = 0; i < n_outs; i++)
        n_ws += !strncmp(outs[i], "ws:", 3);
    if (sink_opts.www_dir && !n_ws) {
        fprintf(stderr, "parlight estimate: --www needs a ws:// server to serve from: --out "
                        "ws://HOST:PORT[/PATH]\n");
        return 2;
    }
    if (password_file && !sink_opts.mqtt_username) {
        fprintf(stderr, "parlight estimate: --mqtt-password-file needs --mqtt-user\n");
        return 2;
    }

    pl_model *model = NULL;
    pl_source *src = NULL;
    pl_sinks *sinks = NULL;
    pl_capture *cap = NULL;
    pl_smoother smoother;
    pl_key_fuser *fuser = NULL; /* --fuse */
    double fuse_t = 0;     /* its clock: the filter's, summed */
    int rc = 1;
    if (alpha < 0) alpha = camera ? PL_SMOOTH_DEFAULT_ALPHA : 1.0f;
    if (pl_smoother_init(&smoother, alpha) < 0) {
        fprintf(stderr, "parlight estimate: --smooth: %s\n", pl_last_error());
        return 2;
    }
    long long done = 0, skipped = 0, done_at_pass = 0;
    int64_t frame_base = 0, pass_frames = 0; /* --loop: frame numbers go on across passes */
    pl_ratelimit warn_limit, event_limit;    /* a storm prints a few lines and a count */
    pl_ratelimit_init(&warn_limit, LOG_BURST, LOG_WINDOW_NS);
    pl_ratelimit_init(&event_limit, LOG_BURST, LOG_WINDOW_NS);
    if (token_file) {
        if (cli_read_token("estimate", token_file, token, sizeof token) < 0) return 2;
        sink_opts.token = token;
    }
    if (password_file) {
        if (cli_read_secret("estimate", "--mqtt-password-file", password_file, password,
                            sizeof password) < 0)
            return 2;
        sink_opts.mqtt_password = password;
    }
    /* a stop request is honoured between the steps of start-up as between frames: each step
     * may take a while (model load, camera open) and every exit goes through `out` */
    if (stop_requested) goto stopped;
    if (poses_path && cli_poses_load(poses_path, &poses) < 0) {
        fprintf(stderr, "parlight estimate: --poses %s\n", pl_last_error());
        return 2;
    }
    if (fuse_age >= 0 && pl_key_fuser_new(fuse_age, &fuser) < 0) {
        fprintf(stderr, "parlight estimate: --fuse: %s\n", pl_last_error());
        goto out;
    }
    int st_open = pl_sinks_open(outs, n_outs, &sink_opts, &sinks);
    if (st_open < 0) {
        fprintf(stderr, "parlight estimate: %s\n", pl_last_error());
        rc = st_open == PL_E_ARG ? 2 : 1;
        goto out;
    }
    for (int i = 0; i < pl_sinks_count(sinks); i++) { /* where readers connect (port 0 too) */
        const pl_sink *k = pl_sinks_get(sinks, i);
        if (!strncmp(pl_sink_spec(k), "tcp:", 4) || !strncmp(pl_sink_spec(k), "unix:", 5) ||
            !strncmp(pl_sink_spec(k), "ws:", 3))
            fprintf(stderr, "parlight estimate: %s: listening on %s%s\n", pl_sink_spec(k),
                    pl_sink_address(k), sink_opts.token ? " (readers send the token first)" : "");
        if (sink_opts.www_dir && !strncmp(pl_sink_spec(k), "ws:", 3)) {
            /* the page connects to ws://its own host/stream unless told another path */
            const char *path = strchr(pl_sink_spec(k) + 5, '/');
            if (path && !strcmp(path, "/stream"))
                fprintf(stderr, "parlight estimate: viewer: open http://%s/ in a browser\n",
                        pl_sink_address(k));
            else
                fprintf(stderr, "parlight estimate: viewer: open http://%s/?ws=ws://%s%s in a "
                                "browser\n", pl_sink_address(k), pl_sink_address(k),
                        path ? path : "/");
        }
    }
    if (stop_requested) goto stopped;
    reload_requested = 0; /* a SIGHUP before the first load asks for what it is about to read */
    if (load_model(model_path, threads, have_anchor ? anchor : NULL, &model) < 0) {
        fprintf(stderr, "parlight estimate: %s\n", pl_last_error());
        goto out;
    }
    if (stop_requested) goto stopped;
    if ((camera ? pl_source_open_camera(camera, &src) : pl_source_open_path(input, &src)) < 0) {
        if (stop_requested) goto stopped; /* an open interrupted by the signal */
        fprintf(stderr, "parlight estimate: %s\n", pl_last_error());
        goto out;
    }
    if (stop_requested) goto stopped;
    /* --realtime: a video at its own rate; a directory or still image (whose t_ns are file
     * times) at one frame per --frame-interval, 30 fps by default */
    if (realtime && !camera && !strncmp(pl_source_describe(src), "video:", 6)) {
        if (interval_ns) {
            fprintf(stderr, "parlight estimate: --frame-interval: %s is a video, replayed at its "
                            "own frame rate\n", input);
            rc = 2;
            goto out;
        }
    } else if (realtime && !camera && !interval_ns) {
        interval_ns = PL_DEFAULT_FRAME_INTERVAL_NS;
    }
    if (wait_clients && wait_for_readers(sinks, wait_clients, &event_limit) < 0) goto stopped;
    /* cameras and --realtime replays run capture on its own thread (port/capture.h): the
     * newest frame wins and the ones replaced unseen are counted in "dropped" */
    if ((camera || realtime) && start_capture(src, realtime, interval_ns, &cap) < 0) {
        fprintf(stderr, "parlight estimate: %s\n", pl_last_error());
        goto out;
    }

    int64_t prev_t_ns = 0, last_start = 0, last_frame_ns = 0;
    char line[16384], source[4096], event[512];
    for (;;) {
        if (n_frames && done >= n_frames) break;
        if (fps_cap > 0 && done) wait_until(last_start + (int64_t)(1e9 / fps_cap), sinks);
        if (stop_requested) break;
        if (reload_requested) {
            reload_requested = 0;
            const pl_model *before = model;
            reload_model(model_path, threads, have_anchor ? anchor : NULL, alpha, &model,
                         &smoother);
            if (model != before) pl_key_fuser_reset(fuser); /* another model's views */
        }
        pl_frame fr;
        int64_t dropped = 0;
        int st;
        if (cap) {
            st = pl_capture_take(cap, &fr, &dropped, 20);
            if (st == PL_CAPTURE_AGAIN) { /* meanwhile the servers accept and serve files */
                pl_sinks_service(sinks);
                while (pl_sinks_next_event(sinks, event, sizeof event))
                    log_limited(&event_limit, "", event);
                continue;
            }
        } else {
            st = pl_source_read(src, &fr);
        }
        const int64_t t0 = pl_now_ns();
        last_start = t0;
        if (st == PL_E_EOF && camera) { /* a camera only ends when it is lost for good */
            fprintf(stderr, "parlight estimate: %s\n", pl_last_error());
            goto out;
        }
        if (st == PL_E_EOF && loop) { /* again from the start, numbering on */
            if (done == done_at_pass) {
                fprintf(stderr, "parlight estimate: --loop: no usable frame in a whole pass of %s\n",
                        input);
                goto out;
            }
            pl_capture_stop(cap); /* the source's counts are final once capture stopped */
            int64_t good = 0, bad = 0;
            pl_source_counts(src, &good, &bad);
            frame_base += good + bad > pass_frames ? good + bad : pass_frames;
            pass_frames = 0;
            done_at_pass = done;
            cap = NULL;
            pl_source_close(src);
            src = NULL;
            if (interval_ns) wait_until(last_frame_ns + interval_ns, sinks); /* pace the seam */
            if (pl_source_open_path(input, &src) < 0 ||
                (realtime && start_capture(src, realtime, interval_ns, &cap) < 0)) {
                fprintf(stderr, "parlight estimate: --loop: %s\n", pl_last_error());
                goto out;
            }
            continue;
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
        /* world space (--orientation, --gravity, --poses): turned before the filter, so that
         * turning the camera does not smear the lights; --at is then in world axes */
        double q[4], R[9], exposure = 0;
        const double *orient = have_orient ? fixed_q : NULL;
        if (poses.n) {
            if (cli_poses_lookup(&poses, frame_base + fr.index, fr.t_ns, q, &exposure) < 0 ||
                pl_quat_to_rotation(q, R) < 0) {
                fprintf(stderr, "parlight estimate: %s\n", pl_last_error());
                goto out;
            }
            orient = q;
        } else if (have_orient) {
            memcpy(R, fixed_R, sizeof R);
        }
        int est = pl_estimate_rgb8(model, fr.image.data, fr.image.width, fr.image.height,
                                   fr.image.stride, &L, &tm);
        const pl_lighting L_cam = L; /* the frame's own lights, camera frame */
        if (est == 0 && orient) pl_lighting_rotate(&L, R, &L);
        pl_key_light key;
        if (est == 0 && fuser) { /* the frame's own lights, before smoothing */
            fuse_t += dt_s;
            if (level_views && !(exposure > 0)) {
                fprintf(stderr,
                        "parlight estimate: %s: --level needs the frame's \"exposure\": %s has "
                        "none for frame %lld\n",
                        fr.name, poses.path, (long long)(frame_base + fr.index));
                goto out;
            }
            pl_lighting at_level;
            int lv = 0;
            if ((level_views ? pl_key_fuser_add_exposed(fuser, &L_cam, R, fuse_t, exposure)
                             : pl_key_fuser_add(fuser, &L_cam, R, fuse_t)) < 0 ||
                pl_key_fuser_get(fuser, fuse_t, &key) < 0 ||
                (aim_views && key.views >= aim_views &&
                 pl_lighting_aim_primary(&L, key.dir, &L) < 0) ||
                (level_views &&
                 (lv = pl_key_fuser_level(fuser, fuse_t, &L, exposure, &at_level)) < 0)) {
                fprintf(stderr, "parlight estimate: %s: %s\n", fr.name, pl_last_error());
                goto out;
            }
            if (level_views && lv >= level_views) L = at_level;
        }
        if (est < 0 || pl_smoother_update(&smoother, &L, dt_s, &L) < 0 ||
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
        if (fr.index + 1 > pass_frames) pass_frames = fr.index + 1;
        const pl_frame_meta meta = {frame_base + fr.index, fr.t_ns, source, orient,
                                    tm, total_ms, latency_ms, dropped};
        int len = fuser ? pl_frame_format_json_key(&meta, &L, &key, line, sizeof line)
                        : pl_frame_format_json(&meta, &L, line, sizeof line);
        if (len < 0) {
            fprintf(stderr, "parlight estimate: internal error: JSON line too long\n");
            goto out;
        }
        const char *out_line = line;
        if (thumb_w && add_thumb(&thumb, &fr.image, thumb_w, line, &thumb_line) == 0)
            out_line = thumb_line;
        else if (thumb_w)
            log_limited(&warn_limit, "warning: no thumbnail for this frame: ", pl_last_error());
        if (pl_sinks_write(sinks, out_line, strlen(out_line)) < 0) {
            if (n_outs == 0) { /* stdout alone: its reader is gone, nobody is listening */
                fprintf(stderr, "parlight estimate: %s\n", pl_last_error());
                goto out;
            }
            log_limited(&warn_limit, "warning: ", pl_last_error());
        }
        while (pl_sinks_next_event(sinks, event, sizeof event))
            log_limited(&event_limit, "", event);
        last_frame_ns = t0;
        done++;
    }
    if (cap) {
        char last[512];
        const int64_t bad = pl_capture_bad_frames(cap, last, sizeof last);
        if (bad) fprintf(stderr, "parlight estimate: warning: %lld bad frame%s skipped, the last: %s\n",
                         (long long)bad, bad == 1 ? "" : "s", last);
        skipped += bad;
    }
    log_held(&warn_limit, "sink warnings");
    log_held(&event_limit, "sink messages");
    if (stop_requested) {
    stopped:
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
    app_thumb_free(&thumb);
    free(thumb_line);
    cli_poses_free(&poses);
    pl_capture_stop(cap);
    pl_sinks_close(sinks);
    pl_source_close(src);
    pl_model_free(model);
    pl_key_fuser_free(fuser);
    return rc;
}
