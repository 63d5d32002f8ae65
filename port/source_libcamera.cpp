/* libcamera frame source: the C interface of port/libcamera_src.h over libcamera 0.0.3.
 * Every entry point catches every exception; the requestCompleted callback only queues. */
#include "port/libcamera_src.h"

#include <ctype.h>
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

extern "C" {
#include "core/util.h"
#include "parlight.h"
}
#include "port/image_mem.h"
#include "port/pixfmt.h"

int pl_libcam_is_spec(const char *spec)
{
    return spec && strncmp(spec, "libcamera", 9) == 0 && (spec[9] == '\0' || spec[9] == ':');
}

#ifndef PL_HAVE_LIBCAMERA

struct pl_libcam {
    int unused;
};

int pl_libcam_open(const char *spec, pl_libcam **out)
{
    if (out) *out = NULL;
    return pl_error(PL_E_UNSUPPORTED, "%s: parlight was built without libcamera (libcamera-dev)",
                    spec ? spec : "libcamera");
}
int pl_libcam_read(pl_libcam *, pl_image_u8 *, size_t *, int64_t *, int64_t *)
{
    return pl_error(PL_E_UNSUPPORTED, "libcamera: not built in");
}
const char *pl_libcam_describe(const pl_libcam *)
{
    return "libcamera";
}
int pl_libcam_fps(const pl_libcam *, double *)
{
    return pl_error(PL_E_UNSUPPORTED, "libcamera: not built in");
}
void pl_libcam_close(pl_libcam *) {}
int pl_libcam_list(char *buf, size_t n, int *count)
{
    if (buf && n) buf[0] = '\0';
    if (count) *count = 0;
    return pl_error(PL_E_UNSUPPORTED, "parlight was built without libcamera (libcamera-dev)");
}

#else

#include <sys/mman.h>
#include <unistd.h>

#include <chrono>
#include <condition_variable>
#include <deque>
#include <exception>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include <libcamera/libcamera.h>
#include <libcamera/logging.h>

using namespace libcamera;

namespace
{

constexpr int kFrameTimeoutMs = 5000;
constexpr int kMaxTimeouts = 3; /* then the source ends (PL_E_EOF) */

/* One mmap of a dmabuf (planes of a buffer may share one fd: mapped once per fd). */
struct Mapping {
    void *addr = MAP_FAILED;
    size_t len = 0;
};

void quiet_logs()
{
    if (!getenv("LIBCAMERA_LOG_LEVELS") && !getenv("LIBCAMERA_LOG_FILE"))
        logSetTarget(LoggingTargetNone);
}

bool parse_index(const char *s, size_t *out)
{
    if (!*s || strlen(s) > 6) return false;
    size_t v = 0;
    for (const char *p = s; *p; p++) {
        if (!isdigit((unsigned char)*p)) return false;
        v = v * 10 + (size_t)(*p - '0');
    }
    *out = v;
    return true;
}

} // namespace

struct pl_libcam {
    std::unique_ptr<CameraManager> cm;
    std::shared_ptr<Camera> camera;
    bool acquired = false, started = false;
    std::unique_ptr<CameraConfiguration> config;
    Stream *stream = nullptr;
    std::unique_ptr<FrameBufferAllocator> alloc;
    std::vector<std::unique_ptr<Request>> requests;
    std::map<int, Mapping> maps; /* by dmabuf fd */
    /* per buffer: address of plane 0 and the bytes mapped from there */
    std::map<const FrameBuffer *, std::pair<const uint8_t *, size_t>> planes;
    std::string desc;
    int width = 0, height = 0;
    unsigned stride = 0;
    PixelFormat fmt;
    pl_pixfmt pix = PL_PIX_YUYV;
    bool mjpeg = false;
    pl_yuv_coeffs yuv{};
    size_t min_bytes = 0;

    std::mutex mu;
    std::condition_variable cv;
    std::deque<Request *> done; /* completed, not yet read */
    bool disconnected = false;
    bool have_seq0 = false;
    int timeouts = 0; /* consecutive reads without a frame */
    int64_t seq0 = 0;

