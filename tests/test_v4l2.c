/* port/source_v4l2 without a camera (the rig, tests/test_camera_vivid.sh, covers a real driver):
 * the strict spec parser (every field, every malformed form), opening things that are not cameras
 * (missing node, /dev/null, a regular file) through pl_source_open_camera with one clear message,
 * and the in-memory MJPEG decode (port/image_mem.cpp): a JPEG written by OpenCV decodes to the
 * same size, padding after EOI is accepted, truncated or non-JPEG frames are refused. */
#include <linux/videodev2.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/image.h"
#include "core/util.h"
#include "port/image_jpeg.h"
#include "port/image_mem.h"
#include "port/source.h"
#include "port/v4l2.h"
#include "tests/check.h"

static void good(const char *spec, const char *path, int w, int h, double fps, uint32_t fourcc)
{
    pl_v4l2_spec s;
    int rc = pl_v4l2_parse_spec(spec, &s);
    CHECK(rc == PL_OK, "'%s' refused: %s", spec, pl_last_error());
    if (rc != PL_OK) return;
    CHECK(strcmp(s.path, path) == 0, "'%s': path '%s'", spec, s.path);
    CHECK(s.width == w && s.height == h, "'%s': size %dx%d", spec, s.width, s.height);
    CHECK(s.fps == fps, "'%s': fps %g", spec, s.fps);
    CHECK(s.fourcc == fourcc, "'%s': fourcc %08x", spec, s.fourcc);
}

static void bad(const char *spec, const char *needle)
{
    pl_v4l2_spec s;
    int rc = pl_v4l2_parse_spec(spec, &s);
    CHECK(rc == PL_E_ARG, "'%s' accepted (rc %d)", spec, rc);
    CHECK(strstr(pl_last_error(), needle) != NULL, "'%s': message '%s' lacks '%s'", spec,
          pl_last_error(), needle);
}

static void test_spec(void)
{
    good("v4l2:/dev/video0", "/dev/video0", 0, 0, 0, 0);
    good("v4l2:/dev/video12:640x480", "/dev/video12", 640, 480, 0, 0);
    good("v4l2:/dev/video0:1280x720@30", "/dev/video0", 1280, 720, 30, 0);
    good("v4l2:/dev/video0:1280x720@29.97:mjpeg", "/dev/video0", 1280, 720, 29.97,
         V4L2_PIX_FMT_MJPEG);
    good("v4l2:/dev/video0:320x180:nv12", "/dev/video0", 320, 180, 0, V4L2_PIX_FMT_NV12);
    good("v4l2:/dev/v4l/by-id/usb-cam-video-index0:8x8:rgb24",
         "/dev/v4l/by-id/usb-cam-video-index0", 8, 8, 0, V4L2_PIX_FMT_RGB24);
    good("v4l2:/dev/video0:640x480:yuyv", "/dev/video0", 640, 480, 0, V4L2_PIX_FMT_YUYV);

    bad(NULL, "NULL");
    bad("", "unknown kind");
    bad("/dev/video0", "unknown kind");
    bad("V4L2:/dev/video0", "unknown kind");
    bad("libcamera:0", "unknown kind");
    bad("v4l2:", "absolute");
    bad("v4l2:video0", "absolute");
    bad("v4l2::640x480", "absolute");
    bad("v4l2:/dev/video0:", "is not WxH");
    bad("v4l2:/dev/video0:640", "is not WxH");
    bad("v4l2:/dev/video0:640x", "is not WxH");
    bad("v4l2:/dev/video0:x480", "is not WxH");
    bad("v4l2:/dev/video0:0x480", "is not WxH");
    bad("v4l2:/dev/video0:640x0", "is not WxH");
    bad("v4l2:/dev/video0:-640x480", "is not WxH");
    bad("v4l2:/dev/video0:640X480", "is not WxH");
    bad("v4l2:/dev/video0:40000x480", "is not WxH");
    bad("v4l2:/dev/video0:9999999999x480", "is not WxH");
    bad("v4l2:/dev/video0:640x480x2", "is not WxH");
    bad("v4l2:/dev/video0:640 x480", "is not WxH");
    bad("v4l2:/dev/video0:@30", "is not WxH");
    bad("v4l2:/dev/video0:640x480@", "frame rate");
    bad("v4l2:/dev/video0:640x480@0", "frame rate");
    bad("v4l2:/dev/video0:640x480@-5", "frame rate");
    bad("v4l2:/dev/video0:640x480@1001", "frame rate");
    bad("v4l2:/dev/video0:640x480@nan", "frame rate");
    bad("v4l2:/dev/video0:640x480@1e3", "frame rate");
    bad("v4l2:/dev/video0:640x480@.5", "frame rate");
    bad("v4l2:/dev/video0:640x480@30.", "frame rate");
    bad("v4l2:/dev/video0:640x480@3.0.1", "frame rate");
    bad("v4l2:/dev/video0:640x480:", "is not one of");
    bad("v4l2:/dev/video0:640x480:YUYV", "is not one of");
    bad("v4l2:/dev/video0:640x480:bgr24", "is not one of");
    bad("v4l2:/dev/video0:640x480:yuyv:extra", "is not one of");
    char longpath[400] = "v4l2:/";
    memset(longpath + 6, 'a', 300);
    longpath[306] = '\0';
    bad(longpath, "longer than");
}

