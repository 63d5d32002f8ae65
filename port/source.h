/* Frame sources: where frames come from (files now; V4L2 and libcamera share this lifecycle).
 *
 *     pl_source *src;
 *     if (pl_source_open_path(path, &src) < 0) { report pl_last_error(); ... }
 *     pl_frame f;
 *     for (;;) {
 *         int rc = pl_source_read(src, &f);
 *         if (rc == PL_E_EOF) break;
 *         if (rc < 0) { warn pl_last_error(), count it, continue; }   (this frame only)
 *         ... f.image ...
 *     }
 *     pl_source_counts(src, &good, &bad);  (good == 0: the caller says "no readable frame")
 *     pl_source_close(src);
 *
 * Who says what: the library returns one error per bad frame (message naming the file and the
 * problem) and PL_E_EOF at the end, whose message summarises "N frames, G good, B bad"; deciding
 * that a run with no good frame failed, and saying so, is the caller's (the app's) job.
 * Errors at open are fatal for the source: nothing to read. */
#ifndef PL_PORT_SOURCE_H
#define PL_PORT_SOURCE_H

#include <stdint.h>

#include "core/image.h"

#ifdef __cplusplus
extern "C" {
#endif

/* One frame. image: 8-bit RGB owned by the source; its pixels (and `name`) stay valid until the
 * next pl_source_read or pl_source_close, and the buffer is reused (parlight allocates nothing
 * per video frame once sizes settle; decoding a still file still allocates inside OpenCV and
 * holds the file's bytes for the decode). Do not free or keep them: copy what must outlive the
 * next read.
 * t_ns: still images and directory frames: the file's modification time (CLOCK_REALTIME,
 * nanoseconds since the epoch, st_mtim); video frames: time from the start of the stream
 * (CAP_PROP_POS_MSEC, else index / fps), so the first frame is ~0.
 * index: 0-based position in the source (directories: position of the file in name order, so a
 * bad file leaves a gap; videos: decoded frame number). name: the file name within the directory,
 * or the path for a still image or video. */
typedef struct pl_frame {
    pl_image_u8 image;
    int64_t t_ns;
    int64_t index;
    const char *name;
} pl_frame;

typedef struct pl_source pl_source;

/* Opens an image file, a video file or a directory of frames.
 *  - Directory: its regular files (symlinks followed) in byte-wise name order (strcmp); hidden
 *    names (leading '.') and sub-directories are skipped. Each file is decoded as a still image
 *    when read; files that are not images (judged by content, not extension: a text file named
 *    .jpg is bad) are bad frames, reported one per read. A directory with no candidate file is
 *    refused at open (PL_E_FORMAT). Frames are decoded at read time, so a directory is not
 *    validated ahead.
 *  - File with a video extension (mp4 m4v mov avi mkv webm mjpeg mjpg mpg mpeg ts m2ts wmv flv
 *    ogv 3gp y4m h264 264 hevc h265, any case): opened as a video (OpenCV's FFmpeg backend); if
 *    that fails it is tried as a still image (a misnamed photo), and if both fail the message
 *    gives both reasons. A video with no decodable frame is refused. (Video goes first, not
 *    after a failed imread, because a raw .mjpeg stream is also a valid JPEG: imread would give
 *    its first frame only.) FFmpeg itself may print a
 *    line to stderr about a broken container ("moov atom not found"): that is FFmpeg's logger,
 *    outside parlight's control.
 *  - Any other file: a still image (one frame), decoded at open so errors come here.
 *    Video detection is by extension only: FFmpeg's probing accepts almost anything (text
 *    files included), so content sniffing would turn bad stills into "videos".
 * Errors name the path: PL_E_ARG, PL_E_IO (missing, unreadable, not a file or directory),
 * PL_E_FORMAT, PL_E_UNSUPPORTED, PL_E_NOMEM. */
int pl_source_open_path(const char *path, pl_source **out);

/* Opens a camera from a spec "v4l2:/dev/videoN[:WxH[@FPS][:FORMAT]]" (syntax, formats, timestamps
 * and the reopen policy: port/v4l2.h and docs/CAMERAS.md) or "libcamera[:ID|N]"
 * (port/libcamera_src.h; describe "libcamera:<id>", no reopen: disconnect ends the source).
 * Reads then give the driver's CLOCK_MONOTONIC capture time in t_ns and its frame sequence in
 * index; PL_E_DEVICE for each failed attempt to get a lost camera back (the caller warns and
 * reads again), PL_E_EOF once it gives up. describe: "v4l2:<path>". Errors at open: PL_E_ARG
 * (bad spec), PL_E_IO, PL_E_DEVICE, PL_E_UNSUPPORTED, PL_E_NOMEM. */
int pl_source_open_camera(const char *spec, pl_source **out);

/* Next frame: PL_OK; PL_E_EOF at the end (and on every later call); or an error for this frame
 * only (a bad file in a directory): the caller warns, counts, and calls read again. */
int pl_source_read(pl_source *src, pl_frame *frame);

/* "file:<path>", "video:<path>" or "dir:<path>"; owned by the source. */
const char *pl_source_describe(const pl_source *src);

/* Frame rate declared by a video: PL_OK and *fps > 0; PL_E_UNSUPPORTED for still images,
 * directories and videos that declare none. */
int pl_source_fps(const pl_source *src, double *fps);

/* Frames handed out (good) and bad frames reported so far. Either pointer may be NULL. */
void pl_source_counts(const pl_source *src, int64_t *good, int64_t *bad);

/* Frees everything; NULL is fine. */
void pl_source_close(pl_source *src);

#ifdef __cplusplus
}
#endif
#endif
