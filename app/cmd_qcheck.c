/* parlight qcheck: how far an int8 model is from its float original, per layer and end to end
 * (quant/qcheck.h, docs/QUANT.md "Accuracy check"). */
#include <getopt.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "app/cli.h"
#include "app/commands.h"
#include "model/observer.h"
#include "parlight.h"
#include "port/source.h"
#include "quant/qcheck.h"

static void help(FILE *f)
{
    fprintf(f,
            "usage: parlight qcheck --float F.plm --int8 Q.plm --input PATH [--json]\n"
            "                       [--max-frames K] [--layers K]\n\n"
            "Runs both models on every frame of PATH (image, video or directory; use frames that\n"
            "were not used for calibration) and reports, worst first, each layer's SQNR (dB) and\n"
            "cosine of int8 against float, then end to end: direction error of each light in\n"
            "degrees (lights matched by angle), colour and ambient relative errors, the env-map\n"
            "relative RMSE and the relative L2 of all outputs (median, p95, max over frames).\n"
            "Beside them, the float model's own noise floor: the same errors between float on\n"
            "the frame and float on the frame with +-1 code value of seeded noise per pixel\n"
            "value (an invisible change). int8 errors near that floor are as good as int8 can\n"
            "be told apart from float on this network.\n\n"
            "  --float F.plm    the float (fp32) model\n"
            "  --int8 Q.plm     the int8 model made from it (parlight quantize)\n"
            "  --input PATH     check frames\n"
            "  --json           one JSON object on stdout instead of the text report\n"
            "  --max-frames K   stop after K good frames\n"
            "  --layers K       text report: show the K worst layers (default 10; 0 = all)\n"
            "  --no-noise-floor skip the float noise-floor runs (half the time)\n"
            "  --max-pixels N   images of up to N pixels (default 67108864 = 64 Mi; at most\n"
            "                   268435456)\n");
}

static int load(const char *path, const char *want, const char *flag, pl_model **m)
{
    if (pl_model_load(path, m) < 0) {
        fprintf(stderr, "parlight qcheck: %s\n", pl_last_error());
        return -1;
    }
    if (strcmp(pl_model_precision(*m), want)) {
        fprintf(stderr, "parlight qcheck: %s %s: precision is %s, expected %s\n", flag, path,
                pl_model_precision(*m), want);
        pl_model_free(*m);
        *m = NULL;
        return -1;
    }
    return 0;
}

struct series {
    double *v;
    size_t n, cap;
};

static int push(struct series *s, double x)
{
    if (s->n == s->cap) {
        size_t cap = s->cap ? 2 * s->cap : 64;
        double *p = realloc(s->v, cap * sizeof *p);
        if (!p) return -1;
        s->v = p;
        s->cap = cap;
    }
    s->v[s->n++] = x;
    return 0;
}

static int by_sqnr(const void *a, const void *b)
{
    const double x = pl_qcheck_sqnr_db(a), y = pl_qcheck_sqnr_db(b);
    return x < y ? -1 : x > y;
}

enum { S_DIR, S_RGB, S_AMB, S_ENV, S_OUT, N_SERIES };

/* Adds the errors of one compared frame to the series. */
static int push_frame(struct series *s, const pl_qcheck_frame *r)
{
    int oom = 0;
    for (int i = 0; i < r->n_lights; i++)
        oom |= push(&s[S_DIR], r->dir_err_deg[i]) | push(&s[S_RGB], r->rgb_rel[i]);
    return oom | push(&s[S_AMB], r->ambient_rel) | push(&s[S_ENV], r->envmap_rel_rmse) |
           push(&s[S_OUT], r->output_rel_l2);
}

/* The frame with every value moved by -1, 0 or +1 code value (clamped to 0..255), from a
 * xorshift generator seeded per frame, so the floor is reproducible. */
static void add_noise(const pl_image_u8 *in, uint8_t *out, uint64_t seed)
{
    uint64_t x = seed * 0x9E3779B97F4A7C15ull + 1;
    for (int y = 0; y < in->height; y++) {
        const uint8_t *row = in->data + (size_t)y * in->stride;
        uint8_t *o = out + (size_t)y * in->width * 3;
        for (int i = 0; i < in->width * 3; i++) {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            const int v = row[i] + (int)(x % 3) - 1;
            o[i] = (uint8_t)(v < 0 ? 0 : v > 255 ? 255 : v);
        }
    }
}

