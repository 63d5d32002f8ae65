/* Decoding a compressed image held in memory (an MJPEG camera frame) into 8-bit RGB, through
 * OpenCV's imdecode, in port/image_mem.cpp. */
#ifndef PL_PORT_IMAGE_MEM_H
#define PL_PORT_IMAGE_MEM_H

#include <stddef.h>
#include <stdint.h>

#include "core/image.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Decodes the JPEG in data[0..n) into img's buffer (reused through *capacity, see
 * pl_image_u8_reserve) as 8-bit RGB. `what` names the frame in messages ("v4l2:/dev/video0 frame
 * 12"). Checked before decoding: the SOI marker at the start and an EOI marker (FF D9) in the
 * data (drivers may pad after it with zeros), so that a truncated frame is refused instead of
 * being grey-padded by libjpeg; the declared size from the SOF marker against the image limits.
 * MJPEG frames without Huffman tables (common in webcams) decode with the standard tables
 * (libjpeg-turbo's default). Errors: PL_E_FORMAT (not a JPEG, truncated, decoder failed),
 * PL_E_NOMEM. Never throws. */
int pl_image_decode_jpeg_rgb8_reuse(const uint8_t *data, size_t n, const char *what,
                                    pl_image_u8 *img, size_t *capacity);

#ifdef __cplusplus
}
#endif
#endif
