/* The libcamera source through its plugin (port/plugin.h): built when the Makefile defines
 * PL_LIBCAMERA_PLUGIN (PLUGINS=1 and libcamera found); then port/source_libcamera.cpp lives in
 * parlight-libcamera.so and these forwarders load it when a libcamera spec is opened or the
 * cameras are listed. Contracts: port/libcamera_src.h. */
#ifdef PL_LIBCAMERA_PLUGIN

#include "core/util.h"
#include "port/libcamera_src.h"
#include "port/plugin.h"

#include <string.h>

#define CAM_FN(type, name, what)                                                                   \
    int st_ = PL_E_UNSUPPORTED;                                                                    \
    type fn_ = (type)pl_plugin_sym("libcamera", #name, what, &st_);                                \
    if (!fn_) return st_

/* Answered here, without loading libcamera: the same test as source_libcamera.cpp's. */
int pl_libcam_is_spec(const char *spec)
{
    return spec && strncmp(spec, "libcamera", 9) == 0 && (spec[9] == '\0' || spec[9] == ':');
}

int pl_libcam_open(const char *spec, pl_libcam **out)
{
    if (out) *out = NULL;
    typedef int (*fn)(const char *, pl_libcam **);
    CAM_FN(fn, pl_libcam_open, spec ? spec : "libcamera");
    return fn_(spec, out);
}

int pl_libcam_read(pl_libcam *cam, pl_image_u8 *img, size_t *capacity, int64_t *t_ns,
                   int64_t *index)
{
    typedef int (*fn)(pl_libcam *, pl_image_u8 *, size_t *, int64_t *, int64_t *);
    CAM_FN(fn, pl_libcam_read, "libcamera");
    return fn_(cam, img, capacity, t_ns, index);
}

const char *pl_libcam_describe(const pl_libcam *cam)
{
    int st;
    const char *(*f)(const pl_libcam *) = (const char *(*)(const pl_libcam *))pl_plugin_sym(
        "libcamera", "pl_libcam_describe", "libcamera", &st);
    return f ? f(cam) : "libcamera";
}

int pl_libcam_fps(const pl_libcam *cam, double *fps)
{
    typedef int (*fn)(const pl_libcam *, double *);
    CAM_FN(fn, pl_libcam_fps, "libcamera");
    return fn_(cam, fps);
}

void pl_libcam_close(pl_libcam *cam)
{
    if (!cam) return; /* a camera only exists when the plugin opened it */
    int st;
    void (*f)(pl_libcam *) =
        (void (*)(pl_libcam *))pl_plugin_sym("libcamera", "pl_libcam_close", "libcamera", &st);
    if (f) f(cam);
}

int pl_libcam_list(char *buf, size_t n, int *count)
{
    typedef int (*fn)(char *, size_t, int *);
    CAM_FN(fn, pl_libcam_list, "libcamera");
    return fn_(buf, n, count);
}

#else
typedef int pl_libcamera_plugin_unused;
#endif