    /* libcamera's thread: hand the request over, nothing else. */
    void on_complete(Request *r)
    {
        {
            std::lock_guard<std::mutex> lk(mu);
            done.push_back(r);
        }
        cv.notify_one();
    }
    void on_disconnect()
    {
        {
            std::lock_guard<std::mutex> lk(mu);
            disconnected = true;
        }
        cv.notify_one();
    }
    int requeue(Request *r)
    {
        r->reuse(Request::ReuseBuffers);
        int rc = camera->queueRequest(r);
        if (rc < 0)
            return pl_error(PL_E_DEVICE, "%s: cannot queue a request again: %s", desc.c_str(),
                            strerror(-rc));
        return PL_OK;
    }
};

static void teardown(pl_libcam *c)
{
    if (c->camera) {
        if (c->started) c->camera->stop();
        c->started = false;
        c->camera->requestCompleted.disconnect(c, &pl_libcam::on_complete);
        c->camera->disconnected.disconnect(c, &pl_libcam::on_disconnect);
    }
    c->done.clear();
    c->requests.clear();
    for (auto &m : c->maps)
        if (m.second.addr != MAP_FAILED) munmap(m.second.addr, m.second.len);
    c->maps.clear();
    c->planes.clear();
    if (c->alloc && c->stream) c->alloc->free(c->stream);
    c->alloc.reset();
    c->config.reset();
    if (c->camera && c->acquired) c->camera->release();
    c->acquired = false;
    c->camera.reset();
    if (c->cm) c->cm->stop();
    c->cm.reset();
}

static int start_manager(pl_libcam *c, const char *spec)
{
    quiet_logs();
    c->cm = std::make_unique<CameraManager>();
    int rc = c->cm->start();
    if (rc < 0) {
        c->cm.reset();
        return pl_error(PL_E_DEVICE, "%s: libcamera's camera manager did not start: %s", spec,
                        strerror(-rc));
    }
    return PL_OK;
}

static int pick_camera(pl_libcam *c, const char *spec)
{
    std::vector<std::shared_ptr<Camera>> cams = c->cm->cameras();
    if (cams.empty())
        return pl_error(PL_E_DEVICE,
                        "%s: libcamera finds no camera (without udevd it needs /run/udev/data "
                        "entries; see docs/CAMERAS.md)",
                        spec);
    const char *id = spec[9] == ':' ? spec + 10 : NULL;
    size_t idx = 0;
    if (!id) {
        c->camera = cams[0];
    } else if (parse_index(id, &idx)) {
        if (idx >= cams.size())
            return pl_error(PL_E_ARG, "%s: camera index %zu out of range (libcamera has %zu)", spec,
                            idx, cams.size());
        c->camera = cams[idx];
    } else {
        c->camera = c->cm->get(id);
        if (!c->camera) {
            std::string have;
            for (auto &k : cams)
                have += (have.empty() ? "" : ", ") + k->id();
            return pl_error(PL_E_DEVICE, "%s: no libcamera camera with ID '%s' (have: %s)", spec,
                            id, have.c_str());
        }
    }
    c->desc = "libcamera:" + c->camera->id();
    int rc = c->camera->acquire();
    if (rc < 0)
        return pl_error(PL_E_DEVICE,
                        "%s: cannot acquire camera %s: %s (in use by another process?)", spec,
                        c->camera->id().c_str(), strerror(-rc));
    c->acquired = true;
    return PL_OK;
}

