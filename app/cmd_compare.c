/* parlight compare: renders the same sphere lit by two lightings (panoramas or lights JSON) and
 * prints RMSE and scale-invariant RMSE between the renders (docs/LIGHTING.md). */
#include <getopt.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "app/cli.h"
#include "app/commands.h"
#include "app/light_io.h"
#include "core/util.h"
#include "light/light.h"
#include "light/lights_json.h"
#include "port/hdr_io.h"

static void usage(FILE *f)
{
    fprintf(f,
            "usage: parlight compare A B [--sphere diffuse|glossy] [--size S] [--json]\n"
            "\n"
            "A and B are each a lights JSON (.json) or an equirectangular panorama (.exr, .hdr).\n"
            "Renders the same sphere lit by each and prints\n"
            "  rmse    = sqrt(mean over sphere pixels and channels of (A - B)^2)\n"
            "  si_rmse = the same after scaling A by alpha = <A,B>/<A,A> (printed too)\n"
            "\n"
            "  --sphere M   diffuse (default) or glossy\n"
            "  --size S     render size in pixels (default 64)\n"
            "  --json       print one JSON object instead of text\n"
            "  --max-pixels N panoramas of up to N pixels (default 67108864 = 64 Mi; at most "
            "268435456)\n"
            "  -h, --help   this text\n");
}

static int render_input(const char *path, pl_material m, int size, pl_image_f32 *out)
{
    int kind = pl_app_input_kind(path);
    if (kind == 1) {
        pl_lighting L;
        int rc = pl_lighting_read_json(path, &L);
        if (rc < 0) return rc;
        return pl_render_sphere_lights(&L, m, size, out);
    }
    if (kind == 2) {
        pl_image_f32 env;
        int rc = pl_hdr_read_panorama(path, &env);
        if (rc < 0) return rc;
        rc = pl_render_sphere_envmap(&env, m, size, out);
        pl_image_f32_free(&env);
        return rc;
    }
    return pl_error(PL_E_ARG,
                    "%s: unknown input type (expected .json lights, .exr or .hdr panorama)", path);
}

int cmd_compare(int argc, char **argv)
{
    static const struct option opts[] = {{"sphere", required_argument, 0, 's'},
                                         {"size", required_argument, 0, 'S'},
                                         {"json", no_argument, 0, 'j'},
                                         {"max-pixels", required_argument, 0, CLI_OPT_MAX_PIXELS},
                                         {"help", no_argument, 0, 'h'},
                                         {0, 0, 0, 0}};
    pl_material m = PL_MATERIAL_DIFFUSE;
    int size = 64, json = 0;
    optind = 1;
    opterr = 0;
    for (;;) {
        int c = getopt_long(argc, argv, ":h", opts, NULL);
        if (c == -1) break;
        switch (c) {
        case 's':
            if (!strcmp(optarg, "diffuse"))
                m = PL_MATERIAL_DIFFUSE;
            else if (!strcmp(optarg, "glossy"))
                m = PL_MATERIAL_GLOSSY;
            else {
                fprintf(stderr, "parlight compare: --sphere '%s': expected diffuse or glossy\n",
                        optarg);
                return 2;
            }
            break;
        case 'S': {
            char *end;
            long v = strtol(optarg, &end, 10);
            if (end == optarg || *end || v < 1 || v > 4096) {
                fprintf(stderr, "parlight compare: --size '%s': expected an integer in 1..4096\n",
                        optarg);
                return 2;
            }
            size = (int)v;
            break;
        }
        case 'j':
            json = 1;
            break;
        case CLI_OPT_MAX_PIXELS:
            if (cli_max_pixels("compare", optarg) < 0) return 2;
            break;
        case 'h':
            usage(stdout);
            return 0;
        default:
            return cli_getopt_error("compare", c, argv);
        }
    }
    if (argc - optind != 2) {
        fprintf(stderr, "parlight compare: expected two inputs A B, got %d\n", argc - optind);
        usage(stderr);
        return 2;
    }
    const char *a_path = argv[optind], *b_path = argv[optind + 1];
    pl_image_f32 a = {0, 0, NULL}, b = {0, 0, NULL};
    int rc = render_input(a_path, m, size, &a);
    if (rc == 0) rc = render_input(b_path, m, size, &b);
    if (rc < 0) {
        fprintf(stderr, "parlight compare: %s\n", pl_last_error());
        pl_image_f32_free(&a);
        pl_image_f32_free(&b);
        return 1;
    }
    double rmse = pl_render_rmse(&a, &b), si = pl_render_si_rmse(&a, &b);
    pl_image_f32_free(&a);
    pl_image_f32_free(&b);
    const char *mat = m == PL_MATERIAL_DIFFUSE ? "diffuse" : "glossy";
    if (json) {
        printf("{\"a\":");
        pl_app_put_json_string(stdout, a_path);
        printf(",\"b\":");
        pl_app_put_json_string(stdout, b_path);
        printf(",\"sphere\":\"%s\",\"size\":%d,\"rmse\":%.9g,\"si_rmse\":%.9g}\n", mat, size, rmse,
               si);
    } else
        printf("rmse %.6g\nsi_rmse %.6g\n", rmse, si);
    return 0;
}
