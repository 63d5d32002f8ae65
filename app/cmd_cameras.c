/* parlight cameras: the V4L2 capture devices with their formats, frame sizes and rates, and the
 * cameras libcamera sees. */
#include <dirent.h>
#include <getopt.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "app/cli.h"
#include "app/commands.h"
#include "core/util.h"
#include "parlight.h"
#include "port/libcamera_src.h"
#include "port/v4l2.h"

static void help(FILE *f)
{
    fprintf(f,
            "usage: parlight cameras [--device PATH]\n"
            "       parlight cameras --grab SPEC [--frames N]\n\n"
            "Lists the V4L2 video capture devices (/dev/video*, in number order) with their\n"
            "driver, card name, pixel formats, frame sizes and frame rates. Formats parlight\n"
            "reads (YUYV, NV12, RGB24, MJPEG) are marked 'usable'; use one with\n"
            "  parlight estimate --camera v4l2:/dev/videoN[:WxH[@FPS][:yuyv|nv12|rgb24|mjpeg]]\n"
            "Nodes that are not capture devices (outputs, metadata, VBI) are named and skipped.\n"
            "Then the cameras libcamera sees, for --camera libcamera[:ID|N] (a UVC camera\n"
            "appears in both lists).\n"
            "Exit status: 0 when at least one camera was listed, 1 otherwise.\n\n"
            "  --device PATH   list only this device node\n"
            "  --grab SPEC     capture from a camera without a model, to check it: opens SPEC\n"
            "                  (v4l2:/dev/videoN[:WxH[@FPS][:FORMAT]] or libcamera[:ID|N]), reads\n"
            "                  N frames (default\n"
            "                  10) and prints one line per frame (index, driver time, size, mean\n"
            "                  R G B after conversion) and the frame rate; exit 0 when all N came\n"
            "  --frames N      frames to grab, 1..100000\n");
}

static void print_rate(const pl_v4l2_interval *iv)
{
    if (!iv->num || !iv->den) {
        printf("?");
        return;
    }
    printf("%.4g", (double)iv->den / iv->num);
}

static void print_device(const pl_v4l2_device_info *d)
{
    printf("%s: %s (driver %s, bus %s)\n", d->path, d->card, d->driver, d->bus_info);
    char fcc[5];
    for (int i = 0; i < d->n_formats; i++) {
        const pl_v4l2_format_info *f = &d->formats[i];
        printf("  %-5s %-32s%s%s\n", pl_v4l2_fourcc_str(f->fourcc, fcc), f->description,
               f->compressed ? " compressed" : "", f->usable ? " usable" : "");
        for (int k = 0; k < f->n_sizes; k++) {
            const pl_v4l2_frame_size *s = &f->sizes[k];
            if (s->stepwise)
                printf("        %ux%u to %ux%u, step %ux%u", s->width, s->height, s->max_width,
                       s->max_height, s->step_width, s->step_height);
            else
                printf("        %ux%u", s->width, s->height);
            if (s->n_intervals) {
                printf(" @ ");
                if (s->interval_stepwise) {
                    print_rate(&s->intervals[1]);
                    printf(" to ");
                    print_rate(&s->intervals[0]);
                } else {
                    for (int j = 0; j < s->n_intervals; j++) {
                        printf(j ? ", " : "");
                        print_rate(&s->intervals[j]);
                    }
                }
                printf(" fps");
            }
            printf("\n");
        }
    }
}

typedef int (*read_fn)(void *cam, pl_image_u8 *img, size_t *capacity, int64_t *t_ns,
                       int64_t *index);

/* Reads n frames, printing one line each; bad frames and lost-device attempts are warned about
 * and counted, as parlight estimate does. Returns the exit status. */
static int grab_frames(void *cam, read_fn read, int n)
{
    pl_image_u8 img = {0, 0, 0, NULL};
    size_t cap = 0;
    int got = 0, failed = 0, rc = 0;
    int64_t t_first = 0, t_last = 0;
    while (got < n) {
        int64_t t_ns, index;
        int st = read(cam, &img, &cap, &t_ns, &index);
        if (st == PL_E_EOF) {
            fprintf(stderr, "parlight cameras: %s\n", pl_last_error());
            rc = 1;
            break;
        }
        if (st < 0) {
            fprintf(stderr, "parlight cameras: warning: %s\n", pl_last_error());
            failed++;
            continue;
        }
        double sum[3] = {0, 0, 0};
        for (int y = 0; y < img.height; y++) {
            const uint8_t *row = img.data + (size_t)y * img.stride;
            for (int x = 0; x < img.width; x++)
                for (int k = 0; k < 3; k++)
                    sum[k] += row[3 * x + k];
        }
        const double np = (double)img.width * img.height;
        printf("frame %lld t_ns %lld %dx%d mean_rgb %.2f %.2f %.2f\n", (long long)index,
               (long long)t_ns, img.width, img.height, sum[0] / np, sum[1] / np, sum[2] / np);
        fflush(stdout);
        if (got == 0) t_first = t_ns;
        t_last = t_ns;
        got++;
    }
    if (got > 1 && t_last > t_first)
        printf("%d frames, %.2f frames/s (driver timestamps), %d failed reads\n", got,
               (got - 1) / ((double)(t_last - t_first) / 1e9), failed);
    else
        printf("%d frames, %d failed reads\n", got, failed);
    fflush(stdout);
    pl_image_u8_free(&img);
    return rc;
}

static int read_v4l2(void *cam, pl_image_u8 *img, size_t *capacity, int64_t *t_ns, int64_t *index)
{
    return pl_v4l2_read(cam, img, capacity, t_ns, index);
}

