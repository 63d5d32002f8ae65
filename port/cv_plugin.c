/* The OpenCV side through its plugin (port/plugin.h): built when the Makefile defines
 * PL_OPENCV_PLUGIN (PLUGINS=1 and OpenCV found); then port/image_io.cpp, video_cv.cpp and
 * test_helpers_cv.cpp live in parlight-opencv.so and these forwarders load it on first use.
 * Each forwarder has the signature and contract of the function it forwards to (see
 * port/image_codec.h, port/video_cv.h, port/test_helpers.h). */
#ifdef PL_OPENCV_PLUGIN

#include "core/util.h"
#include "port/image_codec.h"
#include "port/plugin.h"
#include "port/test_helpers.h"
#include "port/video_cv.h"

#include <string.h>

/* The plugin's function `name` as a pointer of type `type`, or return its error status. */
#define CV_FN(type, name, what)                                                                    \
    int st_ = PL_E_UNSUPPORTED;                                                                    \
    type fn_ = (type)pl_plugin_sym("opencv", #name, what, &st_);                                   \
    if (!fn_) return st_

int pl_codec_have_opencv(void)
{
    return 1;
}

int pl_cv_image_decode_rgb8(const uint8_t *p, size_t n, const char *what, int flags,
                            pl_image_u8 *img, size_t *cap)
{
    typedef int (*fn)(const uint8_t *, size_t, const char *, int, pl_image_u8 *, size_t *);
    CV_FN(fn, pl_cv_image_decode_rgb8, what);
    return fn_(p, n, what, flags, img, cap);
}

int pl_cv_image_write_rgb8(const char *path, const pl_image_u8 *img)
{
    typedef int (*fn)(const char *, const pl_image_u8 *);
    CV_FN(fn, pl_cv_image_write_rgb8, path);
    return fn_(path, img);
}

int pl_cv_has_writer(const char *path)
{
    int st = 0;
    int (*f)(const char *) = (int (*)(const char *))pl_plugin_sym("opencv", "pl_cv_has_writer",
                                                                  path, &st);
    /* Without the plugin, say yes: the write then fails with the plugin's message. */
    return f ? f(path) : 1;
}

int pl_video_open(const char *path, pl_video **out)
{
    if (out) *out = NULL;
    typedef int (*fn)(const char *, pl_video **);
    CV_FN(fn, pl_video_open, path ? path : "video");
    return fn_(path, out);
}

int pl_video_read(pl_video *v, pl_image_u8 *img, size_t *capacity, int64_t *t_ns)
{
    typedef int (*fn)(pl_video *, pl_image_u8 *, size_t *, int64_t *);
    CV_FN(fn, pl_video_read, "video");
    return fn_(v, img, capacity, t_ns);
}

int pl_video_fps(const pl_video *v, double *fps)
{
    typedef int (*fn)(const pl_video *, double *);
    CV_FN(fn, pl_video_fps, "video");
    return fn_(v, fps);
}

void pl_video_close(pl_video *v)
{
    if (!v) return; /* a video only exists when the plugin opened it */
    int st;
    void (*f)(pl_video *) = (void (*)(pl_video *))pl_plugin_sym("opencv", "pl_video_close",
                                                                "video", &st);
    if (f) f(v);
}

int pl_test_write_image(const char *path, int width, int height, int channels, int depth,
                        const void *pixels)
{
    typedef int (*fn)(const char *, int, int, int, int, const void *);
    CV_FN(fn, pl_test_write_image, path);
    return fn_(path, width, height, channels, depth, pixels);
}

int pl_test_write_video(const char *path, const char *fourcc, double fps, int width, int height,
                        int n_frames, const uint8_t *rgb)
{
    typedef int (*fn)(const char *, const char *, double, int, int, int, const uint8_t *);
    CV_FN(fn, pl_test_write_video, path);
    return fn_(path, fourcc, fps, width, height, n_frames, rgb);
}

#else
/* ISO C wants something in a translation unit. */
typedef int pl_cv_plugin_unused;
#endif
