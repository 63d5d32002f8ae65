/* libFuzzer target: still-image and camera-frame decoding without OpenCV: the header and
 * truncation checks of port/image_files.c (PNG chunks and CRCs, JPEG markers, BMP), the
 * libjpeg and libpng glue (port/jpeg_codec.c: EXIF orientation, CMYK; port/png_codec.c:
 * palette, 16-bit, tRNS) through pl_image_read_rgb8 on the input as a file, and the MJPEG frame
 * path (pl_image_decode_jpeg_rgb8_reuse) on the same bytes from memory. The fuzz build has no
 * OpenCV (its plugin is a separate library): other formats are refused with a message.
 *
 * A refused input must come with a message; an accepted image must have a sane size and every
 * pixel byte is read. Seeds: tests/fuzz/corpus/image (tools/fuzz-corpus.py). */
#include <stdint.h>
#include <stdlib.h>

#include "parlight.h"
#include "port/image.h"
#include "port/image_mem.h"
#include "tests/fuzz/fuzz_input.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static void check_image(const pl_image_u8 *img)
{
    if (img->width < 1 || img->height < 1 || !img->data || img->stride < (size_t)img->width * 3)
        abort();
    unsigned sum = 0;
    for (int y = 0; y < img->height; y++)
        for (size_t x = 0; x < (size_t)img->width * 3; x++)
            sum += img->data[(size_t)y * img->stride + x];
    volatile unsigned sink = sum;
    (void)sink;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    pl_image_u8 img;
    int rc = pl_image_read_rgb8(fuzz_input_path(data, size), &img);
    fuzz_expect_message(rc, pl_last_error());
    if (rc == 0) {
        check_image(&img);
        pl_image_u8_free(&img);
    }

    if (size >= 2 && data[0] == 0xff && data[1] == 0xd8) {
        pl_image_u8 frame = {0, 0, 0, NULL};
        size_t cap = 0;
        rc = pl_image_decode_jpeg_rgb8_reuse(data, size, "fuzz frame", &frame, &cap);
        fuzz_expect_message(rc, pl_last_error());
        if (rc == 0) check_image(&frame);
        pl_image_u8_free(&frame);
    }
    return 0;
}