static int configure(pl_libcam *c, const char *spec)
{
    c->config = c->camera->generateConfiguration({StreamRole::VideoRecording});
    if (!c->config || c->config->empty())
        c->config = c->camera->generateConfiguration({StreamRole::Viewfinder});
    if (!c->config || c->config->empty())
        return pl_error(PL_E_DEVICE, "%s: the camera offers no video configuration", spec);
    StreamConfiguration &sc = c->config->at(0);
    const PixelFormat prefs[] = {formats::YUYV, formats::MJPEG, formats::NV12, formats::BGR888};
    std::vector<PixelFormat> offered = sc.formats().pixelformats();
    PixelFormat chosen;
    for (const PixelFormat &p : prefs) {
        for (const PixelFormat &o : offered)
            if (o == p) chosen = p;
        if (chosen.isValid()) break;
    }
    if (!chosen.isValid()) {
        std::string have;
        for (const PixelFormat &o : offered)
            have += (have.empty() ? "" : " ") + o.toString();
        return pl_error(PL_E_UNSUPPORTED,
                        "%s: no pixel format parlight reads (YUYV MJPEG NV12 BGR888); offered: %s",
                        spec, have.c_str());
    }
    /* validate and configure talk to the device (UVC: probe control requests), which can fail
     * once in a while: three tries, 50 ms apart */
    const Size size = sc.size;
    CameraConfiguration::Status st = CameraConfiguration::Invalid;
    int rc = -EIO;
    for (int attempt = 0; attempt < 3 && (st == CameraConfiguration::Invalid || rc < 0);
         attempt++) {
        if (attempt) usleep(50000);
        sc.pixelFormat = chosen;
        sc.size = size;
        sc.bufferCount = 4;
        st = c->config->validate();
        if (st == CameraConfiguration::Invalid || sc.pixelFormat != chosen) continue;
        rc = c->camera->configure(c->config.get());
    }
    if (st == CameraConfiguration::Invalid)
        return pl_error(PL_E_DEVICE, "%s: configuration %s %s refused (3 tries)", spec,
                        chosen.toString().c_str(), size.toString().c_str());
    if (sc.pixelFormat != chosen)
        return pl_error(PL_E_DEVICE, "%s: asked for %s, the pipeline gives %s", spec,
                        chosen.toString().c_str(), sc.pixelFormat.toString().c_str());
    if (rc < 0)
        return pl_error(PL_E_DEVICE, "%s: configure %s %s failed: %s", spec,
                        chosen.toString().c_str(), sc.size.toString().c_str(), strerror(-rc));
    if (sc.size.width < 1 || sc.size.height < 1 || sc.size.width > 32768 || sc.size.height > 32768)
        return pl_error(PL_E_FORMAT, "%s: frame size %s out of range", spec,
                        sc.size.toString().c_str());
    c->stream = sc.stream();
    c->width = (int)sc.size.width;
    c->height = (int)sc.size.height;
    c->stride = sc.stride;
    c->fmt = chosen;
    c->mjpeg = chosen == formats::MJPEG;
    if (!c->mjpeg) {
        c->pix = chosen == formats::YUYV   ? PL_PIX_YUYV
                 : chosen == formats::NV12 ? PL_PIX_NV12
                                           : PL_PIX_RGB24;
        size_t row = c->pix == PL_PIX_YUYV   ? 4 * (((size_t)c->width + 1) / 2)
                     : c->pix == PL_PIX_NV12 ? (size_t)c->width
                                             : 3 * (size_t)c->width;
        size_t stride = c->stride ? c->stride : row;
        c->stride = (unsigned)stride;
        rc = pl_pixfmt_min_bytes(c->pix, c->width, c->height, stride, &c->min_bytes);
        if (rc < 0) return pl_error_prefix(rc, "%s: ", spec);
    }
    /* YCbCr coding from the stream's colour space; BT.601 limited when it does not say. */
    pl_yuv_matrix m = PL_YUV_BT601;
    pl_yuv_range r = PL_YUV_LIMITED;
    if (sc.colorSpace) {
        const ColorSpace &cs = *sc.colorSpace;
        if (cs.ycbcrEncoding == ColorSpace::YcbcrEncoding::Rec709) m = PL_YUV_BT709;
        if (cs.range == ColorSpace::Range::Full) r = PL_YUV_FULL;
    }
    pl_yuv_coeffs_init(&c->yuv, m, r);
    return PL_OK;
}

