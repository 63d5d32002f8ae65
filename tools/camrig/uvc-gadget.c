/* uvc-gadget: a userspace USB Video Class webcam that streams a directory of image files, for the
 * camera rig (tools/camrig, docs/CAMERAS.md "The UVC webcam").
 *
 *   uvc-gadget [--udc FILE] [--ep NAME] [--fps N] [--verbose] DIR   be the webcam (guest)
 *   uvc-gadget --expected OUTDIR DIR                         write what a reader will see
 *
 * The device: gadgetfs (mounted at /dev/gadget) on the dummy_hcd virtual controller, whose UDC
 * file is /dev/gadget/dummy_udc. One configuration, an interface association of a VideoControl
 * interface (camera terminal -> streaming output terminal, no controls) and a VideoStreaming
 * interface with one BULK IN endpoint (ep1in-bulk, address 0x81): dummy_hcd has no isochronous
 * endpoints, which is why the kernel's own UVC function cannot stream there. UVC 1.0 class
 * descriptors are written to gadgetfs as raw bytes. Format 1: uncompressed YUY2 (YUYV 4:2:2,
 * 16 bits a pixel) at the size of the files (all files must have the same even width); format 2,
 * when every file is a JPEG: MJPEG, each frame the file's own bytes. One frame size, one frame
 * interval (--fps, default 5), a colour matching descriptor saying BT.709 primaries, BT.709
 * transfer, BT.601 (SMPTE 170M) matrix, which V4L2 reads as sRGB + BT.601 limited range.
 *
 * Control requests handled: the VideoStreaming PROBE and COMMIT controls (SET_CUR takes the
 * host's format index, every GET returns that format's one configuration; GET_LEN 26, GET_INFO 3),
 * SET_CONFIGURATION, SET_INTERFACE (acknowledged); everything else is stalled. A COMMIT starts (or
 * restarts) the stream from the first file: each payload is a 2-byte UVC header (bHeaderLength 2,
 * bmHeaderInfo EOH|EOF|FID, FID toggling per frame) followed by exactly one frame, written in one
 * transfer, paced at the frame interval; the files are sent in name order, cyclically. uvcvideo
 * stops a bulk stream with CLEAR_FEATURE(HALT), which dummy_hcd handles itself, so the device
 * only learns of a new session from the next COMMIT: a write still pending from the last
 * session is interrupted (SIGUSR1) and dropped.
 *
 * RGB -> YUYV (BT.601, limited range; the inverse of port/pixfmt.h's YUYV reader):
 *   Y' = 0.299 R + 0.587 G + 0.114 B      (R, G, B the file's 8-bit values / 255)
 *   Y  = 16 + 219 Y'
 *   U  = 128 + 224 (B - Y') / 1.772,  V = 128 + 224 (R - Y') / 1.402
 * each rounded to nearest and clamped to 0..255; U and V of a pixel pair are those of the mean of
 * its two pixels' R, G, B. A round trip loses chroma resolution (pairs share U, V) and rounds:
 * `--expected OUTDIR DIR` writes, for every file NAME of DIR, OUTDIR/NAME.png holding exactly the
 * RGB that port/pixfmt.h's BT.601-limited YUYV conversion makes of the frame this device sends
 * (files in the same name order), so that lights estimated from those PNGs can be compared with
 * lights estimated through the camera.
 *
 * --race-delay-us N (a test aid) sleeps N us before reading each SET_CUR's data, so that the
 * host's next request overtakes it (see handle_setup).
 *
 * Exit: runs until killed (0 is never returned in device mode); 1 on errors (message on stderr),
 * 2 on bad usage. */
#include <errno.h>
#include <fcntl.h>
#include <getopt.h>
#include <linux/usb/ch9.h>
#include <linux/usb/gadgetfs.h>
#include <linux/usb/video.h>
#include <poll.h>
#include <pthread.h>
#include <sched.h>
#include <signal.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include "core/util.h"
#include "parlight.h"
#include "port/image.h"
#include "port/pixfmt.h"
#include "port/source.h"

#define EP_ADDR 0x81
#define PROBE_LEN 26 /* UVC 1.0 probe/commit control */
#define MAX_FRAMES 64

typedef struct frame {
    uint8_t *payload; /* 2-byte header + YUYV frame */
    size_t len;
} frame;

