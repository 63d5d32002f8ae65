/* HDR image files: OpenEXR (.exr) and Radiance RGBE (.hdr), read into linear float RGB.
 *
 * Reading (the format is picked by content, not by name):
 *   - OpenEXR 3 (port/exr_io.cpp, through the OpenEXR C++ library): half, float or uint channels;
 *     R,G,B (A ignored), or luminance Y (grey, copied to R=G=B) with optional RY/BY chroma;
 *     scanline or tiled files, mip/rip-mapped ones read at level 0 (full resolution); any
 *     compression the library knows; the first part of a multi-part file. The data window is
 *     the image (display window ignored).
 *   - Radiance RGBE (port/hdr_io.c): "#?RADIANCE" / "#?RGBE" header, FORMAT=32-bit_rle_rgbe,
 *     resolution line "-Y H +X W" (the standard orientation) or "+Y H +X W" (flipped rows);
 *     new-style run-length scanlines, flat scanlines and old-style RLE. EXPOSURE= lines are
 *     ignored (values are taken as stored, like most tools do). XYZE files are rejected.
 *     A mantissa m with exponent e decodes as (m + 0.5) * 2^(e - 136) (Radiance's colr_color).
 * Values: negative values are clamped to 0, NaN and +-Inf become 0 (a panorama is radiance).
 * Limits: declared sizes are checked against PL_IMAGE_MAX_SIDE and the read limit
 * (pl_image_max_pixels, core/image.h), and, for pl_hdr_read_panorama, against the 2:1 shape, from
 * the header, before any pixel buffer is allocated; an RGBE file must hold the bytes its declared
 * size needs at least (and is read only up to the most it can need); an EXR header is first read
 * by OpenEXRCore with OpenEXR's own size limits, its chunk table must fit in the file, and a file
 * whose chunks are missing (truncated EXR) is rejected before decoding.
 * Errors: PL_E_IO (cannot open/read/write), PL_E_FORMAT (malformed, truncated, wrong magic, not
 * 2:1 where required), PL_E_UNSUPPORTED (valid but not handled: XYZE, deep EXR, odd orientation),
 * PL_E_NOMEM; the message names the file.
 * Ownership: *out is filled only on success; its pixels are malloc'ed and belong to the caller
 * (release with pl_image_f32_free, or free(out->data)). */
#ifndef PL_PORT_HDR_IO_H
#define PL_PORT_HDR_IO_H

#include "core/image.h"
#include "parlight.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Reads any .exr or .hdr file as linear RGB float (see above). */
int pl_hdr_read(const char *path, pl_image_f32 *out);
/* The same, and the image must be a 2:1 equirectangular panorama (width == 2*height, height >= 2),
 * else PL_E_FORMAT naming the size found. */
int pl_hdr_read_panorama(const char *path, pl_image_f32 *out);

/* Writes `img` by extension: ".exr" (float RGB, ZIP compression: lossless) or ".hdr" (RGBE with
 * new-style run-length encoding). Negative/NaN values are written as 0. Overwrites an existing
 * file: the caller decides about overwriting. Anything else is PL_E_ARG. */
int pl_hdr_write(const char *path, const pl_image_f32 *img);

/* Storage type of an EXR written by pl_hdr_write_exr. */
typedef enum pl_exr_type { PL_EXR_FLOAT = 0, PL_EXR_HALF = 1 } pl_exr_type;
/* Writes an OpenEXR file (RGB, ZIP) with the given channel type. Half clips to 65504. */
int pl_hdr_write_exr(const char *path, const pl_image_f32 *img, pl_exr_type type);
/* Writes a Radiance RGBE file (new-style RLE). */
int pl_hdr_write_rgbe(const char *path, const pl_image_f32 *img);

/* ---- internal: the OpenEXR shim (port/exr_io.cpp), called by the functions above ---------- */
/* panorama: 1 when the caller needs a 2:1 image (checked on the data window, before reading). */
int pl_exr_read_file(const char *path, int panorama, pl_image_f32 *out);
/* The checks on a declared size, before any allocation: the read limit
 * (pl_image_check_read_size) and, when `panorama`, width == 2 x height. PL_E_FORMAT naming path. */
int pl_hdr_check_declared(const char *path, long long w, long long h, int panorama);
int pl_exr_write_file(const char *path, const pl_image_f32 *img, pl_exr_type type);

#ifdef __cplusplus
}
#endif
#endif
