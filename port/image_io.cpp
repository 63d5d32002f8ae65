// The OpenCV side of still images (port/image_codec.h): formats other than JPEG and PNG (BMP,
// TIFF, WebP, PNM, ...) and writers for them, and JPEG/PNG when the build lacks libjpeg/libpng.
// port/image_files.c reads the file and checks its header first. No exception leaves this file.
// Without OpenCV (PL_HAVE_OPENCV unset: a cross build, WITH_OPENCV=0) the same functions say so.
#ifdef PL_HAVE_OPENCV
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/core/utils/logger.hpp>

#include <cctype>
#include <cerrno>
#include <cstdlib>
#include <mutex>
#include <cstdio>
#include <cstring>
#include <new>
#include <string>
#include <vector>

#include <sys/stat.h>
#include <unistd.h>

extern "C" {
#include "core/image.h"
#include "core/util.h"
#include "port/cv_log.h"
#include "port/image_codec.h"
}

namespace
{
std::mutex quiet_mutex;
int quiet_depth;
cv::utils::logging::LogLevel quiet_saved;
} // namespace

extern "C" void pl_cv_log_quiet_enter(void)
{
    try {
        static const bool user_set = std::getenv("OPENCV_LOG_LEVEL") != nullptr;
        if (user_set) return;
        std::lock_guard<std::mutex> lock(quiet_mutex);
        if (quiet_depth++ == 0)
            quiet_saved = cv::utils::logging::setLogLevel(cv::utils::logging::LOG_LEVEL_SILENT);
    } catch (...) {
    }
}

extern "C" void pl_cv_log_quiet_leave(void)
{
    try {
        static const bool user_set = std::getenv("OPENCV_LOG_LEVEL") != nullptr;
        if (user_set) return;
        std::lock_guard<std::mutex> lock(quiet_mutex);
        if (quiet_depth > 0 && --quiet_depth == 0) cv::utils::logging::setLogLevel(quiet_saved);
    } catch (...) {
    }
}

namespace
{

const char *depth_name(int depth)
{
    switch (depth) {
    case CV_8U:
        return "8-bit unsigned";
    case CV_8S:
        return "8-bit signed";
    case CV_16U:
        return "16-bit unsigned";
    case CV_16S:
        return "16-bit signed";
    case CV_32S:
        return "32-bit integer";
    case CV_32F:
        return "32-bit float";
    case CV_64F:
        return "64-bit float";
    default:
        return "16-bit float";
    }
}

// Converts a decoded 8/16-bit, 1/3/4-channel BGR(A) Mat into img (reusing its buffer).
int mat_to_rgb8(const char *path, const cv::Mat &m, pl_image_u8 *img, size_t *cap)
{
    if (m.dims != 2) return pl_error(PL_E_UNSUPPORTED, "%s: %d-dimensional image", path, m.dims);
    int rc = pl_image_check_read_size(path, m.cols, m.rows);
    if (rc < 0) return rc;
    const int cn = m.channels();
    if (cn != 1 && cn != 3 && cn != 4)
        return pl_error(PL_E_UNSUPPORTED, "%s: %d channels per pixel (expected 1, 3 or 4)", path,
                        cn);
    cv::Mat m8;
    if (m.depth() == CV_8U) {
        m8 = m;
    } else if (m.depth() == CV_16U) {
        m8.create(m.rows, m.cols, CV_MAKETYPE(CV_8U, cn));
        for (int y = 0; y < m.rows; y++) {
            const uint16_t *s = m.ptr<uint16_t>(y);
            uint8_t *d = m8.ptr<uint8_t>(y);
            for (int x = 0; x < m.cols * cn; x++)
                d[x] = (uint8_t)(((uint32_t)s[x] * 255u + 32767u) / 65535u);
        }
    } else if (m.depth() == CV_32F || m.depth() == CV_64F || m.depth() == CV_16F) {
        return pl_error(PL_E_UNSUPPORTED,
                        "%s: %s pixels (an HDR image): not read as 8-bit RGB; use the HDR reader",
                        path, depth_name(m.depth()));
    } else {
        return pl_error(PL_E_UNSUPPORTED,
                        "%s: %s pixels are not supported (expected 8 or 16-bit unsigned)", path,
                        depth_name(m.depth()));
    }
    rc = pl_image_u8_reserve(img, cap, m.cols, m.rows);
    if (rc < 0) return pl_error_prefix(rc, "%s", path);
    cv::Mat out(img->height, img->width, CV_8UC3, img->data, img->stride);
    const int code = cn == 1   ? cv::COLOR_GRAY2RGB
                     : cn == 3 ? cv::COLOR_BGR2RGB
                               : cv::COLOR_BGRA2RGB;
    cv::cvtColor(m8, out, code);
    if (out.data != img->data)
        return pl_error(PL_E_INTERNAL, "%s: colour conversion reallocated", path);
    return PL_OK;
}

} // namespace

extern "C" int pl_codec_have_opencv(void)
{
    return 1;
}

