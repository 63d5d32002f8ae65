/* parlight crop: perspective LDR crops of an HDR panorama with their ground truth (light/crop.h,
 * docs/EXTRACTION.md "Crops"). */
#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>
#include <unistd.h>

#include "app/cli.h"
#include "app/commands.h"
#include "app/light_io.h"
#include "app/lightdata.h"
#include "core/util.h"
#include "light/crop.h"
#include "light/eval.h"
#include "light/extract.h"
#include "light/light.h"
#include "port/hdr_io.h"
#include "port/image_jpeg.h"

static void usage(FILE *f)
{
    fprintf(
        f,
        "usage: parlight crop --hdr PANO --yaw D --pitch D --fov D --out CROP.png [--gt GT.json]\n"
        "       parlight crop --hdr PANO --batch N --out-dir DIR\n"
        "       parlight crop --hdr PANO --list FILE [--size WxH] [--gt-map W]\n"
        "\n"
        "Renders a perspective LDR crop of an HDR equirectangular panorama (pinhole at its "
        "centre,\n"
        "bilinear sampling), exposed automatically (the crop's median luminance -> 0.18, then\n"
        "--exposure EV), through the response v = clip(k L)^(1/gamma), 8 bits. The ground truth\n"
        "(GT.json) is `parlight extract` of the panorama rotated into the crop's camera frame, "
        "with\n"
        "colours and ambient times the exposure scale k (fields exposure_scale, yaw_deg, "
        "pitch_deg,\n"
        "fov_deg added). Batch mode writes the paper's crops: N yaws 360/N apart at pitch 0, fov "
        "60\n"
        "(N = 8: yaw 0, 45, ..., 315), as DIR/<name>_yawDDD.png and .json. List mode makes\n"
        "many crops of one panorama, read and extracted once (what tools/train/make_dataset.py\n"
        "uses): FILE has one crop a line, 7 tab-separated fields: OUT.png GT.json yaw pitch\n"
        "fov exposure gamma (ranges as the flags; '#' lines and empty lines skipped).\n"
        "\n"
        "  --hdr FILE          the panorama (.exr/.hdr, width = 2 x height)\n"
        "  --yaw D             longitude of the view centre, degrees (0 = panorama centre, + = "
        "right)\n"
        "  --pitch D           latitude of the view centre, degrees (+ = up), default 0\n"
        "  --fov D             horizontal field of view, degrees (default 60)\n"
        "  --size WxH          output size (default 640x480)\n"
        "  --exposure EV       offset of the automatic exposure, stops (default 0)\n"
        "  --gamma G           response exponent 1/G (default 2.2; 1 = linear)\n"
        "  --out FILE          the crop: .png, or .jpg/.jpeg (quality --quality, default 90)\n"
        "  --gt FILE           the ground-truth JSON\n"
        "  --gt-map W          add the panorama itself to GT.json, rotated into the crop's\n"
        "                      camera frame, times k, area-averaged to W x W/2 (even, 4..256):\n"
        "                      field radiance_map (docs/EXTRACTION.md, \"Crops\")\n"
        "  --batch N           batch mode: N crops (1..64)\n"
        "  --list FILE         list mode: the crops listed in FILE (- for standard input)\n"
        "  --out-dir DIR       batch mode output folder (created if missing)\n"
        "  --format png|jpg    batch mode image format (default png)\n"
        "  --quality Q         JPEG quality 1..100 (default 90)\n"
        "  --max-lights K      keep at most K extracted lights (default %d)\n"
        "  --force             overwrite existing outputs\n"
        "  --max-pixels N      panoramas of up to N pixels (default 67108864 = 64 Mi; at most "
        "268435456)\n"
        "  -h, --help          this text\n",
        PL_MAX_LIGHTS);
}

static int has_ext(const char *p, const char *e)
{
    size_t n = strlen(p), m = strlen(e);
    return n >= m && !strcasecmp(p + n - m, e);
}

static int write_crop(const char *path, const pl_image_u8 *img, int quality)
{
    if (has_ext(path, ".jpg") || has_ext(path, ".jpeg"))
        return pl_image_write_jpeg(path, img, quality);
    return pl_image_write_rgb8(path, img);
}

/* The crop's radiance map for --gt-map: the panorama in the crop's camera frame on the crop's
 * scale (pl_eval_envmap_to_camera at the truth render's width, so the rotation is sampled finely),
 * then area-averaged to width x width/2 (pl_envmap_downsample). */
