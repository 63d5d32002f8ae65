/* The live pipeline's capture side: a thread that reads a frame source as fast as it delivers
 * (or, for a replayed video, at the video's own frame rate) and leaves the newest frame in a
 * one-slot mailbox. Capture never waits for inference: a frame still in the mailbox when the next
 * one arrives is replaced and counted as dropped.
 *
 *     pl_capture *cap;
 *     pl_capture_start(src, realtime, &cap);
 *     for (;;) {
 *         int rc = pl_capture_take(cap, &frame, &dropped, 100);
 *         if (rc == PL_CAPTURE_AGAIN) continue;            (check for a stop request here)
 *         if (rc == PL_E_EOF) break;                       (the source ended)
 *         if (rc < 0) { report pl_last_error(); break; }   (the source failed for good)
 *         ... frame.image until the next take ...
 *     }
 *     pl_capture_stop(cap);
 *
 * Three frame buffers rotate between the capture thread, the mailbox and the consumer; they are
 * allocated when the first frame (or a new frame size) arrives, never per frame. */
#ifndef PL_PORT_CAPTURE_H
#define PL_PORT_CAPTURE_H

#include <stddef.h>
#include <stdint.h>

#include "port/source.h"

/* pl_capture_take found no frame within its timeout (not an error). */
#define PL_CAPTURE_AGAIN 1

typedef struct pl_capture pl_capture;

/* Starts the capture thread on `src` (still owned by the caller, who closes it after
 * pl_capture_stop). realtime: pace reads by the frames' t_ns (videos replay at their own rate:
 * frame k is released at start + t_ns(k) - t_ns(0)); live sources are paced by the device. */
int pl_capture_start(pl_source *src, int realtime, pl_capture **out);

/* The same, paced by a fixed interval instead of the frames' t_ns: the k-th good frame (from 0)
 * is released at start + k * interval_ns (interval_ns > 0, at most PL_CAPTURE_MAX_INTERVAL_NS).
 * For directories and still images, whose t_ns are file modification times that say nothing
 * about a frame rate (--realtime --frame-interval). */
#define PL_CAPTURE_MAX_INTERVAL_NS (3600LL * 1000000000LL)
int pl_capture_start_paced(pl_source *src, int64_t interval_ns, pl_capture **out);

/* Waits up to timeout_ms for a frame not yet taken. PL_OK: *frame holds the newest frame (valid
 * until the next take or stop) and *dropped the frames replaced unseen since the previous take.
 * PL_CAPTURE_AGAIN: nothing new yet. PL_E_EOF: the source ended and every frame was handed out.
 * Other negative: the source failed (message in pl_last_error()). */
int pl_capture_take(pl_capture *cap, pl_frame *frame, int64_t *dropped, int timeout_ms);

/* Frames the source reported bad (skipped) so far; the last one's message into last_msg (cap
 * bytes; may be NULL). */
int64_t pl_capture_bad_frames(pl_capture *cap, char *last_msg, size_t cap_bytes);

/* Stops the thread (it finishes the read in flight) and frees everything. NULL is fine. */
void pl_capture_stop(pl_capture *cap);

#endif
