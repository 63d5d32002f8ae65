/* Video files through OpenCV's VideoCapture (port/video_cv.cpp), as a plain C interface for the
 * file source (port/source_file.c). Internal to port/. */
#ifndef PL_PORT_VIDEO_CV_H
#define PL_PORT_VIDEO_CV_H

#include <stdint.h>

#include "core/image.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct pl_video pl_video;

/* Opens `path` with OpenCV's FFmpeg backend (only: see video_cv.cpp) and decodes the first
 * frame, so that a file that opens but holds no decodable frame is refused here: PL_E_FORMAT
 * with the path in the message. The first frame is handed out by the first pl_video_read. */
int pl_video_open(const char *path, pl_video **out);
/* Decodes the next frame into img (buffer reused through *capacity, see pl_image_u8_reserve) as
 * 8-bit RGB. *t_ns: the frame's time from the start of the stream, from CAP_PROP_POS_MSEC
 * (index / fps when the backend gives none). PL_E_EOF at the end; OpenCV cannot tell a decode
 * error mid-stream from the end, so both end the video. */
int pl_video_read(pl_video *v, pl_image_u8 *img, size_t *capacity, int64_t *t_ns);
/* Nominal frame rate from the container; PL_E_UNSUPPORTED when it declares none. */
int pl_video_fps(const pl_video *v, double *fps);
void pl_video_close(pl_video *v);

#ifdef __cplusplus
}
#endif
#endif
