/* light/eval: quartiles, angles, baselines (a) and (b) against their documented rules, the map
 * rotation into a crop's frame (exact for a yaw by whole columns, close for any rotation), and a
 * whole crop of a synthetic panorama where the extracted lights (c) must beat the mean ambient
 * (a) and an estimate equal to the ground truth must score as (c). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/util.h"
#include "light/crop.h"
#include "light/eval.h"
#include "light/extract.h"
#include "light/light.h"
#include "light_test.h"

static void test_quartiles(void)
{
    const double v[] = {4, NAN, 1, 3, 2};
    pl_eval_stats s;
    CHECK(pl_eval_quartiles(v, 5, &s) == 0, "quartiles: %s", pl_last_error());
    CHECK(s.n == 4 && fabs(s.q1 - 1.75) < 1e-12 && fabs(s.median - 2.5) < 1e-12 &&
              fabs(s.q3 - 3.25) < 1e-12,
          "quartiles of 1..4: n %d q1 %g median %g q3 %g", s.n, s.q1, s.median, s.q3);
    const double one = 7;
    CHECK(pl_eval_quartiles(&one, 1, &s) == 0 && s.n == 1 && s.q1 == 7 && s.median == 7 &&
              s.q3 == 7,
          "one value");
    const double nan1 = NAN;
    CHECK(pl_eval_quartiles(&nan1, 1, &s) == 0 && s.n == 0 && isnan(s.median), "all NaN");
    CHECK(pl_eval_quartiles(NULL, 0, &s) == 0 && s.n == 0 && isnan(s.q1), "empty");
    CHECK(pl_eval_quartiles(NULL, 3, &s) == PL_E_ARG, "NULL values accepted");
    const double odd[] = {5, 1, 9};
    CHECK(pl_eval_quartiles(odd, 3, &s) == 0 && s.median == 5 && s.q1 == 3 && s.q3 == 7,
          "1, 5, 9: q1 %g median %g q3 %g", s.q1, s.median, s.q3);
}

static void test_angle(void)
{
    const float x[3] = {1, 0, 0}, y[3] = {0, 2, 0}, mx[3] = {-3, 0, 0}, z0[3] = {0, 0, 0};
    const float d45[3] = {1, 1, 0};
    CHECK(fabs(pl_eval_angle_deg(x, y) - 90) < 1e-9, "x, y");
    CHECK(fabs(pl_eval_angle_deg(x, x)) < 1e-6, "x, x: %g", pl_eval_angle_deg(x, x));
    CHECK(fabs(pl_eval_angle_deg(x, mx) - 180) < 1e-6, "x, -x");
    CHECK(fabs(pl_eval_angle_deg(x, d45) - 45) < 1e-5, "x, 45 degrees");
    CHECK(isnan(pl_eval_angle_deg(x, z0)), "zero vector");
}

/* A W x H crop image filled with `bg`, and a rectangle [x0, x1) x [y0, y1) with `fg`. */
static int make_ldr(pl_image_u8 *img, int W, int H, const uint8_t bg[3], int x0, int y0, int x1,
                    int y1, const uint8_t fg[3])
{
    if (pl_image_u8_alloc(img, W, H) < 0) return -1;
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            const uint8_t *c = x >= x0 && x < x1 && y >= y0 && y < y1 ? fg : bg;
            memcpy(img->data + (size_t)y * img->stride + 3 * (size_t)x, c, 3);
        }
    return 0;
}

