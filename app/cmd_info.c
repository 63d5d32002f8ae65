/* parlight info --model M.plm: what a model file holds. */
#include <getopt.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "app/cli.h"
#include "app/commands.h"
#include "kernels/dispatch.h"
#include "parlight.h"

static void help(FILE *f)
{
    fprintf(f, "usage: parlight info --model M.plm\n\n"
               "Prints the model's architecture, precision, number of lights N, input size,\n"
               "parameter count, file size, working memory and provenance, then the\n"
               "instruction-set path the kernels run on (the best this CPU supports, or\n"
               "PARLIGHT_ISA=ref|avx2|avxvnni|avx512vnni|...) and, per kernel slot of the int8\n"
               "and fp32 tables, the implementation used.\n");
}

/* The selected path, the paths this CPU runs, and every slot of both kernel tables. */
static int print_kernels(void)
{
    const pl_kernels *k;
    if (pl_kernels_get(&k) < 0) {
        fprintf(stderr, "parlight info: %s\n", pl_last_error());
        return 1;
    }
    printf("isa path     %s (PARLIGHT_ISA %s; this CPU runs:", pl_isa_name(k->isa),
           getenv("PARLIGHT_ISA") && *getenv("PARLIGHT_ISA") ? "set" : "unset, best chosen");
    for (int i = 0; i < PL_ISA_COUNT; i++)
        if (pl_isa_supported((pl_isa)i)) printf(" %s", pl_isa_name((pl_isa)i));
    printf(")\n");
    enum { MAX_SLOTS = 16 };
    const char *op[MAX_SLOTS], *impl[MAX_SLOTS];
    int n = pl_kernels_s8_list(&k->s8, op, impl, MAX_SLOTS);
    for (int i = 0; i < n && i < MAX_SLOTS; i++)
        printf("%-12s %-28s %s\n", i ? "" : "kernels s8", op[i], impl[i]);
    n = pl_kernels_f32_list(&k->f32, op, impl, MAX_SLOTS);
    for (int i = 0; i < n && i < MAX_SLOTS; i++)
        printf("%-12s %-28s %s\n", i ? "" : "kernels f32", op[i], impl[i]);
    return 0;
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
        case 'm':
            model_path = optarg;
            break;
        case 'h':
            help(stdout);
            return 0;
        default:
            return cli_getopt_error("info", c, argv);
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
    if (info.anchor[0] != 0 || info.anchor[1] != 0)
        printf("anchor       w %g, b %g stops, gamma %g (intensity anchor, docs/LIGHTING.md)\n",
               info.anchor[0], info.anchor[1], info.anchor[2]);
    else
        printf("anchor       off (the network's own intensity)\n");
    printf("provenance   %s\n", info.provenance[0] ? info.provenance : "(none recorded)");
    pl_model_free(m);
    return print_kernels();
}
