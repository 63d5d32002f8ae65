/* light/crop + `parlight crop`: camera geometry (rotation, projection, centre pixel), a light at a
 * known direction appears at the right pixel in the crop and, after the rotation, at the same
 * pixel in gt.json; the exposure rule and the response curve; the CLI (single, batch, refusing to
 * overwrite without --force). Run from the repository root with BUILD set (tests/run.sh does).
 * needs: openexr (tests/run.sh skips this test in a build without it) */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "core/util.h"
#include "light/crop.h"
#include "light/equirect.h"
#include "light/extract.h"
#include "light/light.h"
#include "light/lights_json.h"
#include "port/hdr_io.h"
#include "port/image.h"
#include "port/json_file.h"
#include "tests/check.h"

static void dir_of(double yaw_deg, double pitch_deg, float d[3])
{
    double y = yaw_deg * M_PI / 180, p = pitch_deg * M_PI / 180;
    d[0] = (float)(sin(y) * cos(p));
    d[1] = (float)sin(p);
    d[2] = (float)(-cos(y) * cos(p));
}

static void test_geometry(void)
{
    pl_crop_params p;
    pl_crop_default_params(&p);
    double R[9];
    pl_crop_rotation(&p, R);
    for (int i = 0; i < 9; i++)
        CHECK(fabs(R[i] - (i % 4 == 0)) < 1e-12, "yaw 0 pitch 0: R[%d] = %g", i, R[i]);
    double angles[][2] = {{30, 10}, {-135, -40}, {270, 80}, {0, -90}, {359, 45}};
    for (size_t t = 0; t < sizeof angles / sizeof angles[0]; t++) {
        p.yaw_deg = angles[t][0], p.pitch_deg = angles[t][1];
        pl_crop_rotation(&p, R);
        double det = R[0] * (R[4] * R[8] - R[5] * R[7]) - R[1] * (R[3] * R[8] - R[5] * R[6]) +
                     R[2] * (R[3] * R[7] - R[4] * R[6]);
        double orth = 0;
        for (int i = 0; i < 3; i++)
            for (int j = 0; j < 3; j++) {
                double d = 0;
                for (int k = 0; k < 3; k++)
                    d += R[3 * k + i] * R[3 * k + j];
                orth = fmax(orth, fabs(d - (i == j)));
            }
        CHECK(fabs(det - 1) < 1e-9 && orth < 1e-9, "R not a rotation (det %g, orth %g)", det, orth);
        float f[3];
        dir_of(p.yaw_deg, p.pitch_deg, f);
        /* the optical axis (camera -z) maps to the panorama direction (yaw, pitch) */
        for (int k = 0; k < 3; k++)
            CHECK(fabs(-R[3 * k + 2] - f[k]) < 1e-6, "axis of yaw %g pitch %g: %g vs %g", p.yaw_deg,
                  p.pitch_deg, -R[3 * k + 2], (double)f[k]);
    }
    /* projection: the centre of the image, a point at the right edge of the fov */
    pl_crop_default_params(&p);
    double x, y;
    float ax[3] = {0, 0, -1};
    CHECK(pl_crop_project(&p, ax, &x, &y) && fabs(x - 320) < 1e-9 && fabs(y - 240) < 1e-9,
          "centre at %g %g", x, y);
    float edge[3];
    dir_of(30, 0, edge); /* camera frame == panorama frame at yaw 0 */
    pl_crop_project(&p, edge, &x, &y);
    CHECK(fabs(x - 640) < 1e-3 && fabs(y - 240) < 1e-3, "right edge of a 60 degree fov at %g %g", x,
          y);
    float up[3];
    dir_of(0, 10, up);
    CHECK(pl_crop_project(&p, up, &x, &y) && y < 240, "up is up: y = %g", y);
    float back[3] = {0, 0, 1};
    CHECK(!pl_crop_project(&p, back, &x, &y), "a direction behind the camera projected");
}

/* A panorama with one small bright light at (yaw 40, pitch 12) and a dim ambient. */
static void make_scene(pl_lighting *T, pl_image_f32 *pano)
{
    memset(T, 0, sizeof *T);
    T->n_lights = 1;
    dir_of(40, 12, T->lights[0].dir);
    T->lights[0].solid_angle_sr = 0.003f;
    T->lights[0].distance_m = 2;
    T->lights[0].rgb[0] = 400, T->lights[0].rgb[1] = 300, T->lights[0].rgb[2] = 200;
    T->ambient[0] = T->ambient[1] = T->ambient[2] = 0.2f;
    if (pl_envmap_from_lights(T, 1024, pano) < 0) {
        printf("envmap: %s\n", pl_last_error());
        exit(1);
    }
}

/* Where the light is in a linear crop: the luminance-weighted centroid of the pixels above half
 * the maximum (the lobe is symmetric, so this is its centre to a fraction of a pixel). */
