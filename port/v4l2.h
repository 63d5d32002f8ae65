/* V4L2 cameras (Linux), in port/source_v4l2.c: the capture lifecycle behind the frame-source
 * interface (port/source.h, pl_source_open_camera) and the device listing behind `parlight
 * cameras`. Internal to port/ and app/. Behaviour, formats and the reopen policy: docs/CAMERAS.md.
 *
 * Spec syntax (strict; anything else is PL_E_ARG with a message saying what was expected):
 *     v4l2:PATH[:WxH[@FPS][:FORMAT]]
 *   PATH    absolute path of the device node, without ':' (e.g. /dev/video0)
 *   W, H    decimal integers 1..PL_IMAGE_MAX_SIDE; the device must accept exactly this size
 *   FPS     decimal number in (0, 1000], e.g. 30 or 29.97; the device must give it within 1%
 *   FORMAT  yuyv | nv12 | rgb24 | mjpeg (lower case); without it the first of these four that
 *           the device offers, in this order
 * Without WxH the device's current size is kept; without @FPS its current rate. */
#ifndef PL_PORT_V4L2_H
#define PL_PORT_V4L2_H

#include <stddef.h>
#include <stdint.h>

#include "core/image.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Reopen policy after a lost device (disappeared, I/O error, or no frame within the poll
 * timeout): waits of PL_V4L2_BACKOFF_FIRST_S doubling up to PL_V4L2_BACKOFF_MAX_S between
 * attempts, giving up once PL_V4L2_GIVE_UP_S have passed since the loss. */
#define PL_V4L2_BACKOFF_FIRST_S 0.1
#define PL_V4L2_BACKOFF_MAX_S 2.0
#define PL_V4L2_GIVE_UP_S 10.0
/* A read waits at most max(PL_V4L2_POLL_TIMEOUT_MS, 3 frame intervals) for a frame. */
#define PL_V4L2_POLL_TIMEOUT_MS 2000
/* Buffers requested from the driver (it may grant 2..8). */
#define PL_V4L2_BUFFERS 4

typedef struct pl_v4l2_spec {
    char path[256];
    int width, height; /* 0: keep the device's current size */
    double fps;        /* 0: keep the device's current rate */
    uint32_t fourcc;   /* V4L2_PIX_FMT_*; 0: first usable the device offers */
} pl_v4l2_spec;

/* Parses "v4l2:..." (syntax above) into *out. PL_E_ARG naming the spec and the problem. */
int pl_v4l2_parse_spec(const char *spec, pl_v4l2_spec *out);

typedef struct pl_v4l2 pl_v4l2;

/* Opens the device and starts streaming: QUERYCAP (a video capture device with streaming I/O,
 * single-planar API), ENUM_FMT + S_FMT (format as in the spec), S_PARM (when FPS is given),
 * REQBUFS/QUERYBUF/mmap, QBUF all, STREAMON. Errors at open are final (no retry): PL_E_IO
 * (missing node, permission), PL_E_DEVICE (not a capture device, an ioctl failed),
 * PL_E_UNSUPPORTED (no usable format, size or rate refused: the message lists what the device
 * offers), PL_E_NOMEM. */
int pl_v4l2_open(const pl_v4l2_spec *spec, pl_v4l2 **out);

/* Next frame, converted to 8-bit RGB into img (buffer reused through *capacity).
 * *t_ns: the driver's capture timestamp in ns on CLOCK_MONOTONIC (V4L2_BUF_FLAG_TIMESTAMP_
 * MONOTONIC, the usual case); drivers that give no monotonic timestamp get the monotonic time at
 * dequeue instead. *index: the driver's frame sequence number counted from the first frame, so a
 * gap means frames the driver dropped; after a reopen it continues from the last index + 1.
 * The frame handed out is the newest one the driver has filled: frames that queued up while the
 * caller was busy are given back unread, and show as gaps in *index (a live source drops stale
 * frames rather than falling behind). When even the newest is older than two frame intervals
 * (every buffer was full, so the driver had stopped capturing), it is given back too and the
 * next fresh frame is awaited (at most one frame interval more).
 * Returns PL_OK; PL_E_FORMAT for one bad frame (driver-flagged error, short or corrupt data: the
 * caller counts it and reads on); PL_E_DEVICE when the device was lost or a reopen attempt failed
 * (one error per attempt; the next read waits out the backoff and tries again); PL_E_EOF once
 * the reopen policy gives up (and on every later call). */
int pl_v4l2_read(pl_v4l2 *cam, pl_image_u8 *img, size_t *capacity, int64_t *t_ns, int64_t *index);

/* "v4l2:<path>" (owned by cam). */
const char *pl_v4l2_describe(const pl_v4l2 *cam);
/* Negotiated frame rate (from G_PARM); PL_E_UNSUPPORTED when the driver reports none. */
int pl_v4l2_fps(const pl_v4l2 *cam, double *fps);
/* Negotiated format: width, height, FOURCC and the YCbCr coding used ("BT.601 limited", ...).
 * Any pointer may be NULL. */
void pl_v4l2_format(const pl_v4l2 *cam, int *width, int *height, uint32_t *fourcc,
                    const char **coding);
/* STREAMOFF, munmap, close; NULL is fine. */
void pl_v4l2_close(pl_v4l2 *cam);

/* ---- device listing (parlight cameras) ----------------------------------------------------- */

typedef struct pl_v4l2_interval {
    uint32_t num, den; /* frame interval num/den seconds (fps = den/num) */
} pl_v4l2_interval;

typedef struct pl_v4l2_frame_size {
    /* discrete: width x height (max_* = width/height); stepwise/continuous: the range */
    int stepwise;
    uint32_t width, height, max_width, max_height, step_width, step_height;
    int n_intervals;       /* discrete intervals listed (at most 16) */
    int interval_stepwise; /* 1: intervals[0] min, intervals[1] max */
    pl_v4l2_interval intervals[16];
} pl_v4l2_frame_size;

typedef struct pl_v4l2_format_info {
    uint32_t fourcc;
    char description[32];
    int compressed;
    int usable; /* parlight can read it (YUYV, NV12, RGB24, MJPEG) */
    int n_sizes;
    pl_v4l2_frame_size *sizes; /* at most 64 */
} pl_v4l2_format_info;

typedef struct pl_v4l2_device_info {
    char path[256];
    char driver[17], card[33], bus_info[33];
    uint32_t device_caps;
    int is_capture; /* single-planar video capture with streaming I/O */
    int n_formats;
    pl_v4l2_format_info *formats;
} pl_v4l2_device_info;

/* Queries one device node (QUERYCAP, ENUM_FMT, ENUM_FRAMESIZES, ENUM_FRAMEINTERVALS) without
 * streaming. Free with pl_v4l2_device_info_free. Errors: PL_E_IO (cannot open), PL_E_DEVICE
 * (not a V4L2 device), PL_E_NOMEM. Non-capture devices succeed with is_capture = 0 and no
 * formats. */
int pl_v4l2_query_device(const char *path, pl_v4l2_device_info *info);
void pl_v4l2_device_info_free(pl_v4l2_device_info *info);

/* FOURCC as text ("YUYV", "MJPG"); buf holds at least 5 bytes; returns buf. */
const char *pl_v4l2_fourcc_str(uint32_t fourcc, char buf[5]);

#ifdef __cplusplus
}
#endif
#endif
