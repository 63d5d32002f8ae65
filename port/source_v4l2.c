/* V4L2 capture, shaped as its lifecycle (the kernel's capture.c example):
 *   dev_open -> dev_init (QUERYCAP, ENUM_FMT, S_FMT, S_PARM, REQBUFS mmap, QUERYBUF, mmap)
 *   -> dev_start (QBUF all, STREAMON) -> read_frame (poll, DQBUF, convert, QBUF)
 *   -> dev_stop (STREAMOFF) -> dev_uninit (munmap, REQBUFS 0) -> dev_close.
 * Every ioctl goes through xioctl, which retries EINTR. A lost device is closed and reopened
 * with the backoff in port/v4l2.h. The interface and spec syntax are in port/v4l2.h. */
#include "port/v4l2.h"

#include <errno.h>
#include <fcntl.h>
#include <linux/videodev2.h>
#include <math.h>
#include <poll.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/ioctl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include "core/util.h"
#include "port/image_mem.h"
#include "port/pixfmt.h"

/* The formats parlight reads, in the order chosen when the spec names none. */
static const struct {
    uint32_t fourcc;
    const char *name;
} usable_formats[] = {{V4L2_PIX_FMT_YUYV, "yuyv"},
                      {V4L2_PIX_FMT_NV12, "nv12"},
                      {V4L2_PIX_FMT_RGB24, "rgb24"},
                      {V4L2_PIX_FMT_MJPEG, "mjpeg"}};
#define N_USABLE (sizeof usable_formats / sizeof usable_formats[0])

static bool is_usable(uint32_t fourcc)
{
    for (size_t i = 0; i < N_USABLE; i++)
        if (usable_formats[i].fourcc == fourcc) return true;
    return false;
}

const char *pl_v4l2_fourcc_str(uint32_t f, char buf[5])
{
    for (int i = 0; i < 4; i++) {
        char ch = (char)((f >> (8 * i)) & 0xff);
        buf[i] = ch >= 0x20 && ch < 0x7f ? ch : '?';
    }
    buf[4] = '\0';
    for (int i = 3; i > 0 && buf[i] == ' '; i--) /* "RGB3", "GREY", "Y10 " -> "Y10" */
        buf[i] = '\0';
    return buf;
}

static int xioctl(int fd, unsigned long request, void *arg)
{
    int r;
    do
        r = ioctl(fd, request, arg);
    while (r == -1 && errno == EINTR);
    return r;
}

/* ---- spec ----------------------------------------------------------------------------------- */

static int parse_uint(const char *s, size_t n, long max, long *out)
{
    if (n == 0 || n > 9) return -1;
    long v = 0;
    for (size_t i = 0; i < n; i++) {
        if (s[i] < '0' || s[i] > '9') return -1;
        v = v * 10 + (s[i] - '0');
    }
    if (v < 1 || v > max) return -1;
    *out = v;
    return 0;
}

static int parse_fps(const char *s, size_t n, double *out)
{
    char buf[32];
    if (n == 0 || n >= sizeof buf) return -1;
    memcpy(buf, s, n);
    buf[n] = '\0';
    int dots = 0;
    for (size_t i = 0; i < n; i++) {
        if (buf[i] == '.')
            dots++;
        else if (buf[i] < '0' || buf[i] > '9')
            return -1;
    }
    if (dots > 1 || buf[0] == '.' || buf[n - 1] == '.') return -1;
    double v = strtod(buf, NULL);
    if (!(v > 0.0 && v <= 1000.0)) return -1;
    *out = v;
    return 0;
}