static int map_buffers(pl_libcam *c, const char *spec)
{
    c->alloc = std::make_unique<FrameBufferAllocator>(c->camera);
    int n = c->alloc->allocate(c->stream);
    if (n <= 0)
        return pl_error(PL_E_DEVICE, "%s: cannot allocate frame buffers: %s", spec,
                        n < 0 ? strerror(-n) : "none allocated");
    for (const std::unique_ptr<FrameBuffer> &fb : c->alloc->buffers(c->stream)) {
        const std::vector<FrameBuffer::Plane> &planes = fb->planes();
        if (planes.empty()) return pl_error(PL_E_DEVICE, "%s: a frame buffer without planes", spec);
        /* map each dmabuf once, over the extent of all planes on it */
        std::map<int, size_t> extent;
        for (const FrameBuffer::Plane &p : planes) {
            int fd = p.fd.get();
            size_t end = 0;
            if (p.offset == FrameBuffer::Plane::kInvalidOffset ||
                !pl_add_size(p.offset, p.length, &end))
                return pl_error(PL_E_DEVICE, "%s: a frame buffer plane with a bad offset", spec);
            if (end > extent[fd]) extent[fd] = end;
        }
        for (auto &e : extent) {
            Mapping &m = c->maps[e.first];
            if (m.addr != MAP_FAILED && m.len >= e.second) continue;
            if (m.addr != MAP_FAILED) munmap(m.addr, m.len);
            m.addr = mmap(NULL, e.second, PROT_READ, MAP_SHARED, e.first, 0);
            m.len = e.second;
            if (m.addr == MAP_FAILED)
                return pl_error(PL_E_DEVICE, "%s: mmap of a frame buffer (%zu bytes) failed: %s",
                                spec, e.second, strerror(errno));
        }
        /* planes are contiguous for the single-planar formats used here: the image starts at
         * plane 0 and spans to the end of the last plane on the same fd */
        const FrameBuffer::Plane &p0 = planes[0];
        const Mapping &m = c->maps[p0.fd.get()];
        size_t avail = extent[p0.fd.get()] - p0.offset;
        c->planes[fb.get()] = {(const uint8_t *)m.addr + p0.offset, avail};
        if (!c->mjpeg && avail < c->min_bytes)
            return pl_error(PL_E_DEVICE, "%s: frame buffer of %zu bytes, a frame needs %zu", spec,
                            avail, c->min_bytes);
        std::unique_ptr<Request> req = c->camera->createRequest();
        if (!req) return pl_error(PL_E_DEVICE, "%s: cannot create a request", spec);
        int rc = req->addBuffer(c->stream, fb.get());
        if (rc < 0)
            return pl_error(PL_E_DEVICE, "%s: cannot add a buffer to a request: %s", spec,
                            strerror(-rc));
        c->requests.push_back(std::move(req));
    }
    return PL_OK;
}

static int start(pl_libcam *c, const char *spec)
{
    c->camera->requestCompleted.connect(c, &pl_libcam::on_complete);
    c->camera->disconnected.connect(c, &pl_libcam::on_disconnect);
    int rc = c->camera->start();
    if (rc < 0) return pl_error(PL_E_DEVICE, "%s: cannot start: %s", spec, strerror(-rc));
    c->started = true;
    for (std::unique_ptr<Request> &r : c->requests) {
        rc = c->camera->queueRequest(r.get());
        if (rc < 0)
            return pl_error(PL_E_DEVICE, "%s: cannot queue a request: %s", spec, strerror(-rc));
    }
    return PL_OK;
}

int pl_libcam_open(const char *spec, pl_libcam **out)
{
    if (!out) return pl_error(PL_E_ARG, "pl_libcam_open: out is NULL");
    *out = NULL;
    if (!pl_libcam_is_spec(spec))
        return pl_error(PL_E_ARG, "camera spec '%s': expected libcamera[:ID|N]",
                        spec ? spec : "(null)");
    if (spec[9] == ':' && spec[10] == '\0')
        return pl_error(PL_E_ARG, "%s: empty camera ID after ':' (expected libcamera[:ID|N])",
                        spec);
    pl_libcam *c = NULL;
    int rc;
    try {
        c = new pl_libcam();
        rc = start_manager(c, spec);
        if (rc == PL_OK) rc = pick_camera(c, spec);
        if (rc == PL_OK) rc = configure(c, spec);
        if (rc == PL_OK) rc = map_buffers(c, spec);
        if (rc == PL_OK) rc = start(c, spec);
    } catch (const std::bad_alloc &) {
        rc = pl_error(PL_E_NOMEM, "%s: out of memory", spec);
    } catch (const std::exception &e) {
        rc = pl_error(PL_E_DEVICE, "%s: libcamera: %s", spec, e.what());
    } catch (...) {
        rc = pl_error(PL_E_INTERNAL, "%s: unknown exception from libcamera", spec);
    }
    if (rc < 0) {
        pl_libcam_close(c);
        return rc;
    }
    *out = c;
    return PL_OK;
}