static void brightest(const pl_image_f32 *img, double *bx, double *by)
{
    double bv = 0, sx = 0, sy = 0, sw = 0;
    for (int i = 0; i < img->width * img->height; i++) {
        const float *p = img->data + 3 * i;
        bv = fmax(bv, 0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2]);
    }
    for (int i = 0; i < img->width * img->height; i++) {
        const float *p = img->data + 3 * i;
        double v = 0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2];
        if (v < 0.5 * bv) continue;
        sx += v * (i % img->width + 0.5), sy += v * (i / img->width + 0.5), sw += v;
    }
    *bx = sx / sw, *by = sy / sw;
}

static void test_light_pixel(void)
{
    pl_lighting T, E, C;
    pl_image_f32 pano, lin;
    make_scene(&T, &pano);
    pl_extract_params ep;
    pl_extract_default_params(&ep);
    CHECK(pl_extract_lights(&pano, &ep, &E, NULL) == 0 && E.n_lights == 1, "extract: %d lights %s",
          E.n_lights, pl_last_error());
    double views[][3] = {{20, 5, 60}, {55, 20, 90}, {40, 12, 30}, {-300, 0, 120}};
    for (size_t v = 0; v < sizeof views / sizeof views[0]; v++) {
        pl_crop_params p;
        pl_crop_default_params(&p);
        p.yaw_deg = views[v][0], p.pitch_deg = views[v][1], p.fov_deg = views[v][2];
        CHECK(pl_crop_linear(&pano, &p, &lin) == 0, "crop: %s", pl_last_error());
        double bx, by, ex, ey, gx, gy;
        brightest(&lin, &bx, &by);
        /* expected from the true direction rotated into the camera */
        pl_crop_lighting(&T, &p, 1.0, &C);
        int in = pl_crop_project(&p, C.lights[0].dir, &ex, &ey);
        CHECK(in, "view %zu: light not in view", v);
        /* within a pixel, or 0.05 degrees when the crop magnifies the panorama's pixels */
        double tol = fmax(1.0, 0.05 / (p.fov_deg / p.width));
        CHECK(hypot(bx - ex, by - ey) < tol,
              "view %zu: light seen at (%.2f, %.2f), expected (%.2f, %.2f)", v, bx, by, ex, ey);
        /* the ground truth (extracted, rotated) lands on the same pixel */
        double k = pl_crop_exposure_scale(&lin, 0);
        pl_crop_lighting(&E, &p, k, &C);
        pl_crop_project(&p, C.lights[0].dir, &gx, &gy);
        CHECK(hypot(gx - ex, gy - ey) < tol,
              "view %zu: gt light at (%.2f, %.2f), expected (%.2f, %.2f)", v, gx, gy, ex, ey);
        CHECK(fabs(C.lights[0].rgb[0] - E.lights[0].rgb[0] * k) < 1e-3 * C.lights[0].rgb[0] &&
                  fabs(C.ambient[1] - E.ambient[1] * k) < 1e-6,
              "view %zu: colours not scaled by k", v);
        printf("  view yaw %g pitch %g fov %g: light at (%.2f, %.2f), expected (%.2f, %.2f), gt "
               "(%.2f, %.2f)\n",
               p.yaw_deg, p.pitch_deg, p.fov_deg, bx, by, ex, ey, gx, gy);
        pl_image_f32_free(&lin);
    }
    pl_image_f32_free(&pano);
}

static void test_exposure(void)
{
    pl_image_f32 pano, lin;
    pl_image_u8 ldr;
    pl_image_f32_alloc(&pano, 64, 32);
    for (int i = 0; i < 64 * 32 * 3; i++)
        pano.data[i] = 2.0f;
    pl_crop_params p;
    pl_crop_default_params(&p);
    p.width = 8, p.height = 6;
    pl_crop_linear(&pano, &p, &lin);
    double k = pl_crop_exposure_scale(&lin, 0);
    CHECK(fabs(k - 0.09) < 1e-6, "k = %g, expected 0.18 / 2", k);
    CHECK(fabs(pl_crop_exposure_scale(&lin, 1) - 0.18) < 1e-6, "+1 EV: k = %g",
          pl_crop_exposure_scale(&lin, 1));
    pl_crop_to_ldr(&lin, k, 2.2, &ldr);
    int want = (int)lround(pow(0.18, 1 / 2.2) * 255);
    CHECK(ldr.data[0] == want, "grey 0.18 through gamma 2.2: %d, expected %d", ldr.data[0], want);
    pl_image_u8_free(&ldr);
    pl_crop_to_ldr(&lin, 10.0, 2.2, &ldr);
    CHECK(ldr.data[0] == 255, "over-exposed value not clipped: %d", ldr.data[0]);
    pl_image_u8_free(&ldr);
    pl_crop_to_ldr(&lin, k, 1.0, &ldr);
    CHECK(ldr.data[0] == (int)lround(0.18 * 255), "gamma 1: %d", ldr.data[0]);
    pl_image_u8_free(&ldr);
    pl_image_f32_free(&lin);
    pl_image_f32_free(&pano);
    p.fov_deg = 0;
    CHECK(pl_crop_check_params(&p) == PL_E_ARG, "fov 0 accepted");
}

static int run(const char *cmd)
{
    fflush(stdout);
    int rc = system(cmd);
    return WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
}