int pl_v4l2_parse_spec(const char *spec, pl_v4l2_spec *out)
{
    static const char syntax[] = "expected v4l2:/dev/videoN[:WxH[@FPS][:yuyv|nv12|rgb24|mjpeg]]";
    if (!spec || !out) return pl_error(PL_E_ARG, "camera spec: NULL argument");
    memset(out, 0, sizeof *out);
    if (strncmp(spec, "v4l2:", 5) != 0)
        return pl_error(PL_E_ARG, "camera spec '%s': unknown kind (%s)", spec, syntax);
    const char *p = spec + 5;
    const char *colon = strchr(p, ':');
    size_t plen = colon ? (size_t)(colon - p) : strlen(p);
    if (plen == 0 || p[0] != '/')
        return pl_error(PL_E_ARG, "camera spec '%s': device path must be absolute (%s)", spec,
                        syntax);
    if (plen >= sizeof out->path)
        return pl_error(PL_E_ARG, "camera spec '%s': device path longer than %zu bytes", spec,
                        sizeof out->path - 1);
    memcpy(out->path, p, plen);
    out->path[plen] = '\0';
    if (!colon) return PL_OK;

    /* :WxH[@FPS] */
    const char *sz = colon + 1;
    const char *colon2 = strchr(sz, ':');
    size_t szlen = colon2 ? (size_t)(colon2 - sz) : strlen(sz);
    const char *x = memchr(sz, 'x', szlen);
    const char *at = memchr(sz, '@', szlen);
    long w, h;
    size_t hlen = at ? (size_t)(at - (x ? x + 1 : sz)) : szlen - (x ? (size_t)(x + 1 - sz) : 0);
    if (!x || (at && at < x) || parse_uint(sz, (size_t)(x - sz), PL_IMAGE_MAX_SIDE, &w) < 0 ||
        parse_uint(x + 1, hlen, PL_IMAGE_MAX_SIDE, &h) < 0)
        return pl_error(PL_E_ARG,
                        "camera spec '%s': size '%.*s' is not WxH with W, H in 1..%d (%s)", spec,
                        (int)szlen, sz, PL_IMAGE_MAX_SIDE, syntax);
    out->width = (int)w;
    out->height = (int)h;
    if (at && parse_fps(at + 1, szlen - (size_t)(at + 1 - sz), &out->fps) < 0)
        return pl_error(PL_E_ARG,
                        "camera spec '%s': frame rate '%.*s' is not a number in (0, 1000] (%s)",
                        spec, (int)(szlen - (size_t)(at + 1 - sz)), at + 1, syntax);
    if (!colon2) return PL_OK;

    const char *f = colon2 + 1;
    for (size_t i = 0; i < N_USABLE; i++)
        if (strcmp(f, usable_formats[i].name) == 0) {
            out->fourcc = usable_formats[i].fourcc;
            return PL_OK;
        }
    return pl_error(
        PL_E_ARG, "camera spec '%s': format '%s' is not one of yuyv, nv12, rgb24, mjpeg", spec, f);
}

/* ---- the capture lifecycle ------------------------------------------------------------------ */

typedef struct mapped_buffer {
    void *start;
    size_t length;
} mapped_buffer;

struct pl_v4l2 {
    pl_v4l2_spec spec;
    char desc[270];
    int fd; /* -1 while closed (before open, or lost) */
    mapped_buffer bufs[8];
    unsigned n_bufs;
    bool streaming;
    /* negotiated */
    uint32_t fourcc;
    int width, height;
    size_t bytesperline, min_bytes;
    pl_yuv_coeffs yuv;
    const char *coding;
    double fps;
    int poll_timeout_ms;
    /* frame numbering across reopens */
    bool have_seq0;
    uint32_t seq0;
    int64_t index_base, next_index;
    /* loss and reopen */
    int64_t lost_since_ns; /* 0 while the device works */
    int64_t next_try_ns;
    double backoff_s;
    int attempts;
    bool gave_up;
    bool loss_pending; /* lost after a good frame: the message is due on the next read */
    char lost_reason[160];
    char lost_msg[640];
};

static void dev_close(pl_v4l2 *c)
{
    if (c->fd >= 0) close(c->fd);
    c->fd = -1;
}

static int dev_open(pl_v4l2 *c)
{
    struct stat st;
    if (stat(c->spec.path, &st) != 0)
        return pl_error(PL_E_IO, "%s: cannot open camera: %s", c->desc, strerror(errno));
    if (!S_ISCHR(st.st_mode))
        return pl_error(PL_E_IO, "%s: not a device node (a V4L2 camera is a character device)",
                        c->desc);
    c->fd = open(c->spec.path, O_RDWR | O_NONBLOCK | O_CLOEXEC);
    if (c->fd < 0) return pl_error(PL_E_IO, "%s: cannot open camera: %s", c->desc, strerror(errno));
    return PL_OK;
}

/* Space-separated FOURCCs of the capture formats the device offers, into buf. */
static void list_formats(int fd, char *buf, size_t cap)
{
    size_t n = 0;
    buf[0] = '\0';
    for (uint32_t i = 0; i < 256; i++) {
        struct v4l2_fmtdesc fd_ = {.index = i, .type = V4L2_BUF_TYPE_VIDEO_CAPTURE};
        if (xioctl(fd, VIDIOC_ENUM_FMT, &fd_) < 0) break;
        char fcc[5];
        int w = snprintf(buf + n, cap - n, "%s%s", n ? " " : "",
                         pl_v4l2_fourcc_str(fd_.pixelformat, fcc));
        if (w < 0 || (size_t)w >= cap - n) {
            if (cap > 4) memcpy(buf + cap - 4, "...", 4);
            return;
        }
        n += (size_t)w;
    }
    if (n == 0) snprintf(buf, cap, "none");
}

static int choose_format(pl_v4l2 *c, uint32_t *fourcc)
{
    bool offered[N_USABLE] = {false};
    for (uint32_t i = 0; i < 256; i++) {
        struct v4l2_fmtdesc d = {.index = i, .type = V4L2_BUF_TYPE_VIDEO_CAPTURE};
        if (xioctl(c->fd, VIDIOC_ENUM_FMT, &d) < 0) break;
        for (size_t k = 0; k < N_USABLE; k++)
            if (d.pixelformat == usable_formats[k].fourcc) offered[k] = true;
    }
    for (size_t k = 0; k < N_USABLE; k++) {
        if (c->spec.fourcc ? c->spec.fourcc == usable_formats[k].fourcc : offered[k]) {
            if (!offered[k]) break;
            *fourcc = usable_formats[k].fourcc;
            return PL_OK;
        }
    }
    char list[512], fcc[5];
    list_formats(c->fd, list, sizeof list);
    if (c->spec.fourcc)
        return pl_error(PL_E_UNSUPPORTED, "%s: the device does not offer %s (it offers: %s)",
                        c->desc, pl_v4l2_fourcc_str(c->spec.fourcc, fcc), list);
    return pl_error(PL_E_UNSUPPORTED,
                    "%s: no usable pixel format: the device offers %s; parlight reads YUYV, NV12, "
                    "RGB24 and MJPEG",
                    c->desc, list);
}

