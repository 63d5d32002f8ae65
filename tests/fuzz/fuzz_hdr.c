/* libFuzzer target: the Radiance RGBE reader (port/hdr_io.c: header, flat, new- and old-style
 * RLE scanlines), through pl_hdr_read on the input as a file. Inputs with OpenEXR's magic are
 * left to fuzz_exr.c.
 *
 * A refused input must come with a message; an accepted image must keep pl_hdr_read's promise
 * (fuzz_check_hdr_image).
 * Seeds: tests/fuzz/corpus/hdr (tools/fuzz-corpus.py). */
#include <stdint.h>
#include <string.h>

#include "parlight.h"
#include "port/hdr_io.h"
#include "tests/fuzz/fuzz_input.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static const uint8_t exr_magic[4] = {0x76, 0x2f, 0x31, 0x01};
    if (size >= 4 && !memcmp(data, exr_magic, 4)) return 0; /* fuzz_exr's inputs */
    pl_image_f32 img;
    int rc = pl_hdr_read(fuzz_input_path(data, size), &img);
    fuzz_expect_message(rc, pl_last_error());
    if (rc < 0) return 0;
    fuzz_check_hdr_image(&img);
    pl_image_f32_free(&img);
    return 0;
}