static frame g_frames[MAX_FRAMES]; /* YUYV payloads */
static frame g_jpegs[MAX_FRAMES];  /* MJPEG payloads: the files' own bytes, when all are JPEGs */
static bool g_have_mjpeg;
static size_t g_jpeg_max; /* largest JPEG */
static int g_format = 1;  /* format index of the last PROBE/COMMIT: 1 YUYV, 2 MJPEG */
static int g_n_frames;
static int g_w, g_h;
static uint32_t g_interval; /* 100 ns units */

static pthread_mutex_t g_mu = PTHREAD_MUTEX_INITIALIZER;
static pthread_cond_t g_cv = PTHREAD_COND_INITIALIZER;
static unsigned g_gen;      /* bumped by each COMMIT */
static unsigned g_seen_gen; /* the generation the stream thread works on */
static int g_ep_fd = -1;
static bool g_verbose;
static unsigned g_race_delay_us; /* test aid: delay before reading a SET_CUR's data */

/* ---- RGB -> YUYV -------------------------------------------------------------------------- */

static uint8_t clamp_u8(double v)
{
    v = v < 0 ? 0 : v > 255 ? 255 : v;
    return (uint8_t)(v + 0.5);
}

static void rgb_to_yuyv(const pl_image_u8 *img, uint8_t *dst)
{
    for (int y = 0; y < img->height; y++) {
        const uint8_t *p = img->data + (size_t)y * img->stride;
        uint8_t *d = dst + (size_t)y * (size_t)img->width * 2;
        for (int x = 0; x < img->width; x += 2, p += 6, d += 4) {
            double r0 = p[0] / 255.0, g0 = p[1] / 255.0, b0 = p[2] / 255.0;
            double r1 = p[3] / 255.0, g1 = p[4] / 255.0, b1 = p[5] / 255.0;
            double y0 = 0.299 * r0 + 0.587 * g0 + 0.114 * b0;
            double y1 = 0.299 * r1 + 0.587 * g1 + 0.114 * b1;
            double rm = (r0 + r1) / 2, bm = (b0 + b1) / 2, ym = (y0 + y1) / 2;
            d[0] = clamp_u8(16 + 219 * y0);
            d[1] = clamp_u8(128 + 224 * (bm - ym) / 1.772);
            d[2] = clamp_u8(16 + 219 * y1);
            d[3] = clamp_u8(128 + 224 * (rm - ym) / 1.402);
        }
    }
}

/* The file's bytes as an MJPEG payload (2-byte header + JPEG, plus a zero byte when that is a
 * multiple of 64 bytes: the bulk transfer must end with a short packet and gadgetfs sends no
 * zero-length one; decoders ignore bytes after EOI). Leaves p->payload NULL when the file is not
 * a JPEG (SOI at the start, EOI at the end) of at most 4 MB. */
static void load_jpeg(const char *dir, const char *name, frame *p)
{
    char path[4096];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    FILE *f = fopen(path, "rb");
    if (!f) return;
    uint8_t *b = malloc((4u << 20) + 3);
    size_t n = b ? fread(b + 2, 1, (4u << 20) + 1, f) : 0;
    fclose(f);
    if (!b || n < 4 || n > (4u << 20) || b[2] != 0xff || b[3] != 0xd8 || b[n] != 0xff ||
        b[n + 1] != 0xd9) {
        free(b);
        return;
    }
    p->len = n + 2;
    if (p->len % 64 == 0) b[p->len++] = 0;
    p->payload = b;
    if (n > g_jpeg_max) g_jpeg_max = n;
}

/* Reads DIR (port/source.h: name order) into g_frames; with expected_dir also writes the
 * round-tripped RGB of every frame there. */
