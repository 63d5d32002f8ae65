/* parlight render: environment maps, cube maps and sphere renders from a lights JSON (or a
 * panorama), at the camera or at another point (docs/LIGHTING.md). */
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
    fprintf(
        f, "usage: parlight render (--lights L.json | --env PANO.exr|.hdr) --out OUT [options]\n"
           "\n"
           "Renders the lighting (eq. 4: spherical Gaussians + ambient) to an image file.\n"
           "OUT .exr/.hdr is linear float RGB; .png is tonemapped (99th percentile -> 1, sRGB, "
           "8-bit).\n"
           "\n"
           "  --lights FILE      lights JSON ({\"lights\":[...],\"ambient\":[...]}, e.g. an "
           "estimate line)\n"
           "  --env FILE         an equirectangular panorama instead (cube map or sphere only)\n"
           "  --out FILE         output image (.exr, .hdr or .png)\n"
           "  --width W          environment map width, height W/2 (default 512, even)\n"
           "  --at x,y,z         relight at this point (metres, camera frame) first (lights only:\n"
           "                     a panorama has no depth)\n"
           "  --cubemap FACE     write a cube map of FACE x FACE faces instead of the panorama\n"
           "  --layout L         cube-map layout: cross (4x3 horizontal cross, default) or strip\n"
           "                     (6x1: +X -X +Y -Y +Z -Z)\n"
           "  --sphere M         render a sphere instead: diffuse or glossy\n"
           "  --size S           sphere render size in pixels (default 256)\n"
           "  --force            overwrite OUT if it exists\n"
           "  --max-pixels N     panoramas of up to N pixels (default 67108864 = 64 Mi; at most "
           "268435456)\n"
           "  -h, --help         this text\n");
}

/* Lays the 6 faces out as a horizontal cross (4F x 3F, unused cells 0) or a 6F x F strip. */
static int cube_image(const float *faces, int F, int cross, pl_image_f32 *out)
{
    int w = cross ? 4 * F : 6 * F, h = cross ? 3 * F : F;
    int rc = pl_image_f32_alloc(out, w, h);
    if (rc < 0) return rc;
    memset(out->data, 0, (size_t)w * (size_t)h * 3 * sizeof(float));
    /* cross cells (column, row) of +X, -X, +Y, -Y, +Z, -Z */
    static const int cell[6][2] = {{2, 1}, {0, 1}, {1, 0}, {1, 2}, {1, 1}, {3, 1}};
    for (int f = 0; f < 6; f++) {
        int cx = cross ? cell[f][0] : f, cy = cross ? cell[f][1] : 0;
        for (int y = 0; y < F; y++)
            memcpy(out->data + (((size_t)(cy * F + y)) * (size_t)w + (size_t)(cx * F)) * 3,
                   faces + (((size_t)f * (size_t)F + (size_t)y) * (size_t)F) * 3,
                   (size_t)F * 3 * sizeof(float));
    }
    return 0;
}

static int parse_int(const char *s, const char *flag, int lo, int hi, int *out)
{
    char *end;
    long v = strtol(s, &end, 10);
    if (end == s || *end || v < lo || v > hi) {
        fprintf(stderr, "parlight render: %s '%s': expected an integer in %d..%d\n", flag, s, lo,
                hi);
        return -1;
    }
    *out = (int)v;
    return 0;
}