static void test_cli(void)
{
    const char *b = getenv("BUILD"), *t = getenv("PL_TEST_TMP");
    char bin[512], dir[512], cmd[8192], pano_path[600], out[600], gt[600];
    snprintf(bin, sizeof bin, "%s/parlight", b && *b ? b : "build");
    struct stat sb;
    if (stat(bin, &sb) != 0) {
        printf("note: %s not built: CLI part skipped\n", bin);
        return;
    }
    snprintf(dir, sizeof dir, "%s/crop", t && *t ? t : "/tmp");
    mkdir(t && *t ? t : "/tmp", 0755);
    mkdir(dir, 0755);
    pl_lighting T;
    pl_image_f32 pano;
    make_scene(&T, &pano);
    snprintf(pano_path, sizeof pano_path, "%s/scene.exr", dir);
    CHECK(pl_hdr_write(pano_path, &pano) == 0, "%s", pl_last_error());
    pl_image_f32_free(&pano);
    snprintf(out, sizeof out, "%s/c.png", dir);
    snprintf(gt, sizeof gt, "%s/c.json", dir);
    remove(out);
    remove(gt);
    snprintf(cmd, sizeof cmd, "%s crop --hdr '%s' --yaw 20 --pitch 5 --fov 60 --out '%s' --gt '%s'",
             bin, pano_path, out, gt);
    CHECK(run(cmd) == 0, "%s failed", cmd);
    pl_lighting G;
    CHECK(pl_lighting_read_json(gt, &G) == 0 && G.n_lights == 1, "gt.json: %s", pl_last_error());
    pl_crop_params p;
    pl_crop_default_params(&p);
    p.yaw_deg = 20, p.pitch_deg = 5;
    pl_lighting C;
    pl_crop_lighting(&T, &p, 1.0, &C);
    double ex, ey, gx, gy;
    pl_crop_project(&p, C.lights[0].dir, &ex, &ey);
    pl_crop_project(&p, G.lights[0].dir, &gx, &gy);
    CHECK(hypot(gx - ex, gy - ey) < 1.0, "gt.json light at (%.2f, %.2f), expected (%.2f, %.2f)", gx,
          gy, ex, ey);
    FILE *f = fopen(gt, "r");
    char text[65536] = "";
    if (f) {
        size_t n = fread(text, 1, sizeof text - 1, f);
        text[n] = 0;
        fclose(f);
    }
    CHECK(strstr(text, "\"exposure_scale\":") && strstr(text, "\"yaw_deg\":20") &&
              strstr(text, "\"pitch_deg\":5") && strstr(text, "\"fov_deg\":60") &&
              strstr(text, "\"distance_assumed\":true"),
          "gt.json lacks fields: %.300s", text);
    snprintf(cmd + strlen(cmd), sizeof cmd - strlen(cmd), " 2>/dev/null");
    CHECK(run(cmd) == 1, "an existing output was overwritten without --force");
    cmd[strlen(cmd) - 12] = 0;
    snprintf(cmd + strlen(cmd), sizeof cmd - strlen(cmd), " --force");
    CHECK(run(cmd) == 0, "--force did not overwrite");
    pl_image_u8 img;
    CHECK(pl_image_read_rgb8(out, &img) == 0 && img.width == 640 && img.height == 480,
          "crop image: %s", pl_last_error());
    pl_image_u8_free(&img);
    snprintf(cmd, sizeof cmd,
             "%s crop --hdr '%s' --batch 8 --size 64x48 --out-dir '%s/batch' >/dev/null", bin,
             pano_path, dir);
    CHECK(run(cmd) == 0, "batch failed");
    for (int i = 0; i < 8; i++) {
        char pth[1200];
        snprintf(pth, sizeof pth, "%s/batch/scene_yaw%03d.png", dir, i * 45);
        CHECK(stat(pth, &sb) == 0, "batch output %s missing", pth);
        snprintf(pth, sizeof pth, "%s/batch/scene_yaw%03d.json", dir, i * 45);
        CHECK(pl_lighting_read_json(pth, &G) == 0, "batch gt %s: %s", pth, pl_last_error());
    }
    snprintf(cmd, sizeof cmd,
             "%s crop --hdr '%s' --batch 8 --size 64x48 --out-dir '%s/batch' 2>/dev/null", bin,
             pano_path, dir);
    CHECK(run(cmd) == 1, "batch overwrote without --force");
    snprintf(cmd, sizeof cmd, "%s crop --hdr '%s' --yaw 20 --fov 0 --out '%s/x.png' 2>/dev/null",
             bin, pano_path, dir);
    CHECK(run(cmd) == 2, "--fov 0 not a usage error");
    snprintf(cmd, sizeof cmd, "%s crop --hdr '%s/missing.exr' --yaw 0 --out '%s/x.png' 2>/dev/null",
             bin, dir, dir);
    CHECK(run(cmd) == 1, "missing panorama not a failure");
}

int main(void)
{
    test_geometry();
    test_exposure();
    test_light_pixel();
    test_cli();
    if (failures) {
        printf("%d failure(s)\n", failures);
        return 1;
    }
    printf("all crop tests passed\n");
    return 0;
}
