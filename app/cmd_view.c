/* parlight view: the live viewer (docs/VIEWER.md). Runs `parlight estimate` with a ws:// server
 * that also serves the viewer page (app/viewer) on the same port, and says which URL to open.
 * Everything it does not take itself goes to estimate unchanged. */
#include <errno.h>
#include <getopt.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "app/cli.h"
#include "app/commands.h"

/* Where `make` found the viewer: the source tree's app/viewer (Makefile). */
#ifndef PL_VIEWER_DIR
#define PL_VIEWER_DIR "app/viewer"
#endif

/* flags of view itself, then what view adds: at most this many estimate arguments */
#define VIEW_MAX_ARGS 256

static void usage(FILE *f)
{
    fprintf(f,
            "usage: parlight view --model M.plm (--input PATH | --camera SPEC) [--port P]\n"
            "                     [--host H] [--www DIR] [estimate options]\n"
            "\n"
            "The live viewer: runs parlight estimate with a WebSocket server on HOST:PORT that\n"
            "also serves the viewer page (three.js: spheres, a small scene with the primary\n"
            "light's shadow, the environment map and the lights, updated every frame), and\n"
            "prints the URL to open. docs/VIEWER.md.\n"
            "\n"
            "  --port P        port, 0..65535 (default 8080; 0: a free one, printed)\n"
            "  --host H        address to listen on (default 127.0.0.1: this machine only;\n"
            "                  0.0.0.0 for every interface: anyone who can reach it may watch)\n"
            "  --www DIR       the viewer's folder (default: app/viewer of the source tree\n"
            "                  parlight was built in)\n"
            "\n"
            "It adds --thumb 160 (the page shows the camera frame). With --input, view\n"
            "replays it for ever (--loop --realtime) and a directory at one frame per 500 ms\n"
            "(--frame-interval 500), each unless given. Any other\n"
            "option is parlight estimate's (parlight estimate --help): --out adds sinks,\n"
            "--wait-clients N waits for N pages before the first frame, --token-file F.\n");
}

static int has_flag(int argc, char **argv, const char *flag)
{
    size_t n = strlen(flag);
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--")) return 0;
        if (!strncmp(argv[i], flag, n) && (argv[i][n] == '\0' || argv[i][n] == '=')) return 1;
    }
    return 0;
}

/* The value of an estimate flag given as "--flag V" or "--flag=V", or NULL. */
static const char *flag_value(int argc, char **argv, const char *flag)
{
    size_t n = strlen(flag);
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--")) return NULL;
        if (!strcmp(argv[i], flag) && i + 1 < argc) return argv[i + 1];
        if (!strncmp(argv[i], flag, n) && argv[i][n] == '=') return argv[i] + n + 1;
    }
    return NULL;
}

int cmd_view(int argc, char **argv)
{
    const char *port = "8080", *host = "127.0.0.1", *www = PL_VIEWER_DIR;
    char *args[VIEW_MAX_ARGS];
    int n = 0;
    if (argc + 16 > VIEW_MAX_ARGS) {
        fprintf(stderr, "parlight view: too many arguments (at most %d)\n", VIEW_MAX_ARGS - 16);
        return 2;
    }
    args[n++] = "estimate";
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        const char **dst = !strcmp(a, "--port")   ? &port
                           : !strcmp(a, "--host") ? &host
                           : !strcmp(a, "--www")  ? &www
                                                  : NULL;
        if (!strcmp(a, "-h") || !strcmp(a, "--help")) {
            usage(stdout);
            return 0;
        }
        if (!dst) {
            args[n++] = argv[i];
            continue;
        }
        if (i + 1 >= argc) {
            fprintf(stderr, "parlight view: %s needs a value\n", a);
            return 2;
        }
        *dst = argv[++i];
    }
    int p;
    if (cli_int("view", "--port", port, 0, 65535, &p) < 0) return 2;
    if (!host[0] || strchr(host, '/') || strchr(host, ' ')) {
        fprintf(stderr, "parlight view: --host '%s': expected an address or a host name\n", host);
        return 2;
    }
    /* the page's three.js comes from npm (npm ci in app/viewer, which make deps runs) */
    char three[4096];
    struct stat st;
    snprintf(three, sizeof three, "%s/node_modules/three/build/three.module.min.js", www);
    if (stat(www, &st) < 0) {
        fprintf(stderr, "parlight view: --www %s: %s\n", www, strerror(errno));
        return 1;
    }
    if (!S_ISDIR(st.st_mode)) {
        fprintf(stderr, "parlight view: --www %s: not a directory\n", www);
        return 1;
    }
    if (stat(three, &st) < 0) {
        fprintf(stderr,
                "parlight view: %s is missing: install the viewer's packages (make deps, or "
                "npm ci in %s)\n",
                three, www);
        return 1;
    }
    static char spec[512];
    const int bracket = strchr(host, ':') && host[0] != '['; /* an IPv6 address written bare */
    snprintf(spec, sizeof spec, "ws://%s%s%s:%d/stream", bracket ? "[" : "", host,
             bracket ? "]" : "", p);
    args[n++] = "--out";
    args[n++] = spec;
    args[n++] = "--www";
    args[n++] = (char *)www;
    if (!has_flag(argc, argv, "--thumb")) { /* the page shows the camera frame */
        args[n++] = "--thumb";
        args[n++] = "160";
    }
    const char *input = flag_value(argc, argv, "--input");
    if (input) {
        if (!has_flag(argc, argv, "--loop")) args[n++] = "--loop";
        if (!has_flag(argc, argv, "--realtime")) args[n++] = "--realtime";
        if (!has_flag(argc, argv, "--frame-interval") && stat(input, &st) == 0 &&
            S_ISDIR(st.st_mode)) {
            args[n++] = "--frame-interval";
            args[n++] = "500";
        }
    }
    args[n] = NULL;
    optind = 0; /* estimate parses its own argv afresh (GNU getopt: 0 resets its state) */
    return cmd_estimate(n, args);
}