static int radiance_map(const pl_image_f32 *pano, const pl_crop_params *cp, double k, int width,
                        pl_image_f32 *out)
{
    pl_image_f32 cam = {0, 0, NULL};
    int rc = pl_eval_envmap_to_camera(pano, cp, k, PL_EVAL_TRUTH_MAP_WIDTH, &cam);
    if (rc < 0) return rc;
    rc = pl_envmap_downsample(&cam, width, out);
    pl_image_f32_free(&cam);
    return rc;
}

static void put_map(FILE *f, const pl_image_f32 *m)
{
    fprintf(f,
            ",\"radiance_map\":{\"width\":%d,\"height\":%d,\"frame\":\"crop camera, "
            "equirectangular (docs/EXTRACTION.md)\",\"scale\":\"linear radiance times "
            "exposure_scale\",\"rgb\":[",
            m->width, m->height);
    size_t n = (size_t)m->width * (size_t)m->height * 3;
    for (size_t i = 0; i < n; i++)
        fprintf(f, "%s%.5g", i ? "," : "", (double)m->data[i]);
    fputs("]}", f);
}

static int write_gt(const char *path, const char *src, const pl_image_f32 *pano,
                    const pl_lighting *L, const pl_extract_params *ep, const pl_extract_info *info,
                    const pl_crop_params *cp, double k, const char *image, const pl_image_f32 *map)
{
    FILE *f = fopen(path, "w");
    if (!f) return pl_error(PL_E_IO, "%s: cannot create", path);
    fputc('{', f);
    int rc = pl_app_put_extract_json(f, src, pano->width, pano->height, L, ep, info, 0);
    fprintf(f, ",\"image\":");
    pl_app_put_json_string(f, image);
    fprintf(f,
            ",\"frame\":\"crop camera (x right, y up, looking along -z)\",\"exposure_scale\":%.9g,"
            "\"yaw_deg\":%.9g,\"pitch_deg\":%.9g,\"fov_deg\":%.9g,\"width\":%d,\"height\":%d,"
            "\"exposure_ev\":%.9g,\"gamma\":%.9g,\"exposure_rule\":\"k = 2^ev * 0.18 / median "
            "luminance of the linear crop\"",
            k, cp->yaw_deg, cp->pitch_deg, cp->fov_deg, cp->width, cp->height, cp->exposure_ev,
            cp->gamma);
    if (map) put_map(f, map);
    fputs("}\n", f);
    int bad = ferror(f);
    if (fclose(f) != 0) bad = 1;
    if (rc < 0) return rc;
    if (bad) return pl_error(PL_E_IO, "%s: write failed", path);
    return PL_OK;
}

/* One crop: image + ground truth. */
static int do_crop(const char *src, const pl_image_f32 *pano, const pl_lighting *Lp,
                   const pl_extract_params *ep, const pl_extract_info *info,
                   const pl_crop_params *cp, const char *out, const char *gt, int quality,
                   int map_width)
{
    pl_image_f32 lin = {0, 0, NULL};
    pl_image_u8 ldr = {0, 0, 0, NULL};
    int rc = pl_crop_linear(pano, cp, &lin);
    if (rc < 0) return rc;
    double k = pl_crop_exposure_scale(&lin, cp->exposure_ev);
    rc = pl_crop_to_ldr(&lin, k, cp->gamma, &ldr);
    pl_image_f32_free(&lin);
    if (rc < 0) return rc;
    rc = write_crop(out, &ldr, quality);
    pl_image_u8_free(&ldr);
    if (rc < 0 || !gt) return rc;
    pl_lighting Lc;
    if ((rc = pl_crop_lighting(Lp, cp, k, &Lc)) < 0) return rc;
    pl_image_f32 map = {0, 0, NULL};
    if (map_width && (rc = radiance_map(pano, cp, k, map_width, &map)) < 0) return rc;
    const char *base = strrchr(out, '/');
    rc = write_gt(gt, src, pano, &Lc, ep, info, cp, k, base ? base + 1 : out,
                  map_width ? &map : NULL);
    pl_image_f32_free(&map);
    return rc;
}

static int parse_size(const char *s, int *w, int *h)
{
    char x;
    int n = 0;
    if (sscanf(s, "%d%c%d%n", w, &x, h, &n) != 3 || (x != 'x' && x != 'X') || s[n] || *w < 1 ||
        *h < 1 || *w > 8192 || *h > 8192) {
        fprintf(stderr, "parlight crop: --size '%s': expected WxH, 1..8192 each\n", s);
        return -1;
    }
    return 0;
}

/* One crop of a --list file. */
typedef struct list_item {
    char out[1024], gt[1024];
    double yaw, pitch, fov, exposure, gamma;
} list_item;

