/* golden_check MODEL.plm FRAME.png REF.f32 — compares the C float path with PyTorch.
 *
 * Loads MODEL with the public API, reads FRAME (which must already be the model's input size, so
 * the resize is the identity), runs pl_estimate_rgb8, and compares z (pl_model_last_latent) and
 * every output head with REF, written by tools/golden.py from the unfolded PyTorch model in
 * float64: little-endian float32 z[3072], dir[3N], distance[N], size[N], rgb[3N], ambient[3].
 *
 * Errors, and what passes (tolerance TOL = 1e-4):
 *   z:        relative L2 error ||c - r|| / ||r|| <= TOL.
 *   dir:      per light, the vector error ||c_i - r_i|| / ||r_i|| <= TOL (unit vectors: about
 *             the angle between them, in radians). Components are not judged one by one: a
 *             small component of a unit vector carries no more precision than the others.
 *   distance, size, rgb, ambient: for every element
 *             |c - r| / max(|r|, 1e-3 * max_j |r_j|) <= TOL, where max_j runs over that head's
 *             elements: relative per element, with a floor at 1e-3 of the head's largest value
 *             so that a value near zero is judged against the head's scale, not against itself.
 * The worst light or element of each head is printed with its values.
 * Exit 0 on pass, 1 on failure (or any error), 2 on bad usage. */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "parlight.h"
#include "port/image.h"

#define TOL 1e-4
#define FLOOR 1e-3

enum { H_DIR, H_DISTANCE, H_SIZE, H_RGB, H_AMBIENT, N_HEADS };
static const char *const head_names[N_HEADS] = {"dir", "distance", "size", "rgb", "ambient"};

/* Reads a whole file of little-endian float32 values; *out is malloc'ed. */
static int read_f32_file(const char *path, float **out, size_t *count)
{
    FILE *f = fopen(path, "rb");
    if (!f) {
        fprintf(stderr, "golden_check: cannot open %s\n", path);
        return -1;
    }
    unsigned char *bytes = NULL;
    size_t cap = 0, len = 0;
    for (;;) {
        if (len == cap) {
            size_t ncap = cap ? 2 * cap : 65536;
            if (ncap > ((size_t)1 << 28)) {
                fprintf(stderr, "golden_check: %s: larger than 256 MiB\n", path);
                goto fail;
            }
            unsigned char *nb = realloc(bytes, ncap);
            if (!nb) goto fail;
            bytes = nb;
            cap = ncap;
        }
        size_t got = fread(bytes + len, 1, cap - len, f);
        len += got;
        if (got == 0) break;
    }
    if (ferror(f) || len % 4 != 0) {
        fprintf(stderr, "golden_check: %s: read error or size %zu not a multiple of 4\n", path, len);
        goto fail;
    }
    fclose(f);
    f = NULL;
    float *v = malloc(len ? len : 1);
    if (!v) goto fail;
    for (size_t i = 0; i < len / 4; i++) {
        uint32_t u = (uint32_t)bytes[4 * i] | (uint32_t)bytes[4 * i + 1] << 8 |
                     (uint32_t)bytes[4 * i + 2] << 16 | (uint32_t)bytes[4 * i + 3] << 24;
        memcpy(&v[i], &u, 4);
    }
    free(bytes);
    *out = v;
    *count = len / 4;
    return 0;
fail:
    if (f) fclose(f);
    free(bytes);
    return -1;
}

/* Worst per-light vector error of the directions (3 floats per light); *worst_i: the light. */
static double dir_error(const float *c, const float *r, int n_lights, int *worst_i)
{
    double worst = 0;
    *worst_i = 0;
    for (int i = 0; i < n_lights; i++) {
        double num = 0, den = 0;
        for (int k = 0; k < 3; k++) {
            double d = (double)c[3 * i + k] - (double)r[3 * i + k];
            num += d * d;
            den += (double)r[3 * i + k] * (double)r[3 * i + k];
        }
        double e = sqrt(num) / (den > 0 ? sqrt(den) : 1.0);
        if (!(e <= worst)) { /* also catches NaN */
            worst = e;
            *worst_i = i;
        }
    }
    return worst;
}

/* Worst per-element error of a head, as defined at the top; *worst_i gets its index. */
static double head_error(const float *c, const float *r, int n, int *worst_i)
{
    double rmax = 0;
    for (int i = 0; i < n; i++) rmax = fmax(rmax, fabs((double)r[i]));
    double worst = 0;
    *worst_i = 0;
    for (int i = 0; i < n; i++) {
        double den = fmax(fabs((double)r[i]), FLOOR * rmax);
        double e = fabs((double)c[i] - (double)r[i]) / (den > 0 ? den : 1.0);
        if (!(e <= worst)) { /* also catches NaN */
            worst = e;
            *worst_i = i;
        }
    }
    return worst;
}

