/* Plugins: optional libraries loaded with dlopen only when an input needs them (port/plugin.c).
 *
 * A plain `parlight estimate` on JPEG/PNG frames should not pay for OpenCV's ~240 shared
 * libraries (~58 MB of RSS) nor libcamera's (~7 MB): with PLUGINS=1 (the Makefile's default when
 * the library is there) the OpenCV side (port/image_io.cpp, video_cv.cpp, test_helpers_cv.cpp)
 * is built into $(BUILD)/parlight-opencv.so and port/source_libcamera.cpp into
 * $(BUILD)/parlight-libcamera.so; the core calls them through the forwarders in
 * port/cv_plugin.c and port/libcamera_plugin.c, which load the plugin on first use.
 *
 * Where a plugin is looked for, first hit wins: $PARLIGHT_PLUGIN_DIR; the folder of the running
 * executable; its parent (test programs live in $(BUILD)/tests/); ../lib/parlight beside it
 * (an installed layout); the folder of the library itself plus /parlight (libparlight.so in
 * LIBDIR: LIBDIR/parlight, where `make install` puts the plugins).
 *
 * A plugin takes the core's functions it calls (pl_error, the image buffers, the pixel
 * conversions) from the table below, handed to its pl_plugin_bind when it is loaded, not from
 * the symbols of whatever loaded it: the same plugin then works under the static CLI, under an
 * app linked with libparlight.a and under one linked with libparlight.so, whose exports are the
 * public API only. port/plugin_guest.c, linked into each plugin, defines those functions as
 * calls through the table, so the plugins' sources call them as everywhere else. */
#ifndef PL_PORT_PLUGIN_H
#define PL_PORT_PLUGIN_H

#include <stddef.h>
#include <stdint.h>

#include "core/image.h"
#include "port/pixfmt.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Changes whenever pl_plugin_host does: a plugin built for another ABI is refused at load. */
#define PL_PLUGIN_ABI 1

typedef struct pl_plugin_host {
    int abi;                                        /* PL_PLUGIN_ABI */
    int (*error)(int status, const char *fmt, ...); /* core/status.h */
    int (*error_prefix)(int status, const char *fmt, ...);
    long long (*image_max_pixels)(void); /* core/image.h */
    int (*image_check_read_size)(const char *what, long long width, long long height);
    int (*image_u8_reserve)(pl_image_u8 *img, size_t *capacity, int width, int height);
    int (*image_decode_jpeg_rgb8_reuse)(const uint8_t *data, size_t n, const char *what,
                                        pl_image_u8 *img, size_t *capacity); /* port/image_mem.h */
    void (*yuv_coeffs_init)(pl_yuv_coeffs *c, pl_yuv_matrix matrix, pl_yuv_range range);
    int (*pixfmt_min_bytes)(pl_pixfmt fmt, int w, int h, size_t stride, size_t *bytes);
    const char *(*pixfmt_name)(pl_pixfmt fmt);
    void (*yuyv_to_rgb8)(const uint8_t *src, size_t src_stride, int w, int h,
                         const pl_yuv_coeffs *c, uint8_t *dst, size_t dst_stride);
    void (*nv12_to_rgb8)(const uint8_t *y_plane, size_t y_stride, const uint8_t *uv_plane,
                         size_t uv_stride, int w, int h, const pl_yuv_coeffs *c, uint8_t *dst,
                         size_t dst_stride);
    void (*rgb24_to_rgb8)(const uint8_t *src, size_t src_stride, int w, int h, uint8_t *dst,
                          size_t dst_stride);
} pl_plugin_host;

/* What every plugin exports (port/plugin_guest.c): keeps `host` (static storage, never freed)
 * for the calls that follow. 0, or < 0 when host->abi is not the plugin's PL_PLUGIN_ABI. */
typedef int (*pl_plugin_bind_fn)(const pl_plugin_host *host);

/* The address of `sym` in plugin `name` ("opencv" -> parlight-opencv.so), loading the plugin on
 * first use (thread-safe; a plugin is loaded at most once and never unloaded). NULL when it
 * cannot be loaded or lacks the symbol: then the message (pl_last_error) says which plugin,
 * where it was looked for and why it failed, prefixed with `what` (the file or spec that needed
 * it), and *status is PL_E_UNSUPPORTED. */
void *pl_plugin_sym(const char *name, const char *sym, const char *what, int *status);

#ifdef __cplusplus
}
#endif
#endif