static int read_libcam(void *cam, pl_image_u8 *img, size_t *capacity, int64_t *t_ns, int64_t *index)
{
    return pl_libcam_read(cam, img, capacity, t_ns, index);
}

/* --grab: a camera without a model. */
static int grab(const char *spec, int n)
{
    if (pl_libcam_is_spec(spec)) {
        pl_libcam *cam = NULL;
        if (pl_libcam_open(spec, &cam) < 0) {
            fprintf(stderr, "parlight cameras: %s\n", pl_last_error());
            return 1;
        }
        printf("%s\n", pl_libcam_describe(cam));
        int rc = grab_frames(cam, read_libcam, n);
        pl_libcam_close(cam);
        return rc;
    }
    pl_v4l2_spec vs;
    pl_v4l2 *cam = NULL;
    if (pl_v4l2_parse_spec(spec, &vs) < 0 || pl_v4l2_open(&vs, &cam) < 0) {
        fprintf(stderr, "parlight cameras: %s\n", pl_last_error());
        return 1;
    }
    int w, h;
    uint32_t fourcc;
    const char *coding;
    char fcc[5];
    double fps = 0;
    pl_v4l2_format(cam, &w, &h, &fourcc, &coding);
    (void)pl_v4l2_fps(cam, &fps);
    printf("%s: %dx%d %s, %s, %.4g fps nominal\n", pl_v4l2_describe(cam), w, h,
           pl_v4l2_fourcc_str(fourcc, fcc), coding, fps);
    int rc = grab_frames(cam, read_v4l2, n);
    pl_v4l2_close(cam);
    return rc;
}

/* The cameras libcamera sees; returns how many (0 when none or libcamera is unavailable). */
static int list_libcamera(void)
{
    char buf[4096];
    int count = 0;
    if (pl_libcam_list(buf, sizeof buf, &count) < 0) {
        printf("libcamera: %s\n", pl_last_error());
        return 0;
    }
    if (!count) {
        printf("libcamera: no cameras\n");
        return 0;
    }
    printf("libcamera: %d camera%s\n%s", count, count == 1 ? "" : "s", buf);
    if (buf[0] && buf[strlen(buf) - 1] != '\n') printf("\n");
    return count;
}

/* Lists one node; returns 1 when it was a capture device, 0 when skipped, -1 on error. */
static int list_one(const char *path)
{
    pl_v4l2_device_info d;
    if (pl_v4l2_query_device(path, &d) < 0) {
        fprintf(stderr, "parlight cameras: %s\n", pl_last_error());
        return -1;
    }
    int rc = 0;
    if (d.is_capture) {
        print_device(&d);
        rc = 1;
    } else {
        printf("%s: %s (driver %s): not a video capture device, skipped\n", d.path, d.card,
               d.driver);
    }
    pl_v4l2_device_info_free(&d);
    return rc;
}

static int video_number(const char *name)
{
    if (strncmp(name, "video", 5) != 0 || !name[5]) return -1;
    int n = 0;
    for (const char *p = name + 5; *p; p++) {
        if (*p < '0' || *p > '9' || n > 100000) return -1;
        n = n * 10 + (*p - '0');
    }
    return n;
}

static int cmp_int(const void *a, const void *b)
{
    return *(const int *)a - *(const int *)b;
}

int cmd_cameras(int argc, char **argv)
{
    static const struct option opts[] = {{"device", required_argument, 0, 'd'},
                                         {"grab", required_argument, 0, 'g'},
                                         {"frames", required_argument, 0, 'n'},
                                         {"help", no_argument, 0, 'h'},
                                         {0, 0, 0, 0}};
    const char *device = NULL, *spec = NULL;
    int c, frames = 10, have_frames = 0;
    opterr = 0;
    while ((c = getopt_long(argc, argv, ":d:g:n:h", opts, NULL)) != -1) {
        switch (c) {
        case 'd':
            device = optarg;
            break;
        case 'g':
            spec = optarg;
            break;
        case 'n':
            if (cli_int("cameras", "--frames", optarg, 1, 100000, &frames) < 0) return 2;
            have_frames = 1;
            break;
        case 'h':
            help(stdout);
            return 0;
        default:
            return cli_getopt_error("cameras", c, argv);
        }
    }
    if (optind < argc) {
        fprintf(stderr, "parlight cameras: unexpected argument '%s'\n", argv[optind]);
        return 2;
    }
    if (spec && device) {
        fprintf(stderr, "parlight cameras: --grab and --device exclude each other\n");
        return 2;
    }
    if (have_frames && !spec) {
        fprintf(stderr, "parlight cameras: --frames goes with --grab\n");
        return 2;
    }
    if (spec) return grab(spec, frames);
    if (device) return list_one(device) == 1 ? 0 : 1;

    int nums[256], n = 0;
    DIR *dir = opendir("/dev");
    if (dir) {
        struct dirent *e;
        while ((e = readdir(dir)) && n < 256) {
            int k = video_number(e->d_name);
            if (k >= 0) nums[n++] = k;
        }
        closedir(dir);
    }
    qsort(nums, (size_t)n, sizeof nums[0], cmp_int);
    int found = 0;
    for (int i = 0; i < n; i++) {
        char path[32];
        snprintf(path, sizeof path, "/dev/video%d", nums[i]);
        if (list_one(path) == 1) found++;
    }
    if (!found) printf("V4L2: no capture device%s\n", n ? "" : " (no /dev/video* node)");
    found += list_libcamera();
    if (!found) {
        fprintf(stderr, "parlight cameras: no camera found\n");
        return 1;
    }
    return 0;
}
