/* Loading plugins on first use (port/plugin.h). */
#include "core/image.h"
#include "core/util.h"
#include "port/plugin.h"

#include <dlfcn.h>
#include <limits.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#define MAX_PLUGINS 4

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

static void *load(const char *name, char *error, size_t error_len)
{
    if (strcmp(name, "opencv") == 0) opencv_limits();
    char file[64], dirs[4][PATH_MAX], tried[1024] = "";
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
    char last[400] = "not found";
    for (int i = 0; i < nd; i++) {
        char path[4096];
        snprintf(path, sizeof path, "%.3950s/%.60s", dirs[i], file);
        size_t used = strlen(tried);
        if (used + 2 < sizeof tried)
            snprintf(tried + used, sizeof tried - used, "%s%.300s", used ? ", " : "", dirs[i]);
        if (access(path, F_OK) != 0) continue;
        void *h = dlopen(path, RTLD_NOW | RTLD_LOCAL);
        if (h) return h;
        const char *e = dlerror();
        snprintf(last, sizeof last, "%s", e ? e : "dlopen failed");
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
