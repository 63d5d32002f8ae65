/* parlight bench: time pl_estimate_rgb8 on one frame, R runs after W warm-up ones, and report the
 * median, min and max milliseconds per frame, the instruction-set path, threads, GMAC/s and the
 * peak RSS. tools/bench/run.sh (`make bench`) runs it beside the peers (docs/PERFORMANCE.md). */
#include <getopt.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <time.h>

#include "app/cli.h"
#include "app/commands.h"
#include "core/util.h"
#include "kernels/isa.h"
#include "model/graph.h"
#include "model/profile.h"
#include "parlight.h"
#include "port/image.h"

static void help(FILE *f)
{
    fprintf(
        f, "usage: parlight bench --model M.plm [--threads N] [--runs R] [--warmup W]\n"
           "                      [--input IMAGE] [--layers | --layers-cpu] [--json]\n\n"
           "Runs R estimates after W warm-up ones on one frame and prints the median, min and\n"
           "max milliseconds per frame (preprocess + network + heads, as pl_estimate_rgb8 spends\n"
           "them), the instruction-set path (PARLIGHT_ISA forces one), the thread count, GMAC/s\n"
           "at the median and the process's peak RSS.\n\n"
           "  --model M.plm   model file, fp32 or int8 (see parlight info)\n"
           "  --threads N     worker threads, 1..64 (default 1)\n"
           "  --runs R        timed runs, 1..100000 (default 30)\n"
           "  --warmup W      untimed runs first, 0..10000 (default 3)\n"
           "  --input IMAGE   the frame (a still image, any size of at least 8 x 8; it is\n"
           "                  cropped and resized as estimate does). Default: a fixed\n"
           "                  deterministic pattern of the model's input size\n"
           "  --layers        also the time of each stage of the network (stem, max pool,\n"
           "                  each block's 1x1s and 3x3s, transitions, norm5, heads):\n"
           "                  median and min over the runs, ms per frame\n"
           "  --layers-cpu    the same in the calling thread's CPU time, which other\n"
           "                  processes disturb less than wall time (use with --threads 1)\n"
           "  --json          one JSON object on stdout instead of the table: model, precision,\n"
           "                  input_h, input_w, n_lights, isa, threads, runs, warmup, frame,\n"
           "                  median_ms, min_ms, max_ms, mean_ms, median_infer_ms,\n"
           "                  median_cpu_ms (CPU time of all threads per frame),\n"
           "                  gmac_per_frame, gmac_per_s, peak_rss_kib (with --layers:\n"
           "                  stage_clock (wall or thread_cpu) and stages, [{stage,\n"
           "                  median_ms, min_ms}] in network order)\n"
           "  --max-pixels N  an --input of up to N pixels (default 67108864 = 64 Mi; at most\n"
           "                  268435456)\n\n"
           "GMAC counts the multiply-accumulates of the DenseNet-121 graph as written (transition\n"
           "convolutions before their pooling, as PyTorch runs them), the FC and the heads, from\n"
           "the model's input size and metadata: 2.777 GMAC at 192 x 256 (2.775 of it in the\n"
           "features). The same count divides every engine's time in `make bench`, so GMAC/s\n"
           "compare across engines.\n");
}

/* Multiply-accumulates of one frame through the model's graph (model/graph.h: convolutions as
 * tools/model.py writes them, transitions' 1x1 at full size before their pool; FC, heads).
 * Pooling, BN, ReLU and additions are not counted. */
static int64_t model_macs(const pl_model *m)
{
    const pl_graph *g = pl_model_graph(m);
    int64_t macs = 0;
    for (int i = 0; i < g->n_nodes; i++)
        macs += pl_graph_node_macs(g, &g->nodes[i]);
    return macs;
}

/* A fixed frame of w x h: smooth gradients with a bright window and a hashed texture, so the
 * network sees something image-like and every run of every build sees the same pixels. */
