// TEST HELPERS ONLY: fixture writers for the C tests (see port/test_helpers.h). Without OpenCV
// they return PL_E_UNSUPPORTED and the tests that need them skip.
#ifdef PL_HAVE_OPENCV
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include <cstring>

extern "C" {
#include "core/util.h"
#include "port/test_helpers.h"
}

extern "C" int pl_test_write_image(const char *path, int width, int height, int channels, int depth,
                                   const void *pixels)
{
    try {
        const int d = depth == 8 ? CV_8U : depth == 16 ? CV_16U : depth == 32 ? CV_32F : -1;
        if (!path || !pixels || width < 1 || height < 1 || d < 0 || channels < 1 || channels > 4)
            return pl_error(PL_E_ARG, "pl_test_write_image: bad arguments");
        cv::Mat m(height, width, CV_MAKETYPE(d, channels), const_cast<void *>(pixels));
        if (!cv::imwrite(path, m)) return pl_error(PL_E_IO, "%s: imwrite failed", path);
        return PL_OK;
    } catch (const cv::Exception &e) {
        return pl_error(PL_E_IO, "%s: %s", path, e.what());
    } catch (...) {
        return pl_error(PL_E_INTERNAL, "%s: exception", path);
    }
}

extern "C" int pl_test_write_video(const char *path, const char *fourcc, double fps, int width,
                                   int height, int n_frames, const uint8_t *rgb)
{
    try {
        if (!path || !fourcc || strlen(fourcc) != 4 || !rgb || width < 1 || height < 1 ||
            n_frames < 1)
            return pl_error(PL_E_ARG, "pl_test_write_video: bad arguments");
        cv::VideoWriter w(path, cv::VideoWriter::fourcc(fourcc[0], fourcc[1], fourcc[2], fourcc[3]),
                          fps, cv::Size(width, height), true);
        if (!w.isOpened())
            return pl_error(PL_E_IO, "%s: VideoWriter cannot open (%s)", path, fourcc);
        const size_t frame = (size_t)width * (size_t)height * 3;
        cv::Mat bgr;
        for (int i = 0; i < n_frames; i++) {
            cv::Mat m(height, width, CV_8UC3, const_cast<uint8_t *>(rgb + frame * (size_t)i));
            cv::cvtColor(m, bgr, cv::COLOR_RGB2BGR);
            w.write(bgr);
        }
        w.release();
        return PL_OK;
    } catch (const cv::Exception &e) {
        return pl_error(PL_E_IO, "%s: %s", path, e.what());
    } catch (...) {
        return pl_error(PL_E_INTERNAL, "%s: exception", path);
    }
}

#else // !PL_HAVE_OPENCV

extern "C" {
#include "core/util.h"
#include "port/test_helpers.h"
}

extern "C" int pl_test_write_image(const char *path, int, int, int, int, const void *)
{
    return pl_error(PL_E_UNSUPPORTED, "%s: this build has no OpenCV to write test images",
                    path ? path : "image");
}

extern "C" int pl_test_write_video(const char *path, const char *, double, int, int, int,
                                   const uint8_t *)
{
    return pl_error(PL_E_UNSUPPORTED, "%s: this build has no OpenCV to write test videos",
                    path ? path : "video");
}

#endif
