/* Image files through the codecs and OpenCV (port/image_files.c, port/image_io.cpp): the I/O
 * side of core/image.h's buffers. */
#ifndef PL_PORT_IMAGE_H
#define PL_PORT_IMAGE_H

#include <stddef.h>

#include "core/image.h"

#ifdef __cplusplus
extern "C" {
#endif

/* ---- files through OpenCV (port/image_io.cpp) ---------------------------------------------- */

/* Reads a still image (JPEG, PNG, BMP, TIFF, WebP, PNM, ... whatever this OpenCV decodes; the
 * format is found from the file's content, not its name) as 8-bit RGB into a new image that the
 * caller frees with pl_image_u8_free.
 *  - Grayscale is expanded to RGB; alpha is dropped (the colour channels are kept as they are,
 *    not composited); 16-bit is scaled to 8-bit as (v * 255 + 32767) / 65535 (v*255/65535
 *    rounded to nearest); 8-bit JPEGs get their EXIF orientation applied.
 *  - Floating-point images (Radiance .hdr, float TIFF, EXR) are refused with PL_E_UNSUPPORTED:
 *    they are HDR and need the HDR path, not a silent tone map. Signed 16-bit also unsupported.
 *  - Guard against decompression bombs: the declared size is checked against PL_IMAGE_MAX_SIDE
 *    and the read limit (pl_image_max_pixels, core/image.h) BEFORE decoding: read from the
 *    header by parlight for PNG, JPEG, BMP, TIFF (IFD 0) and PNM; for other formats by OpenCV,
 *    whose OPENCV_IO_MAX_IMAGE_* limits port/plugin.c sets from the read limit before OpenCV
 *    loads; the decoded size is checked again afterwards. OpenEXR and Radiance files are refused
 *    unread (PL_E_UNSUPPORTED: they need the HDR reader). Files over 1 GiB are refused unread.
 *  - Checked before decoding, so that the decoders neither return half images nor print: PNG
 *    chunk lengths and CRCs up to IEND; JPEG markers up to the first scan and an end-of-image
 *    marker after it (libjpeg would pad a truncated file with grey); BMP compression and, when
 *    uncompressed, that all pixel rows are present. Damage inside a JPEG scan is still decoded
 *    (as libjpeg does) and libjpeg prints "Corrupt JPEG data ..." to stderr: not ours to stop.
 * Errors, each naming the path: PL_E_IO (missing, not a regular file, unreadable), PL_E_FORMAT
 * (zero bytes, not an image OpenCV recognises, corrupt or truncated data, too large),
 * PL_E_UNSUPPORTED (float/signed data, odd channel count). Never throws. */
int pl_image_read_rgb8(const char *path, pl_image_u8 *out);
/* Same, decoding into img's buffer (see pl_image_u8_reserve) instead of a new image. */
int pl_image_read_rgb8_reuse(const char *path, pl_image_u8 *img, size_t *capacity);
/* Writes 8-bit RGB to a file whose format OpenCV knows from the extension (.png, .jpg, .bmp,
 * .tif, .ppm, ...). An unknown or missing extension is PL_E_ARG and nothing is written. An
 * existing file is overwritten: deciding whether that is wanted is the caller's job. PL_E_IO
 * when the file cannot be written. */
int pl_image_write_rgb8(const char *path, const pl_image_u8 *img);

#ifdef __cplusplus
}
#endif
#endif