/* YCbCr matrix and range from the format's colorimetry fields (defaults as the kernel maps them).
 */
static void set_coding(pl_v4l2 *c, const struct v4l2_pix_format *pix)
{
    uint32_t cs = pix->colorspace, enc = V4L2_YCBCR_ENC_DEFAULT, q = V4L2_QUANTIZATION_DEFAULT;
    if (pix->priv == V4L2_PIX_FMT_PRIV_MAGIC) {
        enc = pix->ycbcr_enc;
        q = pix->quantization;
    }
    if (enc == V4L2_YCBCR_ENC_DEFAULT) enc = V4L2_MAP_YCBCR_ENC_DEFAULT(cs);
    if (q == V4L2_QUANTIZATION_DEFAULT) q = V4L2_MAP_QUANTIZATION_DEFAULT(0, cs, enc);
    const pl_yuv_matrix m =
        enc == V4L2_YCBCR_ENC_709 || enc == V4L2_YCBCR_ENC_XV709 ? PL_YUV_BT709 : PL_YUV_BT601;
    const pl_yuv_range r = q == V4L2_QUANTIZATION_FULL_RANGE ? PL_YUV_FULL : PL_YUV_LIMITED;
    pl_yuv_coeffs_init(&c->yuv, m, r);
    static const char *const names[2][2] = {{"BT.601 limited", "BT.601 full"},
                                            {"BT.709 limited", "BT.709 full"}};
    c->coding = names[m][r];
    if (pix->pixelformat == V4L2_PIX_FMT_RGB24) c->coding = "RGB";
    if (pix->pixelformat == V4L2_PIX_FMT_MJPEG) c->coding = "JPEG (BT.601 full, by the decoder)";
}

static int set_rate(pl_v4l2 *c)
{
    struct v4l2_streamparm parm = {.type = V4L2_BUF_TYPE_VIDEO_CAPTURE};
    int have = xioctl(c->fd, VIDIOC_G_PARM, &parm) == 0;
    if (c->spec.fps > 0) {
        if (!have || !(parm.parm.capture.capability & V4L2_CAP_TIMEPERFRAME))
            return pl_error(PL_E_UNSUPPORTED, "%s: the device does not let its frame rate be set",
                            c->desc);
        parm.parm.capture.timeperframe.numerator = 1000;
        parm.parm.capture.timeperframe.denominator = (uint32_t)lround(c->spec.fps * 1000.0);
        if (xioctl(c->fd, VIDIOC_S_PARM, &parm) < 0)
            return pl_error(PL_E_DEVICE, "%s: VIDIOC_S_PARM %.3g fps: %s", c->desc, c->spec.fps,
                            strerror(errno));
    }
    const struct v4l2_fract *t = &parm.parm.capture.timeperframe;
    c->fps = have && t->numerator && t->denominator ? (double)t->denominator / t->numerator : 0;
    if (c->spec.fps > 0 && fabs(c->fps - c->spec.fps) > 0.01 * c->spec.fps)
        return pl_error(PL_E_UNSUPPORTED,
                        "%s: asked for %.3g fps, the device gives %.3g fps at %dx%d (see parlight "
                        "cameras)",
                        c->desc, c->spec.fps, c->fps, c->width, c->height);
    c->poll_timeout_ms = PL_V4L2_POLL_TIMEOUT_MS;
    if (c->fps > 0 && 3000.0 / c->fps > c->poll_timeout_ms)
        c->poll_timeout_ms = (int)(3000.0 / c->fps);
    return PL_OK;
}

