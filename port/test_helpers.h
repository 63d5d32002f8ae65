/* TEST HELPERS ONLY (port/test_helpers_cv.cpp): write fixture files with OpenCV so that the C
 * tests can make gray, RGBA, 16-bit and float images and small videos at test time. Not part of
 * the pipeline; nothing outside tests/ should call them. */
#ifndef PL_PORT_TEST_HELPERS_H
#define PL_PORT_TEST_HELPERS_H

#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* Writes width x height pixels of `channels` (1, 3 or 4) channels in OpenCV's order (gray, BGR,
 * BGRA), `depth` 8 (uint8_t), 16 (uint16_t) or 32 (float), rows packed, to `path` with
 * cv::imwrite (format from the extension). PL_OK or a negative status with a message. */
int pl_test_write_image(const char *path, int width, int height, int channels, int depth,
                        const void *pixels);

/* Writes n_frames packed RGB frames of width x height (consecutive in `rgb`) as a video with
 * cv::VideoWriter and the given FourCC (e.g. "MJPG" in .avi needs no external codec). */
int pl_test_write_video(const char *path, const char *fourcc, double fps, int width, int height,
                        int n_frames, const uint8_t *rgb);

#ifdef __cplusplus
}
#endif
#endif