static int load_frames(const char *dir, const char *expected_dir)
{
    pl_source *src;
    if (pl_source_open_path(dir, &src) < 0) {
        fprintf(stderr, "uvc-gadget: %s\n", pl_last_error());
        return 1;
    }
    pl_frame f;
    int rc;
    pl_yuv_coeffs c;
    pl_yuv_coeffs_init(&c, PL_YUV_BT601, PL_YUV_LIMITED);
    while ((rc = pl_source_read(src, &f)) != PL_E_EOF) {
        if (rc < 0) {
            fprintf(stderr, "uvc-gadget: %s\n", pl_last_error());
            pl_source_close(src);
            return 1;
        }
        if (g_n_frames == MAX_FRAMES) {
            fprintf(stderr, "uvc-gadget: %s: more than %d frames\n", dir, MAX_FRAMES);
            pl_source_close(src);
            return 1;
        }
        if (g_n_frames == 0) {
            g_w = f.image.width;
            g_h = f.image.height;
            if (g_w % 2 || g_w > 4096 || g_h > 4096) {
                fprintf(stderr, "uvc-gadget: %s: %dx%d: YUYV needs an even width <= 4096\n", f.name,
                        g_w, g_h);
                pl_source_close(src);
                return 1;
            }
        } else if (f.image.width != g_w || f.image.height != g_h) {
            fprintf(stderr, "uvc-gadget: %s is %dx%d, the first frame %dx%d: one size only\n",
                    f.name, f.image.width, f.image.height, g_w, g_h);
            pl_source_close(src);
            return 1;
        }
        size_t n = (size_t)g_w * (size_t)g_h * 2;
        frame *fr = &g_frames[g_n_frames++];
        fr->len = n + 2;
        fr->payload = malloc(fr->len);
        if (!fr->payload) {
            fprintf(stderr, "uvc-gadget: out of memory\n");
            pl_source_close(src);
            return 1;
        }
        rgb_to_yuyv(&f.image, fr->payload + 2);
        load_jpeg(dir, f.name, &g_jpegs[g_n_frames - 1]);
        if (expected_dir) {
            pl_image_u8 out;
            if (pl_image_u8_alloc(&out, g_w, g_h) < 0) {
                fprintf(stderr, "uvc-gadget: %s\n", pl_last_error());
                pl_source_close(src);
                return 1;
            }
            pl_yuyv_to_rgb8(fr->payload + 2, (size_t)g_w * 2, g_w, g_h, &c, out.data, out.stride);
            char path[4096];
            snprintf(path, sizeof path, "%s/%s.png", expected_dir, f.name);
            if (pl_image_write_rgb8(path, &out) < 0) {
                fprintf(stderr, "uvc-gadget: %s\n", pl_last_error());
                pl_image_u8_free(&out);
                pl_source_close(src);
                return 1;
            }
            pl_image_u8_free(&out);
        }
    }
    pl_source_close(src);
    if (g_n_frames == 0) {
        fprintf(stderr, "uvc-gadget: %s: no readable frame\n", dir);
        return 1;
    }
    g_have_mjpeg = true;
    for (int i = 0; i < g_n_frames; i++)
        if (!g_jpegs[i].payload) g_have_mjpeg = false;
    return 0;
}

/* ---- descriptors ------------------------------------------------------------------------- */

typedef struct buf {
    uint8_t b[512];
    size_t n;
} buf;

static void put(buf *d, const void *p, size_t n)
{
    memcpy(d->b + d->n, p, n);
    d->n += n;
}
static void put8(buf *d, unsigned v)
{
    d->b[d->n++] = (uint8_t)v;
}
static void put16(buf *d, unsigned v)
{
    put8(d, v & 0xff);
    put8(d, (v >> 8) & 0xff);
}
static void put32(buf *d, uint32_t v)
{
    put16(d, v & 0xffff);
    put16(d, v >> 16);
}
static void set16(buf *d, size_t at, unsigned v)
{
    d->b[at] = (uint8_t)(v & 0xff);
    d->b[at + 1] = (uint8_t)(v >> 8);
}

static void endpoint_desc(buf *d, unsigned maxpacket)
{
    put8(d, USB_DT_ENDPOINT_SIZE);
    put8(d, USB_DT_ENDPOINT);
    put8(d, EP_ADDR);
    put8(d, USB_ENDPOINT_XFER_BULK);
    put16(d, maxpacket);
    put8(d, 0);
}

