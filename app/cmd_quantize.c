/* parlight quantize: float .plm -> int8 .plm, calibrated on frames (docs/QUANT.md). */
#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "app/cli.h"
#include "app/commands.h"
#include "parlight.h"
#include "quant/quantize.h"

static void help(FILE *f)
{
    fprintf(
        f,
        "usage: parlight quantize --model F.plm --calib PATH --out Q.plm\n"
        "                         [--method minmax|percentile|entropy|mse] [--percentile P]\n"
        "                         [--keep-float LAYER,...] [--max-frames K] [--headroom F]\n"
        "                         [--block-floor F] [--force]\n\n"
        "Runs the float model F.plm over the calibration frames (an image, a video or a\n"
        "directory of frames), picks every activation's int8 range with the method, folds the\n"
        "batch norms, the input normalisation and the per-segment scales into per-output-channel\n"
        "symmetric int8 weights, and writes the int8 model Q.plm (docs/QUANT.md).\n"
        "The method sets the ranges of the bottleneck and fc outputs; the dense blocks'\n"
        "channels keep their calibrated [min, max]. Use many varied frames (100+ real frames\n"
        "of the kind the model will see: tools/make-calib-frames.sh); a few frames give\n"
        "ranges that new frames exceed.\n\n"
        "  --model F.plm       float (fp32) model\n"
        "  --calib PATH        calibration frames; keep them disjoint from the check frames\n"
        "  --method M          minmax (default), percentile, entropy (KL) or mse\n"
        "  --percentile P      for --method percentile, in (50, 100] (default 99.99)\n"
        "  --keep-float L,...  layers computed in float on float inputs, their weights stored\n"
        "                      int8 per row: fc (on the exact band means), transition1,\n"
        "                      transition2, transition3 (the heads are always float)\n"
        "  --max-frames K      use at most K good frames (default: all)\n"
        "  --headroom F        widen every calibrated range F times, F in [1, 16] (default 1):\n"
        "                      coarser steps, but frames beyond the calibration frames'\n"
        "                      ranges do not saturate\n"
        "  --block-floor F     a dense-block channel's step is at least F times the widest\n"
        "                      channel's step of its layer, F in [0, 1] (default 0.25):\n"
        "                      larger F, fewer narrow channels that new frames overflow\n"
        "  --out Q.plm         the int8 model to write\n"
        "  --force             replace Q.plm if it exists\n"
        "  -v, --verbose       one line per calibration frame on stderr\n"
        "  --max-pixels N      images of up to N pixels (default 67108864 = 64 Mi; at most\n"
        "                      268435456)\n");
}

static void progress(void *ctx, int64_t good, int64_t bad, const char *frame, const char *error)
{
    const int verbose = *(const int *)ctx;
    if (error)
        fprintf(stderr, "parlight quantize: warning: skipped a frame: %s\n", error);
    else if (verbose)
        fprintf(stderr, "parlight quantize: frame %lld (%lld bad): %s\n", (long long)good,
                (long long)bad, frame);
}

int cmd_quantize(int argc, char **argv)
{
    static const struct option opts[] = {{"model", required_argument, 0, 'm'},
                                         {"calib", required_argument, 0, 'c'},
                                         {"method", required_argument, 0, 'M'},
                                         {"percentile", required_argument, 0, 'p'},
                                         {"keep-float", required_argument, 0, 'k'},
                                         {"max-frames", required_argument, 0, 'n'},
                                         {"headroom", required_argument, 0, 'H'},
                                         {"block-floor", required_argument, 0, 'B'},
                                         {"out", required_argument, 0, 'o'},
                                         {"force", no_argument, 0, 'f'},
                                         {"verbose", no_argument, 0, 'v'},
                                         {"max-pixels", required_argument, 0, CLI_OPT_MAX_PIXELS},
                                         {"help", no_argument, 0, 'h'},
                                         {0, 0, 0, 0}};
    pl_quantize_opts o = {.method = PL_CALIB_MINMAX, .percentile = 99.99};
    int force = 0, verbose = 0, c;
    opterr = 0;
    while ((c = getopt_long(argc, argv, ":m:c:M:p:k:n:H:B:o:fvh", opts, NULL)) != -1) {
        switch (c) {
        case 'm':
            o.float_path = optarg;
            break;
        case 'c':
            o.calib = optarg;
            break;
        case 'M':
            if (pl_calib_method_parse(optarg, &o.method) < 0) {
                fprintf(stderr, "parlight quantize: --method: %s\n", pl_last_error());
                return 2;
            }
            break;
        case 'p':
            if (cli_double("quantize", "--percentile", optarg, 50, 100, 1, &o.percentile) < 0)
                return 2;
            break;
        case 'k':
            o.keep_float = optarg;
            break;
        case 'H':
            if (cli_double("quantize", "--headroom", optarg, 1, 16, 0, &o.headroom) < 0) return 2;
            break;
        case 'B':
            if (cli_double("quantize", "--block-floor", optarg, 0, 1, 0, &o.block_floor) < 0)
                return 2;
            o.block_floor_set = 1;
            break;
        case 'n':
            if (cli_int("quantize", "--max-frames", optarg, 1, 1000000, &o.max_frames) < 0)
                return 2;
            break;
        case 'o':
            o.out_path = optarg;
            break;
        case 'f':
            force = 1;
            break;
        case 'v':
            verbose = 1;
            break;
        case CLI_OPT_MAX_PIXELS:
            if (cli_max_pixels("quantize", optarg) < 0) return 2;
            break;
        case 'h':
            help(stdout);
            return 0;
        default:
            return cli_getopt_error("quantize", c, argv);
        }
    }
    if (optind < argc) {
        fprintf(stderr, "parlight quantize: unexpected argument '%s'\n", argv[optind]);
        return 2;
    }
    if (!o.float_path || !o.calib || !o.out_path) {
        fprintf(stderr, "parlight quantize: --model, --calib and --out are required\n");
        return 2;
    }
    struct stat st;
    if (!force && stat(o.out_path, &st) == 0) {
        fprintf(stderr, "parlight quantize: %s exists (use --force to replace it)\n", o.out_path);
        return 1;
    }
    o.progress = progress;
    o.progress_ctx = &verbose;
    pl_quantize_report rep;
    if (pl_quantize_model(&o, &rep) < 0) {
        fprintf(stderr, "parlight quantize: %s\n", pl_last_error());
        return 1;
    }
    fprintf(stderr,
            "parlight quantize: wrote %s (%s, %lld calibration frames, %lld bad, %d "
            "activations)\n",
            o.out_path,
            o.method == PL_CALIB_PERCENTILE ? "percentile" : pl_calib_method_name(o.method),
            (long long)rep.frames_good, (long long)rep.frames_bad, rep.n_activations);
    return 0;
}