/* The next tab-separated field of *s, NUL-terminated in place (*s moves past it); NULL when
 * none is left. */
static char *next_field(char **s)
{
    if (!*s) return NULL;
    char *f = *s, *t = strchr(f, '\t');
    if (t) {
        *t = '\0';
        *s = t + 1;
    } else {
        *s = NULL;
    }
    return f;
}

/* Reads a --list file (see usage) into *items (allocated), checking every field; on error says
 * which line and field and returns -1. */
static int read_list(const char *path, list_item **items, int *n)
{
    FILE *f = strcmp(path, "-") ? fopen(path, "r") : stdin;
    if (!f) {
        fprintf(stderr, "parlight crop: --list %s: cannot open\n", path);
        return -1;
    }
    char line[4096];
    int cap = 0, line_no = 0, rc = 0;
    *items = NULL;
    *n = 0;
    while (fgets(line, sizeof line, f)) {
        line_no++;
        size_t len = strlen(line);
        if (len == sizeof line - 1 && line[len - 1] != '\n') {
            fprintf(stderr, "parlight crop: %s:%d: line longer than %zu bytes\n", path, line_no,
                    sizeof line - 2);
            rc = -1;
            break;
        }
        while (len && (line[len - 1] == '\n' || line[len - 1] == '\r'))
            line[--len] = '\0';
        if (!len || line[0] == '#') continue;
        if (*n == cap) {
            int ncap = cap ? 2 * cap : 64;
            if (ncap > 1000000) {
                fprintf(stderr, "parlight crop: %s: more than 1000000 crops\n", path);
                rc = -1;
                break;
            }
            list_item *t = realloc(*items, (size_t)ncap * sizeof *t);
            if (!t) {
                fprintf(stderr, "parlight crop: %s: out of memory\n", path);
                rc = -1;
                break;
            }
            *items = t;
            cap = ncap;
        }
        list_item *it = &(*items)[*n];
        char *rest = line, *fld[7];
        int k = 0;
        while (k < 7 && (fld[k] = next_field(&rest)) != NULL)
            k++;
        if (k < 7 || rest) {
            fprintf(stderr,
                    "parlight crop: %s:%d: expected 7 tab-separated fields (OUT GT yaw pitch fov "
                    "exposure gamma)\n",
                    path, line_no);
            rc = -1;
            break;
        }
        char where[64];
        snprintf(where, sizeof where, "line %d", line_no);
        if (!*fld[0] || !*fld[1] || strlen(fld[0]) >= sizeof it->out ||
            strlen(fld[1]) >= sizeof it->gt) {
            fprintf(stderr, "parlight crop: %s:%d: empty or too long output name\n", path, line_no);
            rc = -1;
            break;
        }
        if (!(has_ext(fld[0], ".png") || has_ext(fld[0], ".jpg") || has_ext(fld[0], ".jpeg"))) {
            fprintf(stderr, "parlight crop: %s:%d: %s: expected a .png, .jpg or .jpeg name\n", path,
                    line_no, fld[0]);
            rc = -1;
            break;
        }
        snprintf(it->out, sizeof it->out, "%s", fld[0]);
        snprintf(it->gt, sizeof it->gt, "%s", fld[1]);
        if (pl_app_double("crop", where, fld[2], -360, 360, &it->yaw) < 0 ||
            pl_app_double("crop", where, fld[3], -90, 90, &it->pitch) < 0 ||
            pl_app_double("crop", where, fld[4], 1, 170, &it->fov) < 0 ||
            pl_app_double("crop", where, fld[5], -20, 20, &it->exposure) < 0 ||
            pl_app_double("crop", where, fld[6], 0.2, 5, &it->gamma) < 0) {
            fprintf(stderr,
                    "parlight crop: %s:%d: bad number (fields 3-7: yaw pitch fov exposure "
                    "gamma)\n",
                    path, line_no);
            rc = -1;
            break;
        }
        (*n)++;
    }
    if (rc == 0 && ferror(f)) {
        fprintf(stderr, "parlight crop: --list %s: read error\n", path);
        rc = -1;
    }
    if (rc == 0 && *n == 0) {
        fprintf(stderr, "parlight crop: --list %s: no crops listed\n", path);
        rc = -1;
    }
    if (f != stdin) fclose(f);
    if (rc < 0) {
        free(*items);
        *items = NULL;
        *n = 0;
    }
    return rc;
}

