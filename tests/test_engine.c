/* light/sh.c pl_lighting_engine: DirectionalLight(dir, irradiance) + LightProbe(sh9), as three.js,
 * WebXR, ARCore and Unity add them, against the diffuse irradiance of the whole lighting
 * integrated by brute force, on 200 normals. Also shows what the engine form is for: the full
 * sh9 plus a directional light of the primary counts that light twice. Errors are relative to
 * the largest irradiance over the normals (docs/LIGHTING.md, "Engine-ready lighting"). */
#include <stdlib.h>
#include <string.h>

#include "core/util.h"
#include "light/light.h"
#include "light_test.h"

/* Irradiance at unit normal n of eq. (4): pi * ambient + each lobe integrated around its axis
 * (theta up to where exp(lam (cos theta - 1)) < e^-40, so tiny lobes are resolved). */
static void exact_irradiance(const pl_lighting *L, const double n[3], double e[3])
{
    for (int c = 0; c < 3; c++)
        e[c] = M_PI * L->ambient[c];
    for (int i = 0; i < L->n_lights; i++) {
        const pl_light *li = &L->lights[i];
        double l[3] = {li->dir[0], li->dir[1], li->dir[2]}, e1[3], e2[3];
        double ln = sqrt(l[0] * l[0] + l[1] * l[1] + l[2] * l[2]);
        for (int k = 0; k < 3; k++)
            l[k] /= ln;
        frame3(l, e1, e2);
        double lam = 4 * M_PI / li->solid_angle_sr, tmax = M_PI;
        if (lam > 20) tmax = fmin(M_PI, acos(fmax(-1.0, 1 - 40 / lam)));
        const int NT = 300, NP = 180;
        double acc = 0;
        for (int a = 0; a < NT; a++) {
            double th = (a + 0.5) * tmax / NT, g = exp(lam * (cos(th) - 1));
            double w = g * sin(th) * (tmax / NT) * (2 * M_PI / NP);
            for (int b = 0; b < NP; b++) {
                double ph = (b + 0.5) * 2 * M_PI / NP, cu = 0;
                for (int k = 0; k < 3; k++)
                    cu += n[k] * (cos(th) * l[k] + sin(th) * (cos(ph) * e1[k] + sin(ph) * e2[k]));
                if (cu > 0) acc += w * cu;
            }
        }
        for (int c = 0; c < 3; c++)
            e[c] += acc * li->rgb[c];
    }
}

/* What an engine computes: probe irradiance sum_k A_l sh_k Y_k(n), plus a directional light. */
static void engine_irradiance(const float sh[27], const float dir[3], const float irr[3],
                              const double n[3], double e[3])
{
    const double A[3] = {M_PI, 2 * M_PI / 3, M_PI / 4};
    float shA[27], nf[3] = {(float)n[0], (float)n[1], (float)n[2]}, r[3];
    for (int k = 0; k < 9; k++)
        for (int c = 0; c < 3; c++)
            shA[k * 3 + c] = (float)(sh[k * 3 + c] * A[k == 0 ? 0 : k < 4 ? 1 : 2]);
    pl_sh9_eval(shA, nf, r);
    double cd = n[0] * dir[0] + n[1] * dir[1] + n[2] * dir[2];
    for (int c = 0; c < 3; c++)
        e[c] = r[c] + (cd > 0 ? cd * irr[c] : 0);
}

/* Largest error over 200 normals (a Fibonacci sphere), relative to the largest irradiance, of
 * the engine form; and of the full sh9 alone and of the full sh9 + the directional light. */