static void synthetic_frame(pl_image_u8 *img)
{
    uint32_t s = 0x9e3779b9u;
    for (int y = 0; y < img->height; y++) {
        uint8_t *row = img->data + (size_t)y * img->stride;
        for (int x = 0; x < img->width; x++) {
            s ^= s << 13;
            s ^= s >> 17;
            s ^= s << 5;
            const int noise = (int)(s & 15u) - 8;
            const int window = x > img->width / 2 && y < img->height / 3;
            const int v[3] = {40 + 150 * x / img->width, 60 + 120 * y / img->height,
                              90 + 60 * (x + y) / (img->width + img->height)};
            for (int c = 0; c < 3; c++) {
                int p = (window ? 235 : v[c]) + noise;
                row[3 * x + c] = (uint8_t)(p < 0 ? 0 : p > 255 ? 255 : p);
            }
        }
    }
}

/* CPU time of the whole process (all threads), milliseconds: on a busy machine, a 1-thread run's
 * CPU time per frame stays near the quiet machine's wall time while its wall time does not. */
static double cpu_ms(void)
{
    struct timespec ts;
    if (clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts) != 0) return 0.0;
    return (double)ts.tv_sec * 1e3 + (double)ts.tv_nsec * 1e-6;
}

static int cmp_double(const void *a, const void *b)
{
    const double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* Median of n sorted values. */
static double median_sorted(const double *v, int n)
{
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

/* What `estimate --fuse` adds to a frame at most: pl_key_fuser_get with every heading bin
 * holding a view (8 yaws x 3 pitches, here the bench frame's lights seen from each), the median
 * of FUSE_RUNS calls in milliseconds; < 0 on an error. */
#define FUSE_HEADINGS 24
#define FUSE_RUNS 21
static double key_fuser_ms(const pl_lighting *L)
{
    pl_key_fuser *k = NULL;
    if (pl_key_fuser_new(0, &k) < 0) return -1;
    for (int v = 0; v < FUSE_HEADINGS; v++) {
        const double yaw = (v % 8) * (M_PI / 4), pitch = (v / 8 - 1) * (M_PI / 4);
        const double cy = cos(yaw), sy = sin(yaw), cp = cos(pitch), sp = sin(pitch);
        /* camera-to-world: yaw about y after pitch about x */
        const double R[9] = {cy, sy * sp, sy * cp, 0, cp, -sp, -sy, cy * sp, cy * cp};
        if (pl_key_fuser_add(k, L, R, 0) < 0) {
            pl_key_fuser_free(k);
            return -1;
        }
    }
    double t[FUSE_RUNS];
    pl_key_light key;
    for (int i = 0; i < FUSE_RUNS; i++) {
        const int64_t t0 = pl_now_ns();
        pl_key_fuser_get(k, 0, &key);
        t[i] = (double)(pl_now_ns() - t0) * 1e-6;
    }
    pl_key_fuser_free(k);
    qsort(t, FUSE_RUNS, sizeof *t, cmp_double);
    return median_sorted(t, FUSE_RUNS);
}

static void json_string(const char *s)
{
    putchar('"');
    for (; *s; s++) {
        const unsigned char ch = (unsigned char)*s;
        if (ch == '"' || ch == '\\')
            printf("\\%c", ch);
        else if (ch < 0x20)
            printf("\\u%04x", ch);
        else
            putchar(ch);
    }
    putchar('"');
}

int cmd_bench(int argc, char **argv)
{
    static const struct option opts[] = {{"model", required_argument, 0, 'm'},
                                         {"threads", required_argument, 0, 't'},
                                         {"runs", required_argument, 0, 'r'},
                                         {"warmup", required_argument, 0, 'w'},
                                         {"input", required_argument, 0, 'i'},
                                         {"json", no_argument, 0, 'j'},
                                         {"layers", no_argument, 0, 'l'},
                                         {"layers-cpu", no_argument, 0, 'L'},
                                         {"max-pixels", required_argument, 0, CLI_OPT_MAX_PIXELS},
                                         {"help", no_argument, 0, 'h'},
                                         {0, 0, 0, 0}};
    const char *model_path = NULL, *input = NULL;
    int threads = 1, runs = 30, warmup = 3, json = 0, layers = 0, c;
    opterr = 0;
    while ((c = getopt_long(argc, argv, ":m:t:r:w:i:jlLh", opts, NULL)) != -1) {
        switch (c) {
        case 'm':
            model_path = optarg;
            break;
        case 't':
            if (cli_int("bench", "--threads", optarg, 1, 64, &threads) < 0) return 2;
            break;
        case 'r':
            if (cli_int("bench", "--runs", optarg, 1, 100000, &runs) < 0) return 2;
            break;
        case 'w':
            if (cli_int("bench", "--warmup", optarg, 0, 10000, &warmup) < 0) return 2;
            break;
        case 'i':
            input = optarg;
            break;
        case 'j':
            json = 1;
            break;
        case 'l':
            layers = 1;
            break;
        case 'L':
            layers = 2;
            break;
        case CLI_OPT_MAX_PIXELS:
            if (cli_max_pixels("bench", optarg) < 0) return 2;
            break;
        case 'h':
            help(stdout);
            return 0;
        default:
            return cli_getopt_error("bench", c, argv);
        }
    }
    if (optind < argc) {
        fprintf(stderr, "parlight bench: unexpected argument '%s'\n", argv[optind]);
        return 2;
    }
    if (!model_path) {
        fprintf(stderr, "parlight bench: --model is required (see --help)\n");
        return 2;
    }

    int rc = 1;
    pl_model *model = NULL;
    pl_image_u8 frame = {0};
    double *total = NULL, *infer = NULL, *cpu = NULL, *stage = NULL;
    pl_profile prof;
    pl_isa isa;
    if (pl_isa_select(&isa) < 0) {
        fprintf(stderr, "parlight bench: %s\n", pl_last_error());
        return 1;
    }
    if (pl_model_load(model_path, &model) < 0 || pl_model_set_threads(model, threads) < 0) {
        fprintf(stderr, "parlight bench: %s\n", pl_last_error());
        goto out;
    }
    pl_model_info info;
    int64_t macs;
    if (pl_model_get_info(model, &info) < 0) {
        fprintf(stderr, "parlight bench: %s\n", pl_last_error());
        goto out;
    }
    macs = model_macs(model);
    if (input) {
        if (pl_image_read_rgb8(input, &frame) < 0) {
            fprintf(stderr, "parlight bench: %s\n", pl_last_error());
            goto out;
        }
        if (frame.width < 8 || frame.height < 8) {
            fprintf(stderr, "parlight bench: %s: %d x %d pixels, need at least 8 x 8\n", input,
                    frame.width, frame.height);
            goto out;
        }
    } else {
        if (pl_image_u8_alloc(&frame, info.input_w, info.input_h) < 0) {
            fprintf(stderr, "parlight bench: %s\n", pl_last_error());
            goto out;
        }
        synthetic_frame(&frame);
    }
    total = malloc((size_t)runs * sizeof *total);
    infer = malloc((size_t)runs * sizeof *infer);
    cpu = malloc((size_t)runs * sizeof *cpu);
    stage = malloc((size_t)runs * PL_PROF_N * sizeof *stage);
    if (!total || !infer || !cpu || !stage) {
        fprintf(stderr, "parlight bench: out of memory for %d runs\n", runs);
        goto out;
    }

    if (layers && pl_model_set_profile(model, &prof) < 0) {
        fprintf(stderr, "parlight bench: %s\n", pl_last_error());
        goto out;
    }
    pl_lighting L;
    pl_timing tm;
    for (int i = 0; i < warmup + runs; i++) {
        memset(&prof, 0, sizeof prof);
        prof.thread_cpu = layers == 2;
        const double c0 = cpu_ms();
        const int64_t t0 = pl_now_ns();
        if (pl_estimate_rgb8(model, frame.data, frame.width, frame.height, frame.stride, &L, &tm) <
            0) {
            fprintf(stderr, "parlight bench: %s\n", pl_last_error());
            goto out;
        }
        const int64_t t1 = pl_now_ns();
        const double c1 = cpu_ms();
        if (i >= warmup) {
            total[i - warmup] = (double)(t1 - t0) * 1e-6;
            infer[i - warmup] = tm.infer_ms;
            cpu[i - warmup] = c1 - c0;
            for (int s = 0; s < PL_PROF_N; s++)
                stage[(size_t)s * runs + (size_t)(i - warmup)] = (double)prof.ns[s] * 1e-6;
        }
    }
    double mean = 0;
    for (int i = 0; i < runs; i++)
        mean += total[i];
    mean /= runs;
    qsort(total, (size_t)runs, sizeof *total, cmp_double);
    qsort(infer, (size_t)runs, sizeof *infer, cmp_double);
    qsort(cpu, (size_t)runs, sizeof *cpu, cmp_double);
    for (int s = 0; s < PL_PROF_N; s++)
        qsort(stage + (size_t)s * runs, (size_t)runs, sizeof *stage, cmp_double);
    const double med = median_sorted(total, runs), med_infer = median_sorted(infer, runs);
    const double med_cpu = median_sorted(cpu, runs);
    const double gmac = (double)macs * 1e-9, gmacs = med > 0 ? gmac / (med * 1e-3) : 0;
    const double fuse_ms = key_fuser_ms(&L);
    if (fuse_ms < 0) {
        fprintf(stderr, "parlight bench: key fuser: %s\n", pl_last_error());
        goto out;
    }
    struct rusage ru;
    long rss_kib = getrusage(RUSAGE_SELF, &ru) == 0 ? ru.ru_maxrss : -1;

    if (json) {
        printf("{\"model\":");
        json_string(model_path);
        printf(",\"precision\":\"%s\",\"input_h\":%d,\"input_w\":%d,\"n_lights\":%d,"
               "\"isa\":\"%s\",\"threads\":%d,\"runs\":%d,\"warmup\":%d,\"frame\":",
               info.precision, info.input_h, info.input_w, info.n_lights, pl_isa_name(isa), threads,
               runs, warmup);
        json_string(input ? input : "synthetic");
        printf(",\"median_ms\":%.4f,\"min_ms\":%.4f,\"max_ms\":%.4f,\"mean_ms\":%.4f,"
               "\"median_infer_ms\":%.4f,\"median_cpu_ms\":%.4f,\"gmac_per_frame\":%.6f,"
               "\"gmac_per_s\":%.3f,\"peak_rss_kib\":%ld,\"key_fuser_get_ms\":%.4f",
               med, total[0], total[runs - 1], mean, med_infer, med_cpu, gmac, gmacs, rss_kib,
               fuse_ms);
        if (layers) {
            printf(",\"stage_clock\":\"%s\",\"stages\":[", layers == 2 ? "thread_cpu" : "wall");
            for (int s = 0; s < PL_PROF_N; s++)
                printf("%s{\"stage\":\"%s\",\"median_ms\":%.4f,\"min_ms\":%.4f}", s ? "," : "",
                       pl_prof_stage_name(s), median_sorted(stage + (size_t)s * runs, runs),
                       stage[(size_t)s * runs]);
            printf("]");
        }
        printf("}\n");
    } else {
        printf("model      %s (%s, %d x %d, N=%d)\n", model_path, info.precision, info.input_w,
               info.input_h, info.n_lights);
        printf("frame      %s (%d x %d)\n", input ? input : "synthetic", frame.width, frame.height);
        printf("isa        %s\n", pl_isa_name(isa));
        printf("threads    %d\n", threads);
        printf("runs       %d after %d warm-up\n", runs, warmup);
        printf("median     %.3f ms/frame (network and heads %.3f ms)\n", med, med_infer);
        printf("min        %.3f ms\n", total[0]);
        printf("max        %.3f ms\n", total[runs - 1]);
        printf("CPU        %.3f ms/frame, median, all threads\n", med_cpu);
        printf("GMAC/s     %.1f (%.3f GMAC per frame, at the median)\n", gmacs, gmac);
        printf("peak RSS   %.1f MiB\n", (double)rss_kib / 1024.0);
        printf("key fuser  %.3f ms per pl_key_fuser_get, all %d headings kept (estimate --fuse)\n",
               fuse_ms, FUSE_HEADINGS);
        if (layers) {
            double sum = 0;
            for (int s = 0; s < PL_PROF_N; s++)
                sum += median_sorted(stage + (size_t)s * runs, runs);
            printf("%-17s median ms   min ms   share\n",
                   layers == 2 ? "stage (CPU)" : "stage (wall)");
            for (int s = 0; s < PL_PROF_N; s++) {
                const double m = median_sorted(stage + (size_t)s * runs, runs);
                printf("  %-14s %9.3f %8.3f %6.1f%%\n", pl_prof_stage_name(s), m,
                       stage[(size_t)s * runs], sum > 0 ? 100.0 * m / sum : 0.0);
            }
        }
    }
    rc = 0;
out:
    free(total);
    free(infer);
    free(cpu);
    free(stage);
    pl_image_u8_free(&frame);
    pl_model_free(model);
    return rc;
}