static void config_desc(buf *d, unsigned maxpacket)
{
    size_t start = d->n;
    /* configuration */
    put8(d, USB_DT_CONFIG_SIZE);
    put8(d, USB_DT_CONFIG);
    put16(d, 0); /* wTotalLength, below */
    put8(d, 2);  /* interfaces */
    put8(d, 1);  /* bConfigurationValue */
    put8(d, 0);
    put8(d, USB_CONFIG_ATT_ONE | USB_CONFIG_ATT_SELFPOWER);
    put8(d, 50);
    /* interface association */
    put8(d, 8);
    put8(d, USB_DT_INTERFACE_ASSOCIATION);
    put8(d, 0);
    put8(d, 2);
    put8(d, USB_CLASS_VIDEO);
    put8(d, UVC_SC_VIDEO_INTERFACE_COLLECTION);
    put8(d, 0);
    put8(d, 0);
    /* VideoControl interface */
    put8(d, USB_DT_INTERFACE_SIZE);
    put8(d, USB_DT_INTERFACE);
    put8(d, 0);
    put8(d, 0);
    put8(d, 0);
    put8(d, USB_CLASS_VIDEO);
    put8(d, UVC_SC_VIDEOCONTROL);
    put8(d, 0);
    put8(d, 0);
    size_t vc = d->n;
    put8(d, 13); /* VC header */
    put8(d, USB_DT_CS_INTERFACE);
    put8(d, UVC_VC_HEADER);
    put16(d, 0x0100);
    put16(d, 0); /* wTotalLength of the class-specific VC descriptors, below */
    put32(d, 48000000);
    put8(d, 1);
    put8(d, 1);  /* baInterfaceNr: the streaming interface */
    put8(d, 18); /* camera input terminal */
    put8(d, USB_DT_CS_INTERFACE);
    put8(d, UVC_VC_INPUT_TERMINAL);
    put8(d, 1);
    put16(d, UVC_ITT_CAMERA);
    put8(d, 0);
    put8(d, 0);
    put16(d, 0);
    put16(d, 0);
    put16(d, 0);
    put8(d, 3);
    put8(d, 0);
    put8(d, 0);
    put8(d, 0);
    put8(d, 9); /* output terminal: streaming */
    put8(d, USB_DT_CS_INTERFACE);
    put8(d, UVC_VC_OUTPUT_TERMINAL);
    put8(d, 2);
    put16(d, UVC_TT_STREAMING);
    put8(d, 0);
    put8(d, 1);
    put8(d, 0);
    set16(d, vc + 5, (unsigned)(d->n - vc));
    /* VideoStreaming interface */
    put8(d, USB_DT_INTERFACE_SIZE);
    put8(d, USB_DT_INTERFACE);
    put8(d, 1);
    put8(d, 0);
    put8(d, 1);
    put8(d, USB_CLASS_VIDEO);
    put8(d, UVC_SC_VIDEOSTREAMING);
    put8(d, 0);
    put8(d, 0);
    size_t vs = d->n;
    int nfmt = g_have_mjpeg ? 2 : 1;
    put8(d, 13 + (unsigned)nfmt); /* input header */
    put8(d, USB_DT_CS_INTERFACE);
    put8(d, UVC_VS_INPUT_HEADER);
    put8(d, (unsigned)nfmt);
    put16(d, 0); /* wTotalLength, below */
    put8(d, EP_ADDR);
    put8(d, 0);
    put8(d, 2); /* bTerminalLink */
    put8(d, 0);
    put8(d, 0);
    put8(d, 0);
    put8(d, 1); /* bControlSize */
    for (int i = 0; i < nfmt; i++)
        put8(d, 0);
    static const uint8_t yuy2[16] = {'Y',  'U',  'Y',  '2',  0x00, 0x00, 0x10, 0x00,
                                     0x80, 0x00, 0x00, 0xaa, 0x00, 0x38, 0x9b, 0x71};
    put8(d, 27); /* format: uncompressed */
    put8(d, USB_DT_CS_INTERFACE);
    put8(d, UVC_VS_FORMAT_UNCOMPRESSED);
    put8(d, 1);
    put8(d, 1);
    put(d, yuy2, 16);
    put8(d, 16);
    put8(d, 1);
    put8(d, 0);
    put8(d, 0);
    put8(d, 0);
    put8(d, 0);
    uint32_t fsize = (uint32_t)g_w * (uint32_t)g_h * 2;
    uint32_t bitrate = (uint32_t)((uint64_t)fsize * 8 * 10000000u / g_interval);
    put8(d, 30); /* frame */
    put8(d, USB_DT_CS_INTERFACE);
    put8(d, UVC_VS_FRAME_UNCOMPRESSED);
    put8(d, 1);
    put8(d, 0);
    put16(d, (unsigned)g_w);
    put16(d, (unsigned)g_h);
    put32(d, bitrate);
    put32(d, bitrate);
    put32(d, fsize);
    put32(d, g_interval);
    put8(d, 1);
    put32(d, g_interval);
    put8(d, 6); /* colour matching */
    put8(d, USB_DT_CS_INTERFACE);
    put8(d, UVC_VS_COLORFORMAT);
    put8(d, 1); /* BT.709 primaries */
    put8(d, 1); /* BT.709 transfer */
    put8(d, 4); /* SMPTE 170M (BT.601) matrix */
    if (g_have_mjpeg) {
        put8(d, 11); /* format: MJPEG */
        put8(d, USB_DT_CS_INTERFACE);
        put8(d, UVC_VS_FORMAT_MJPEG);
        put8(d, 2);
        put8(d, 1);
        put8(d, 0);
        put8(d, 1);
        put8(d, 0);
        put8(d, 0);
        put8(d, 0);
        put8(d, 0);
        uint32_t jbitrate = (uint32_t)((uint64_t)g_jpeg_max * 8 * 10000000u / g_interval);
        put8(d, 30); /* frame */
        put8(d, USB_DT_CS_INTERFACE);
        put8(d, UVC_VS_FRAME_MJPEG);
        put8(d, 1);
        put8(d, 0);
        put16(d, (unsigned)g_w);
        put16(d, (unsigned)g_h);
        put32(d, jbitrate);
        put32(d, jbitrate);
        put32(d, (uint32_t)g_jpeg_max);
        put32(d, g_interval);
        put8(d, 1);
        put32(d, g_interval);
        put8(d, 6); /* colour matching */
        put8(d, USB_DT_CS_INTERFACE);
        put8(d, UVC_VS_COLORFORMAT);
        put8(d, 1);
        put8(d, 1);
        put8(d, 4);
    }
    set16(d, vs + 4, (unsigned)(d->n - vs));
    endpoint_desc(d, maxpacket);
    set16(d, start + 2, (unsigned)(d->n - start));
}

