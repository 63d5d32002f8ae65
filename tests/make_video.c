/* make_video OUT FPS N FRAME — writes an MJPG video of N frames from one image (each frame a
 * little brighter than the one before, so frames differ), for the pipeline tests. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "port/image.h"
#include "port/test_helpers.h"
#include "parlight.h"

int main(int argc, char **argv)
{
    if (argc != 5) {
        fprintf(stderr, "usage: make_video OUT.avi FPS N FRAME\n");
        return 2;
    }
    double fps = atof(argv[2]);
    int n = atoi(argv[3]);
    pl_image_u8 img;
    if (pl_image_read_rgb8(argv[4], &img) < 0) {
        fprintf(stderr, "make_video: %s\n", pl_last_error());
        return 1;
    }
    size_t frame = (size_t)img.width * img.height * 3;
    uint8_t *rgb = malloc(frame * (size_t)n);
    if (!rgb) return 1;
    for (int k = 0; k < n; k++)
        for (int y = 0; y < img.height; y++)
            for (int x = 0; x < img.width * 3; x++) {
                int v = img.data[(size_t)y * img.stride + x] + k;
                rgb[frame * k + ((size_t)y * img.width * 3) + x] = (uint8_t)(v > 255 ? 255 : v);
            }
    int rc = pl_test_write_video(argv[1], "MJPG", fps, img.width, img.height, n, rgb);
    if (rc < 0) fprintf(stderr, "make_video: %s\n", pl_last_error());
    free(rgb);
    pl_image_u8_free(&img);
    return rc < 0 ? 1 : 0;
}