static void expect_open_error(const char *spec, int want, const char *needle)
{
    pl_source *src = (pl_source *)1;
    int rc = pl_source_open_camera(spec, &src);
    CHECK(rc == want, "open '%s': rc %d, want %d (%s)", spec, rc, want, pl_last_error());
    CHECK(src == NULL, "open '%s': out not NULL on failure", spec);
    CHECK(strstr(pl_last_error(), needle) != NULL, "open '%s': message '%s' lacks '%s'", spec,
          pl_last_error(), needle);
    CHECK(strchr(pl_last_error(), '\n') == NULL, "open '%s': message has a newline", spec);
}

static void test_open_errors(const char *tmpdir)
{
    expect_open_error("v4l2:/dev/video-does-not-exist", PL_E_IO,
                      "v4l2:/dev/video-does-not-exist: cannot open camera: No such file");
    expect_open_error("v4l2:/dev/null", PL_E_DEVICE, "v4l2:/dev/null: not a V4L2 device");
    char spec[600];
    snprintf(spec, sizeof spec, "v4l2:%s", tmpdir);
    expect_open_error(spec, PL_E_IO, "not a device node");
    expect_open_error("v4l2:/dev/video0:640", PL_E_ARG, "is not WxH");
    pl_source_close(NULL);

    pl_v4l2_device_info info;
    CHECK(pl_v4l2_query_device("/dev/null", &info) == PL_E_DEVICE, "query /dev/null");
    CHECK(info.formats == NULL && info.n_formats == 0, "query /dev/null left formats");
    CHECK(pl_v4l2_query_device("/dev/video-does-not-exist", &info) == PL_E_IO, "query missing");
    char f[5];
    CHECK(strcmp(pl_v4l2_fourcc_str(V4L2_PIX_FMT_YUYV, f), "YUYV") == 0, "fourcc YUYV");
    CHECK(strcmp(pl_v4l2_fourcc_str(V4L2_PIX_FMT_Y10, f), "Y10") == 0, "fourcc Y10: '%s'", f);
}

static unsigned char *slurp(const char *path, size_t *n)
{
    FILE *fp = fopen(path, "rb");
    if (!fp) return NULL;
    fseek(fp, 0, SEEK_END);
    long len = ftell(fp);
    fseek(fp, 0, SEEK_SET);
    unsigned char *b = malloc((size_t)len + 64);
    *n = b ? fread(b, 1, (size_t)len, fp) : 0;
    fclose(fp);
    return b;
}

