/* Loading plugins on first use (port/plugin.h). */
#include "core/image.h"
#include "core/status.h"
#include "core/util.h"
#include "port/image_mem.h"
#include "port/plugin.h"

#include <dlfcn.h>
#include <limits.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#define MAX_PLUGINS 4

static const pl_plugin_host host = {
    .abi = PL_PLUGIN_ABI,
    .error = pl_error,
    .error_prefix = pl_error_prefix,
    .image_max_pixels = pl_image_max_pixels,
    .image_check_read_size = pl_image_check_read_size,
    .image_u8_reserve = pl_image_u8_reserve,
    .image_decode_jpeg_rgb8_reuse = pl_image_decode_jpeg_rgb8_reuse,
    .yuv_coeffs_init = pl_yuv_coeffs_init,
    .pixfmt_min_bytes = pl_pixfmt_min_bytes,
    .pixfmt_name = pl_pixfmt_name,
    .yuyv_to_rgb8 = pl_yuyv_to_rgb8,
    .nv12_to_rgb8 = pl_nv12_to_rgb8,
    .rgb24_to_rgb8 = pl_rgb24_to_rgb8,
};

static pthread_mutex_t lock = PTHREAD_MUTEX_INITIALIZER;
static struct {
    char name[32];
    void *handle;
    char error[512]; /* why it could not be loaded (kept: later calls report the same) */
} plugins[MAX_PLUGINS];

/* Folder of the running executable, or "" when /proc is not there. */
static void exe_dir(char *out, size_t n)
{
    char path[PATH_MAX];
    const ssize_t len = readlink("/proc/self/exe", path, sizeof path - 1);
    out[0] = '\0';
    if (len <= 0) return;
    path[len] = '\0';
    char *slash = strrchr(path, '/');
    if (!slash) return;
    *slash = '\0';
    snprintf(out, n, "%s", path[0] ? path : "/");
}

/* OpenCV reads its decoder limits from the environment once, when libopencv_imgcodecs is loaded
 * (OPENCV_IO_MAX_IMAGE_PIXELS, default 2^30, checked on the header before imdecode allocates):
 * hand it parlight's read limit (core/image.h) unless the user set them. Formats whose header
 * port/image_files.c reads itself are checked before OpenCV anyway; this covers the rest (WebP,
 * Sun raster, JPEG 2000, ...). A build that links OpenCV in (PLUGINS=0) loads it at start-up,
 * before any flag is parsed: there only OpenCV's default applies to those formats. */
static void opencv_limits(void)
{
    char v[32];
    snprintf(v, sizeof v, "%lld", pl_image_max_pixels());
    setenv("OPENCV_IO_MAX_IMAGE_PIXELS", v, 0);
    snprintf(v, sizeof v, "%d", PL_IMAGE_MAX_SIDE);
    setenv("OPENCV_IO_MAX_IMAGE_WIDTH", v, 0);
    setenv("OPENCV_IO_MAX_IMAGE_HEIGHT", v, 0);
}

/* Folder of the object this code is linked into (libparlight.so, or the executable for a static
 * link), or "". */
static void lib_dir(char *out, size_t n)
{
    Dl_info info;
    out[0] = '\0';
    if (!dladdr((void *)lib_dir, &info) || !info.dli_fname) return;
    char path[PATH_MAX];
    if (!realpath(info.dli_fname, path)) return;
    char *slash = strrchr(path, '/');
    if (!slash) return;
    *slash = '\0';
    snprintf(out, n, "%s", path[0] ? path : "/");
}

/* dlopen, then hand the plugin the host table; NULL with *why set when either fails. */
static void *open_plugin(const char *path, char *why, size_t why_len)
{
    void *h = dlopen(path, RTLD_NOW | RTLD_LOCAL);
    if (!h) {
        const char *e = dlerror();
        snprintf(why, why_len, "%s", e ? e : "dlopen failed");
        return NULL;
    }
    pl_plugin_bind_fn bind = (pl_plugin_bind_fn)dlsym(h, "pl_plugin_bind");
    if (!bind || bind(&host) < 0) {
        snprintf(why, why_len, "%.300s: %s", path,
                 bind ? "built for another plugin ABI (rebuild it with this parlight)"
                      : "not a parlight plugin (no pl_plugin_bind)");
        dlclose(h);
        return NULL;
    }
    return h;
}

static void *load(const char *name, char *error, size_t error_len)
{
    if (strcmp(name, "opencv") == 0) opencv_limits();
    char file[64], dirs[5][PATH_MAX], tried[1024] = "";
    snprintf(file, sizeof file, "parlight-%s.so", name);
    int nd = 0;
    const char *env = getenv("PARLIGHT_PLUGIN_DIR");
    if (env && env[0]) snprintf(dirs[nd++], sizeof dirs[0], "%.3900s", env);
    char exe[PATH_MAX];
    exe_dir(exe, sizeof exe);
    if (exe[0]) {
        snprintf(dirs[nd++], sizeof dirs[0], "%.3900s", exe);
        snprintf(dirs[nd++], sizeof dirs[0], "%.3900s/..", exe);
        snprintf(dirs[nd++], sizeof dirs[0], "%.3900s/../lib/parlight", exe);
    }
    char lib[PATH_MAX];
    lib_dir(lib, sizeof lib);
    if (lib[0] && strcmp(lib, exe) != 0)
        snprintf(dirs[nd++], sizeof dirs[0], "%.3900s/parlight", lib);
    char last[400] = "not found";
    for (int i = 0; i < nd; i++) {
        char path[4096];
        snprintf(path, sizeof path, "%.3950s/%.60s", dirs[i], file);
        size_t used = strlen(tried);
        if (used + 2 < sizeof tried)
            snprintf(tried + used, sizeof tried - used, "%s%.300s", used ? ", " : "", dirs[i]);
        if (access(path, F_OK) != 0) continue;
        void *h = open_plugin(path, last, sizeof last);
        if (h) return h;
    }
    snprintf(error, error_len, "cannot load the %s plugin %s (looked in %s): %s", name, file,
             nd ? tried : "(no folder: set PARLIGHT_PLUGIN_DIR)", last);
    return NULL;
}

void *pl_plugin_sym(const char *name, const char *sym, const char *what, int *status)
{
    void *handle = NULL;
    char error[512] = "";
    pthread_mutex_lock(&lock);
    int slot = -1;
    for (int i = 0; i < MAX_PLUGINS; i++) {
        if (strcmp(plugins[i].name, name) == 0) {
            slot = i;
            break;
        }
        if (slot < 0 && !plugins[i].name[0]) slot = i;
    }
    if (slot >= 0) {
        if (strcmp(plugins[slot].name, name) != 0) {
            snprintf(plugins[slot].name, sizeof plugins[slot].name, "%s", name);
            plugins[slot].handle = load(name, plugins[slot].error, sizeof plugins[slot].error);
        }
        handle = plugins[slot].handle;
        snprintf(error, sizeof error, "%s", plugins[slot].error);
    } else {
        snprintf(error, sizeof error, "too many plugins (%d)", MAX_PLUGINS);
    }
    pthread_mutex_unlock(&lock);
    void *p = handle ? dlsym(handle, sym) : NULL;
    if (!p) {
        if (handle) snprintf(error, sizeof error, "the %s plugin lacks %s", name, sym);
        *status = pl_error(PL_E_UNSUPPORTED, "%s: %s", what ? what : name, error);
    }
    return p;
}