static void device_desc(buf *d)
{
    put8(d, USB_DT_DEVICE_SIZE);
    put8(d, USB_DT_DEVICE);
    put16(d, 0x0200);
    put8(d, USB_CLASS_MISC);
    put8(d, 2);
    put8(d, 1); /* interface association */
    put8(d, 64);
    put16(d, 0x1d6b); /* Linux Foundation */
    put16(d, 0x0102); /* its UVC gadget ID */
    put16(d, 0x0100);
    put8(d, 0);
    put8(d, 0);
    put8(d, 0);
    put8(d, 1);
}

/* ---- probe / commit ---------------------------------------------------------------------- */

static void probe_values(uint8_t p[PROBE_LEN])
{
    pthread_mutex_lock(&g_mu);
    int fmt = g_format;
    pthread_mutex_unlock(&g_mu);
    size_t max_payload = g_frames[0].len;
    uint32_t max_frame = (uint32_t)g_w * (uint32_t)g_h * 2;
    if (fmt == 2) {
        max_frame = (uint32_t)g_jpeg_max;
        max_payload = g_jpeg_max + 3;
    }
    buf d = {.n = 0};
    put16(&d, 1); /* bmHint: frame interval fixed */
    put8(&d, (unsigned)fmt);
    put8(&d, 1); /* frame */
    put32(&d, g_interval);
    put16(&d, 0);
    put16(&d, 0);
    put16(&d, 0);
    put16(&d, 0);
    put16(&d, 0);
    put32(&d, max_frame);
    put32(&d, (uint32_t)max_payload); /* one payload per frame */
    memcpy(p, d.b, PROBE_LEN);
}

/* ---- streaming --------------------------------------------------------------------------- */

static void on_usr1(int sig)
{
    (void)sig;
}

static void sleep_until(struct timespec *t)
{
    while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, t, NULL) == EINTR) {
    }
}

static void *stream_main(void *arg)
{
    (void)arg;
    for (;;) {
        pthread_mutex_lock(&g_mu);
        while (g_gen == 0 || g_ep_fd < 0)
            pthread_cond_wait(&g_cv, &g_mu);
        unsigned gen = g_gen;
        g_seen_gen = gen;
        int fd = g_ep_fd;
        frame *frames = g_format == 2 ? g_jpegs : g_frames;
        pthread_mutex_unlock(&g_mu);
        struct timespec next;
        clock_gettime(CLOCK_MONOTONIC, &next);
        uint8_t fid = 0;
        for (long k = 0;; k++) {
            pthread_mutex_lock(&g_mu);
            bool stale = gen != g_gen;
            pthread_mutex_unlock(&g_mu);
            if (stale) break;
            frame *f = &frames[k % g_n_frames];
            f->payload[0] = 2;
            f->payload[1] = (uint8_t)(UVC_STREAM_EOH | UVC_STREAM_EOF | fid);
            fid ^= UVC_STREAM_FID;
            ssize_t n = write(fd, f->payload, f->len);
            if (n < 0 && errno != EINTR && errno != ESHUTDOWN && errno != ECONNRESET)
                fprintf(stderr, "uvc-gadget: write: %s\n", strerror(errno));
            long ns = (long)g_interval * 100;
            next.tv_nsec += ns % 1000000000L;
            next.tv_sec += ns / 1000000000L + next.tv_nsec / 1000000000L;
            next.tv_nsec %= 1000000000L;
            struct timespec now;
            clock_gettime(CLOCK_MONOTONIC, &now);
            if (now.tv_sec > next.tv_sec + 1) next = now; /* stalled (no host): no burst after */
            sleep_until(&next);
        }
    }
    return NULL;
}