extern "C" int pl_cv_image_decode_rgb8(const uint8_t *p, size_t n, const char *what, int flags,
                                       pl_image_u8 *img, size_t *cap)
{
    if (!p || !what || !img || !cap)
        return pl_error(PL_E_ARG, "pl_cv_image_decode_rgb8: NULL argument");
    if (n == 0 || n > (size_t)INT32_MAX)
        return pl_error(PL_E_FORMAT, "%s: %zu bytes: not an image OpenCV can take", what, n);
    struct Quiet {
        Quiet()
        {
            pl_cv_log_quiet_enter();
        }
        ~Quiet()
        {
            pl_cv_log_quiet_leave();
        }
    } quiet;
    try {
        // JPEG: IMREAD_COLOR, so that the EXIF orientation is applied (always 8-bit anyway).
        const int mode = flags & PL_CV_EXIF ? cv::IMREAD_COLOR : cv::IMREAD_UNCHANGED;
        cv::Mat raw(1, (int)n, CV_8U, const_cast<uint8_t *>(p));
        cv::Mat m = cv::imdecode(raw, mode);
        if (m.empty()) {
            if (flags & PL_CV_KNOWN)
                return pl_error(PL_E_FORMAT, "%s: corrupt or truncated image data (decoder failed)",
                                what);
            return pl_error(PL_E_FORMAT,
                            "%s: not an image (content matches no format OpenCV decodes)", what);
        }
        return mat_to_rgb8(what, m, img, cap);
    } catch (const std::bad_alloc &) {
        return pl_error(PL_E_NOMEM, "%s: out of memory while decoding", what);
    } catch (const cv::Exception &e) {
        // validateInputImageSize: the header declares more than OPENCV_IO_MAX_IMAGE_* allow
        // (port/plugin.c sets them from the read limit), refused before OpenCV allocates.
        if (e.err.find("CV_IO_MAX_IMAGE") != std::string::npos)
            return pl_error(PL_E_FORMAT,
                            "%s: the image's declared size is over the limit of %lld pixels, "
                            "%d per side (OpenCV's header check)",
                            what, pl_image_max_pixels(), PL_IMAGE_MAX_SIDE);
        return pl_error(PL_E_FORMAT, "%s: OpenCV cannot decode it: %s", what, e.what());
    } catch (...) {
        return pl_error(PL_E_INTERNAL, "%s: unexpected exception while decoding", what);
    }
}

extern "C" int pl_cv_has_writer(const char *path)
{
    pl_cv_log_quiet_enter();
    int ok = 0;
    try {
        ok = path && cv::haveImageWriter(path);
    } catch (...) {
    }
    pl_cv_log_quiet_leave();
    return ok;
}

extern "C" int pl_cv_image_write_rgb8(const char *path, const pl_image_u8 *img)
{
    if (!path || !img || !img->data || img->width < 1 || img->height < 1 ||
        img->stride < (size_t)img->width * 3)
        return pl_error(PL_E_ARG, "pl_cv_image_write_rgb8: invalid image or path");
    struct Quiet {
        Quiet()
        {
            pl_cv_log_quiet_enter();
        }
        ~Quiet()
        {
            pl_cv_log_quiet_leave();
        }
    } quiet;
    try {
        cv::Mat rgb(img->height, img->width, CV_8UC3, img->data, img->stride), bgr;
        cv::cvtColor(rgb, bgr, cv::COLOR_RGB2BGR);
        if (!cv::imwrite(path, bgr))
            return pl_error(PL_E_IO, "%s: OpenCV could not write the image", path);
        return PL_OK;
    } catch (const std::bad_alloc &) {
        return pl_error(PL_E_NOMEM, "%s: out of memory while encoding", path);
    } catch (const cv::Exception &e) {
        return pl_error(PL_E_IO, "%s: OpenCV cannot write it: %s", path, e.what());
    } catch (...) {
        return pl_error(PL_E_INTERNAL, "%s: unexpected exception while encoding", path);
    }
}

#else // !PL_HAVE_OPENCV

extern "C" {
#include "core/util.h"
#include "port/cv_log.h"
#include "port/image_codec.h"
}

extern "C" void pl_cv_log_quiet_enter(void) {}
extern "C" void pl_cv_log_quiet_leave(void) {}

extern "C" int pl_codec_have_opencv(void)
{
    return 0;
}

extern "C" int pl_cv_image_decode_rgb8(const uint8_t *, size_t, const char *what, int,
                                       pl_image_u8 *, size_t *)
{
    return pl_error(PL_E_UNSUPPORTED, "%s: this build has no OpenCV: cannot decode this format",
                    what ? what : "image");
}

extern "C" int pl_cv_has_writer(const char *)
{
    return 0;
}

extern "C" int pl_cv_image_write_rgb8(const char *path, const pl_image_u8 *)
{
    return pl_error(PL_E_UNSUPPORTED, "%s: this build has no OpenCV: cannot write this format",
                    path ? path : "image");
}

#endif
