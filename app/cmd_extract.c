/* parlight extract: ground-truth lights + ambient from an HDR panorama (light/extract.h,
 * docs/EXTRACTION.md). */
#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "app/cli.h"
#include "app/commands.h"
#include "app/lightdata.h"
#include "core/util.h"
#include "light/extract.h"
#include "port/hdr_io.h"

static void usage(FILE *f)
{
    fprintf(
        f,
        "usage: parlight extract --hdr PANO [--json] [options]\n"
        "\n"
        "Extracts the parametric lights (direction, size, colour; distance from an assumed room)\n"
        "and the ambient term of an HDR equirectangular panorama (.exr or .hdr, width = 2 x "
        "height),\n"
        "as the paper's dataset section does (docs/EXTRACTION.md). --json prints the lights JSON\n"
        "that `parlight render --lights` and `parlight compare` read.\n"
        "\n"
        "  --hdr FILE            the panorama\n"
        "  --json                print JSON (default: a readable table)\n"
        "  --out FILE            write the JSON to FILE instead of stdout (implies --json)\n"
        "  --force               overwrite --out if it exists\n"
        "  --max-lights K        keep at most K lights (1..%d, default %d)\n"
        "  --room-height M       assumed floor-to-ceiling height, metres (default 2.8)\n"
        "  --camera-height M     assumed camera height above the floor (default 1.6)\n"
        "  --room-width M        assumed room width (x), camera centred (default 6)\n"
        "  --room-depth M        assumed room depth (z), camera centred (default 6)\n"
        "  --no-refine           keep the mean colours (skip the least-squares refinement)\n"
        "  --max-pixels N        panoramas of up to N pixels (default 67108864 = 64 Mi; at most "
        "268435456)\n"
        "  -h, --help            this text\n",
        PL_MAX_LIGHTS, PL_MAX_LIGHTS);
}

