/* OpenCV logs warnings through its logger (CV_LOG_WARNING, e.g. imwrite's "can't open file for
 * writing"); the library reports through pl_error instead and never prints. Wrap each OpenCV call
 * that can warn in enter/leave: the first caller in saves OpenCV's global log level and silences
 * it, the last one out restores it (counted under a mutex, so threads can overlap). Nothing is
 * changed when the user set OPENCV_LOG_LEVEL. Not covered, because they bypass the logger:
 * OpenCV 4.6's imread/imdecode print decoder exceptions with std::cerr (image_io.cpp checks
 * headers first so that the decoders are rarely reached with a broken file), libjpeg's and
 * libpng's own warnings, and FFmpeg's av_log. Implemented in port/image_io.cpp. */
#ifndef PL_PORT_CV_LOG_H
#define PL_PORT_CV_LOG_H

#ifdef __cplusplus
extern "C" {
#endif

void pl_cv_log_quiet_enter(void);
void pl_cv_log_quiet_leave(void);

#ifdef __cplusplus
}
#endif
#endif
