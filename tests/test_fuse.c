/* light/fuse.c: the key light over views. One lobe gives its own direction, turned by the
 * camera's rotation; a light seen from three headings wins over a brighter lobe that stays put
 * in every camera frame (what one frame cannot tell apart); a camera that dwells on one heading
 * counts once; views expire by age; a view's exposure does not matter; a light smaller than the
 * search grid's spacing is still found; bad arguments are refused and leave the state alone.
 * The public handle (pl_key_fuser_*, include/parlight.h) gives the internal fuser's answer bit
 * for bit, and pl_frame_format_json_key writes it as the CLI does. pl_lighting_aim_primary turns
 * a frame's primary light, and nothing else, to the key light. pl_key_fuser_level brings a frame to
 * the mean level (log2 energy over exposure) of the kept exposed views, and only those. */
#include <string.h>

#include "core/json.h"
#include "core/status.h"
#include "light/fuse.h"
#include "light/light.h"
#include "light_test.h"

static pl_light lobe(double x, double y, double z, float sr, float lum)
{
    pl_light l;
    float d[3] = {(float)x, (float)y, (float)z};
    unit3(d);
    memcpy(l.dir, d, sizeof d);
    l.distance_m = 3.0f;
    l.solid_angle_sr = sr;
    l.rgb[0] = l.rgb[1] = l.rgb[2] = lum;
    return l;
}

/* Camera-to-world rotation of a camera turned by `heading` radians about world y (heading 0
 * looks along -z, pi/2 along +x: the fuser's heading convention). */
static void heading_R(double heading, double R[9])
{
    double c = cos(heading), s = sin(heading);
    double M[9] = {c, 0, -s, 0, 1, 0, s, 0, c};
    memcpy(R, M, sizeof M);
}

/* World direction w into the camera frame of R (R^T w). */
static void to_cam(const double R[9], const double w[3], double out[3])
{
    for (int k = 0; k < 3; k++)
        out[k] = R[k] * w[0] + R[3 + k] * w[1] + R[6 + k] * w[2];
}

/* The angle between a and b in degrees (atan2 of |a x b| and a . b: exact near 0 too). */
static double deg_between(const float a[3], const double b[3])
{
    double c0 = a[1] * b[2] - a[2] * b[1], c1 = a[2] * b[0] - a[0] * b[2],
           c2 = a[0] * b[1] - a[1] * b[0];
    return atan2(sqrt(c0 * c0 + c1 * c1 + c2 * c2), a[0] * b[0] + a[1] * b[1] + a[2] * b[2]) * 180 /
           M_PI;
}

static void test_one_lobe(void)
{
    pl_fuser f;
    pl_lighting L = {0};
    double I[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1}, R[9], w[3];
    float key[3];
    int views;
    CHECK(pl_fuser_init(&f, 0) == 0, "init");
    CHECK(pl_fuser_key(&f, 0, key, &views) == PL_E_ARG && views == 0 && key[1] == 1,
          "an empty fuser has no key light");
    L.n_lights = 1;
    L.lights[0] = lobe(0.3, 0.5, -0.8, 2.5f, 1.0f);
    CHECK(pl_fuser_add(&f, &L, I, 0) == 0, "add");
    CHECK(pl_fuser_key(&f, 0, key, &views) == 0 && views == 1, "key of one view");
    double d0[3] = {L.lights[0].dir[0], L.lights[0].dir[1], L.lights[0].dir[2]};
    CHECK(deg_between(key, d0) < 0.01, "one lobe: key %.4f deg off its direction",
          deg_between(key, d0));
    /* the same frame from a camera turned 90 degrees: the key turns with it */
    pl_fuser_reset(&f);
    heading_R(M_PI / 2, R);
    CHECK(pl_fuser_add(&f, &L, R, 0) == 0, "add turned");
    CHECK(pl_fuser_key(&f, 0, key, NULL) == 0, "key turned");
    for (int k = 0; k < 3; k++)
        w[k] = R[3 * k] * d0[0] + R[3 * k + 1] * d0[1] + R[3 * k + 2] * d0[2];
    CHECK(deg_between(key, w) < 0.01, "turned: key %.4f deg off R d", deg_between(key, w));
}