static int dev_init(pl_v4l2 *c)
{
    struct v4l2_capability cap;
    memset(&cap, 0, sizeof cap);
    if (xioctl(c->fd, VIDIOC_QUERYCAP, &cap) < 0)
        return pl_error(errno == ENOTTY ? PL_E_DEVICE : PL_E_IO,
                        "%s: not a V4L2 device (VIDIOC_QUERYCAP: %s)", c->desc, strerror(errno));
    const uint32_t caps =
        cap.capabilities & V4L2_CAP_DEVICE_CAPS ? cap.device_caps : cap.capabilities;
    if (!(caps & V4L2_CAP_VIDEO_CAPTURE))
        return pl_error(
            PL_E_DEVICE, "%s: %s (%s) is not a single-planar video capture device%s", c->desc,
            (const char *)cap.card, (const char *)cap.driver,
            caps & V4L2_CAP_VIDEO_CAPTURE_MPLANE ? " (multi-planar capture is not supported)" : "");
    if (!(caps & V4L2_CAP_STREAMING))
        return pl_error(PL_E_DEVICE, "%s: %s does not support streaming I/O (mmap)", c->desc,
                        (const char *)cap.card);

    uint32_t fourcc = 0;
    int rc = choose_format(c, &fourcc);
    if (rc < 0) return rc;
    struct v4l2_format fmt = {.type = V4L2_BUF_TYPE_VIDEO_CAPTURE};
    if (xioctl(c->fd, VIDIOC_G_FMT, &fmt) < 0)
        return pl_error(PL_E_DEVICE, "%s: VIDIOC_G_FMT: %s", c->desc, strerror(errno));
    if (c->spec.width) {
        fmt.fmt.pix.width = (uint32_t)c->spec.width;
        fmt.fmt.pix.height = (uint32_t)c->spec.height;
    }
    fmt.fmt.pix.pixelformat = fourcc;
    fmt.fmt.pix.field = V4L2_FIELD_NONE;
    fmt.fmt.pix.bytesperline = 0; /* let the driver choose */
    if (xioctl(c->fd, VIDIOC_S_FMT, &fmt) < 0)
        return pl_error(PL_E_DEVICE, "%s: VIDIOC_S_FMT: %s%s", c->desc, strerror(errno),
                        errno == EBUSY ? " (another program is using the camera)" : "");
    const struct v4l2_pix_format *pix = &fmt.fmt.pix;
    char want[5], got[5];
    if (pix->pixelformat != fourcc)
        return pl_error(PL_E_UNSUPPORTED, "%s: asked for %s, the driver set %s", c->desc,
                        pl_v4l2_fourcc_str(fourcc, want),
                        pl_v4l2_fourcc_str(pix->pixelformat, got));
    if (c->spec.width &&
        (pix->width != (uint32_t)c->spec.width || pix->height != (uint32_t)c->spec.height))
        return pl_error(PL_E_UNSUPPORTED,
                        "%s: asked for %dx%d %s, the device gives %ux%u (see parlight cameras)",
                        c->desc, c->spec.width, c->spec.height, pl_v4l2_fourcc_str(fourcc, want),
                        pix->width, pix->height);
    if (pix->field != V4L2_FIELD_NONE && pix->field != V4L2_FIELD_INTERLACED &&
        pix->field != V4L2_FIELD_INTERLACED_TB && pix->field != V4L2_FIELD_INTERLACED_BT)
        return pl_error(PL_E_UNSUPPORTED, "%s: field order %u gives half frames (not supported)",
                        c->desc, pix->field);
    if (pl_image_check_size(c->desc, pix->width, pix->height) < 0) return PL_E_UNSUPPORTED;
    c->fourcc = fourcc;
    c->width = (int)pix->width;
    c->height = (int)pix->height;
    c->bytesperline = pix->bytesperline;
    c->min_bytes = 1;
    if (fourcc != V4L2_PIX_FMT_MJPEG) {
        const pl_pixfmt pf = fourcc == V4L2_PIX_FMT_YUYV   ? PL_PIX_YUYV
                             : fourcc == V4L2_PIX_FMT_NV12 ? PL_PIX_NV12
                                                           : PL_PIX_RGB24;
        if (c->bytesperline == 0)
            c->bytesperline = pf == PL_PIX_YUYV   ? (size_t)(c->width + 1) / 2 * 4
                              : pf == PL_PIX_NV12 ? (size_t)(c->width + 1) / 2 * 2
                                                  : (size_t)c->width * 3;
        rc = pl_pixfmt_min_bytes(pf, c->width, c->height, c->bytesperline, &c->min_bytes);
        if (rc < 0) return pl_error_prefix(PL_E_UNSUPPORTED, "%s", c->desc);
    }
    set_coding(c, pix);
    rc = set_rate(c);
    if (rc < 0) return rc;

    struct v4l2_requestbuffers req = {
        .count = PL_V4L2_BUFFERS, .type = V4L2_BUF_TYPE_VIDEO_CAPTURE, .memory = V4L2_MEMORY_MMAP};
    if (xioctl(c->fd, VIDIOC_REQBUFS, &req) < 0)
        return pl_error(PL_E_DEVICE, "%s: VIDIOC_REQBUFS (mmap): %s", c->desc, strerror(errno));
    if (req.count < 2)
        return pl_error(PL_E_DEVICE, "%s: the driver granted %u buffer(s); at least 2 are needed",
                        c->desc, req.count);
    if (req.count > sizeof c->bufs / sizeof c->bufs[0])
        req.count = sizeof c->bufs / sizeof c->bufs[0];
    for (unsigned i = 0; i < req.count; i++) {
        struct v4l2_buffer b = {
            .index = i, .type = V4L2_BUF_TYPE_VIDEO_CAPTURE, .memory = V4L2_MEMORY_MMAP};
        if (xioctl(c->fd, VIDIOC_QUERYBUF, &b) < 0)
            return pl_error(PL_E_DEVICE, "%s: VIDIOC_QUERYBUF %u: %s", c->desc, i, strerror(errno));
        if (b.length < c->min_bytes)
            return pl_error(PL_E_DEVICE, "%s: buffer %u holds %u bytes, a %dx%d frame needs %zu",
                            c->desc, i, b.length, c->width, c->height, c->min_bytes);
        void *p = mmap(NULL, b.length, PROT_READ | PROT_WRITE, MAP_SHARED, c->fd, b.m.offset);
        if (p == MAP_FAILED)
            return pl_error(PL_E_DEVICE, "%s: mmap of buffer %u: %s", c->desc, i, strerror(errno));
        c->bufs[i].start = p;
        c->bufs[i].length = b.length;
        c->n_bufs = i + 1;
    }
    return PL_OK;
}