static void test_baselines(void)
{
    pl_crop_params p;
    pl_crop_default_params(&p);
    pl_image_u8 img;
    const uint8_t bg[3] = {128, 64, 0}, fg[3] = {255, 255, 200}, black[3] = {0, 0, 0};
    if (make_ldr(&img, p.width, p.height, bg, 0, 0, 0, 0, fg) < 0) {
        CHECK(0, "alloc");
        return;
    }
    pl_lighting L;
    CHECK(pl_eval_baseline_ambient(&img, 2.2, &L) == 0 && L.n_lights == 0, "(a) %s",
          pl_last_error());
    for (int c = 0; c < 3; c++) {
        double want = pow(bg[c] / 255.0, 2.2);
        CHECK(fabs(L.ambient[c] - want) < 1e-6, "(a) ambient[%d] %g, want %g", c,
              (double)L.ambient[c], want);
    }
    pl_image_u8_free(&img);

    /* (b) on black with one bright rectangle: the light points at the rectangle's centre */
    make_ldr(&img, p.width, p.height, black, 500, 100, 510, 112, fg);
    CHECK(pl_eval_baseline_brightest(&img, &p, &L) == 0 && L.n_lights == 1, "(b) %s",
          pl_last_error());
    double x, y;
    int in = pl_crop_project(&p, L.lights[0].dir, &x, &y);
    CHECK(in && fabs(x - 505) < 1e-3 && fabs(y - 106) < 1e-3,
          "(b) light at pixel %g %g, want 505 106", x, y);
    CHECK(fabs(L.lights[0].solid_angle_sr - PL_EVAL_BRIGHT_SR) < 1e-7 && L.ambient[0] == 0,
          "(b) size %g ambient %g", (double)L.lights[0].solid_angle_sr, (double)L.ambient[0]);
    pl_image_u8_free(&img);

    /* (b) on a grey background: the lighting's mean radiance over the crop's pixel directions is
     * the crop's mean linear colour, and the ambient the mean of the rest */
    const uint8_t grey[3] = {90, 100, 110};
    p.width = 160, p.height = 120; /* cells of 20 px */
    make_ldr(&img, p.width, p.height, grey, 20, 40, 40, 60, fg);
    CHECK(pl_eval_baseline_brightest(&img, &p, &L) == 0, "(b) %s", pl_last_error());
    pl_lighting A;
    pl_eval_baseline_ambient(&img, p.gamma, &A);
    double mean[3] = {0, 0, 0}, R[9];
    pl_crop_rotation(&p, R); /* identity at yaw 0 pitch 0: pixel directions in the camera frame */
    const double t = tan(p.fov_deg * M_PI / 360), asp = (double)p.height / p.width;
    for (int j = 0; j < p.height; j++)
        for (int i = 0; i < p.width; i++) {
            float u[3] = {(float)((2.0 * (i + 0.5) / p.width - 1) * t),
                          (float)((1 - 2.0 * (j + 0.5) / p.height) * t * asp), -1.0f},
                  rgb[3];
            unit3(u);
            pl_lights_radiance(&L, u, rgb);
            for (int c = 0; c < 3; c++)
                mean[c] += rgb[c];
        }
    for (int c = 0; c < 3; c++) {
        mean[c] /= (double)p.width * p.height;
        double rest = pow(grey[c] / 255.0, p.gamma);
        CHECK(fabs(mean[c] - A.ambient[c]) < 1e-4 * A.ambient[c],
              "(b) mean radiance[%d] %g, crop mean %g", c, mean[c], (double)A.ambient[c]);
        CHECK(fabs(L.ambient[c] - rest) < 1e-6, "(b) ambient[%d] %g, want %g", c,
              (double)L.ambient[c], rest);
    }
    in = pl_crop_project(&p, L.lights[0].dir, &x, &y);
    CHECK(in && x > 20 && x < 40 && y > 40 && y < 60, "(b) light at %g %g, want in the cell", x, y);
    p.width = 100;
    CHECK(pl_eval_baseline_brightest(&img, &p, &L) == PL_E_ARG, "size mismatch accepted");
    pl_image_u8_free(&img);
}

