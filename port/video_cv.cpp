// Video files through cv::VideoCapture behind the C interface in port/video_cv.h. No exception
// leaves this file. Without OpenCV (PL_HAVE_OPENCV unset) pl_video_open says so.
#ifdef PL_HAVE_OPENCV
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>
#include <opencv2/videoio/registry.hpp>

#include <cmath>
#include <cstring>
#include <new>
#include <string>

extern "C" {
#include "core/util.h"
#include "port/cv_log.h"
#include "port/video_cv.h"
}

namespace
{
struct Quiet {
    Quiet()
    {
        pl_cv_log_quiet_enter();
    }
    ~Quiet()
    {
        pl_cv_log_quiet_leave();
    }
};
} // namespace

struct pl_video {
    cv::VideoCapture cap;
    cv::Mat frame; // reused by VideoCapture::read while the size stays the same
    std::string path;
    bool pending = false; // frame holds the first frame, decoded by open, not yet handed out
    int64_t pending_t = 0;
    int64_t index = 0; // frames handed out
};

namespace
{

int64_t frame_time(pl_video *v)
{
    const double ms = v->cap.get(cv::CAP_PROP_POS_MSEC);
    if (std::isfinite(ms) && ms >= 0 && (ms > 0 || v->index == 0))
        return (int64_t)std::llround(ms * 1e6);
    const double fps = v->cap.get(cv::CAP_PROP_FPS);
    if (std::isfinite(fps) && fps > 0) return (int64_t)std::llround((double)v->index * 1e9 / fps);
    return 0;
}

int to_rgb8(pl_video *v, pl_image_u8 *img, size_t *cap)
{
    const cv::Mat &m = v->frame;
    const char *path = v->path.c_str();
    int rc = pl_image_check_read_size(path, m.cols, m.rows);
    if (rc < 0) return rc;
    if (m.depth() != CV_8U || (m.channels() != 1 && m.channels() != 3 && m.channels() != 4))
        return pl_error(PL_E_UNSUPPORTED,
                        "%s: video frames of OpenCV type %d (expected 8-bit, 1/3/4 channels)", path,
                        m.type());
    rc = pl_image_u8_reserve(img, cap, m.cols, m.rows);
    if (rc < 0) return pl_error_prefix(rc, "%s", path);
    cv::Mat out(img->height, img->width, CV_8UC3, img->data, img->stride);
    const int cn = m.channels();
    cv::cvtColor(m, out,
                 cn == 1   ? cv::COLOR_GRAY2RGB
                 : cn == 3 ? cv::COLOR_BGR2RGB
                           : cv::COLOR_BGRA2RGB);
    return PL_OK;
}

int open_video(const char *path, pl_video **out)
{
    pl_video *v = new (std::nothrow) pl_video;
    if (!v) return pl_error(PL_E_NOMEM, "%s: out of memory opening the video", path);
    v->path = path;
    // FFmpeg only: OpenCV's built-in MJPEG/AVI reader (CAP_OPENCV_MJPEG) reads uninitialised
    // memory on truncated files (seen under valgrind with 4.6) and prints to stderr.
    if (!cv::videoio_registry::hasBackend(cv::CAP_FFMPEG)) {
        delete v;
        return pl_error(PL_E_UNSUPPORTED,
                        "%s: this OpenCV has no FFmpeg backend: cannot read videos", path);
    }
    if (!v->cap.open(path, cv::CAP_FFMPEG)) {
        delete v;
        return pl_error(PL_E_FORMAT, "%s: cannot open as a video (FFmpeg cannot demux it)", path);
    }
    if (!v->cap.read(v->frame) || v->frame.empty()) {
        delete v;
        return pl_error(PL_E_FORMAT, "%s: video has no decodable frame", path);
    }
    v->pending = true;
    v->pending_t = frame_time(v);
    *out = v;
    return PL_OK;
}

} // namespace

extern "C" int pl_video_open(const char *path, pl_video **out)
{
    Quiet quiet;
    if (!path || !out) return pl_error(PL_E_ARG, "pl_video_open: NULL argument");
    *out = nullptr;
    try {
        return open_video(path, out);
    } catch (const std::bad_alloc &) {
        return pl_error(PL_E_NOMEM, "%s: out of memory opening the video", path);
    } catch (const cv::Exception &e) {
        return pl_error(PL_E_FORMAT, "%s: OpenCV cannot open it as a video: %s", path, e.what());
    } catch (...) {
        return pl_error(PL_E_INTERNAL, "%s: unexpected exception opening the video", path);
    }
}

extern "C" int pl_video_read(pl_video *v, pl_image_u8 *img, size_t *capacity, int64_t *t_ns)
{
    Quiet quiet;
    if (!v || !img || !capacity || !t_ns) return pl_error(PL_E_ARG, "pl_video_read: NULL argument");
    const char *path = v->path.c_str();
    try {
        if (v->pending) {
            v->pending = false;
            *t_ns = v->pending_t;
        } else {
            if (!v->cap.read(v->frame) || v->frame.empty())
                return pl_error(PL_E_EOF, "%s: end of video after %lld frames", path,
                                (long long)v->index);
            *t_ns = frame_time(v);
        }
        int rc = to_rgb8(v, img, capacity);
        v->index++;
        return rc;
    } catch (const std::bad_alloc &) {
        return pl_error(PL_E_NOMEM, "%s: out of memory decoding frame %lld", path,
                        (long long)v->index);
    } catch (const cv::Exception &e) {
        return pl_error(PL_E_FORMAT, "%s: frame %lld: %s", path, (long long)v->index, e.what());
    } catch (...) {
        return pl_error(PL_E_INTERNAL, "%s: unexpected exception decoding frame %lld", path,
                        (long long)v->index);
    }
}

extern "C" int pl_video_fps(const pl_video *v, double *fps)
{
    if (!v || !fps) return pl_error(PL_E_ARG, "pl_video_fps: NULL argument");
    try {
        const double f = v->cap.get(cv::CAP_PROP_FPS);
        if (!std::isfinite(f) || f <= 0 || f > 10000)
            return pl_error(PL_E_UNSUPPORTED, "%s: the video declares no frame rate",
                            v->path.c_str());
        *fps = f;
        return PL_OK;
    } catch (...) {
        return pl_error(PL_E_INTERNAL, "%s: exception reading the frame rate", v->path.c_str());
    }
}

extern "C" void pl_video_close(pl_video *v)
{
    Quiet quiet;
    try {
        delete v;
    } catch (...) {
    }
}

#else // !PL_HAVE_OPENCV

extern "C" {
#include "core/util.h"
#include "port/video_cv.h"
}

extern "C" int pl_video_open(const char *path, pl_video **out)
{
    if (out) *out = nullptr;
    return pl_error(PL_E_UNSUPPORTED, "%s: this build has no OpenCV: cannot read videos",
                    path ? path : "video");
}

extern "C" int pl_video_read(pl_video *, pl_image_u8 *, size_t *, int64_t *)
{
    return pl_error(PL_E_ARG, "pl_video_read: no video is open (this build has no OpenCV)");
}

extern "C" int pl_video_fps(const pl_video *, double *)
{
    return pl_error(PL_E_ARG, "pl_video_fps: no video is open (this build has no OpenCV)");
}

extern "C" void pl_video_close(pl_video *) {}

#endif