static int dev_start(pl_v4l2 *c)
{
    for (unsigned i = 0; i < c->n_bufs; i++) {
        struct v4l2_buffer b = {
            .index = i, .type = V4L2_BUF_TYPE_VIDEO_CAPTURE, .memory = V4L2_MEMORY_MMAP};
        if (xioctl(c->fd, VIDIOC_QBUF, &b) < 0)
            return pl_error(PL_E_DEVICE, "%s: VIDIOC_QBUF %u: %s", c->desc, i, strerror(errno));
    }
    enum v4l2_buf_type type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    if (xioctl(c->fd, VIDIOC_STREAMON, &type) < 0)
        return pl_error(PL_E_DEVICE, "%s: VIDIOC_STREAMON: %s", c->desc, strerror(errno));
    c->streaming = true;
    c->have_seq0 = false;
    return PL_OK;
}

static void dev_stop(pl_v4l2 *c)
{
    if (c->streaming && c->fd >= 0) {
        enum v4l2_buf_type type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
        (void)xioctl(c->fd, VIDIOC_STREAMOFF, &type); /* fails harmlessly on a lost device */
    }
    c->streaming = false;
}

static void dev_uninit(pl_v4l2 *c)
{
    for (unsigned i = 0; i < c->n_bufs; i++)
        munmap(c->bufs[i].start, c->bufs[i].length);
    c->n_bufs = 0;
    if (c->fd >= 0) {
        struct v4l2_requestbuffers req = {
            .count = 0, .type = V4L2_BUF_TYPE_VIDEO_CAPTURE, .memory = V4L2_MEMORY_MMAP};
        (void)xioctl(c->fd, VIDIOC_REQBUFS, &req);
    }
}

static void dev_shutdown(pl_v4l2 *c)
{
    dev_stop(c);
    dev_uninit(c);
    dev_close(c);
}

static int dev_bringup(pl_v4l2 *c)
{
    int rc = dev_open(c);
    if (rc == PL_OK) rc = dev_init(c);
    if (rc == PL_OK) rc = dev_start(c);
    if (rc < 0) dev_shutdown(c);
    return rc;
}

int pl_v4l2_open(const pl_v4l2_spec *spec, pl_v4l2 **out)
{
    if (!spec || !out) return pl_error(PL_E_ARG, "pl_v4l2_open: NULL argument");
    *out = NULL;
    pl_v4l2 *c = calloc(1, sizeof *c);
    if (!c) return pl_error(PL_E_NOMEM, "v4l2:%s: out of memory", spec->path);
    c->spec = *spec;
    c->fd = -1;
    snprintf(c->desc, sizeof c->desc, "v4l2:%s", spec->path);
    int rc = dev_bringup(c);
    if (rc < 0) {
        free(c);
        return rc;
    }
    *out = c;
    return PL_OK;
}

static void sleep_until(int64_t t_ns)
{
    for (;;) {
        int64_t left = t_ns - pl_now_ns();
        if (left <= 0) return;
        struct timespec ts = {(time_t)(left / 1000000000), (long)(left % 1000000000)};
        nanosleep(&ts, NULL); /* EINTR: loop and sleep the rest */
    }
}

/* Closes the device after a failure and starts (or continues) the reopen schedule. `what` and,
 * when err != 0, strerror(err) make the reason. */
static int lost(pl_v4l2 *c, const char *what, int err)
{
    if (err)
        snprintf(c->lost_reason, sizeof c->lost_reason, "%s: %s", what, strerror(err));
    else
        snprintf(c->lost_reason, sizeof c->lost_reason, "%s", what);
    dev_shutdown(c);
    const int64_t now = pl_now_ns();
    if (!c->lost_since_ns) {
        c->lost_since_ns = now;
        c->backoff_s = PL_V4L2_BACKOFF_FIRST_S;
        c->attempts = 0;
    }
    c->next_try_ns = now + (int64_t)(c->backoff_s * 1e9);
    snprintf(c->lost_msg, sizeof c->lost_msg,
             "%s: device lost (%s); reopening (backoff %.1f s doubling to %.0f s, giving up after "
             "%.0f s)",
             c->desc, c->lost_reason, PL_V4L2_BACKOFF_FIRST_S, PL_V4L2_BACKOFF_MAX_S,
             PL_V4L2_GIVE_UP_S);
    return pl_error(PL_E_DEVICE, "%s", c->lost_msg);
}