static void test_mjpeg(const char *tmpdir)
{
    pl_image_u8 src;
    if (pl_image_u8_alloc(&src, 64, 48) < 0) {
        CHECK(0, "alloc");
        return;
    }
    for (int y = 0; y < 48; y++)
        for (int x = 0; x < 64; x++) {
            uint8_t *p = src.data + (size_t)y * src.stride + (size_t)x * 3;
            p[0] = (uint8_t)(x * 4);
            p[1] = (uint8_t)(y * 5);
            p[2] = 128;
        }
    char path[600];
    snprintf(path, sizeof path, "%s/frame.jpg", tmpdir);
    CHECK(pl_image_write_jpeg(path, &src, 95) == PL_OK, "write jpeg: %s", pl_last_error());
    size_t n = 0;
    unsigned char *jpg = slurp(path, &n);
    CHECK(jpg && n > 100, "read back %s", path);
    if (!jpg) return;
    pl_image_u8 img = {0, 0, 0, NULL};
    size_t cap = 0;
    int rc = pl_image_decode_jpeg_rgb8_reuse(jpg, n, "test frame", &img, &cap);
    CHECK(rc == PL_OK && img.width == 64 && img.height == 48, "decode: rc %d %dx%d %s", rc,
          img.width, img.height, pl_last_error());
    if (rc == PL_OK) {
        double err = 0;
        for (int y = 0; y < 48; y++)
            for (int x = 0; x < 64 * 3; x++)
                err += abs((int)img.data[(size_t)y * img.stride + (size_t)x] -
                           (int)src.data[(size_t)y * src.stride + (size_t)x]);
        err /= 64.0 * 48 * 3;
        CHECK(err < 3.0, "decoded pixels differ by %.2f on average (RGB order?)", err);
    }
    /* drivers pad MJPEG buffers with zeros after EOI */
    memset(jpg + n, 0, 64);
    rc = pl_image_decode_jpeg_rgb8_reuse(jpg, n + 64, "padded frame", &img, &cap);
    CHECK(rc == PL_OK, "zero padding after EOI refused: %s", pl_last_error());
    rc = pl_image_decode_jpeg_rgb8_reuse(jpg, n / 2, "half frame", &img, &cap);
    CHECK(rc == PL_E_FORMAT && strstr(pl_last_error(), "half frame: truncated"),
          "truncated frame: rc %d '%s'", rc, pl_last_error());
    rc = pl_image_decode_jpeg_rgb8_reuse(jpg + 2, n - 2, "no soi", &img, &cap);
    CHECK(rc == PL_E_FORMAT && strstr(pl_last_error(), "not a JPEG"), "no SOI: rc %d '%s'", rc,
          pl_last_error());
    rc = pl_image_decode_jpeg_rgb8_reuse(jpg, 3, "tiny", &img, &cap);
    CHECK(rc == PL_E_FORMAT, "3-byte frame: rc %d", rc);
    /* a corrupt scan keeps its markers: the decoder may still fail or give garbage, never crash */
    for (size_t i = n / 2; i < n - 4; i += 7)
        jpg[i] = 0xff;
    rc = pl_image_decode_jpeg_rgb8_reuse(jpg, n, "corrupt frame", &img, &cap);
    CHECK(rc == PL_OK || rc == PL_E_FORMAT, "corrupt frame: rc %d", rc);
    free(jpg);
    pl_image_u8_free(&img);
    pl_image_u8_free(&src);
}

int main(void)
{
    const char *base = getenv("PL_TEST_TMP");
    char tmpdir[512];
    snprintf(tmpdir, sizeof tmpdir, "%s/v4l2", base ? base : "/tmp");
    char cmd[600];
    snprintf(cmd, sizeof cmd, "mkdir -p '%s'", tmpdir);
    if (system(cmd) != 0) {
        printf("cannot create %s\n", tmpdir);
        return 1;
    }
    test_spec();
    test_open_errors(tmpdir);
    test_mjpeg(tmpdir);
    if (failures) {
        printf("%d failure(s)\n", failures);
        return 1;
    }
    printf("v4l2 (no device): all checks passed\n");
    return 0;
}