int cmd_crop(int argc, char **argv)
{
    static const struct option opts[] = {{"hdr", required_argument, 0, 'i'},
                                         {"yaw", required_argument, 0, 'y'},
                                         {"pitch", required_argument, 0, 'p'},
                                         {"fov", required_argument, 0, 'v'},
                                         {"size", required_argument, 0, 's'},
                                         {"exposure", required_argument, 0, 'e'},
                                         {"gamma", required_argument, 0, 'g'},
                                         {"out", required_argument, 0, 'o'},
                                         {"gt", required_argument, 0, 't'},
                                         {"gt-map", required_argument, 0, 'm'},
                                         {"batch", required_argument, 0, 'b'},
                                         {"list", required_argument, 0, 'l'},
                                         {"out-dir", required_argument, 0, 'd'},
                                         {"format", required_argument, 0, 'F'},
                                         {"quality", required_argument, 0, 'q'},
                                         {"max-lights", required_argument, 0, 'k'},
                                         {"force", no_argument, 0, 'f'},
                                         {"max-pixels", required_argument, 0, CLI_OPT_MAX_PIXELS},
                                         {"help", no_argument, 0, 'h'},
                                         {0, 0, 0, 0}};
    const char *hdr = NULL, *out = NULL, *gt = NULL, *dir = NULL, *fmt = "png", *list = NULL;
    int batch = 0, quality = 90, force = 0, have_yaw = 0, map_width = 0;
    pl_crop_params cp;
    pl_crop_default_params(&cp);
    pl_extract_params ep;
    pl_extract_default_params(&ep);
    optind = 1;
    opterr = 0;
    int c;
    while ((c = getopt_long(argc, argv, ":h", opts, NULL)) != -1) {
        switch (c) {
        case 'i':
            hdr = optarg;
            break;
        case 'y':
            if (pl_app_double("crop", "--yaw", optarg, -360, 360, &cp.yaw_deg) < 0) return 2;
            have_yaw = 1;
            break;
        case 'p':
            if (pl_app_double("crop", "--pitch", optarg, -90, 90, &cp.pitch_deg) < 0) return 2;
            break;
        case 'v':
            if (pl_app_double("crop", "--fov", optarg, 1, 170, &cp.fov_deg) < 0) return 2;
            break;
        case 's':
            if (parse_size(optarg, &cp.width, &cp.height) < 0) return 2;
            break;
        case 'e':
            if (pl_app_double("crop", "--exposure", optarg, -20, 20, &cp.exposure_ev) < 0) return 2;
            break;
        case 'g':
            if (pl_app_double("crop", "--gamma", optarg, 0.2, 5, &cp.gamma) < 0) return 2;
            break;
        case 'o':
            out = optarg;
            break;
        case 't':
            gt = optarg;
            break;
        case 'm':
            if (cli_int("crop", "--gt-map", optarg, 4, 256, &map_width) < 0) return 2;
            if (map_width % 2) {
                fprintf(stderr, "parlight crop: --gt-map %d: expected an even width\n", map_width);
                return 2;
            }
            break;
        case 'b':
            if (cli_int("crop", "--batch", optarg, 1, 64, &batch) < 0) return 2;
            break;
        case 'l':
            list = optarg;
            break;
        case 'd':
            dir = optarg;
            break;
        case 'F':
            if (strcmp(optarg, "png") && strcmp(optarg, "jpg")) {
                fprintf(stderr, "parlight crop: --format '%s': expected png or jpg\n", optarg);
                return 2;
            }
            fmt = optarg;
            break;
        case 'q':
            if (cli_int("crop", "--quality", optarg, 1, 100, &quality) < 0) return 2;
            break;
        case 'k':
            if (cli_int("crop", "--max-lights", optarg, 1, PL_MAX_LIGHTS, &ep.max_lights) < 0)
                return 2;
            break;
        case 'f':
            force = 1;
            break;
        case CLI_OPT_MAX_PIXELS:
            if (cli_max_pixels("crop", optarg) < 0) return 2;
            break;
        case 'h':
            usage(stdout);
            return 0;
        default:
            return cli_getopt_error("crop", c, argv);
        }
    }
    if (optind < argc) {
        fprintf(stderr, "parlight crop: unexpected argument '%s'\n", argv[optind]);
        return 2;
    }
    if (!hdr) {
        fprintf(stderr, "parlight crop: --hdr PANO is required\n");
        return 2;
    }
    list_item *items = NULL;
    int n_items = 0;
    if (list) {
        if (batch || dir || out || gt || have_yaw) {
            fprintf(stderr, "parlight crop: --list takes no --batch, --out-dir, --out, --gt or "
                            "--yaw (the list gives them)\n");
            return 2;
        }
        if (read_list(list, &items, &n_items) < 0) return 2;
        for (int i = 0; i < n_items && !force; i++) {
            const char *chk[2] = {items[i].out, items[i].gt};
            for (int j = 0; j < 2; j++)
                if (access(chk[j], F_OK) == 0) {
                    fprintf(stderr, "parlight crop: %s already exists (use --force to overwrite)\n",
                            chk[j]);
                    free(items);
                    return 1;
                }
        }
    } else if (batch) {
        if (!dir || out || gt || have_yaw) {
            fprintf(stderr,
                    "parlight crop: --batch needs --out-dir and takes no --out, --gt or --yaw\n");
            return 2;
        }
    } else if (!out || dir) {
        fprintf(stderr, "parlight crop: --out FILE is required (or --batch N --out-dir DIR)\n");
        return 2;
    }
    if (!batch && !list &&
        !(has_ext(out, ".png") || has_ext(out, ".jpg") || has_ext(out, ".jpeg"))) {
        fprintf(stderr, "parlight crop: --out %s: expected a .png, .jpg or .jpeg name\n", out);
        return 2;
    }
    if (!batch && !list && !force) {
        const char *chk[2] = {out, gt};
        for (int i = 0; i < 2; i++)
            if (chk[i] && access(chk[i], F_OK) == 0) {
                fprintf(stderr, "parlight crop: %s already exists (use --force to overwrite)\n",
                        chk[i]);
                return 1;
            }
    }
    /* batch names: DIR/<panorama stem>_yawDDD.<fmt> and .json */
    char stem[256];
    const char *b = strrchr(hdr, '/');
    snprintf(stem, sizeof stem, "%s", b ? b + 1 : hdr);
    char *dot = strrchr(stem, '.');
    if (dot) *dot = '\0';
    char(*names)[2][1024] = NULL;
    if (batch) {
        if (mkdir(dir, 0755) != 0 && access(dir, W_OK) != 0) {
            fprintf(stderr, "parlight crop: cannot create or write %s\n", dir);
            return 1;
        }
        names = calloc((size_t)batch, sizeof *names);
        if (!names) return 1;
        for (int i = 0; i < batch; i++) {
            int yaw = (int)lround(360.0 * i / batch);
            snprintf(names[i][0], sizeof names[i][0], "%s/%s_yaw%03d.%s", dir, stem, yaw, fmt);
            snprintf(names[i][1], sizeof names[i][1], "%s/%s_yaw%03d.json", dir, stem, yaw);
            for (int j = 0; j < 2 && !force; j++)
                if (access(names[i][j], F_OK) == 0) {
                    fprintf(stderr, "parlight crop: %s already exists (use --force to overwrite)\n",
                            names[i][j]);
                    free(names);
                    return 1;
                }
        }
    }
    pl_image_f32 pano;
    if (pl_hdr_read_panorama(hdr, &pano) < 0) {
        fprintf(stderr, "parlight crop: %s\n", pl_last_error());
        free(names);
        free(items);
        return 1;
    }
    pl_lighting L;
    pl_extract_info info;
    int rc = pl_extract_lights(&pano, &ep, &L, &info);
    if (rc < 0) {
        fprintf(stderr, "parlight crop: %s: %s\n", hdr, pl_last_error());
        pl_image_f32_free(&pano);
        free(names);
        free(items);
        return 1;
    }
    if (list) {
        for (int i = 0; i < n_items && rc == 0; i++) {
            cp.yaw_deg = items[i].yaw;
            cp.pitch_deg = items[i].pitch;
            cp.fov_deg = items[i].fov;
            cp.exposure_ev = items[i].exposure;
            cp.gamma = items[i].gamma;
            rc = do_crop(hdr, &pano, &L, &ep, &info, &cp, items[i].out, items[i].gt, quality,
                         map_width);
        }
    } else if (!batch) {
        rc = do_crop(hdr, &pano, &L, &ep, &info, &cp, out, gt, quality, map_width);
    } else {
        for (int i = 0; i < batch && rc == 0; i++) {
            cp.yaw_deg = 360.0 * i / batch;
            cp.pitch_deg = cp.pitch_deg; /* --pitch applies to all (default 0) */
            rc = do_crop(hdr, &pano, &L, &ep, &info, &cp, names[i][0], names[i][1], quality,
                         map_width);
            if (rc == 0) printf("%s %s\n", names[i][0], names[i][1]);
        }
    }
    pl_image_f32_free(&pano);
    free(names);
    free(items);
    if (rc < 0) {
        fprintf(stderr, "parlight crop: %s\n", pl_last_error());
        return 1;
    }
    return 0;
}
