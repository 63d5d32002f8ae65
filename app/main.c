/* parlight — command-line entry point: dispatches to the subcommands in app/commands.h. */
#include <stdio.h>
#include <string.h>

#include "app/commands.h"
#include "core/image.h"
#include "parlight.h"

static const struct command {
    const char *name;
    int (*run)(int argc, char **argv);
    const char *summary;
} commands[] = {
#define PL_ENTRY(name, summary) {#name, cmd_##name, summary},
    PL_COMMANDS(PL_ENTRY)
#undef PL_ENTRY
};

static void usage(FILE *f)
{
    fprintf(f, "usage: parlight <command> [options]   (parlight <command> --help for details)\n"
               "       parlight --version\n\n"
               "Estimates indoor lighting (N lights + ambient) from camera frames.\n\ncommands:\n");
    for (size_t i = 0; i < sizeof commands / sizeof commands[0]; i++)
        fprintf(f, "  %-10s %s\n", commands[i].name, commands[i].summary);
}

int main(int argc, char **argv)
{
    /* Messages about images over the read limit name the flag that raises it. */
    pl_image_set_max_pixels(PL_IMAGE_DEFAULT_MAX_PIXELS, "--max-pixels");
    if (argc < 2) {
        usage(stderr);
        return 2;
    }
    if (!strcmp(argv[1], "--version") || !strcmp(argv[1], "-V")) {
        printf("parlight %s\n", pl_version());
        return 0;
    }
    if (!strcmp(argv[1], "--help") || !strcmp(argv[1], "-h") || !strcmp(argv[1], "help")) {
        usage(stdout);
        return 0;
    }
    for (size_t i = 0; i < sizeof commands / sizeof commands[0]; i++)
        if (!strcmp(argv[1], commands[i].name)) return commands[i].run(argc - 1, argv + 1);
    fprintf(stderr, "parlight: unknown command '%s'\n", argv[1]);
    usage(stderr);
    return 2;
}
