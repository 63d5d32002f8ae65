/* The public API's frame and map entry points (include/parlight.h, port/frame_api.c,
 * light/sg.c, light/cubemap.c):
 *  - pl_estimate_yuyv / pl_estimate_nv12 give bit for bit the lights of pl_estimate_rgb8 on the
 *    frame converted by the sources' conversion (port/pixfmt.h), for every encoding, with padded
 *    strides and a separate chroma plane; odd sizes, short strides, NULLs and unknown encodings
 *    are refused with messages naming them;
 *  - pl_image_load_rgb8 decodes as the CLI does (port/image.h), rows packed; a missing file or
 *    one that is not an image is an error naming the path;
 *  - pl_equirect_from_lights is the internal env map, pl_cubemap_from_lights checks its input.
 * Skips (77) without the shipped int8 model. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "core/image.h"
#include "light/light.h"
#include "parlight.h"
#include "port/image.h"
#include "port/pixfmt.h"

static pl_yuv_coeffs coeffs(pl_ycbcr e)
{
    pl_yuv_coeffs c;
    pl_yuv_coeffs_init(&c, e >= PL_YCBCR_BT709_LIMITED ? PL_YUV_BT709 : PL_YUV_BT601,
                       e % 2 ? PL_YUV_FULL : PL_YUV_LIMITED);
    return c;
}

/* A room-like YUV signal: a bright patch top left, a gradient elsewhere, chroma varying. */
static uint8_t luma(int x, int y, int w, int h)
{
    return (uint8_t)(x < w / 3 && y < h / 4 ? 235 : 40 + (x * 90) / w + (y * 60) / h);
}
static uint8_t chroma(int x, int y, int k)
{
    return (uint8_t)(128 + ((x * (k ? 3 : 5) + y * (k ? 7 : 2)) % 61) - 30);
}

static void same(const pl_lighting *a, const pl_lighting *b, const char *what)
{
    CHECK(memcmp(a, b, sizeof *a) == 0, "%s: lights differ from the RGB path", what);
}

static void expect_arg(int rc, const char *msg, const char *what)
{
    CHECK(rc == PL_E_ARG, "%s: status %s, expected PL_E_ARG", what, pl_status_name(rc));
    CHECK(strstr(pl_last_error(), msg) != NULL, "%s: message '%s' lacks '%s'", what,
          pl_last_error(), msg);
}

