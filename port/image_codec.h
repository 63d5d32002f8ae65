/* Image codecs behind port/image.h, port/image_jpeg.h and port/image_mem.h. Internal to port/.
 *
 * JPEG and PNG are decoded and encoded in C with libjpeg(-turbo) and libpng directly
 * (port/jpeg_codec.c, port/png_codec.c), so that the main binary does not load OpenCV for the
 * common still images and camera frames, and so that a cross build for a board has a
 * dependency-light way to read frames. Their output is pixel-identical to what OpenCV 4.6's
 * imdecode gives (same libjpeg-turbo, same decoder settings, same EXIF orientation and 16-bit
 * rules; tests/test_image_codec.c checks it against OpenCV when the build has it).
 *
 * Every other format (BMP, TIFF, WebP, PNM, ...) and videos go through OpenCV
 * (port/image_io.cpp, port/video_cv.cpp), which a build may not have: see docs/PORTING.md.
 *
 * Each feature is on when the target's pkg-config finds the library (the Makefile defines
 * PL_HAVE_LIBJPEG, PL_HAVE_LIBPNG, PL_HAVE_OPENCV); without it the functions below return
 * PL_E_UNSUPPORTED with a message that says which library this build lacks. */
#ifndef PL_PORT_IMAGE_CODEC_H
#define PL_PORT_IMAGE_CODEC_H

#include <stddef.h>
#include <stdint.h>

#include "core/image.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Which codecs this build has (1 or 0), for messages and for tests that must skip. */
int pl_codec_have_jpeg(void);
int pl_codec_have_png(void);
int pl_codec_have_opencv(void);

/* Decodes the JPEG in p[0..n) to 8-bit RGB in img (buffer reused through *cap, see
 * pl_image_u8_reserve), with the EXIF orientation (APP1, IFD0 tag 0x0112) applied as OpenCV's
 * IMREAD_COLOR does. Grayscale is replicated, CMYK/YCCK converted with OpenCV's formula. The
 * caller has checked the markers and the declared size (image_read.c / image_mem.c). libjpeg's
 * warnings (damage inside a scan) are not printed; the damaged image is returned as libjpeg
 * decodes it. `what` names the file or frame in messages. PL_E_FORMAT when libjpeg fails. */
int pl_jpeg_decode_rgb8(const uint8_t *p, size_t n, const char *what, pl_image_u8 *img,
                        size_t *cap);
/* Writes baseline JPEG (4:2:0, quality 1..100, as OpenCV's imwrite does by default). */
int pl_jpeg_write_rgb8(const char *path, const pl_image_u8 *img, int quality);
/* The same into memory: *out (malloc'd, the caller frees it) holds *n bytes. PL_E_ARG for a bad
 * image or quality, PL_E_NOMEM when libjpeg fails, PL_E_UNSUPPORTED without libjpeg. */
int pl_jpeg_encode_rgb8(const pl_image_u8 *img, int quality, unsigned char **out, size_t *n);

/* Decodes the PNG in p[0..n) (chunks and CRCs already checked) to 8-bit RGB: palette expanded,
 * gray replicated, alpha and tRNS dropped (not composited), 16-bit scaled as
 * (v * 255 + 32767) / 65535, no gamma correction — OpenCV's IMREAD_UNCHANGED + our 16->8 rule. */
int pl_png_decode_rgb8(const uint8_t *p, size_t n, const char *what, pl_image_u8 *img,
                       size_t *cap);
/* Writes 8-bit RGB PNG (zlib level 1, SUB filter, RLE strategy: OpenCV's defaults). */
int pl_png_write_rgb8(const char *path, const pl_image_u8 *img);

/* OpenCV fallbacks (port/image_io.cpp). decode: any format cv::imdecode knows, the file's bytes
 * in p[0..n); flags: PL_CV_EXIF applies the EXIF orientation (IMREAD_COLOR, as for JPEG), else
 * IMREAD_UNCHANGED; PL_CV_KNOWN says the header was recognised (a failure is then "corrupt", not
 * "not an image"). write: format from the extension, quality for JPEG (OpenCV's default 95).
 * cv_has_writer: 1 if OpenCV can write that extension. */
enum { PL_CV_EXIF = 1, PL_CV_KNOWN = 2 };
int pl_cv_image_decode_rgb8(const uint8_t *p, size_t n, const char *what, int flags,
                            pl_image_u8 *img, size_t *cap);
int pl_cv_image_write_rgb8(const char *path, const pl_image_u8 *img);
int pl_cv_has_writer(const char *path);

#ifdef __cplusplus
}
#endif
#endif