int main(int argc, char **argv)
{
    if (argc != 4) {
        fprintf(stderr, "usage: golden_check MODEL.plm FRAME.png REF.f32\n");
        return 2;
    }
    const char *model_path = argv[1], *frame_path = argv[2], *ref_path = argv[3];
    int rc = 1;
    pl_model *m = NULL;
    pl_image_u8 img = {0};
    float *ref = NULL, *got = NULL;

    if (pl_model_load(model_path, &m) < 0) {
        fprintf(stderr, "golden_check: %s\n", pl_last_error());
        goto out;
    }
    pl_model_info info;
    if (pl_model_get_info(m, &info) < 0) {
        fprintf(stderr, "golden_check: %s\n", pl_last_error());
        goto out;
    }
    if (pl_image_read_rgb8(frame_path, &img) < 0) {
        fprintf(stderr, "golden_check: %s\n", pl_last_error());
        goto out;
    }
    if (img.width != info.input_w || img.height != info.input_h) {
        fprintf(stderr, "golden_check: %s is %dx%d, the model input is %dx%d (golden frames are "
                "never resized)\n", frame_path, img.width, img.height, info.input_w, info.input_h);
        goto out;
    }
    pl_lighting L;
    pl_timing t;
    if (pl_estimate_rgb8(m, img.data, img.width, img.height, img.stride, &L, &t) < 0) {
        fprintf(stderr, "golden_check: estimate: %s\n", pl_last_error());
        goto out;
    }
    const float *z;
    int nz;
    if (pl_model_last_latent(m, &z, &nz) < 0) {
        fprintf(stderr, "golden_check: latent: %s\n", pl_last_error());
        goto out;
    }
    const int n = info.n_lights;
    if (L.n_lights != n || n < 1 || n > PL_MAX_LIGHTS) {
        fprintf(stderr, "golden_check: estimate gave %d lights, the model has %d\n", L.n_lights, n);
        goto out;
    }
    const int counts[N_HEADS] = {3 * n, n, n, 3 * n, 3};
    size_t want = (size_t)nz + 8u * (size_t)n + 3u, nref;
    if (read_f32_file(ref_path, &ref, &nref) < 0) goto out;
    if (nref != want) {
        fprintf(stderr, "golden_check: %s has %zu floats, expected %zu (z %d + 8N + 3, N = %d): "
                "made for another model?\n", ref_path, nref, want, nz, n);
        goto out;
    }

    /* The C outputs in the reference's layout. */
    got = malloc(want * sizeof *got);
    if (!got) goto out;
    memcpy(got, z, (size_t)nz * sizeof *got);
    float *p = got + nz;
    for (int i = 0; i < n; i++) memcpy(p + 3 * i, L.lights[i].dir, 3 * sizeof *p);
    p += 3 * n;
    for (int i = 0; i < n; i++) p[i] = L.lights[i].distance_m;
    p += n;
    for (int i = 0; i < n; i++) p[i] = L.lights[i].solid_angle_sr;
    p += n;
    for (int i = 0; i < n; i++) memcpy(p + 3 * i, L.lights[i].rgb, 3 * sizeof *p);
    p += 3 * n;
    memcpy(p, L.ambient, 3 * sizeof *p);

    double num = 0, den = 0, zmax = 0;
    for (int i = 0; i < nz; i++) {
        double d = (double)got[i] - (double)ref[i];
        num += d * d;
        den += (double)ref[i] * (double)ref[i];
        zmax = fmax(zmax, fabs(d));
    }
    double zerr = den > 0 ? sqrt(num / den) : sqrt(num);
    int ok = zerr <= TOL;
    printf("golden_check %s on %s (N=%d, infer %.0f ms)\n", frame_path, model_path, n, t.infer_ms);
    printf("  %-9s %-11s %s\n", "output", "error", "measure");
    printf("  %-9s %-11.3e relative L2 (max abs %.2e)  %s\n", "z", zerr, zmax,
           zerr <= TOL ? "ok" : "FAIL");
    const float *gc = got + nz, *rc_ = ref + nz;
    for (int h = 0; h < N_HEADS; h++) {
        int wi;
        if (h == H_DIR) {
            double e = dir_error(gc, rc_, n, &wi);
            int pass = e <= TOL;
            ok &= pass;
            const float *a = gc + 3 * wi, *b = rc_ + 3 * wi;
            printf("  %-9s %-11.3e max ||c-r||/||r|| per light, light %d: c (%.7g %.7g %.7g) "
                   "r (%.7g %.7g %.7g)  %s\n", head_names[h], e, wi, (double)a[0], (double)a[1],
                   (double)a[2], (double)b[0], (double)b[1], (double)b[2], pass ? "ok" : "FAIL");
        } else {
            double e = head_error(gc, rc_, counts[h], &wi);
            int pass = e <= TOL;
            ok &= pass;
            printf("  %-9s %-11.3e max |c-r|/max(|r|,1e-3*max|r|) at [%d]: c %.7g r %.7g  %s\n",
                   head_names[h], e, wi, (double)gc[wi], (double)rc_[wi], pass ? "ok" : "FAIL");
        }
        gc += counts[h];
        rc_ += counts[h];
    }
    printf("  %s (tolerance %.0e)\n", ok ? "PASS" : "FAIL", TOL);
    rc = ok ? 0 : 1;
out:
    free(got);
    free(ref);
    pl_image_u8_free(&img);
    pl_model_free(m);
    return rc;
}