static int reopen(pl_v4l2 *c)
{
    const int64_t give_up_at = c->lost_since_ns + (int64_t)(PL_V4L2_GIVE_UP_S * 1e9);
    if (c->next_try_ns > give_up_at) {
        c->gave_up = true;
        return pl_error(PL_E_EOF,
                        "%s: device lost (%s) and not back after %.0f s (%d reopen "
                        "attempts): giving up",
                        c->desc, c->lost_reason, PL_V4L2_GIVE_UP_S, c->attempts);
    }
    sleep_until(c->next_try_ns);
    c->attempts++;
    int rc = dev_bringup(c);
    if (rc == PL_OK) {
        c->index_base = c->next_index;
        return PL_OK;
    }
    if (rc == PL_E_NOMEM) return rc;
    c->backoff_s =
        c->backoff_s * 2 > PL_V4L2_BACKOFF_MAX_S ? PL_V4L2_BACKOFF_MAX_S : c->backoff_s * 2;
    c->next_try_ns = pl_now_ns() + (int64_t)(c->backoff_s * 1e9);
    return pl_error_prefix(PL_E_DEVICE, "%s: reopen attempt %d failed (next in %.1f s)", c->desc,
                           c->attempts, c->backoff_s);
}

static int convert(pl_v4l2 *c, const uint8_t *p, size_t used, int64_t seq, pl_image_u8 *img,
                   size_t *capacity)
{
    if (c->fourcc == V4L2_PIX_FMT_MJPEG) {
        char what[300];
        snprintf(what, sizeof what, "%s frame %lld", c->desc, (long long)seq);
        int rc = pl_image_decode_jpeg_rgb8_reuse(p, used, what, img, capacity);
        if (rc < 0) return rc;
        if (img->width != c->width || img->height != c->height)
            return pl_error(PL_E_FORMAT, "%s: decoded %dx%d, the stream is %dx%d", what, img->width,
                            img->height, c->width, c->height);
        return PL_OK;
    }
    if (used < c->min_bytes)
        return pl_error(PL_E_FORMAT, "%s frame %lld: %zu bytes, a %dx%d frame needs %zu", c->desc,
                        (long long)seq, used, c->width, c->height, c->min_bytes);
    int rc = pl_image_u8_reserve(img, capacity, c->width, c->height);
    if (rc < 0) return pl_error_prefix(rc, "%s", c->desc);
    switch (c->fourcc) {
    case V4L2_PIX_FMT_YUYV:
        pl_yuyv_to_rgb8(p, c->bytesperline, c->width, c->height, &c->yuv, img->data, img->stride);
        break;
    case V4L2_PIX_FMT_NV12:
        pl_nv12_to_rgb8(p, c->bytesperline, p + c->bytesperline * (size_t)c->height,
                        c->bytesperline, c->width, c->height, &c->yuv, img->data, img->stride);
        break;
    default:
        pl_rgb24_to_rgb8(p, c->bytesperline, c->width, c->height, img->data, img->stride);
        break;
    }
    return PL_OK;
}

/* Waits for a filled buffer: 1 ready, 0 timed out, -1 error (errno set). */
static int wait_frame(pl_v4l2 *c)
{
    const int64_t deadline = pl_now_ns() + (int64_t)c->poll_timeout_ms * 1000000;
    for (;;) {
        int64_t left_ms = (deadline - pl_now_ns() + 999999) / 1000000;
        if (left_ms <= 0) return 0;
        struct pollfd pfd = {.fd = c->fd, .events = POLLIN};
        int r = poll(&pfd, 1, (int)left_ms);
        if (r < 0 && errno == EINTR) continue;
        if (r < 0) return -1;
        if (r == 0) return 0;
        return 1; /* POLLERR/POLLHUP too: DQBUF tells what happened */
    }
}

/* Dequeues the newest filled buffer into *b: waits for one (poll with timeout), then hands back
 * to the driver, unread, any older ones that queued up while the caller was busy (their sequence
 * numbers leave a gap in the indices). Returns PL_OK or lost()'s error. */
static int dequeue_newest(pl_v4l2 *c, struct v4l2_buffer *b)
{
    for (int spurious = 0;; spurious++) {
        int w = wait_frame(c);
        if (w < 0) return lost(c, "poll", errno);
        if (w == 0) {
            char why[64];
            snprintf(why, sizeof why, "no frame within %d ms", c->poll_timeout_ms);
            return lost(c, why, 0);
        }
        memset(b, 0, sizeof *b);
        b->type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
        b->memory = V4L2_MEMORY_MMAP;
        if (xioctl(c->fd, VIDIOC_DQBUF, b) == 0) break;
        if (errno != EAGAIN || spurious > 100) return lost(c, "VIDIOC_DQBUF", errno);
    }
    for (;;) {
        if (b->index >= c->n_bufs || b->bytesused > c->bufs[b->index].length)
            return lost(c, "the driver returned an invalid buffer", 0);
        struct v4l2_buffer newer;
        memset(&newer, 0, sizeof newer);
        newer.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
        newer.memory = V4L2_MEMORY_MMAP;
        if (xioctl(c->fd, VIDIOC_DQBUF, &newer) < 0) return PL_OK; /* EAGAIN: b is the newest */
        if (xioctl(c->fd, VIDIOC_QBUF, b) < 0) return lost(c, "VIDIOC_QBUF", errno);
        *b = newer;
    }
}