static void test_rotation(void)
{
    pl_lighting L;
    memset(&L, 0, sizeof L);
    L.n_lights = 2;
    const float d0[3] = {0.3f, 0.6f, -0.7f}, d1[3] = {-0.8f, -0.1f, 0.5f};
    memcpy(L.lights[0].dir, d0, sizeof d0);
    memcpy(L.lights[1].dir, d1, sizeof d1);
    unit3(L.lights[0].dir);
    unit3(L.lights[1].dir);
    L.lights[0].solid_angle_sr = 0.4f, L.lights[1].solid_angle_sr = 0.8f;
    L.lights[0].distance_m = L.lights[1].distance_m = 2;
    const float c0[3] = {20, 15, 10}, c1[3] = {2, 4, 6};
    memcpy(L.lights[0].rgb, c0, sizeof c0);
    memcpy(L.lights[1].rgb, c1, sizeof c1);
    L.ambient[0] = 0.1f, L.ambient[1] = 0.2f, L.ambient[2] = 0.3f;

    pl_crop_params p;
    pl_crop_default_params(&p);
    pl_image_f32 world = {0, 0, NULL}, cam = {0, 0, NULL}, want = {0, 0, NULL},
                 want_small = {0, 0, NULL};
    pl_lighting Lc;
    /* yaw 45 = 64 columns of 512: the rotated map is the map of the rotated lights */
    p.yaw_deg = 45;
    pl_crop_lighting(&L, &p, 2.0, &Lc);
    if (pl_envmap_from_lights(&L, 512, &world) < 0 || pl_envmap_from_lights(&Lc, 512, &want) < 0 ||
        pl_envmap_downsample(&want, 256, &want_small) < 0 ||
        pl_eval_envmap_to_camera(&world, &p, 2.0, 256, &cam) < 0) {
        CHECK(0, "maps: %s", pl_last_error());
        goto done;
    }
    double worst = 0;
    for (size_t i = 0; i < (size_t)256 * 128 * 3; i++)
        worst = fmax(worst, fabs(cam.data[i] - want_small.data[i]) / (want_small.data[i] + 1e-3));
    CHECK(worst < 1e-4, "yaw 45: rotated map vs map of rotated lights, worst relative %g", worst);
    pl_image_f32_free(&cam);

    /* any rotation: the truth render agrees with the analytic render of the rotated lights */
    p.yaw_deg = 17, p.pitch_deg = 23;
    pl_image_f32 a = {0, 0, NULL}, b = {0, 0, NULL};
    pl_crop_lighting(&L, &p, 0.5, &Lc);
    if (pl_eval_truth_render(&world, &p, 0.5, 32, &a) == 0 &&
        pl_render_sphere_lights(&Lc, PL_MATERIAL_DIFFUSE, 32, &b) == 0) {
        double rmse = pl_render_rmse(&a, &b), zero = 0;
        pl_lighting none;
        memset(&none, 0, sizeof none);
        pl_image_f32 z = {0, 0, NULL};
        if (pl_render_sphere_lights(&none, PL_MATERIAL_DIFFUSE, 32, &z) == 0)
            zero = pl_render_rmse(&z, &b);
        pl_image_f32_free(&z);
        CHECK(rmse < 0.002 * zero, "yaw 17 pitch 23: truth render vs rotated lights rmse %g (%g)",
              rmse, zero);
    } else
        CHECK(0, "renders: %s", pl_last_error());
    pl_image_f32_free(&a);
    pl_image_f32_free(&b);
    CHECK(pl_eval_envmap_to_camera(&world, &p, 1.0, 255, &cam) == PL_E_ARG, "odd width accepted");
    CHECK(pl_eval_envmap_to_camera(&world, &p, NAN, 256, &cam) == PL_E_ARG, "NaN scale accepted");
done:
    pl_image_f32_free(&world);
    pl_image_f32_free(&want);
    pl_image_f32_free(&want_small);
    pl_image_f32_free(&cam);
}