static void errors(const pl_lighting *L, double *engine, double *probe, double *twice)
{
    pl_engine_lighting E;
    pl_lighting_engine(L, &E);
    float full[27], none[3] = {0, 0, 0};
    pl_sh9_from_lights(L, full);
    double emax = 0, de = 0, dp = 0, dt = 0;
    const int N = 120;
    for (int i = 0; i < N; i++) {
        double z = 1 - (2 * i + 1.0) / N, r = sqrt(1 - z * z), ph = i * 2.399963229728653;
        double n[3] = {r * cos(ph), r * sin(ph), z}, ex[3], en[3], ep[3], et[3];
        exact_irradiance(L, n, ex);
        engine_irradiance(E.sh9, E.dir, E.intensity, n, en);
        engine_irradiance(full, E.dir, none, n, ep);
        engine_irradiance(full, E.dir, E.intensity, n, et);
        for (int c = 0; c < 3; c++) {
            emax = fmax(emax, ex[c]);
            de = fmax(de, fabs(en[c] - ex[c]));
            dp = fmax(dp, fabs(ep[c] - ex[c]));
            dt = fmax(dt, fabs(et[c] - ex[c]));
        }
    }
    *engine = de / emax;
    *probe = dp / emax;
    *twice = dt / emax;
}

static pl_light light(float x, float y, float z, float s, float r, float g, float b)
{
    pl_light l = {{x, y, z}, 2, s, {r, g, b}};
    unit3(l.dir);
    return l;
}

static void scenario(const char *name, const pl_lighting *L, double tol)
{
    double e, p, t;
    errors(L, &e, &p, &t);
    printf("%-44s engine %.4f  sh9 alone %.4f  sh9 + directional %.4f\n", name, e, p, t);
    CHECK(e <= tol, "%s: engine form off by %.4f of the peak irradiance (bound %.3f)", name, e,
          tol);
    CHECK(t > 3 * e, "%s: counting the primary twice (%.4f) should be far worse than %.4f", name,
          t, e);
    CHECK(e < p, "%s: the engine form (%.4f) should beat the full sh9 alone (%.4f)", name, e, p);
}

