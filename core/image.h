/* Image buffers as they travel inside parlight (the ground floor: no I/O; files are port/image.h).
 *
 * pl_image_u8: 8-bit RGB, interleaved R,G,B, rows `stride` bytes apart (stride >= 3*width).
 * pl_image_f32: linear float RGB, interleaved, rows packed (3*width floats per row); used for
 * HDR panoramas, environment maps and renders.
 * Both own their pixels when created by the functions here; free with the matching _free. */
#ifndef PL_CORE_IMAGE_H
#define PL_CORE_IMAGE_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef struct pl_image_u8 {
    int width, height;
    size_t stride;
    uint8_t *data;
} pl_image_u8;

typedef struct pl_image_f32 {
    int width, height;
    float *data;
} pl_image_f32;

/* Largest image parlight handles, per side and in pixels: bigger declared sizes are rejected
 * before any allocation (a guard against hostile headers). The ceiling for the read limit below. */
#define PL_IMAGE_MAX_SIDE 32768
#define PL_IMAGE_MAX_PIXELS (256u * 1024u * 1024u)

/* The read limit: the most pixels (width x height) a reader of files and frames decodes, checked
 * on the size a header declares before anything is allocated. Default
 * PL_IMAGE_DEFAULT_MAX_PIXELS = 2^26 (64 Mi pixels: 11584 x 5792 as a 2:1 panorama, 768 MiB as
 * float RGB, 192 MiB as 8-bit RGB): a 4 GB board survives any file. The CLI raises it with
 * --max-pixels (docs/EXTRACTION.md, "Limits").
 * pl_image_set_max_pixels: 1..PL_IMAGE_MAX_PIXELS, else PL_E_ARG; `how_to_raise` (a static
 * string such as "--max-pixels", or NULL) is named in the messages of refused images. Process-wide,
 * like OpenCV's OPENCV_IO_MAX_IMAGE_PIXELS: set it once at start-up, before any reader runs (the
 * OpenCV plugin takes it when it is loaded, see port/plugin.c). */
#define PL_IMAGE_DEFAULT_MAX_PIXELS (64u * 1024u * 1024u)
int pl_image_set_max_pixels(long long max_pixels, const char *how_to_raise);
long long pl_image_max_pixels(void);
/* Checks a declared size against PL_IMAGE_MAX_SIDE and the read limit: PL_E_FORMAT naming `what`
 * (a path), the size, the limit and how to raise it. */
int pl_image_check_read_size(const char *what, long long width, long long height);

/* Allocates width x height pixels (rows packed: stride = 3*width for u8). Sizes must be in
 * 1..PL_IMAGE_MAX_SIDE with width*height <= PL_IMAGE_MAX_PIXELS, else PL_E_ARG; PL_E_NOMEM when
 * the allocation fails. On failure *img is zeroed. Pixels are not initialised. */
int pl_image_u8_alloc(pl_image_u8 *img, int width, int height);
/* Frees the pixels and zeroes *img; NULL or an already-freed (zeroed) image is fine. */
void pl_image_u8_free(pl_image_u8 *img);
int pl_image_f32_alloc(pl_image_f32 *img, int width, int height);
void pl_image_f32_free(pl_image_f32 *img);

/* Reuses img's buffer for a width x height packed image when *capacity (bytes held by img->data)
 * is enough, else reallocates it (the old pixels are lost) and updates *capacity. For sources
 * that hand out one buffer per frame: no allocation once sizes settle. img and *capacity start
 * zeroed; free with pl_image_u8_free. Same size checks as pl_image_u8_alloc; on failure img
 * keeps its old buffer and capacity. */
int pl_image_u8_reserve(pl_image_u8 *img, size_t *capacity, int width, int height);

/* Checks a size against the limits above; PL_E_FORMAT naming `what` (a path) when out of range. */
int pl_image_check_size(const char *what, long long width, long long height);

#ifdef __cplusplus
}
#endif
#endif
