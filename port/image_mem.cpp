// In-memory JPEG decode (MJPEG camera frames) through OpenCV, behind port/image_mem.h.
// No exception leaves this file.
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <cstring>
#include <new>

extern "C" {
#include "port/cv_log.h"
#include "port/image_mem.h"
#include "port/util.h"
}

namespace
{

// Width and height from the first SOF marker before the first scan; -1 when not found.
void jpeg_size(const uint8_t *p, size_t n, long long *w, long long *h)
{
    *w = *h = -1;
    size_t i = 2;
    for (int guard = 0; guard < 10000 && i + 4 <= n; guard++) {
        if (p[i] != 0xff) return;
        const uint8_t m = p[i + 1];
        if (m == 0xff) {
            i++;
            continue;
        }
        if (m == 0xd8 || m == 0x01 || (m >= 0xd0 && m <= 0xd7)) {
            i += 2;
            continue;
        }
        if (m == 0xd9 || m == 0xda) return;
        const size_t len = (size_t)p[i + 2] << 8 | p[i + 3];
        if (len < 2) return;
        if (m >= 0xc0 && m <= 0xcf && m != 0xc4 && m != 0xc8 && m != 0xcc) {
            if (i + 9 > n) return;
            *h = (long long)((unsigned)p[i + 5] << 8 | p[i + 6]);
            *w = (long long)((unsigned)p[i + 7] << 8 | p[i + 8]);
            return;
        }
        i += 2 + len;
    }
}

int decode(const uint8_t *data, size_t n, const char *what, pl_image_u8 *img, size_t *cap)
{
    if (n < 4 || data[0] != 0xff || data[1] != 0xd8)
        return pl_error(PL_E_FORMAT, "%s: not a JPEG frame (%zu bytes, no start-of-image marker)",
                        what, n);
    size_t end = n;
    while (end > 2 && data[end - 1] == 0)
        end--;
    bool eoi = false;
    for (size_t k = end; k >= 4 && k + 16 >= end; k--) // EOI at the end, maybe after padding
        if (data[k - 2] == 0xff && data[k - 1] == 0xd9) {
            eoi = true;
            break;
        }
    if (!eoi)
        return pl_error(PL_E_FORMAT, "%s: truncated JPEG frame (%zu bytes, no end-of-image marker)",
                        what, n);
    long long w, h;
    jpeg_size(data, n, &w, &h);
    if (w < 0) return pl_error(PL_E_FORMAT, "%s: JPEG frame without a frame header (SOF)", what);
    if (pl_image_check_size(what, w, h) < 0) return PL_E_FORMAT;
    if (n > (size_t)INT32_MAX) return pl_error(PL_E_FORMAT, "%s: JPEG frame too large", what);
    cv::Mat raw(1, (int)n, CV_8U, const_cast<uint8_t *>(data));
    cv::Mat bgr = cv::imdecode(raw, cv::IMREAD_COLOR);
    if (bgr.empty() || bgr.type() != CV_8UC3)
        return pl_error(PL_E_FORMAT, "%s: corrupt JPEG frame (decoder failed)", what);
    int rc = pl_image_u8_reserve(img, cap, bgr.cols, bgr.rows);
    if (rc < 0) return pl_error_prefix(rc, "%s", what);
    cv::Mat out(img->height, img->width, CV_8UC3, img->data, img->stride);
    cv::cvtColor(bgr, out, cv::COLOR_BGR2RGB);
    if (out.data != img->data)
        return pl_error(PL_E_INTERNAL, "%s: colour conversion reallocated", what);
    return PL_OK;
}

} // namespace

extern "C" int pl_image_decode_jpeg_rgb8_reuse(const uint8_t *data, size_t n, const char *what,
                                               pl_image_u8 *img, size_t *capacity)
{
    if (!what) what = "JPEG frame";
    if (!data || !img || !capacity)
        return pl_error(PL_E_ARG, "pl_image_decode_jpeg_rgb8_reuse: NULL argument");
    pl_cv_log_quiet_enter();
    int rc;
    try {
        rc = decode(data, n, what, img, capacity);
    } catch (const std::bad_alloc &) {
        rc = pl_error(PL_E_NOMEM, "%s: out of memory while decoding", what);
    } catch (const cv::Exception &e) {
        rc = pl_error(PL_E_FORMAT, "%s: OpenCV cannot decode it: %s", what, e.what());
    } catch (...) {
        rc = pl_error(PL_E_INTERNAL, "%s: unexpected exception while decoding", what);
    }
    pl_cv_log_quiet_leave();
    return rc;
}