/* Three headings 120 degrees apart. Each frame has the room's light (world direction
 * TRI_LIGHT, energy 0.45) and a brighter lobe fixed in the camera frame (0.55, up and to the
 * right): every frame's brightest light is the fixed one, which points somewhere else in each
 * view. tri_view fills view v's lighting and camera-to-world rotation. */
static const double TRI_LIGHT[3] = {0.8, 0.3, 0.2};

static void tri_view(int v, pl_lighting *L, double R[9])
{
    double c[3];
    heading_R(v * 2 * M_PI / 3, R);
    to_cam(R, TRI_LIGHT, c);
    memset(L, 0, sizeof *L);
    L->n_lights = 2;
    L->lights[0] = lobe(0.6, 0.4, -0.7, 2.5f, 0.55f);
    L->lights[1] = lobe(c[0], c[1], c[2], 2.5f, 0.45f);
    L->ambient[0] = L->ambient[1] = L->ambient[2] = 0.3f;
}

static void test_triangulation(void)
{
    pl_fuser f;
    double R[9];
    float key[3];
    int views;
    pl_fuser_init(&f, 0);
    for (int v = 0; v < 3; v++) {
        pl_lighting L;
        tri_view(v, &L, R);
        CHECK(pl_light_energy(&L.lights[0]) > pl_light_energy(&L.lights[1]), "fixed lobe brighter");
        CHECK(pl_fuser_add(&f, &L, R, 0) == 0, "add view %d", v);
    }
    CHECK(pl_fuser_key(&f, 0, key, &views) == 0 && views == 3, "key of 3 views (%d)", views);
    CHECK(deg_between(key, TRI_LIGHT) < 3, "three views: key %.2f deg from the room's light",
          deg_between(key, TRI_LIGHT));
}

/* One heading seen 50 times against two others once each: the heading counts once. */
static void test_dwelling(void)
{
    pl_fuser f;
    double R[9], c[3], a[3] = {0, 0.2, -1}, b[3] = {1, 0.2, 0.3};
    float key[3];
    int views;
    pl_fuser_init(&f, 0);
    for (int i = 0; i < 50; i++) {
        pl_lighting L = {0};
        heading_R(0.01 * (i % 3), R); /* small jitter, same bin */
        to_cam(R, a, c);
        L.n_lights = 1;
        L.lights[0] = lobe(c[0], c[1], c[2], 1.0f, 1.0f);
        pl_fuser_add(&f, &L, R, i);
    }
    for (int v = 1; v <= 2; v++) {
        pl_lighting L = {0};
        heading_R(v * M_PI / 2, R);
        to_cam(R, b, c);
        L.n_lights = 1;
        L.lights[0] = lobe(c[0], c[1], c[2], 1.0f, 1.0f);
        pl_fuser_add(&f, &L, R, 50 + v);
    }
    CHECK(pl_fuser_key(&f, 60, key, &views) == 0 && views == 3, "3 bins, not 52 (%d)", views);
    CHECK(deg_between(key, b) < 1, "two headings outvote one seen 50 times (%.2f deg)",
          deg_between(key, b));
    /* the same two views much brighter (another exposure) change nothing */
    pl_lighting L = {0};
    heading_R(M_PI / 2, R);
    to_cam(R, b, c);
    L.n_lights = 1;
    L.lights[0] = lobe(c[0], c[1], c[2], 1.0f, 1000.0f);
    pl_fuser_add(&f, &L, R, 55);
    float key2[3];
    pl_fuser_key(&f, 60, key2, NULL);
    CHECK(deg_between(key2, (double[3]){key[0], key[1], key[2]}) < 1e-4,
          "a view's exposure does not move the key (%.6f deg)",
          deg_between(key2, (double[3]){key[0], key[1], key[2]}));
}