int cmd_qcheck(int argc, char **argv)
{
    static const struct option opts[] = {{"float", required_argument, 0, 'f'},
                                         {"int8", required_argument, 0, 'q'},
                                         {"input", required_argument, 0, 'i'},
                                         {"json", no_argument, 0, 'j'},
                                         {"max-frames", required_argument, 0, 'n'},
                                         {"layers", required_argument, 0, 'l'},
                                         {"no-noise-floor", no_argument, 0, 'F'},
                                         {"max-pixels", required_argument, 0, CLI_OPT_MAX_PIXELS},
                                         {"help", no_argument, 0, 'h'},
                                         {0, 0, 0, 0}};
    const char *fpath = NULL, *qpath = NULL, *input = NULL;
    int json = 0, max_frames = 0, show = 10, noise_floor = 1, c;
    opterr = 0;
    while ((c = getopt_long(argc, argv, ":f:q:i:jn:l:h", opts, NULL)) != -1) {
        switch (c) {
        case 'f':
            fpath = optarg;
            break;
        case 'q':
            qpath = optarg;
            break;
        case 'i':
            input = optarg;
            break;
        case 'j':
            json = 1;
            break;
        case 'n':
            if (cli_int("qcheck", "--max-frames", optarg, 1, 1000000, &max_frames) < 0) return 2;
            break;
        case 'l':
            if (cli_int("qcheck", "--layers", optarg, 0, 100000, &show) < 0) return 2;
            break;
        case 'F':
            noise_floor = 0;
            break;
        case CLI_OPT_MAX_PIXELS:
            if (cli_max_pixels("qcheck", optarg) < 0) return 2;
            break;
        case 'h':
            help(stdout);
            return 0;
        default:
            return cli_getopt_error("qcheck", c, argv);
        }
    }
    if (optind < argc) {
        fprintf(stderr, "parlight qcheck: unexpected argument '%s'\n", argv[optind]);
        return 2;
    }
    if (!fpath || !qpath || !input) {
        fprintf(stderr, "parlight qcheck: --float, --int8 and --input are required\n");
        return 2;
    }
    int ret = 1;
    pl_model *mf = NULL, *mq = NULL;
    pl_source *src = NULL;
    pl_qcheck_layers layers = {0};
    struct series s[N_SERIES], nf[N_SERIES];
    memset(s, 0, sizeof s);
    memset(nf, 0, sizeof nf);
    uint8_t *noisy = NULL;
    size_t noisy_cap = 0;
    if (load(fpath, "fp32", "--float", &mf) < 0 || load(qpath, "int8", "--int8", &mq) < 0)
        goto done;
    pl_model_info fi, qi;
    pl_model_get_info(mf, &fi);
    pl_model_get_info(mq, &qi);
    if (fi.n_lights != qi.n_lights || fi.input_h != qi.input_h || fi.input_w != qi.input_w) {
        fprintf(stderr, "parlight qcheck: the models differ (N %d vs %d, input %dx%d vs %dx%d)\n",
                fi.n_lights, qi.n_lights, fi.input_w, fi.input_h, qi.input_w, qi.input_h);
        goto done;
    }
    if (pl_model_set_observer(mf, pl_qcheck_layers_float, &layers) < 0 ||
        pl_model_set_observer(mq, pl_qcheck_layers_int8, &layers) < 0) {
        fprintf(stderr, "parlight qcheck: %s\n", pl_last_error());
        goto done;
    }
    if (pl_source_open_path(input, &src) < 0) {
        fprintf(stderr, "parlight qcheck: %s\n", pl_last_error());
        goto done;
    }
    int64_t good = 0, bad = 0;
    for (;;) {
        if (max_frames > 0 && good >= max_frames) break;
        pl_frame fr;
        int rc = pl_source_read(src, &fr);
        if (rc == PL_E_EOF) break;
        pl_lighting lf, lq;
        if (rc == PL_OK)
            rc = pl_estimate_rgb8(mf, fr.image.data, fr.image.width, fr.image.height,
                                  fr.image.stride, &lf, NULL);
        if (rc == PL_OK)
            rc = pl_estimate_rgb8(mq, fr.image.data, fr.image.width, fr.image.height,
                                  fr.image.stride, &lq, NULL);
        if (rc < 0) {
            bad++;
            fprintf(stderr, "parlight qcheck: warning: skipped a frame: %s\n", pl_last_error());
            continue;
        }
        if (layers.error) {
            fprintf(stderr, "parlight qcheck: the two models' layers do not correspond (or out "
                            "of memory)\n");
            goto done;
        }
        pl_qcheck_frame r;
        if (pl_qcheck_compare(&lf, &lq, &r) < 0) {
            fprintf(stderr, "parlight qcheck: %s\n", pl_last_error());
            goto done;
        }
        if (push_frame(s, &r)) {
            fprintf(stderr, "parlight qcheck: out of memory\n");
            goto done;
        }
        if (noise_floor) { /* float against float on the slightly noisy frame, unobserved */
            const size_t need = (size_t)fr.image.width * fr.image.height * 3;
            if (need > noisy_cap) {
                free(noisy);
                noisy_cap = 0;
                if (!(noisy = malloc(need))) {
                    fprintf(stderr, "parlight qcheck: out of memory\n");
                    goto done;
                }
                noisy_cap = need;
            }
            add_noise(&fr.image, noisy, (uint64_t)good);
            pl_lighting ln;
            pl_qcheck_frame rn;
            if (pl_model_set_observer(mf, NULL, NULL) < 0 ||
                pl_estimate_rgb8(mf, noisy, fr.image.width, fr.image.height,
                                 (size_t)fr.image.width * 3, &ln, NULL) < 0 ||
                pl_model_set_observer(mf, pl_qcheck_layers_float, &layers) < 0 ||
                pl_qcheck_compare(&lf, &ln, &rn) < 0) {
                fprintf(stderr, "parlight qcheck: noise floor: %s\n", pl_last_error());
                goto done;
            }
            if (push_frame(nf, &rn)) {
                fprintf(stderr, "parlight qcheck: out of memory\n");
                goto done;
            }
        }
        good++;
    }
    if (good == 0) {
        fprintf(stderr, "parlight qcheck: %s: no usable frame (%lld bad)\n", input, (long long)bad);
        goto done;
    }
    qsort(layers.l, (size_t)layers.n, sizeof *layers.l, by_sqnr);
    double st[N_SERIES][3], fl[N_SERIES][3];
    for (int k = 0; k < N_SERIES; k++) {
        st[k][0] = pl_quantile(s[k].v, s[k].n, 0.5);
        st[k][1] = pl_quantile(s[k].v, s[k].n, 0.95);
        st[k][2] = pl_quantile(s[k].v, s[k].n, 1.0);
        fl[k][0] = pl_quantile(nf[k].v, nf[k].n, 0.5);
        fl[k][1] = pl_quantile(nf[k].v, nf[k].n, 0.95);
        fl[k][2] = pl_quantile(nf[k].v, nf[k].n, 1.0);
    }
    if (json) {
        static const char *keys[N_SERIES] = {"direction_err_deg", "colour_rel_err",
                                             "ambient_rel_err", "envmap_rel_rmse", "output_rel_l2"};
        printf("{\"float\":\"%s\",\"int8\":\"%s\",\"frames\":%lld,\"bad_frames\":%lld", fpath,
               qpath, (long long)good, (long long)bad);
        for (int k = 0; k < N_SERIES; k++)
            printf(",\"%s\":{\"median\":%.6g,\"p95\":%.6g,\"max\":%.6g}", keys[k], st[k][0],
                   st[k][1], st[k][2]);
        if (noise_floor) {
            printf(",\"float_noise_floor\":{");
            for (int k = 0; k < N_SERIES; k++)
                printf("%s\"%s\":{\"median\":%.6g,\"p95\":%.6g,\"max\":%.6g}", k ? "," : "",
                       keys[k], fl[k][0], fl[k][1], fl[k][2]);
            printf("}");
        }
        printf(",\"layers\":[");
        for (int i = 0; i < layers.n; i++)
            printf("%s{\"name\":\"%s\",\"sqnr_db\":%.3f,\"cosine\":%.6f}", i ? "," : "",
                   layers.l[i].name, pl_qcheck_sqnr_db(&layers.l[i]),
                   pl_qcheck_cosine(&layers.l[i]));
        printf("]}\n");
    } else {
        printf("qcheck: %s (int8) against %s (float), %lld frames (%lld bad)\n\n", qpath, fpath,
               (long long)good, (long long)bad);
        const int n = show == 0 || show > layers.n ? layers.n : show;
        printf("layers, worst first (%d of %d)      SQNR dB   cosine\n", n, layers.n);
        for (int i = 0; i < n; i++)
            printf("  %-34s %8.2f  %.6f\n", layers.l[i].name, pl_qcheck_sqnr_db(&layers.l[i]),
                   pl_qcheck_cosine(&layers.l[i]));
        printf("\nend to end                  int8: median        p95        max%s\n",
               noise_floor ? "   float +-1 noise: median     p95" : "");
        static const char *labels[N_SERIES] = {"direction error (deg)", "colour relative error",
                                               "ambient relative error", "env-map relative RMSE",
                                               "output relative L2"};
        for (int k = 0; k < N_SERIES; k++) {
            printf("  %-24s %10.4f %10.4f %10.4f", labels[k], st[k][0], st[k][1], st[k][2]);
            if (noise_floor) printf("   %18.4f %10.4f", fl[k][0], fl[k][1]);
            printf("\n");
        }
    }
    ret = 0;
done:
    for (int k = 0; k < N_SERIES; k++) {
        free(s[k].v);
        free(nf[k].v);
    }
    free(noisy);
    pl_qcheck_layers_free(&layers);
    pl_source_close(src);
    pl_model_free(mf);
    pl_model_free(mq);
    return ret;
}