int cmd_extract(int argc, char **argv)
{
    static const struct option opts[] = {{"hdr", required_argument, 0, 'i'},
                                         {"json", no_argument, 0, 'j'},
                                         {"out", required_argument, 0, 'o'},
                                         {"force", no_argument, 0, 'f'},
                                         {"max-lights", required_argument, 0, 'k'},
                                         {"room-height", required_argument, 0, 'R'},
                                         {"camera-height", required_argument, 0, 'C'},
                                         {"room-width", required_argument, 0, 'W'},
                                         {"room-depth", required_argument, 0, 'D'},
                                         {"no-refine", no_argument, 0, 'n'},
                                         {"max-pixels", required_argument, 0, CLI_OPT_MAX_PIXELS},
                                         {"help", no_argument, 0, 'h'},
                                         {0, 0, 0, 0}};
    const char *hdr = NULL, *out_path = NULL;
    int json = 0, force = 0;
    pl_extract_params prm;
    pl_extract_default_params(&prm);
    double v;
    optind = 1;
    opterr = 0;
    int c;
    while ((c = getopt_long(argc, argv, ":h", opts, NULL)) != -1) {
        switch (c) {
        case 'i':
            hdr = optarg;
            break;
        case 'j':
            json = 1;
            break;
        case 'o':
            out_path = optarg, json = 1;
            break;
        case 'f':
            force = 1;
            break;
        case 'k':
            if (cli_int("extract", "--max-lights", optarg, 1, PL_MAX_LIGHTS, &prm.max_lights) < 0)
                return 2;
            break;
        case 'R':
            if (pl_app_double("extract", "--room-height", optarg, 0.1, 1000,
                              &prm.room.room_height) < 0)
                return 2;
            break;
        case 'C':
            if (pl_app_double("extract", "--camera-height", optarg, 0.01, 1000,
                              &prm.room.camera_height) < 0)
                return 2;
            break;
        case 'W':
            if (pl_app_double("extract", "--room-width", optarg, 0.1, 2000, &v) < 0) return 2;
            prm.room.half_width = v / 2;
            break;
        case 'D':
            if (pl_app_double("extract", "--room-depth", optarg, 0.1, 2000, &v) < 0) return 2;
            prm.room.half_depth = v / 2;
            break;
        case 'n':
            prm.refine = 0;
            break;
        case CLI_OPT_MAX_PIXELS:
            if (cli_max_pixels("extract", optarg) < 0) return 2;
            break;
        case 'h':
            usage(stdout);
            return 0;
        default:
            return cli_getopt_error("extract", c, argv);
        }
    }
    if (optind < argc) {
        fprintf(stderr, "parlight extract: unexpected argument '%s'\n", argv[optind]);
        return 2;
    }
    if (!hdr) {
        fprintf(stderr, "parlight extract: --hdr PANO is required\n");
        usage(stderr);
        return 2;
    }
    if (pl_extract_check_params(&prm) < 0) {
        fprintf(stderr, "parlight extract: %s\n", pl_last_error());
        return 2;
    }
    if (out_path && !force && access(out_path, F_OK) == 0) {
        fprintf(stderr, "parlight extract: %s already exists (use --force to overwrite)\n",
                out_path);
        return 1;
    }
    int64_t t0 = pl_now_ns();
    pl_image_f32 pano;
    if (pl_hdr_read_panorama(hdr, &pano) < 0) {
        fprintf(stderr, "parlight extract: %s\n", pl_last_error());
        return 1;
    }
    double read_ms = (double)(pl_now_ns() - t0) / 1e6;
    pl_lighting L;
    pl_extract_info info;
    int rc = pl_extract_lights(&pano, &prm, &L, &info);
    int W = pano.width, H = pano.height;
    pl_image_f32_free(&pano);
    if (rc < 0) {
        fprintf(stderr, "parlight extract: %s: %s\n", hdr, pl_last_error());
        return 1;
    }
    if (json) {
        FILE *f = stdout;
        if (out_path && !(f = fopen(out_path, "w"))) {
            fprintf(stderr, "parlight extract: cannot create %s\n", out_path);
            return 1;
        }
        fputc('{', f);
        rc = pl_app_put_extract_json(f, hdr, W, H, &L, &prm, &info, 1);
        fprintf(f, ",\"read_ms\":%.3f}\n", read_ms);
        int bad = ferror(f);
        if (out_path && fclose(f) != 0) bad = 1;
        if (rc < 0 || bad) {
            fprintf(stderr, "parlight extract: writing the JSON failed%s%s\n", rc < 0 ? ": " : "",
                    rc < 0 ? pl_last_error() : "");
            return 1;
        }
        return 0;
    }
    printf("%s: %d x %d, peak %.4g, %d candidate region(s), %d light(s) kept; read %.1f ms, "
           "extract %.1f ms (detect %.1f, refine %.1f)\n",
           hdr, W, H, info.peak, info.n_candidates, L.n_lights, read_ms, info.ms_total,
           info.ms_detect, info.ms_refine);
    printf("  #  dir (x, y, z)              elev   azim   dist*  solid_sr  rgb (peak radiance)     "
           "     energy\n");
    for (int i = 0; i < L.n_lights; i++) {
        const pl_light *l = &L.lights[i];
        double el = asin(fmax(-1.0, fmin(1.0, l->dir[1]))) * 180 / M_PI;
        double az = atan2(l->dir[0], -l->dir[2]) * 180 / M_PI;
        printf(
            "  %d  (%6.3f, %6.3f, %6.3f)  %6.1f %6.1f  %5.2f  %8.4f  (%8.3f, %8.3f, %8.3f)  %.4g\n",
            i, l->dir[0], l->dir[1], l->dir[2], el, az, l->distance_m, l->solid_angle_sr, l->rgb[0],
            l->rgb[1], l->rgb[2], info.light[i].fitted_energy);
    }
    printf("  ambient (%.4f, %.4f, %.4f)\n  * distance assumed from a %.1f m high room, camera at "
           "%.1f m, "
           "walls %.1f m / %.1f m away\n",
           L.ambient[0], L.ambient[1], L.ambient[2], prm.room.room_height, prm.room.camera_height,
           prm.room.half_width, prm.room.half_depth);
    return 0;
}
