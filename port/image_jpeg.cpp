// JPEG writer with a quality setting (port/image_jpeg.h). Every exception is caught here.
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <new>
#include <vector>

extern "C" {
#include "port/cv_log.h"
#include "port/image_jpeg.h"
#include "port/util.h"
}

extern "C" int pl_image_write_jpeg(const char *path, const pl_image_u8 *img, int quality)
{
    if (!path || !img || !img->data || img->width < 1 || img->height < 1 ||
        img->stride < (size_t)img->width * 3)
        return pl_error(PL_E_ARG, "pl_image_write_jpeg: invalid image or path");
    if (quality < 1 || quality > 100)
        return pl_error(PL_E_ARG, "%s: JPEG quality %d, expected 1..100", path, quality);
    pl_cv_log_quiet_enter();
    int rc = PL_OK;
    try {
        cv::Mat rgb(img->height, img->width, CV_8UC3, img->data, img->stride), bgr;
        cv::cvtColor(rgb, bgr, cv::COLOR_RGB2BGR);
        std::vector<int> prm = {cv::IMWRITE_JPEG_QUALITY, quality};
        if (!cv::imwrite(path, bgr, prm))
            rc = pl_error(PL_E_IO, "%s: OpenCV could not write the JPEG", path);
    } catch (const std::bad_alloc &) {
        rc = pl_error(PL_E_NOMEM, "%s: out of memory while encoding", path);
    } catch (const std::exception &e) {
        rc = pl_error(PL_E_IO, "%s: OpenCV cannot write it: %s", path, e.what());
    } catch (...) {
        rc = pl_error(PL_E_INTERNAL, "%s: unexpected exception while encoding", path);
    }
    pl_cv_log_quiet_leave();
    return rc;
}