static int convert(pl_libcam *c, const FrameBuffer *fb, pl_image_u8 *img, size_t *capacity)
{
    auto it = c->planes.find(fb);
    if (it == c->planes.end())
        return pl_error(PL_E_INTERNAL, "%s: completed buffer not among ours", c->desc.c_str());
    const uint8_t *p = it->second.first;
    size_t avail = it->second.second;
    const FrameMetadata &md = fb->metadata();
    size_t used = 0;
    for (const FrameMetadata::Plane &pl : md.planes())
        if (!pl_add_size(used, pl.bytesused, &used)) used = SIZE_MAX;
    if (used > avail) used = avail;
    if (c->mjpeg) {
        char what[96];
        snprintf(what, sizeof what, "%s frame %u", c->desc.c_str(), md.sequence);
        int rc = pl_image_decode_jpeg_rgb8_reuse(p, used, what, img, capacity);
        if (rc < 0) return rc;
        if (img->width != c->width || img->height != c->height)
            return pl_error(PL_E_FORMAT, "%s: MJPEG frame %dx%d in a %dx%d stream", what,
                            img->width, img->height, c->width, c->height);
        return PL_OK;
    }
    if (used < c->min_bytes)
        return pl_error(PL_E_FORMAT, "%s frame %u: %zu bytes, a %dx%d %s frame needs %zu",
                        c->desc.c_str(), md.sequence, used, c->width, c->height,
                        pl_pixfmt_name(c->pix), c->min_bytes);
    int rc = pl_image_u8_reserve(img, capacity, c->width, c->height);
    if (rc < 0) return rc;
    switch (c->pix) {
    case PL_PIX_YUYV:
        pl_yuyv_to_rgb8(p, c->stride, c->width, c->height, &c->yuv, img->data, img->stride);
        break;
    case PL_PIX_NV12:
        pl_nv12_to_rgb8(p, c->stride, p + (size_t)c->stride * (size_t)c->height, c->stride,
                        c->width, c->height, &c->yuv, img->data, img->stride);
        break;
    default:
        pl_rgb24_to_rgb8(p, c->stride, c->width, c->height, img->data, img->stride);
        break;
    }
    return PL_OK;
}

static int read_frame(pl_libcam *c, pl_image_u8 *img, size_t *capacity, int64_t *t_ns,
                      int64_t *index)
{
    std::vector<Request *> got;
    {
        std::unique_lock<std::mutex> lk(c->mu);
        if (!c->cv.wait_for(lk, std::chrono::milliseconds(kFrameTimeoutMs),
                            [c] { return !c->done.empty() || c->disconnected; })) {
            if (++c->timeouts >= kMaxTimeouts)
                return pl_error(PL_E_EOF, "%s: no frame for %d s: giving up", c->desc.c_str(),
                                kMaxTimeouts * kFrameTimeoutMs / 1000);
            return pl_error(PL_E_DEVICE, "%s: no frame within %d s", c->desc.c_str(),
                            kFrameTimeoutMs / 1000);
        }
        c->timeouts = 0;
        if (c->disconnected && c->done.empty())
            return pl_error(PL_E_EOF, "%s: camera disconnected", c->desc.c_str());
        got.assign(c->done.begin(), c->done.end());
        c->done.clear();
    }
    /* newest complete one; the others go back unread */
    Request *use = NULL;
    for (size_t i = got.size(); i-- > 0;)
        if (got[i]->status() == Request::RequestComplete) {
            use = got[i];
            break;
        }
    int rc = PL_OK;
    for (Request *r : got)
        if (r != use && r->status() != Request::RequestCancelled) {
            int q = c->requeue(r);
            if (q < 0 && rc == PL_OK) rc = q;
        }
    if (rc < 0) {
        if (use) c->requeue(use);
        return rc;
    }
    if (!use) {
        if (got.back()->status() == Request::RequestCancelled)
            return pl_error(PL_E_EOF, "%s: requests cancelled (camera stopped or disconnected)",
                            c->desc.c_str());
        return pl_error(PL_E_FORMAT, "%s: the pipeline failed a frame", c->desc.c_str());
    }
    const FrameBuffer *fb = use->findBuffer(c->stream);
    if (!fb) {
        c->requeue(use);
        return pl_error(PL_E_INTERNAL, "%s: completed request without our stream's buffer",
                        c->desc.c_str());
    }
    const FrameMetadata &md = fb->metadata();
    if (md.status != FrameMetadata::FrameSuccess) {
        c->requeue(use);
        return pl_error(PL_E_FORMAT, "%s frame %u: flagged as an error by the pipeline",
                        c->desc.c_str(), md.sequence);
    }
    rc = convert(c, fb, img, capacity);
    int64_t ts = (int64_t)md.timestamp;
    const ControlList &meta = use->metadata();
    std::optional<int64_t> sensor_ts = meta.get(controls::SensorTimestamp);
    if (sensor_ts && *sensor_ts > 0) ts = *sensor_ts;
    if (!c->have_seq0) {
        c->have_seq0 = true;
        c->seq0 = md.sequence;
    }
    *t_ns = ts;
    *index = (int64_t)md.sequence - c->seq0;
    int q = c->requeue(use);
    return rc < 0 ? rc : q;
}