int cmd_render(int argc, char **argv)
{
    static const struct option opts[] = {{"lights", required_argument, 0, 'l'},
                                         {"env", required_argument, 0, 'e'},
                                         {"out", required_argument, 0, 'o'},
                                         {"width", required_argument, 0, 'w'},
                                         {"at", required_argument, 0, 'a'},
                                         {"cubemap", required_argument, 0, 'c'},
                                         {"layout", required_argument, 0, 'L'},
                                         {"sphere", required_argument, 0, 's'},
                                         {"size", required_argument, 0, 'S'},
                                         {"force", no_argument, 0, 'f'},
                                         {"max-pixels", required_argument, 0, CLI_OPT_MAX_PIXELS},
                                         {"help", no_argument, 0, 'h'},
                                         {0, 0, 0, 0}};
    const char *lights_path = NULL, *env_path = NULL, *out_path = NULL, *at = NULL;
    int width = 512, face = 0, cross = 1, size = 256, force = 0, sphere = -1;
    optind = 1;
    opterr = 0;
    for (;;) {
        int c = getopt_long(argc, argv, ":h", opts, NULL);
        if (c == -1) break;
        switch (c) {
        case 'l':
            lights_path = optarg;
            break;
        case 'e':
            env_path = optarg;
            break;
        case 'o':
            out_path = optarg;
            break;
        case 'a':
            at = optarg;
            break;
        case 'f':
            force = 1;
            break;
        case 'w':
            if (parse_int(optarg, "--width", 2, PL_IMAGE_MAX_SIDE, &width) < 0) return 2;
            if (width % 2) {
                fprintf(stderr, "parlight render: --width %d: expected an even number\n", width);
                return 2;
            }
            break;
        case 'c':
            if (parse_int(optarg, "--cubemap", 1, 4096, &face) < 0) return 2;
            break;
        case 'S':
            if (parse_int(optarg, "--size", 1, 4096, &size) < 0) return 2;
            break;
        case 'L':
            if (!strcmp(optarg, "cross"))
                cross = 1;
            else if (!strcmp(optarg, "strip"))
                cross = 0;
            else {
                fprintf(stderr, "parlight render: --layout '%s': expected cross or strip\n",
                        optarg);
                return 2;
            }
            break;
        case 's':
            if (!strcmp(optarg, "diffuse"))
                sphere = PL_MATERIAL_DIFFUSE;
            else if (!strcmp(optarg, "glossy"))
                sphere = PL_MATERIAL_GLOSSY;
            else {
                fprintf(stderr, "parlight render: --sphere '%s': expected diffuse or glossy\n",
                        optarg);
                return 2;
            }
            break;
        case CLI_OPT_MAX_PIXELS:
            if (cli_max_pixels("render", optarg) < 0) return 2;
            break;
        case 'h':
            usage(stdout);
            return 0;
        default:
            return cli_getopt_error("render", c, argv);
        }
    }
    if (optind < argc) {
        fprintf(stderr, "parlight render: unexpected argument '%s'\n", argv[optind]);
        return 2;
    }
    if (!!lights_path == !!env_path) {
        fprintf(stderr, "parlight render: give exactly one of --lights or --env\n");
        return 2;
    }
    if (!out_path) {
        fprintf(stderr, "parlight render: --out is required\n");
        return 2;
    }
    if (pl_app_output_kind(out_path) == 0) {
        fprintf(stderr, "parlight render: --out %s: expected a .exr, .hdr or .png file\n",
                out_path);
        return 2;
    }
    if (face && sphere >= 0) {
        fprintf(stderr, "parlight render: --cubemap and --sphere are exclusive\n");
        return 2;
    }
    if (env_path && at) {
        fprintf(stderr,
                "parlight render: --at needs --lights (a panorama has no depth to relight)\n");
        return 2;
    }
    if (env_path && !face && sphere < 0) {
        fprintf(stderr, "parlight render: with --env, give --cubemap or --sphere\n");
        return 2;
    }
    float p[3];
    if (at && pl_app_parse_point(at, p) < 0) {
        fprintf(stderr, "parlight render: %s\n", pl_last_error());
        return 2;
    }

    pl_lighting L;
    pl_image_f32 env = {0, 0, NULL}, img = {0, 0, NULL};
    float *faces = NULL;
    int rc;
    if (lights_path) {
        rc = pl_lighting_read_json(lights_path, &L);
        if (rc == 0 && at) rc = pl_lighting_at_point(&L, p, &L);
    } else {
        rc = pl_hdr_read_panorama(env_path, &env);
    }
    if (rc < 0) goto fail;
    if (face) {
        size_t n = (size_t)6 * (size_t)face * (size_t)face * 3;
        faces = malloc(n * sizeof *faces);
        if (!faces) {
            rc = pl_error(PL_E_NOMEM, "cube map %d: out of memory", face);
            goto fail;
        }
        rc = lights_path ? pl_cubemap_from_lights(&L, face, faces)
                         : pl_cubemap_from_envmap(&env, face, faces);
        if (rc == 0) rc = cube_image(faces, face, cross, &img);
    } else if (sphere >= 0) {
        rc = lights_path ? pl_render_sphere_lights(&L, (pl_material)sphere, size, &img)
                         : pl_render_sphere_envmap(&env, (pl_material)sphere, size, &img);
    } else {
        rc = pl_envmap_from_lights(&L, width, &img);
    }
    if (rc == 0) rc = pl_app_write_image(out_path, &img, force);
fail:
    free(faces);
    pl_image_f32_free(&env);
    pl_image_f32_free(&img);
    if (rc < 0) {
        fprintf(stderr, "parlight render: %s\n", pl_last_error());
        return 1;
    }
    return 0;
}
