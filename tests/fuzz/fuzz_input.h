/* What the libFuzzer targets in tests/fuzz/ share (docs/TESTING.md, "Fuzzing").
 *
 * parlight's loaders take paths (they stat, mmap or hand the path to a library), so the input
 * becomes a file: an anonymous memory file (memfd_create) rewritten for each input and named by
 * its /proc/self/fd path. No disk traffic, nothing left behind, and the loader runs exactly as it
 * does on a real file. Linux only, like the fuzz build. */
#ifndef PL_TESTS_FUZZ_INPUT_H
#define PL_TESTS_FUZZ_INPUT_H

#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <sys/mman.h>
#include <unistd.h>

#include "core/image.h"

/* Writes data[0..size) into the memory file (created on the first call) and returns its path. */
static inline const char *fuzz_input_path(const uint8_t *data, size_t size)
{
    static int fd = -1;
    static char path[64];
    if (fd < 0) {
        /* 4 Mi pixels instead of 64 Mi: a small input declaring a legal but large image must not
         * count as out of memory under libFuzzer's 2 GiB limit (ASan doubles what it costs). */
        if (pl_image_set_max_pixels(4 << 20, "the fuzz targets' limit") < 0) abort();
        fd = memfd_create("parlight-fuzz", MFD_CLOEXEC);
        if (fd < 0) {
            perror("fuzz: memfd_create");
            abort();
        }
        snprintf(path, sizeof path, "/proc/self/fd/%d", fd);
    }
    if (ftruncate(fd, 0) != 0) abort();
    for (size_t done = 0; done < size;) {
        ssize_t n = pwrite(fd, data + done, size - done, (off_t)done);
        if (n <= 0) abort();
        done += (size_t)n;
    }
    return path;
}

/* A loader that refuses an input must say why: an empty message is a bug. */
static inline void fuzz_expect_message(int rc, const char *msg)
{
    if (rc < 0 && (!msg || !msg[0])) {
        fprintf(stderr, "fuzz: refused (status %d) without a message\n", rc);
        abort();
    }
}

/* What pl_hdr_read promises of an image it returns: a sane size and only finite, non-negative
 * pixels. Every pixel is read, so that a short buffer shows. */
static inline void fuzz_check_hdr_image(const pl_image_f32 *img)
{
    if (img->width < 1 || img->height < 1 || !img->data) abort();
    const size_t n = (size_t)img->width * (size_t)img->height * 3;
    for (size_t i = 0; i < n; i++)
        if (!(img->data[i] >= 0.0f) || isinf(img->data[i])) abort();
}

#endif