static int open_endpoint(const char *gadget_dir, const char *ep_name)
{
    char path[512];
    snprintf(path, sizeof path, "%s/%s", gadget_dir, ep_name);
    int fd = open(path, O_RDWR);
    if (fd < 0) {
        fprintf(stderr, "uvc-gadget: open %s: %s\n", path, strerror(errno));
        return -1;
    }
    buf d = {.n = 0};
    put32(&d, 1);
    endpoint_desc(&d, 64);
    endpoint_desc(&d, 512);
    if (write(fd, d.b, d.n) != (ssize_t)d.n) {
        fprintf(stderr, "uvc-gadget: configure %s: %s\n", path, strerror(errno));
        close(fd);
        return -1;
    }
    return fd;
}

static void stall(int fd, const struct usb_ctrlrequest *r)
{
    uint8_t x;
    ssize_t n = (r->bRequestType & USB_DIR_IN) ? read(fd, &x, 0) : write(fd, &x, 0);
    (void)n;
}

static void ack(int fd)
{
    uint8_t x;
    ssize_t n = read(fd, &x, 0);
    (void)n;
}

static void restart_stream(pthread_t th)
{
    pthread_mutex_lock(&g_mu);
    unsigned gen = ++g_gen;
    pthread_cond_broadcast(&g_cv);
    pthread_mutex_unlock(&g_mu);
    /* interrupt a write left over from the last session until the thread picked this one up */
    for (int i = 0; i < 200; i++) {
        pthread_mutex_lock(&g_mu);
        bool done = g_seen_gen == gen;
        pthread_mutex_unlock(&g_mu);
        if (done) break;
        pthread_kill(th, SIGUSR1);
        usleep(5000);
    }
}

static void log_setup(const struct usb_ctrlrequest *r)
{
    if (g_verbose)
        fprintf(stderr, "uvc-gadget: setup %02x %02x value %04x index %04x length %u\n",
                r->bRequestType, r->bRequest, r->wValue, r->wIndex, r->wLength);
}

/* ep0 is non-blocking (run_device): gadgetfs's wakeups are tested without a barrier
 * (ep0_readable: waitqueue_active, then wake_up), so a sleeping reader can miss one on an SMP
 * guest. A missed wakeup for a SET_CUR's data is never repaired: the host's next SETUP clears
 * setup_out_ready before it wakes the reader, the reader sleeps on, and every later request times
 * out (uvcvideo: "Failed to query (129) UVC probe control : -110", a CI run of 2026-12-03). So
 * the data is polled for, 1 ms apart, for up to 2 s; EIDRM (the next request has come) ends the
 * wait as before. */
static ssize_t read_setup_data(int fd, uint8_t *data, unsigned len)
{
    for (int i = 0; i < 2000; i++) {
        ssize_t n = read(fd, data, len);
        if (n >= 0 || (errno != EAGAIN && errno != EINTR)) return n;
        usleep(1000);
    }
    errno = ETIMEDOUT;
    return -1;
}

