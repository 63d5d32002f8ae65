/* libcamera cameras (port/source_libcamera.cpp): a plain C interface over libcamera's C++ API
 * (Debian 12: libcamera 0.0.3). No C++ type appears here. Used by port/source_file.c for specs
 * "libcamera[:ID-or-index]"; docs/CAMERAS.md describes the source.
 *
 * Spec: "libcamera" (the first camera the CameraManager lists), "libcamera:N" (N decimal, 0-based
 * in the manager's order) or "libcamera:ID" (a camera ID exactly as `parlight cameras` or
 * `cam -l` prints it; IDs may contain ':' — everything after the first ':' is the ID).
 *
 * Lifecycle: open = CameraManager::start, get the camera, acquire, generateConfiguration
 * (VideoRecording role) with the first pixel format the stream offers among YUYV, MJPEG, NV12,
 * BGR888 (bytes R,G,B) at the pipeline's default size, validate + configure, FrameBufferAllocator,
 * mmap every dmabuf plane, one request per buffer, start, queue all. libcamera's requestCompleted
 * callback (its thread) only moves the request into a queue (mutex + condition variable); read
 * takes the newest completed request (older ones are requeued unread, as the V4L2 source does),
 * converts its buffer to RGB8 (port/pixfmt.h, MJPEG through port/image_mem.h) and requeues it.
 *
 * Only one libcamera source may be open per process (libcamera allows one CameraManager).
 * libcamera's own log is switched off unless LIBCAMERA_LOG_LEVELS or LIBCAMERA_LOG_FILE is set in
 * the environment (library code does not print). Without libcamera at build time every function
 * returns PL_E_UNSUPPORTED. */
#ifndef PL_PORT_LIBCAMERA_SRC_H
#define PL_PORT_LIBCAMERA_SRC_H

#include <stddef.h>
#include <stdint.h>

#include "core/image.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct pl_libcam pl_libcam;

/* True when spec names this backend: "libcamera" or "libcamera:..." */
int pl_libcam_is_spec(const char *spec);

/* Opens and starts the camera. Errors: PL_E_ARG (spec: empty ID after ':', index out of range),
 * PL_E_DEVICE (no cameras, no camera with that ID, acquire/configure/start failed),
 * PL_E_UNSUPPORTED (no pixel format parlight reads; built without libcamera), PL_E_NOMEM. */
int pl_libcam_open(const char *spec, pl_libcam **out);

/* Newest completed frame as RGB8 into img (buffer reused through *capacity).
 * t_ns: the sensor timestamp of the request metadata (SensorTimestamp) or else the buffer's
 * FrameMetadata timestamp: CLOCK_MONOTONIC nanoseconds (for UVC, the V4L2 driver's timestamp).
 * index: the buffer's sequence counted from the first frame. Errors for this frame only:
 * PL_E_FORMAT (bad size, truncated or broken MJPEG, a frame the pipeline flagged as an error),
 * PL_E_DEVICE (no frame within 5 s). PL_E_EOF once the camera is disconnected, its requests
 * are cancelled, or after three reads in a row without a frame (15 s). */
int pl_libcam_read(pl_libcam *cam, pl_image_u8 *img, size_t *capacity, int64_t *t_ns,
                   int64_t *index);

/* "libcamera:<camera id>"; owned by cam. */
const char *pl_libcam_describe(const pl_libcam *cam);

/* PL_E_UNSUPPORTED: libcamera 0.0.3's UVC pipeline reports no frame rate before streaming. */
int pl_libcam_fps(const pl_libcam *cam, double *fps);

/* Stops, frees, releases. NULL is fine. */
void pl_libcam_close(pl_libcam *cam);

/* Lists the cameras libcamera sees, one per line "  [N] ID  (FORMAT WxH default)" into buf
 * (NUL-terminated, truncated to n). PL_OK with *count (0 when none), or an error. Not while a
 * libcamera source is open. */
int pl_libcam_list(char *buf, size_t n, int *count);

#ifdef __cplusplus
}
#endif
#endif
