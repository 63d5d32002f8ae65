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
 * (an installed layout). A plugin resolves the core's functions (pl_error, ...) from the
 * executable, which is linked with -rdynamic. */
#ifndef PL_PORT_PLUGIN_H
#define PL_PORT_PLUGIN_H

#ifdef __cplusplus
extern "C" {
#endif

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