static void test_yuv(pl_model *m)
{
    const int w = 200, h = 150;
    const size_t ys = 256, uvs = 224, st = 448; /* padded strides */
    uint8_t *yuyv = calloc(st * h, 1), *yp = calloc(ys * h, 1), *uvp = calloc(uvs * (h / 2), 1);
    uint8_t *rgb = malloc((size_t)w * 3 * h);
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            yuyv[y * st + 2 * (size_t)x] = luma(x, y, w, h);
            if (x % 2 == 0) {
                yuyv[y * st + 2 * (size_t)x + 1] = chroma(x, y, 0);
                yuyv[y * st + 2 * (size_t)x + 3] = chroma(x, y, 1);
            }
            yp[y * ys + (size_t)x] = luma(x, y, w, h);
            if (x % 2 == 0 && y % 2 == 0) {
                uvp[(y / 2) * uvs + (size_t)x] = chroma(x, y, 0);
                uvp[(y / 2) * uvs + (size_t)x + 1] = chroma(x, y, 1);
            }
        }
    for (int e = PL_YCBCR_BT601_LIMITED; e <= PL_YCBCR_BT709_FULL; e++) {
        const pl_yuv_coeffs c = coeffs((pl_ycbcr)e);
        pl_lighting ref, got;
        pl_timing t;
        pl_yuyv_to_rgb8(yuyv, st, w, h, &c, rgb, (size_t)w * 3);
        CHECK(pl_estimate_rgb8(m, rgb, w, h, (size_t)w * 3, &ref, NULL) == PL_OK, "%s",
              pl_last_error());
        CHECK(pl_estimate_yuyv(m, yuyv, w, h, st, (pl_ycbcr)e, &got, &t) == PL_OK, "%s",
              pl_last_error());
        same(&ref, &got, "YUYV");
        CHECK(t.preprocess_ms > 0 && t.infer_ms > 0, "YUYV timing %g %g", t.preprocess_ms,
              t.infer_ms);
        pl_nv12_to_rgb8(yp, ys, uvp, uvs, w, h, &c, rgb, (size_t)w * 3);
        CHECK(pl_estimate_rgb8(m, rgb, w, h, (size_t)w * 3, &ref, NULL) == PL_OK, "%s",
              pl_last_error());
        CHECK(pl_estimate_nv12(m, yp, ys, uvp, uvs, w, h, (pl_ycbcr)e, &got, NULL) == PL_OK, "%s",
              pl_last_error());
        same(&ref, &got, "NV12");
    }
    /* a smaller frame after a larger one reuses the model's buffer; a larger one grows it */
    pl_lighting a, b;
    const pl_yuv_coeffs c = coeffs(PL_YCBCR_BT601_LIMITED);
    pl_yuyv_to_rgb8(yuyv, st, 64, 48, &c, rgb, 64 * 3);
    CHECK(pl_estimate_rgb8(m, rgb, 64, 48, 64 * 3, &a, NULL) == PL_OK, "%s", pl_last_error());
    CHECK(pl_estimate_yuyv(m, yuyv, 64, 48, st, PL_YCBCR_BT601_LIMITED, &b, NULL) == PL_OK, "%s",
          pl_last_error());
    same(&a, &b, "YUYV 64x48 after 200x150");

    pl_lighting L;
    expect_arg(pl_estimate_yuyv(m, yuyv, 199, 150, st, 0, &L, NULL), "must be even", "YUYV w 199");
    CHECK(pl_estimate_yuyv(m, yuyv, 198, 149, st, 0, &L, NULL) == PL_OK, "YUYV 198x149: %s",
          pl_last_error());
    expect_arg(pl_estimate_nv12(m, yp, ys, uvp, uvs, 199, 150, 0, &L, NULL), "must be even",
               "NV12 w 199");
    expect_arg(pl_estimate_nv12(m, yp, ys, uvp, uvs, 200, 149, 0, &L, NULL),
               "width and height must be even", "NV12 h 149");
    expect_arg(pl_estimate_yuyv(m, yuyv, 6, 150, st, 0, &L, NULL), "8..", "YUYV 6 wide");
    expect_arg(pl_estimate_nv12(m, yp, ys, uvp, uvs, 200, 4, 0, &L, NULL), "8..", "NV12 4 high");
    expect_arg(pl_estimate_yuyv(m, yuyv, 200, 150, 399, 0, &L, NULL), "stride 399",
               "YUYV short stride");
    expect_arg(pl_estimate_nv12(m, yp, 199, uvp, uvs, 200, 150, 0, &L, NULL), "y_stride 199",
               "NV12 short y stride");
    expect_arg(pl_estimate_nv12(m, yp, ys, uvp, 100, 200, 150, 0, &L, NULL), "uv_stride 100",
               "NV12 short uv stride");
    expect_arg(pl_estimate_yuyv(m, yuyv, 200, 150, st, (pl_ycbcr)7, &L, NULL), "encoding 7",
               "YUYV encoding 7");
    expect_arg(pl_estimate_nv12(m, yp, ys, uvp, uvs, 200, 150, (pl_ycbcr)-1, &L, NULL),
               "encoding -1", "NV12 encoding -1");
    expect_arg(pl_estimate_yuyv(NULL, yuyv, 200, 150, st, 0, &L, NULL), "NULL", "YUYV NULL model");
    expect_arg(pl_estimate_nv12(m, yp, ys, NULL, uvs, 200, 150, 0, &L, NULL), "NULL",
               "NV12 NULL uv");
    free(yuyv);
    free(yp);
    free(uvp);
    free(rgb);
}