static void test_age(void)
{
    pl_fuser f;
    double R[9], c[3], a[3] = {0, 0.5, -1}, b[3] = {-1, 0.1, 0};
    float key[3];
    int views;
    CHECK(pl_fuser_init(&f, 10) == 0, "init 10 s");
    for (int v = 0; v < 2; v++) { /* the old room: two views at t = 0 */
        pl_lighting L = {0};
        heading_R(v * M_PI / 2, R);
        to_cam(R, a, c);
        L.n_lights = 1;
        L.lights[0] = lobe(c[0], c[1], c[2], 1.0f, 1.0f);
        pl_fuser_add(&f, &L, R, 0);
    }
    CHECK(pl_fuser_key(&f, 9, key, &views) == 0 && views == 2 && deg_between(key, a) < 1,
          "at t 9 the old views count (%d)", views);
    pl_lighting L = {0};
    heading_R(M_PI, R);
    to_cam(R, b, c);
    L.n_lights = 1;
    L.lights[0] = lobe(c[0], c[1], c[2], 1.0f, 1.0f);
    pl_fuser_add(&f, &L, R, 20);
    CHECK(pl_fuser_key(&f, 20, key, &views) == 0 && views == 1 && deg_between(key, b) < 0.01,
          "at t 20 they have expired (%d views, %.2f deg)", views, deg_between(key, b));
    CHECK(pl_fuser_key(&f, 31, key, &views) == PL_E_ARG && views == 0, "at t 31 nothing is left");
}

