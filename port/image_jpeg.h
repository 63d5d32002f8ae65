/* JPEG with a chosen quality (pl_image_write_rgb8 uses OpenCV's default, 95). Through OpenCV,
 * in port/image_jpeg.cpp. Used for small sample frames (tools/make-samples.sh). */
#ifndef PL_PORT_IMAGE_JPEG_H
#define PL_PORT_IMAGE_JPEG_H

#include "port/image.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Writes 8-bit RGB as baseline JPEG, quality 1..100 (PL_E_ARG otherwise). Overwrites an existing
 * file (the caller decides). PL_E_IO when it cannot be written. */
int pl_image_write_jpeg(const char *path, const pl_image_u8 *img, int quality);

#ifdef __cplusplus
}
#endif
#endif