static void test_image_load(void)
{
    const char *path = "tests/data/frames/lab-lamps.jpg";
    uint8_t *rgb = (uint8_t *)&rgb;
    int w = 0, h = 0;
    CHECK(pl_image_load_rgb8(path, &rgb, &w, &h) == PL_OK, "%s", pl_last_error());
    pl_image_u8 ref;
    CHECK(pl_image_read_rgb8(path, &ref) == PL_OK, "%s", pl_last_error());
    if (rgb && ref.data) {
        CHECK(w == ref.width && h == ref.height, "size %dx%d vs %dx%d", w, h, ref.width,
              ref.height);
        int rows_same = 1;
        for (int y = 0; y < h && rows_same; y++)
            rows_same =
                !memcmp(rgb + (size_t)y * w * 3, ref.data + (size_t)y * ref.stride, (size_t)w * 3);
        CHECK(rows_same, "pl_image_load_rgb8 pixels differ from the CLI's decoding");
    }
    pl_free(rgb);
    pl_image_u8_free(&ref);
    rgb = (uint8_t *)&rgb;
    int rc = pl_image_load_rgb8("tests/data/no-such-frame.jpg", &rgb, &w, &h);
    CHECK(rc == PL_E_IO && rgb == NULL, "missing file: %s, rgb %p", pl_status_name(rc),
          (void *)rgb);
    CHECK(strstr(pl_last_error(), "no-such-frame.jpg") != NULL, "message '%s'", pl_last_error());
    rc = pl_image_load_rgb8("tests/check.h", &rgb, &w, &h);
    CHECK(rc == PL_E_FORMAT || rc == PL_E_UNSUPPORTED, "not an image: %s (%s)", pl_status_name(rc),
          pl_last_error());
    CHECK(pl_image_load_rgb8(path, NULL, &w, &h) == PL_E_ARG, "NULL rgb accepted");
    pl_free(NULL);
}

static void test_maps(void)
{
    pl_lighting L = {
        2,
        {{{0, 0.6f, -0.8f}, 2.0f, 0.05f, {10, 9, 8}}, {{-1, 0, 0}, 3.0f, 0.8f, {0.5f, 0.6f, 0.7f}}},
        {0.1f, 0.1f, 0.12f}};
    const int W = 64;
    float *env = malloc(sizeof(float) * W * (W / 2) * 3);
    CHECK(pl_equirect_from_lights(&L, W, env) == PL_OK, "%s", pl_last_error());
    pl_image_f32 img;
    CHECK(pl_envmap_from_lights(&L, W, &img) == PL_OK, "%s", pl_last_error());
    CHECK(img.data && !memcmp(env, img.data, sizeof(float) * W * (W / 2) * 3),
          "pl_equirect_from_lights differs from pl_envmap_from_lights");
    pl_image_f32_free(&img);
    expect_arg(pl_equirect_from_lights(&L, 63, env), "width 63", "odd env width");
    expect_arg(pl_equirect_from_lights(&L, W, NULL), "NULL", "NULL env");
    pl_lighting bad = L;
    bad.n_lights = 99;
    expect_arg(pl_equirect_from_lights(&bad, W, env), "n_lights 99", "bad lighting");
    bad = L;
    bad.lights[0].rgb[1] = NAN;
    expect_arg(pl_cubemap_from_lights(&bad, 8, env), "", "NaN colour");
    float *cube = malloc(sizeof(float) * 6 * 8 * 8 * 3);
    CHECK(pl_cubemap_from_lights(&L, 8, cube) == PL_OK, "%s", pl_last_error());
    /* +Y face (index 2), centre pixel: looking up, where light 0 (dir 0, .6, -.8) is not */
    float u[3] = {0, 1, 0}, r[3];
    pl_lights_radiance(&L, u, r);
    const float *px = cube + ((size_t)2 * 64 + 4 * 8 + 4) * 3;
    CHECK(fabsf(px[0] - r[0]) < 0.05f * r[0] + 1e-3f, "cube +Y centre %g vs radiance up %g", px[0],
          r[0]);
    expect_arg(pl_cubemap_from_lights(&L, 0, cube), "face size 0", "face 0");
    free(cube);
    free(env);
}

int main(int argc, char **argv)
{
    const char *path = argc > 1 ? argv[1] : "models/parlight-n3-int8.plm";
    pl_model *m = NULL;
    if (pl_model_load(path, &m) < 0) {
        printf("skip: %s\n", pl_last_error());
        return 77;
    }
    test_yuv(m);
    pl_model_free(m);
    test_image_load();
    test_maps();
    printf(failures ? "%d failure(s)\n" : "api frames: all passed\n", failures);
    return failures ? 1 : 0;
}