static void test_small_light(void)
{
    pl_fuser f;
    pl_lighting L = {0};
    double I[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
    float key[3];
    pl_fuser_init(&f, 0);
    L.n_lights = 2;
    L.lights[0] = lobe(0.123, 0.456, -0.789, 1e-4f, 5000.0f); /* ~0.6 degrees wide */
    L.lights[1] = lobe(-1, 0, 0, 2.0f, 0.01f);
    pl_fuser_add(&f, &L, I, 0);
    double d[3] = {L.lights[0].dir[0], L.lights[0].dir[1], L.lights[0].dir[2]};
    CHECK(pl_fuser_key(&f, 0, key, NULL) == 0 && deg_between(key, d) < 0.01,
          "a light narrower than the grid: %.3f deg off", deg_between(key, d));
}

static void test_bad_args(void)
{
    pl_fuser f;
    pl_lighting L = {0};
    double I[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1}, S[9] = {2, 0, 0, 0, 1, 0, 0, 0, 1};
    float key[3];
    int views;
    CHECK(pl_fuser_init(&f, -1) == PL_E_ARG && pl_fuser_init(&f, NAN) == PL_E_ARG &&
              pl_fuser_init(&f, INFINITY) == PL_E_ARG,
          "a max age < 0 or not finite is refused");
    pl_fuser_init(&f, 0);
    L.n_lights = 1;
    L.lights[0] = lobe(0, 1, 0, 1.0f, 1.0f);
    CHECK(pl_fuser_add(&f, &L, S, 0) == PL_E_ARG && strstr(pl_last_error(), "not a rotation"),
          "a scaled matrix is refused: %s", pl_last_error());
    CHECK(pl_fuser_add(&f, &L, I, NAN) == PL_E_ARG, "a time that is not finite is refused");
    L.lights[0].rgb[1] = -1;
    CHECK(pl_fuser_add(&f, &L, I, 0) == PL_E_ARG, "a bad lighting is refused");
    CHECK(pl_fuser_key(&f, 0, key, &views) == PL_E_ARG && views == 0, "nothing was added");
    pl_lighting dark = {0};
    dark.n_lights = 1;
    dark.lights[0] = lobe(0, 1, 0, 1.0f, 0.0f);
    CHECK(pl_fuser_add(&f, &dark, I, 0) == 0 && pl_fuser_key(&f, 0, key, &views) == PL_E_ARG,
          "a view without light energy holds no key light");
}

/* The public face: the views of test_triangulation through pl_key_fuser_*, equal to the
 * internal fuser's key bit for bit; an empty fuser answers views 0 without an error; refusals. */
static void test_public_api(void)
{
    pl_key_fuser *k = (pl_key_fuser *)1;
    CHECK(pl_key_fuser_new(-1, &k) == PL_E_ARG && k == NULL, "a negative max age is refused");
    CHECK(pl_key_fuser_new(NAN, &k) == PL_E_ARG && k == NULL, "a NaN max age is refused");
    CHECK(pl_key_fuser_new(0, NULL) == PL_E_ARG, "NULL out is refused");
    CHECK(pl_key_fuser_new(0, &k) == 0 && k, "new: %s", pl_last_error());
    pl_key_light key = {{9, 9, 9}, 9};
    pl_error(PL_E_ARG, "sentinel");
    CHECK(pl_key_fuser_get(k, 0, &key) == 0 && key.views == 0 && key.dir[1] == 1 &&
              key.dir[0] == 0 && key.dir[2] == 0 && !strcmp(pl_last_error(), "sentinel"),
          "empty: views 0, dir (0, 1, 0), no error set");
    CHECK(pl_key_fuser_get(k, NAN, &key) == PL_E_ARG, "a NaN time is refused");
    CHECK(pl_key_fuser_get(NULL, 0, &key) == PL_E_ARG && pl_key_fuser_get(k, 0, NULL) == PL_E_ARG,
          "NULL arguments are refused");

    pl_fuser f;
    pl_fuser_init(&f, 0);
    double R[9];
    for (int v = 0; v < 3; v++) {
        pl_lighting L;
        tri_view(v, &L, R);
        pl_fuser_add(&f, &L, R, v);
        CHECK(pl_key_fuser_add(k, &L, R, v) == 0, "public add %d", v);
    }
    float ref[3];
    int ref_views;
    pl_fuser_key(&f, 3, ref, &ref_views);
    CHECK(pl_key_fuser_get(k, 3, &key) == 0 && key.views == 3 && ref_views == 3 &&
              !memcmp(key.dir, ref, sizeof ref),
          "the public key is the internal one, bit for bit");
    CHECK(deg_between(key.dir, TRI_LIGHT) < 3, "and it is the room's light (%.2f deg)",
          deg_between(key.dir, TRI_LIGHT));

    pl_lighting bad = {0};
    bad.n_lights = 1;
    bad.lights[0] = lobe(0, 1, 0, 1.0f, 1.0f);
    bad.lights[0].distance_m = NAN;
    double I[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
    CHECK(pl_key_fuser_add(k, &bad, I, 4) == PL_E_ARG, "a bad lighting is refused");
    CHECK(pl_key_fuser_add(NULL, &bad, I, 4) == PL_E_ARG, "a NULL fuser is refused");
    pl_key_light again;
    pl_key_fuser_get(k, 3, &again);
    CHECK(again.views == 3 && !memcmp(again.dir, key.dir, sizeof key.dir),
          "a refused frame leaves the fuser as it was");

    /* the JSON line with the key light: the plain line with one member more, last */
    pl_lighting L = {0};
    L.n_lights = 1;
    L.lights[0] = lobe(0, 1, 0, 1.0f, 1.0f);
    pl_frame_meta m = {3, 42, "dir:x", NULL, {1, 2}, 3, -1, 0};
    char plain[16384], line[16384];
    int n0 = pl_frame_format_json(&m, &L, plain, sizeof plain);
    int n = pl_frame_format_json_key(&m, &L, &key, line, sizeof line);
    CHECK(n0 > 2 && n > n0 && !strncmp(plain, line, (size_t)n0 - 2) && line[n - 1] == '\n' &&
              (size_t)n == strlen(line),
          "the key line extends the plain one (%d, %d)", n0, n);
    pl_json_doc doc;
    CHECK(pl_json_parse(line, (size_t)n, "line", &doc) == 0, "it parses: %s", pl_last_error());
    const pl_json_value *kl = pl_json_get(&doc.root, "key_light");
    const pl_json_value *dir = kl ? pl_json_get(kl, "dir") : NULL;
    const pl_json_value *views = kl ? pl_json_get(kl, "views") : NULL;
    CHECK(dir && dir->type == PL_JSON_ARRAY && dir->len == 3 && views && views->number == 3,
          "key_light {dir[3], views 3}");
    for (int i = 0; dir && i < 3; i++)
        CHECK(fabs(dir->items[i].number - key.dir[i]) < 1e-5, "key_light.dir[%d]", i);
    pl_json_free(&doc);
    pl_key_light none = {{0, 1, 0}, 0};
    n = pl_frame_format_json_key(&m, &L, &none, line, sizeof line);
    CHECK(n > 0 && strstr(line, ",\"key_light\":null}\n"), "views 0: \"key_light\":null");
    int need = pl_frame_format_json_key(&m, &L, &key, line, sizeof line);
    CHECK(pl_frame_format_json_key(&m, &L, &key, line, (size_t)need) == PL_E_ARG,
          "a buffer one byte short is refused");
    CHECK(pl_frame_format_json_key(&m, &L, &key, line, (size_t)need + 1) == need, "exact fit");
    pl_key_light nan_key = {{NAN, 0, 0}, 1}, neg = {{0, 1, 0}, -1};
    CHECK(pl_frame_format_json_key(&m, &L, &nan_key, line, sizeof line) == PL_E_ARG &&
              pl_frame_format_json_key(&m, &L, &neg, line, sizeof line) == PL_E_ARG &&
              pl_frame_format_json_key(&m, &L, NULL, line, sizeof line) == PL_E_ARG,
          "a key light that is not finite, negative views or NULL are refused");

    pl_key_fuser_reset(k);
    CHECK(pl_key_fuser_get(k, 3, &key) == 0 && key.views == 0, "reset forgets every frame");
    pl_key_fuser_reset(NULL);
    pl_key_fuser_free(k);
    pl_key_fuser_free(NULL);
}

static void test_aim(void)
{
    pl_key_fuser *k = NULL;
    pl_key_light key;
    pl_lighting L, A, B;
    double R[9];
    CHECK(pl_key_fuser_new(0, &k) == 0, "new");
    for (int v = 0; v < 3; v++) {
        tri_view(v, &L, R);
        CHECK(pl_key_fuser_add(k, &L, R, v) == 0, "add %d", v);
    }
    CHECK(pl_key_fuser_get(k, 3, &key) == 0 && key.views == 3, "key of 3 views");
    /* the last view (v 2): its brighter lobe 0 stays put in the camera; the room's light is
     * lobe 1 */
    double kc[3], tc[3];
    to_cam(R, (double[3]){key.dir[0], key.dir[1], key.dir[2]}, kc);
    to_cam(R, TRI_LIGHT, tc);
    const float kcf[3] = {(float)(2 * kc[0]), (float)(2 * kc[1]), (float)(2 * kc[2])};
    CHECK(pl_lighting_aim_primary(&L, kcf, &A) == 0, "aimed: primary is light 0");
    CHECK(deg_between(A.lights[0].dir, tc) < 3, "aimed primary %.2f deg from the room's light",
          deg_between(A.lights[0].dir, tc));
    const float *ad = A.lights[0].dir;
    CHECK(fabs(sqrt(ad[0] * ad[0] + ad[1] * ad[1] + ad[2] * ad[2]) - 1) < 1e-6,
          "a dir of length 2 is normalised");
    CHECK(A.n_lights == L.n_lights && !memcmp(&A.lights[1], &L.lights[1], sizeof L.lights[1]) &&
              !memcmp(A.ambient, L.ambient, sizeof L.ambient) &&
              A.lights[0].distance_m == L.lights[0].distance_m &&
              A.lights[0].solid_angle_sr == L.lights[0].solid_angle_sr &&
              !memcmp(A.lights[0].rgb, L.lights[0].rgb, sizeof L.lights[0].rgb),
          "only the primary's direction changes");
    B = L;
    CHECK(pl_lighting_aim_primary(&B, kcf, &B) == 0 && !memcmp(&A, &B, sizeof A), "out may be L");

    pl_lighting none = L;
    none.n_lights = 0;
    CHECK(pl_lighting_aim_primary(&none, kcf, &B) == 0 && !memcmp(&B, &none, sizeof B),
          "no lights: out is L");
    B = A;
    CHECK(pl_lighting_aim_primary(&L, (float[3]){0, 0, 0}, &B) == PL_E_ARG &&
              strstr(pl_last_error(), "zero") && !memcmp(&B, &A, sizeof B),
          "a zero direction is refused, out untouched");
    CHECK(pl_lighting_aim_primary(&L, (float[3]){NAN, 0, 1}, &B) == PL_E_ARG &&
              strstr(pl_last_error(), "not finite") && !memcmp(&B, &A, sizeof B),
          "a NaN direction is refused, out untouched");
    CHECK(pl_lighting_aim_primary(NULL, kcf, &B) == PL_E_ARG &&
              pl_lighting_aim_primary(&L, NULL, &B) == PL_E_ARG &&
              pl_lighting_aim_primary(&L, kcf, NULL) == PL_E_ARG,
          "NULL arguments are refused");
    pl_key_fuser_free(k);
}

/* A view of the triangulation's room with its energy times 2^s and its exposure times 2^x. */
static void exposed_view(int v, double s, pl_lighting *L, double R[9])
{
    heading_R(v * M_PI / 2, R);
    memset(L, 0, sizeof *L);
    L->n_lights = 2;
    L->lights[0] = lobe(0.6, 0.4, -0.7, 2.5f, (float)(0.55 * exp2(s)));
    L->lights[1] = lobe(-0.2, 0.9, 0.1, 0.3f, (float)(4.0 * exp2(s)));
    L->ambient[0] = (float)(0.3 * exp2(s)), L->ambient[1] = (float)(0.25 * exp2(s));
    L->ambient[2] = (float)(0.2 * exp2(s));
}

static double total_energy(const pl_lighting *L)
{
    return 4 * M_PI * pl_lighting_mean_luminance(L);
}

static void test_level(void)
{
    pl_key_fuser *k = NULL;
    pl_lighting L, F, G;
    double R[9];
    CHECK(pl_key_fuser_new(10, &k) == 0, "new");
    exposed_view(0, 0, &L, R);
    const double e0 = total_energy(&L);
    CHECK(pl_key_fuser_level(k, 0, &L, 1, &F) == 0 && !memcmp(&F, &L, sizeof F),
          "no view yet: the frame as it is");
    /* levels log2(E / exposure) of four headings: e0 x 2^{1, 2, 3, 6}, mean 3; view 1 at half
     * the exposure and half the energy (auto exposure): the same level as at exposure 1 */
    const double s[4] = {1, 2, 3, 6}, x[4] = {0, 1, 0, 0};
    for (int v = 0; v < 4; v++) {
        exposed_view(v, s[v] - x[v], &L, R);
        CHECK(pl_key_fuser_add_exposed(k, &L, R, v, exp2(-x[v])) == 0, "add exposed %d", v);
    }
    /* a frame of heading 0 at exposure 0.5 with some lighting: 2^3 e0 x 0.5 after */
    exposed_view(0, -1.5, &L, R);
    CHECK(pl_key_fuser_level(k, 4, &L, 0.5, &F) == 4, "four views");
    const double want = exp2(3) * e0 * 0.5, c = want / total_energy(&L);
    CHECK(fabs(total_energy(&F) / want - 1) < 1e-5, "energy %.6g, want %.6g (mean level)",
          total_energy(&F), want);
    int same = F.n_lights == L.n_lights;
    for (int i = 0; i < L.n_lights; i++) {
        same &= !memcmp(F.lights[i].dir, L.lights[i].dir, sizeof L.lights[i].dir) &&
                F.lights[i].solid_angle_sr == L.lights[i].solid_angle_sr &&
                F.lights[i].distance_m == L.lights[i].distance_m;
        for (int j = 0; j < 3; j++)
            same &= fabs(F.lights[i].rgb[j] / (L.lights[i].rgb[j] * c) - 1) < 1e-6;
    }
    for (int j = 0; j < 3; j++)
        same &= fabs(F.ambient[j] / (L.ambient[j] * c) - 1) < 1e-6;
    CHECK(same, "one factor on colours and ambient; directions, sizes, distances kept");
    G = L;
    CHECK(pl_key_fuser_level(k, 4, &G, 0.5, &G) == 4 && !memcmp(&G, &F, sizeof G), "out may be L");

    /* an exposure so far from the views' that the colours would leave float's range: the frame
     * as it is, never infinite colours */
    CHECK(pl_key_fuser_level(k, 4, &L, 1e300, &G) == 4 && !memcmp(&G, &L, sizeof G),
          "a level beyond float's range leaves the frame as it is");

    /* refusals leave out and the fuser alone */
    G = F;
    CHECK(pl_key_fuser_level(k, 4, &L, 0, &G) == PL_E_ARG && strstr(pl_last_error(), "exposure") &&
              !memcmp(&G, &F, sizeof G),
          "exposure 0 refused, out untouched");
    CHECK(pl_key_fuser_level(k, 4, &L, NAN, &G) == PL_E_ARG &&
              pl_key_fuser_level(k, INFINITY, &L, 1, &G) == PL_E_ARG &&
              pl_key_fuser_level(NULL, 4, &L, 1, &G) == PL_E_ARG &&
              pl_key_fuser_level(k, 4, NULL, 1, &G) == PL_E_ARG &&
              pl_key_fuser_level(k, 4, &L, 1, NULL) == PL_E_ARG && !memcmp(&G, &F, sizeof G),
          "NaN exposure, infinite time, NULLs refused");
    pl_lighting bad = L;
    bad.ambient[1] = -1;
    CHECK(pl_key_fuser_level(k, 4, &bad, 1, &G) == PL_E_ARG && !memcmp(&G, &F, sizeof G),
          "an invalid lighting refused");
    const double bad_x[4] = {0, -1, NAN, INFINITY};
    for (int i = 0; i < 4; i++)
        CHECK(pl_key_fuser_add_exposed(k, &L, R, 5, bad_x[i]) == PL_E_ARG &&
                  pl_key_fuser_level(k, 5, &L, 0.5, &G) == 4 && !memcmp(&G, &F, sizeof G),
              "add with exposure %g refused, the fuser unchanged", bad_x[i]);

    /* a frame without exposure replaces its heading's level; a black one records none */
    heading_R(3 * M_PI / 2, R);
    CHECK(pl_key_fuser_add(k, &L, R, 6) == 0 && pl_key_fuser_level(k, 6, &L, 1, &G) == 3,
          "plain add drops heading 3's level");
    pl_lighting black = L;
    for (int i = 0; i < black.n_lights; i++)
        black.lights[i].rgb[0] = black.lights[i].rgb[1] = black.lights[i].rgb[2] = 0;
    black.ambient[0] = black.ambient[1] = black.ambient[2] = 0;
    heading_R(M_PI, R);
    CHECK(pl_key_fuser_add_exposed(k, &black, R, 7, 1) == 0 &&
              pl_key_fuser_level(k, 7, &L, 1, &G) == 2,
          "a black frame drops heading 2's level");
    CHECK(pl_key_fuser_level(k, 7, &black, 1, &G) == 2 && !memcmp(&G, &black, sizeof G),
          "a black frame stays black");
    /* views 0 and 1 remain: (1 + 2) / 2 = level 1.5; they expire 10 s after t 0 and 1 */
    CHECK(pl_key_fuser_level(k, 7, &L, 1, &G) == 2 &&
              fabs(total_energy(&G) / (exp2(1.5) * e0) - 1) < 1e-5,
          "the mean of the remaining levels");
    CHECK(pl_key_fuser_level(k, 10.5, &L, 1, &G) == 1 &&
              fabs(total_energy(&G) / (exp2(2) * e0) - 1) < 1e-5,
          "view 0 expired (age 10.5 s > 10 s)");
    pl_key_fuser_reset(k);
    CHECK(pl_key_fuser_level(k, 10.5, &L, 1, &G) == 0 && !memcmp(&G, &L, sizeof G),
          "reset forgets the levels");
    pl_key_fuser_free(k);
}

int main(void)
{
    test_one_lobe();
    test_triangulation();
    test_dwelling();
    test_age();
    test_small_light();
    test_bad_args();
    test_public_api();
    test_aim();
    test_level();
    if (failures) {
        printf("%d failure(s)\n", failures);
        return 1;
    }
    printf("fuse: all passed\n");
    return 0;
}
