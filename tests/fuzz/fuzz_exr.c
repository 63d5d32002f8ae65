/* libFuzzer target: the OpenEXR reader (port/exr_io.cpp: size checks, completeness, RGB / Y /
 * YC channels, scanline and tiled files) through pl_hdr_read, which picks it by the magic
 * 76 2f 31 01. The OpenEXR library itself is Debian's, not instrumented: what is fuzzed is
 * parlight's use of it and its error paths (every exception must become a status).
 *
 * A refused input must come with a message; an accepted image must keep pl_hdr_read's promise
 * (fuzz_check_hdr_image). Seeds: tests/fuzz/corpus/exr
 * (tools/fuzz-corpus.py). */
#include <stdint.h>

#include "parlight.h"
#include "port/hdr_io.h"
#include "tests/fuzz/fuzz_input.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    pl_image_f32 img;
    int rc = pl_hdr_read(fuzz_input_path(data, size), &img);
    fuzz_expect_message(rc, pl_last_error());
    if (rc < 0) return 0;
    fuzz_check_hdr_image(&img);
    pl_image_f32_free(&img);
    return 0;
}