/* A panorama of one strong light over a dim ambient; a crop toward it (yaw 20, pitch 0). */
static void test_crop(void)
{
    pl_lighting L;
    memset(&L, 0, sizeof L);
    L.n_lights = 1;
    const float d[3] = {0.35f, 0.5f, -0.8f};
    memcpy(L.lights[0].dir, d, sizeof d);
    unit3(L.lights[0].dir);
    L.lights[0].solid_angle_sr = 0.05f;
    L.lights[0].distance_m = 2;
    L.lights[0].rgb[0] = 400, L.lights[0].rgb[1] = 380, L.lights[0].rgb[2] = 300;
    L.ambient[0] = 0.3f, L.ambient[1] = 0.3f, L.ambient[2] = 0.35f;
    pl_image_f32 pano = {0, 0, NULL};
    pl_image_u8 ldr = {0, 0, 0, NULL};
    if (pl_envmap_from_lights(&L, 1024, &pano) < 0) {
        CHECK(0, "pano: %s", pl_last_error());
        return;
    }
    pl_extract_params ep;
    pl_extract_default_params(&ep);
    pl_lighting gtp;
    CHECK(pl_extract_lights(&pano, &ep, &gtp, NULL) == 0 && gtp.n_lights >= 1, "extract: %s",
          pl_last_error());
    pl_crop_params p;
    pl_crop_default_params(&p);
    p.yaw_deg = 20, p.width = 320, p.height = 240;
    double k = 0;
    if (pl_eval_make_crop(&pano, &p, &ldr, &k) < 0) {
        CHECK(0, "crop: %s", pl_last_error());
        goto done;
    }
    CHECK(k > 0 && ldr.width == 320 && ldr.height == 240, "crop k %g size %dx%d", k, ldr.width,
          ldr.height);
    pl_lighting gt, pred;
    pl_crop_lighting(&gtp, &p, k, &pred); /* an estimate equal to the ground truth */
    pl_eval_scores s[PL_EVAL_N_METHODS];
    pl_image_f32 truth = {0, 0, NULL};
    if (pl_eval_crop(&pano, &gtp, &p, &ldr, k, &pred, NULL, 32, s, &gt, NULL, &truth) < 0) {
        CHECK(0, "eval crop: %s", pl_last_error());
        goto done;
    }
    /* the truth render handed back scores the estimate as eval did */
    pl_eval_scores again;
    CHECK(truth.width == 32 && pl_eval_score(&pred, &truth, &gt, &again) == 0 &&
              again.rmse == s[PL_EVAL_MODEL].rmse && again.si_rmse == s[PL_EVAL_MODEL].si_rmse,
          "truth_out: %dx%d, rmse %g against %g", truth.width, truth.height, again.rmse,
          s[PL_EVAL_MODEL].rmse);
    pl_image_f32_free(&truth);
    for (int m = 0; m < PL_EVAL_N_METHODS; m++)
        printf("%-24s rmse %.5f si_rmse %.5f angle %.2f scale EV %+.3f\n",
               pl_eval_method_label(m), s[m].rmse, s[m].si_rmse, s[m].angle_deg, s[m].scale_ev);
    const pl_eval_scores *a = &s[PL_EVAL_AMBIENT], *c = &s[PL_EVAL_GT_LIGHTS];
    CHECK(c->rmse < 0.2 * a->rmse && c->si_rmse < 0.2 * a->si_rmse,
          "(c) rmse %g si %g does not beat (a) rmse %g si %g", c->rmse, c->si_rmse, a->rmse,
          a->si_rmse);
    CHECK(c->angle_deg < 1e-3, "(c) angle %g", c->angle_deg);
    CHECK(s[PL_EVAL_MODEL].rmse == c->rmse && s[PL_EVAL_MODEL].si_rmse == c->si_rmse,
          "model = ground truth scored %g, (c) %g", s[PL_EVAL_MODEL].rmse, c->rmse);
    /* the light is up and to the right in this crop: (b) points within 20 degrees of it, and the
     * ambient-only baseline gets the WebXR default (straight up) */
    float up[3] = {0, 1, 0};
    CHECK(s[PL_EVAL_BRIGHTEST].angle_deg < 20, "(b) angle %g", s[PL_EVAL_BRIGHTEST].angle_deg);
    CHECK(fabs(a->angle_deg - pl_eval_angle_deg(up, gt.lights[0].dir)) < 1e-9, "(a) angle %g",
          a->angle_deg);
    /* the truth is on the crop's scale: twice k, twice the render */
    pl_image_f32 t1 = {0, 0, NULL}, t2 = {0, 0, NULL};
    if (pl_eval_truth_render(&pano, &p, k, 16, &t1) == 0 &&
        pl_eval_truth_render(&pano, &p, 2 * k, 16, &t2) == 0) {
        double worst = 0;
        for (size_t i = 0; i < (size_t)16 * 16 * 3; i++)
            worst = fmax(worst, fabs(2 * t1.data[i] - t2.data[i]));
        CHECK(worst < 1e-5, "truth render not linear in k: %g", worst);
        /* scale EV: an estimate at four times the truth's intensity must be dimmed by 2 stops;
         * its shape error (si-RMSE) does not change */
        pl_lighting bright = pred;
        for (int i = 0; i < bright.n_lights; i++)
            for (int ch = 0; ch < 3; ch++) bright.lights[i].rgb[ch] *= 4;
        for (int ch = 0; ch < 3; ch++) bright.ambient[ch] *= 4;
        pl_eval_scores s1, s4;
        if (pl_eval_score(&pred, &t1, &gt, &s1) == 0 && pl_eval_score(&bright, &t1, &gt, &s4) == 0) {
            CHECK(fabs(s1.scale_ev) < 0.05, "estimate = ground truth: scale EV %g", s1.scale_ev);
            CHECK(fabs(s4.scale_ev - (s1.scale_ev - 2)) < 1e-4, "4x brighter: scale EV %g, %g",
                  s4.scale_ev, s1.scale_ev);
            CHECK(fabs(s4.si_rmse - s1.si_rmse) < 1e-4 * (1 + s1.si_rmse), "si-RMSE %g vs %g",
                  s4.si_rmse, s1.si_rmse);
        } else {
            CHECK(0, "score: %s", pl_last_error());
        }
        /* a lighting that renders black has no scale */
        pl_lighting dark = {0};
        CHECK(pl_eval_score(&dark, &t1, &gt, &s1) == 0 && isnan(s1.scale_ev),
              "black lighting: scale EV %g", s1.scale_ev);
    }
    pl_image_f32_free(&t1);
    pl_image_f32_free(&t2);
done:
    pl_image_u8_free(&ldr);
    pl_image_f32_free(&pano);
}

int main(void)
{
    test_quartiles();
    test_angle();
    test_baselines();
    test_rotation();
    test_crop();
    if (failures) {
        printf("%d failure%s\n", failures, failures == 1 ? "" : "s");
        return 1;
    }
    printf("all eval checks passed\n");
    return 0;
}