int main(void)
{
    pl_lighting L;
    /* a lamp: the lobe is small, the form is exact up to the ambient's (exact) SH */
    memset(&L, 0, sizeof L);
    L.n_lights = 1;
    L.lights[0] = light(0.3f, 0.8f, -0.5f, 0.002f, 2000, 1800, 1500);
    L.ambient[0] = L.ambient[1] = L.ambient[2] = 0.3f;
    scenario("one lamp (0.002 sr) + ambient", &L, 0.005);
    /* lobes from a lamp to a window, alone with an ambient: the primary's own error */
    const float sizes[] = {0.01f, 0.05f, 0.1f, 0.2f, 0.5f, 1.0f};
    for (int k = 0; k < 6; k++) {
        L.n_lights = 1;
        L.lights[0] = light(-0.6f, 0.5f, -0.6f, sizes[k], 12 / sizes[k], 12 / sizes[k], 12 / sizes[k]);
        L.ambient[0] = L.ambient[1] = L.ambient[2] = 0.3f;
        char name[64];
        snprintf(name, sizeof name, "one lobe of %.2f sr + ambient", (double)sizes[k]);
        scenario(name, &L, sizes[k] <= 0.01f ? 0.01 : sizes[k] <= 0.1f ? 0.02 : 0.025);
    }
    /* a window (0.2 sr) beside two softer lights: the others' SH truncation remains */
    L.n_lights = 3;
    L.lights[0] = light(-0.6f, 0.5f, -0.6f, 0.2f, 60, 62, 70);
    L.lights[1] = light(0.5f, 0.7f, 0.3f, 1.0f, 1.5f, 1.2f, 0.9f);
    L.lights[2] = light(0.1f, -0.9f, -0.2f, 2.0f, 0.4f, 0.35f, 0.3f);
    scenario("window (0.2 sr) + 2 soft lights + ambient", &L, 0.025);
    /* random rooms with a small primary lobe */
    for (int r = 0; r < 8; r++) {
        memset(&L, 0, sizeof L);
        L.n_lights = 3;
        for (int i = 0; i < 3; i++) {
            float d[3] = {(float)rint_in(-100, 100), (float)rint_in(-100, 100),
                          (float)rint_in(-100, 100) + 0.5f};
            float s = i == 0 ? 0.001f + 0.0005f * (float)rint_in(0, 400)
                             : 0.3f + 0.01f * (float)rint_in(0, 250);
            float k = i == 0 ? 20 / s : 1.0f + 0.01f * rint_in(0, 100);
            L.lights[i] = light(d[0], d[1], d[2], s, k, k * 0.9f, k * 0.8f);
        }
        L.ambient[0] = L.ambient[1] = L.ambient[2] = 0.05f * (float)rint_in(0, 10);
        char name[64];
        snprintf(name, sizeof name, "random room %d (primary %.3f sr)", r,
                 (double)L.lights[0].solid_angle_sr);
        scenario(name, &L, 0.025);
    }
    /* a wide primary lobe (2.9 sr, an overcast window wall): most of it stays in the probe */
    memset(&L, 0, sizeof L);
    L.n_lights = 1;
    L.lights[0] = light(0.2f, 0.9f, -0.3f, 2.9f, 3, 3, 3);
    L.ambient[0] = L.ambient[1] = L.ambient[2] = 0.2f;
    scenario("one wide lobe (2.9 sr) + ambient", &L, 0.01);
    /* engine.dir is the primary light's direction as given when that is unit to float precision
     * (the network normalises in float): normalising again in double moves the last bit of some
     * of them, and engine.dir then prints as another direction than primary.dir. A unit-ish
     * direction (|d| 1.5) is normalised. */
    int moved = 0, same = 0;
    for (int r = 0; r < 2000; r++) {
        float v[3] = {(float)rint_in(-1000, 1000) + 0.25f, (float)rint_in(-1000, 1000),
                      (float)rint_in(-1000, 1000)};
        float fn = sqrtf(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
        double dn = 0;
        for (int k = 0; k < 3; k++) {
            v[k] /= fn;
            dn += (double)v[k] * v[k];
        }
        for (int k = 0; k < 3; k++)
            moved += (float)(v[k] / sqrt(dn)) != v[k];
        memset(&L, 0, sizeof L);
        L.n_lights = 1;
        L.lights[0] = (pl_light){{v[0], v[1], v[2]}, 2, 0.1f, {5, 5, 5}};
        float pd[3], rgb[3];
        pl_lighting_primary(&L, pd, rgb);
        pl_engine_lighting E;
        pl_lighting_engine(&L, &E);
        same += memcmp(E.dir, pd, sizeof pd) == 0;
    }
    CHECK(moved > 0, "no float-normalised direction moves when normalised again (test is blind)");
    CHECK(same == 2000, "engine.dir differs from the primary's unit direction in %d of 2000",
          2000 - same);
    printf("2000 float-unit directions: engine.dir = primary.dir in %d (a double "
           "renormalisation would move %d components)\n", same, moved);
    memset(&L, 0, sizeof L);
    L.n_lights = 1;
    L.lights[0] = (pl_light){{0.9f, 1.2f, 0.0f}, 2, 0.1f, {5, 5, 5}}; /* |d| = 1.5 */
    {
        pl_engine_lighting E;
        pl_lighting_engine(&L, &E);
        double n = sqrt((double)E.dir[0] * E.dir[0] + (double)E.dir[1] * E.dir[1] +
                        (double)E.dir[2] * E.dir[2]);
        CHECK(fabs(n - 1) < 1e-6 && fabs(E.dir[1] - 0.8) < 1e-6, "unit-ish dir not normalised: "
              "(%g, %g, %g)", (double)E.dir[0], (double)E.dir[1], (double)E.dir[2]);
    }
    if (failures) {
        printf("%d failure(s)\n", failures);
        return 1;
    }
    printf("engine: all passed\n");
    return 0;
}