/* True when even the newest queued frame is more than two frame intervals old: every buffer was
 * full, so the driver stopped capturing while the caller was busy. Such a frame is given back
 * and the next (fresh) one is waited for instead: at most one frame interval more. */
static bool is_stale(const pl_v4l2 *c, const struct v4l2_buffer *b)
{
    if ((b->flags & V4L2_BUF_FLAG_TIMESTAMP_MASK) != V4L2_BUF_FLAG_TIMESTAMP_MONOTONIC ||
        !(c->fps > 0))
        return false;
    const int64_t t =
        (int64_t)b->timestamp.tv_sec * 1000000000 + (int64_t)b->timestamp.tv_usec * 1000;
    return pl_now_ns() - t > (int64_t)(2e9 / c->fps);
}

int pl_v4l2_read(pl_v4l2 *c, pl_image_u8 *img, size_t *capacity, int64_t *t_ns, int64_t *index)
{
    if (!c || !img || !capacity || !t_ns || !index)
        return pl_error(PL_E_ARG, "pl_v4l2_read: NULL argument");
    if (c->gave_up)
        return pl_error(PL_E_EOF, "%s: device lost (%s): gave up after %d reopen attempts", c->desc,
                        c->lost_reason, c->attempts);
    if (c->loss_pending) {
        c->loss_pending = false;
        return pl_error(PL_E_DEVICE, "%s", c->lost_msg);
    }
    if (c->fd < 0) {
        int rc = reopen(c);
        if (rc < 0) return rc;
    }
    struct v4l2_buffer b;
    int rc = dequeue_newest(c, &b);
    if (rc < 0) return rc;
    if (is_stale(c, &b)) {
        if (xioctl(c->fd, VIDIOC_QBUF, &b) < 0) return lost(c, "VIDIOC_QBUF", errno);
        rc = dequeue_newest(c, &b);
        if (rc < 0) return rc;
    }
    if (!c->have_seq0) {
        c->seq0 = b.sequence;
        c->have_seq0 = true;
    }
    const int64_t seq = c->index_base + (int64_t)(uint32_t)(b.sequence - c->seq0);
    const size_t used = b.bytesused ? b.bytesused : c->bufs[b.index].length;
    if (b.flags & V4L2_BUF_FLAG_ERROR)
        rc = pl_error(PL_E_FORMAT, "%s frame %lld: the driver flagged it as corrupted", c->desc,
                      (long long)seq);
    else
        rc = convert(c, c->bufs[b.index].start, used, seq, img, capacity);
    if ((b.flags & V4L2_BUF_FLAG_TIMESTAMP_MASK) == V4L2_BUF_FLAG_TIMESTAMP_MONOTONIC)
        *t_ns = (int64_t)b.timestamp.tv_sec * 1000000000 + (int64_t)b.timestamp.tv_usec * 1000;
    else
        *t_ns = pl_now_ns();
    *index = seq;
    c->next_index = seq + 1;
    if (xioctl(c->fd, VIDIOC_QBUF, &b) < 0) {
        int err = errno;
        if (rc == PL_OK) {
            /* This frame is good; the loss is reported by the next read. */
            lost(c, "VIDIOC_QBUF", err);
            c->loss_pending = true;
            return PL_OK;
        }
        return lost(c, "VIDIOC_QBUF", err);
    }
    if (rc == PL_OK) c->lost_since_ns = 0;
    return rc;
}

const char *pl_v4l2_describe(const pl_v4l2 *c)
{
    return c ? c->desc : "(no camera)";
}

int pl_v4l2_fps(const pl_v4l2 *c, double *fps)
{
    if (!c || !fps) return pl_error(PL_E_ARG, "pl_v4l2_fps: NULL argument");
    if (!(c->fps > 0))
        return pl_error(PL_E_UNSUPPORTED, "%s: the driver reports no frame rate", c->desc);
    *fps = c->fps;
    return PL_OK;
}

void pl_v4l2_format(const pl_v4l2 *c, int *width, int *height, uint32_t *fourcc,
                    const char **coding)
{
    if (width) *width = c ? c->width : 0;
    if (height) *height = c ? c->height : 0;
    if (fourcc) *fourcc = c ? c->fourcc : 0;
    if (coding) *coding = c && c->coding ? c->coding : "";
}

void pl_v4l2_close(pl_v4l2 *c)
{
    if (!c) return;
    dev_shutdown(c);
    free(c);
}

/* ---- device listing ------------------------------------------------------------------------- */