static void handle_setup(int fd, const struct usb_ctrlrequest *r, const char *gadget_dir,
                         const char *ep_name, pthread_t th)
{
    unsigned len = r->wLength, value = r->wValue, index = r->wIndex;
    uint8_t data[256];
    if ((r->bRequestType & USB_TYPE_MASK) == USB_TYPE_STANDARD) {
        switch (r->bRequest) {
        case USB_REQ_SET_CONFIGURATION:
            if (value == 1 && g_ep_fd < 0) {
                int ep = open_endpoint(gadget_dir, ep_name);
                pthread_mutex_lock(&g_mu);
                g_ep_fd = ep;
                pthread_cond_broadcast(&g_cv);
                pthread_mutex_unlock(&g_mu);
            }
            ack(fd);
            return;
        case USB_REQ_SET_INTERFACE:
            ack(fd);
            return;
        default:
            stall(fd, r);
            return;
        }
    }
    if ((r->bRequestType & USB_TYPE_MASK) != USB_TYPE_CLASS ||
        (r->bRequestType & USB_RECIP_MASK) != USB_RECIP_INTERFACE || (index & 0xff) != 1 ||
        len > sizeof data) {
        stall(fd, r);
        return;
    }
    unsigned cs = value >> 8;
    if (cs != UVC_VS_PROBE_CONTROL && cs != UVC_VS_COMMIT_CONTROL) {
        stall(fd, r);
        return;
    }
    switch (r->bRequest) {
    case UVC_SET_CUR: {
        if (g_race_delay_us) usleep(g_race_delay_us);
        ssize_t n = read_setup_data(fd, data, len); /* the host's values; one setting here */
        if (n < 0 && errno == EIDRM) {
            /* The data stage completed without us (gadgetfs queues it at once and dummy_hcd
             * ends the transfer), the host went on, and its next request arrived before this
             * read: gadgetfs aborted our view of this one and now holds the new one, whose
             * event we have not read (reading it would stall the request). After a SET_CUR
             * of PROBE uvcvideo always asks a GET of PROBE, answered by the same 26 bytes
             * (gadgetfs truncates them to the request's length): send them now. The new
             * request's event is still queued; its reply then is stale and dummy_hcd drops
             * it when the next SETUP comes. */
            uint8_t p[PROBE_LEN];
            probe_values(p);
            ssize_t w = write(fd, p, PROBE_LEN);
            if (g_verbose)
                fprintf(stderr,
                        "uvc-gadget: SET_CUR overtaken by the next request: answered "
                        "it as a GET of PROBE (%s)\n",
                        w < 0 ? strerror(errno) : "sent");
        } else if (n < 0 && g_verbose) {
            fprintf(stderr, "uvc-gadget: SET_CUR data: %s\n", strerror(errno));
        } else if (n >= 3 && (data[2] == 1 || (data[2] == 2 && g_have_mjpeg))) {
            pthread_mutex_lock(&g_mu);
            g_format = data[2];
            pthread_mutex_unlock(&g_mu);
        }
        if (cs == UVC_VS_COMMIT_CONTROL) restart_stream(th);
        return;
    }
    case UVC_GET_CUR:
    case UVC_GET_MIN:
    case UVC_GET_MAX:
    case UVC_GET_DEF:
    case UVC_GET_RES: {
        uint8_t p[PROBE_LEN];
        probe_values(p);
        if (r->bRequest == UVC_GET_RES) memset(p, 0, sizeof p);
        ssize_t n = write(fd, p, len < PROBE_LEN ? len : PROBE_LEN);
        if (n < 0 && g_verbose) fprintf(stderr, "uvc-gadget: GET reply: %s\n", strerror(errno));
        return;
    }
    case UVC_GET_LEN:
        data[0] = PROBE_LEN;
        data[1] = 0;
        if (write(fd, data, len < 2 ? len : 2) < 0) {
        }
        return;
    case UVC_GET_INFO:
        data[0] = 3;
        if (write(fd, data, len < 1 ? len : 1) < 0) {
        }
        return;
    default:
        stall(fd, r);
    }
}