int pl_libcam_read(pl_libcam *c, pl_image_u8 *img, size_t *capacity, int64_t *t_ns, int64_t *index)
{
    if (!c || !img || !capacity || !t_ns || !index)
        return pl_error(PL_E_ARG, "pl_libcam_read: NULL argument");
    try {
        return read_frame(c, img, capacity, t_ns, index);
    } catch (const std::bad_alloc &) {
        return pl_error(PL_E_NOMEM, "%s: out of memory", c->desc.c_str());
    } catch (const std::exception &e) {
        return pl_error(PL_E_DEVICE, "%s: libcamera: %s", c->desc.c_str(), e.what());
    } catch (...) {
        return pl_error(PL_E_INTERNAL, "%s: unknown exception", c->desc.c_str());
    }
}

const char *pl_libcam_describe(const pl_libcam *c)
{
    return c && !c->desc.empty() ? c->desc.c_str() : "libcamera";
}

int pl_libcam_fps(const pl_libcam *c, double *fps)
{
    (void)fps;
    return pl_error(PL_E_UNSUPPORTED, "%s: libcamera does not report a frame rate here",
                    pl_libcam_describe(c));
}

void pl_libcam_close(pl_libcam *c)
{
    if (!c) return;
    try {
        teardown(c);
    } catch (...) {
    }
    delete c;
}

int pl_libcam_list(char *buf, size_t n, int *count)
{
    if (!buf || n == 0 || !count) return pl_error(PL_E_ARG, "pl_libcam_list: NULL argument");
    buf[0] = '\0';
    *count = 0;
    try {
        quiet_logs();
        CameraManager cm;
        int rc = cm.start();
        if (rc < 0)
            return pl_error(PL_E_DEVICE, "libcamera's camera manager did not start: %s",
                            strerror(-rc));
        std::string s;
        int i = 0;
        for (const std::shared_ptr<Camera> &cam : cm.cameras()) {
            s += "  [" + std::to_string(i++) + "] " + cam->id();
            std::unique_ptr<CameraConfiguration> cfg =
                cam->generateConfiguration({StreamRole::VideoRecording});
            if (cfg && !cfg->empty()) {
                const StreamConfiguration &sc = cfg->at(0);
                s += "  (";
                for (const PixelFormat &p : sc.formats().pixelformats())
                    s += p.toString() + " ";
                s += "default " + sc.toString() + ")";
            }
            s += "\n";
        }
        cm.stop();
        *count = i;
        snprintf(buf, n, "%s", s.c_str());
        return PL_OK;
    } catch (const std::bad_alloc &) {
        return pl_error(PL_E_NOMEM, "libcamera list: out of memory");
    } catch (...) {
        return pl_error(PL_E_INTERNAL, "libcamera list: exception");
    }
}

#endif