static void query_intervals(int fd, uint32_t fourcc, pl_v4l2_frame_size *s)
{
    for (uint32_t i = 0; i < 16; i++) {
        struct v4l2_frmivalenum iv = {
            .index = i, .pixel_format = fourcc, .width = s->width, .height = s->height};
        if (xioctl(fd, VIDIOC_ENUM_FRAMEINTERVALS, &iv) < 0) break;
        if (iv.type == V4L2_FRMIVAL_TYPE_DISCRETE) {
            s->intervals[s->n_intervals].num = iv.discrete.numerator;
            s->intervals[s->n_intervals].den = iv.discrete.denominator;
            s->n_intervals++;
        } else {
            s->interval_stepwise = 1;
            s->intervals[0].num = iv.stepwise.min.numerator;
            s->intervals[0].den = iv.stepwise.min.denominator;
            s->intervals[1].num = iv.stepwise.max.numerator;
            s->intervals[1].den = iv.stepwise.max.denominator;
            s->n_intervals = 2;
            break;
        }
    }
}

static int query_sizes(int fd, pl_v4l2_format_info *f)
{
    f->sizes = calloc(64, sizeof *f->sizes);
    if (!f->sizes) return pl_error(PL_E_NOMEM, "camera listing: out of memory");
    for (uint32_t i = 0; i < 64; i++) {
        struct v4l2_frmsizeenum fs = {.index = i, .pixel_format = f->fourcc};
        if (xioctl(fd, VIDIOC_ENUM_FRAMESIZES, &fs) < 0) break;
        pl_v4l2_frame_size *s = &f->sizes[f->n_sizes++];
        if (fs.type == V4L2_FRMSIZE_TYPE_DISCRETE) {
            s->width = s->max_width = fs.discrete.width;
            s->height = s->max_height = fs.discrete.height;
        } else {
            s->stepwise = 1;
            s->width = fs.stepwise.min_width;
            s->height = fs.stepwise.min_height;
            s->max_width = fs.stepwise.max_width;
            s->max_height = fs.stepwise.max_height;
            s->step_width = fs.stepwise.step_width;
            s->step_height = fs.stepwise.step_height;
        }
        query_intervals(fd, f->fourcc, s);
        if (s->stepwise) break;
    }
    return PL_OK;
}

int pl_v4l2_query_device(const char *path, pl_v4l2_device_info *info)
{
    if (!path || !info) return pl_error(PL_E_ARG, "pl_v4l2_query_device: NULL argument");
    memset(info, 0, sizeof *info);
    snprintf(info->path, sizeof info->path, "%s", path);
    int fd = open(path, O_RDWR | O_NONBLOCK | O_CLOEXEC);
    if (fd < 0) return pl_error(PL_E_IO, "%s: cannot open: %s", path, strerror(errno));
    struct v4l2_capability cap;
    memset(&cap, 0, sizeof cap);
    int rc = PL_OK;
    if (xioctl(fd, VIDIOC_QUERYCAP, &cap) < 0) {
        rc = pl_error(PL_E_DEVICE, "%s: not a V4L2 device (VIDIOC_QUERYCAP: %s)", path,
                      strerror(errno));
        goto out;
    }
    memcpy(info->driver, cap.driver, sizeof cap.driver);
    memcpy(info->card, cap.card, sizeof cap.card);
    memcpy(info->bus_info, cap.bus_info, sizeof cap.bus_info);
    info->device_caps =
        cap.capabilities & V4L2_CAP_DEVICE_CAPS ? cap.device_caps : cap.capabilities;
    info->is_capture =
        (info->device_caps & V4L2_CAP_VIDEO_CAPTURE) && (info->device_caps & V4L2_CAP_STREAMING);
    if (!info->is_capture) goto out;
    info->formats = calloc(128, sizeof *info->formats);
    if (!info->formats) {
        rc = pl_error(PL_E_NOMEM, "%s: out of memory", path);
        goto out;
    }
    for (uint32_t i = 0; i < 128; i++) {
        struct v4l2_fmtdesc d = {.index = i, .type = V4L2_BUF_TYPE_VIDEO_CAPTURE};
        if (xioctl(fd, VIDIOC_ENUM_FMT, &d) < 0) break;
        pl_v4l2_format_info *f = &info->formats[info->n_formats++];
        f->fourcc = d.pixelformat;
        memcpy(f->description, d.description, sizeof f->description);
        f->description[sizeof f->description - 1] = '\0';
        f->compressed = (d.flags & V4L2_FMT_FLAG_COMPRESSED) != 0;
        f->usable = is_usable(d.pixelformat);
        rc = query_sizes(fd, f);
        if (rc < 0) goto out;
    }
out:
    close(fd);
    if (rc < 0) pl_v4l2_device_info_free(info);
    return rc;
}

void pl_v4l2_device_info_free(pl_v4l2_device_info *info)
{
    if (!info) return;
    for (int i = 0; i < info->n_formats; i++)
        free(info->formats[i].sizes);
    free(info->formats);
    info->formats = NULL;
    info->n_formats = 0;
}