static int run_device(const char *udc, const char *ep_name)
{
    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_usr1; /* no SA_RESTART: interrupts a blocked write */
    sigaction(SIGUSR1, &sa, NULL);
    char gadget_dir[256];
    if (strlen(udc) >= sizeof gadget_dir) {
        fprintf(stderr, "uvc-gadget: --udc path too long\n");
        return 2;
    }
    memcpy(gadget_dir, udc, strlen(udc) + 1);
    char *slash = strrchr(gadget_dir, '/');
    if (!slash) {
        fprintf(stderr, "uvc-gadget: --udc needs a path (/dev/gadget/dummy_udc)\n");
        return 2;
    }
    *slash = '\0';
    int fd = open(udc, O_RDWR);
    if (fd < 0) {
        fprintf(stderr, "uvc-gadget: open %s: %s (gadgetfs mounted? dummy_hcd loaded?)\n", udc,
                strerror(errno));
        return 1;
    }
    buf d = {.n = 0};
    put32(&d, 0);
    config_desc(&d, 64);
    config_desc(&d, 512);
    device_desc(&d);
    if (write(fd, d.b, d.n) != (ssize_t)d.n) {
        fprintf(stderr, "uvc-gadget: writing the descriptors to %s: %s\n", udc, strerror(errno));
        return 1;
    }
    pthread_t th;
    /* gadgetfs has no delayed status stage on dummy_hcd: the host may send its next control
     * request before ep0's reader has taken the data of a SET_CUR, and then gadgetfs aborts one
     * of them. Real-time priority for the ep0 reader keeps that window short (best effort). */
    struct sched_param sp = {.sched_priority = 10};
    if (sched_setscheduler(0, SCHED_FIFO, &sp) != 0 && g_verbose)
        fprintf(stderr, "uvc-gadget: no real-time priority: %s\n", strerror(errno));
    if (pthread_create(&th, NULL, stream_main, NULL) != 0) {
        fprintf(stderr, "uvc-gadget: cannot start the stream thread\n");
        return 1;
    }
    fprintf(stderr, "uvc-gadget: %d frames %dx%d YUYV%s, %.2f fps, on %s\n", g_n_frames, g_w, g_h,
            g_have_mjpeg ? " and MJPEG" : "", 1e7 / g_interval, udc);
    /* Events: poll with a 20 ms bound, then a non-blocking read whatever poll said, so that a
     * wakeup gadgetfs lost (see read_setup_data) costs 20 ms, not the host's 5 s timeout. */
    if (fcntl(fd, F_SETFL, fcntl(fd, F_GETFL) | O_NONBLOCK) != 0) {
        fprintf(stderr, "uvc-gadget: making %s non-blocking: %s\n", udc, strerror(errno));
        return 1;
    }
    for (;;) {
        struct usb_gadgetfs_event ev[5];
        struct pollfd pfd = {.fd = fd, .events = POLLIN};
        (void)poll(&pfd, 1, 20);
        ssize_t n = read(fd, ev, sizeof ev);
        if (n < 0) {
            if (errno == EINTR || errno == EAGAIN) continue;
            if (errno == EL2HLT || errno == EIDRM) { /* a request left pending: go on */
                if (g_verbose) fprintf(stderr, "uvc-gadget: ep0: %s\n", strerror(errno));
                continue;
            }
            fprintf(stderr, "uvc-gadget: reading ep0 events: %s\n", strerror(errno));
            return 1;
        }
        for (size_t i = 0; i < (size_t)n / sizeof ev[0]; i++) {
            if (g_verbose && ev[i].type != GADGETFS_SETUP)
                fprintf(stderr, "uvc-gadget: event %d\n", (int)ev[i].type);
            if (ev[i].type == GADGETFS_SETUP) {
                handle_setup(fd, &ev[i].u.setup, gadget_dir, ep_name, th);
                log_setup(&ev[i].u.setup); /* after: the host does not wait for us */
            }
        }
    }
}

int main(int argc, char **argv)
{
    const char *udc = "/dev/gadget/dummy_udc", *ep = "ep1in-bulk", *expected = NULL;
    double fps = 5;
    static const struct option opts[] = {
        {"udc", required_argument, 0, 'u'}, {"ep", required_argument, 0, 'e'},
        {"fps", required_argument, 0, 'f'}, {"expected", required_argument, 0, 'x'},
        {"verbose", no_argument, 0, 'v'},   {"race-delay-us", required_argument, 0, 'r'},
        {"help", no_argument, 0, 'h'},      {0, 0, 0, 0}};
    int c;
    while ((c = getopt_long(argc, argv, "", opts, NULL)) != -1) {
        switch (c) {
        case 'u':
            udc = optarg;
            break;
        case 'e':
            ep = optarg;
            break;
        case 'f': {
            char *end;
            fps = strtod(optarg, &end);
            if (*end || !(fps >= 0.5 && fps <= 60)) {
                fprintf(stderr, "uvc-gadget: --fps: expected 0.5..60, got '%s'\n", optarg);
                return 2;
            }
            break;
        }
        case 'x':
            expected = optarg;
            break;
        case 'v':
            g_verbose = true;
            break;
        case 'r':
            g_race_delay_us = (unsigned)strtoul(optarg, NULL, 10) % 10000000u;
            break;
        case 'h':
            printf("usage: uvc-gadget [--udc FILE] [--ep NAME] [--fps N] [--verbose] DIR\n"
                   "       uvc-gadget --expected OUTDIR DIR\n"
                   "A userspace UVC webcam (gadgetfs, bulk endpoint) streaming DIR's images as\n"
                   "YUYV; --expected writes the RGB a BT.601 limited-range reader sees.\n");
            return 0;
        default:
            return 2;
        }
    }
    if (optind != argc - 1) {
        fprintf(stderr, "uvc-gadget: expected one directory of frames (see --help)\n");
        return 2;
    }
    g_interval = (uint32_t)(1e7 / fps + 0.5);
    if (load_frames(argv[optind], expected)) return 1;
    if (expected) return 0;
    return run_device(udc, ep);
}
