/* parlight info --model M.plm: what a model file holds. */
#include <getopt.h>
#include <stdio.h>
#include <string.h>

#include "app/commands.h"
#include "parlight.h"

static void help(FILE *f)
{
    fprintf(f, "usage: parlight info --model M.plm\n\n"
               "Prints the model's architecture, precision, number of lights N, input size,\n"
               "parameter count, file size, working memory and provenance.\n");
}

int cmd_info(int argc, char **argv)
{
    static const struct option opts[] = {
        {"model", required_argument, 0, 'm'}, {"help", no_argument, 0, 'h'}, {0, 0, 0, 0}};
    const char *model_path = NULL;
    int c;
    opterr = 0;
    while ((c = getopt_long(argc, argv, ":m:h", opts, NULL)) != -1) {
        switch (c) {
        case 'm': model_path = optarg; break;
        case 'h': help(stdout); return 0;
        case ':': fprintf(stderr, "parlight info: %s needs a value\n", argv[optind - 1]); return 2;
        default: fprintf(stderr, "parlight info: unknown option '%s'\n", argv[optind - 1]); return 2;
        }
    }
    if (optind < argc) {
        fprintf(stderr, "parlight info: unexpected argument '%s'\n", argv[optind]);
        return 2;
    }
    if (!model_path) {
        fprintf(stderr, "parlight info: --model is required\n");
        help(stderr);
        return 2;
    }
    pl_model *m;
    if (pl_model_load(model_path, &m) < 0) {
        fprintf(stderr, "parlight info: %s\n", pl_last_error());
        return 1;
    }
    pl_model_info info;
    pl_model_get_info(m, &info);
    printf("model        %s\n", model_path);
    printf("architecture %s (DenseNet-121 features, band pooling, FC, parametric heads)\n",
           info.arch);
    printf("precision    %s\n", info.precision);
    printf("lights (N)   %d\n", info.n_lights);
    printf("input        %d x %d (w x h), RGB\n", info.input_w, info.input_h);
    printf("parameters   %lld (%.2f M)\n", (long long)info.n_params, (double)info.n_params / 1e6);
    printf("file size    %lld bytes (%.1f MiB)\n", (long long)info.file_size,
           (double)info.file_size / (1024.0 * 1024.0));
    printf("arena        %zu bytes (%.1f MiB)\n", info.arena_bytes,
           (double)info.arena_bytes / (1024.0 * 1024.0));
    printf("provenance   %s\n", info.provenance[0] ? info.provenance : "(none recorded)");
    pl_model_free(m);
    return 0;
}
