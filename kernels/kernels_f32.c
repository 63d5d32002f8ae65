/* fp32 kernel slots (kernels/kernels_f32.h): the table, the packed-convolution geometry and the
 * weight packer (run once at load, so plain C). */
#include "kernels/kernels_f32.h"

#include <stdlib.h>
#include <string.h>

#if defined(__x86_64__)
#include "kernels/x86/nn_f32_x86.h"
#elif defined(__aarch64__)
#include "kernels/arm/nn_f32_arm.h"
#endif

/* A slot and the name `parlight info` prints for it, from one identifier. */
#define SLOT(slot, fn) (t->slot = fn, t->slot##_name = #fn)

void pl_kernels_f32_fill(pl_kernels_f32 *t, pl_isa isa)
{
    memset(t, 0, sizeof *t);
    SLOT(bn_relu, nn_bn_relu_f32__ref);
    SLOT(maxpool, nn_maxpool2d_f32__ref);
    SLOT(avgpool, nn_avgpool2d_f32__ref);
    SLOT(fc, nn_fc_f32__ref);
    SLOT(fc_w8, nn_fc_w8_f32__ref);
#if defined(__x86_64__)
    /* AVX-512F is all the AVX-512 kernels need: a Skylake-SP (no VNNI) runs them too */
    if (pl_isa_includes(isa, PL_ISA_AVX512F)) {
        t->packed = 1;
        SLOT(conv, nn_conv_gemm_f32_8x48__avx512f);
        SLOT(wino, nn_conv_wino_f32_8x48__avx512f);
        SLOT(bn_relu, nn_bn_relu_f32__avx512f);
        SLOT(fc, nn_fc_f32__avx512f);
        SLOT(fc_w8, nn_fc_w8_f32__avx512f);
        SLOT(maxpool, nn_maxpool2d_f32__avx512f);
        SLOT(avgpool, nn_avgpool2d_f32__avx512f);
    } else if (pl_isa_includes(isa, PL_ISA_AVX2)) {
        t->packed = 1;
        SLOT(conv, nn_conv_gemm_f32_4x24__avx2);
        SLOT(wino, nn_conv_wino_f32_4x24__avx2);
        SLOT(bn_relu, nn_bn_relu_f32__avx2);
        SLOT(fc, nn_fc_f32__avx2);
        SLOT(fc_w8, nn_fc_w8_f32__avx2);
        SLOT(maxpool, nn_maxpool2d_f32__avx2);
        SLOT(avgpool, nn_avgpool2d_f32__avx2);
    }
#elif defined(__aarch64__)
    /* NEON for every Arm path (dotprod and i8mm add nothing to fp32); bn_relu stays the
     * reference loop, which gcc already vectorises for the AArch64 baseline */
    if (pl_isa_includes(isa, PL_ISA_NEON)) {
        t->packed = 1;
        SLOT(conv, nn_conv_gemm_f32_8x12__neon);
        SLOT(wino, nn_conv_wino_f32_8x12__neon);
        SLOT(fc, nn_fc_f32__neon);
        SLOT(maxpool, nn_maxpool2d_f32__neon);
        SLOT(avgpool, nn_avgpool2d_f32__neon);
    }
#else
    (void)isa;
#endif
}

#undef SLOT

int pl_kernels_f32_list(const pl_kernels_f32 *t, const char **op, const char **impl, int max)
{
    const char *ops[9], *impls[9];
    int n = 0;
    if (t->packed) {
        ops[n] = "conv (7x7, 1x1+bn, 3x3)";
        impls[n++] = t->conv_name;
        ops[n] = "pack weights (load)";
        impls[n++] = "pl_f32_pack_weights";
        if (t->wino) {
            const char *e = getenv("PARLIGHT_WINOGRAD");
            ops[n] = "conv 3x3 s1 (winograd)";
            impls[n++] = !e || !*e            ? t->wino_name
                         : !strcmp(e, "0")    ? "off (PARLIGHT_WINOGRAD=0)"
                         : !strcmp(e, "2")    ? "F(2x2,3x3) for all (PARLIGHT_WINOGRAD=2)"
                         : !strcmp(e, "4")    ? "F(4x4,3x3) for all (PARLIGHT_WINOGRAD=4)"
                         : !strcmp(e, "auto") ? t->wino_name
                                              : "PARLIGHT_WINOGRAD invalid: models will not load";
            ops[n] = "winograd weights (load)";
            impls[n++] = "pl_f32_wino_pack_weights";
        }
    } else {
        ops[n] = "conv2d";
        impls[n++] = "nn_conv2d_f32__ref";
    }
    ops[n] = "bn_relu";
    impls[n++] = t->bn_relu_name;
    ops[n] = "maxpool2d";
    impls[n++] = t->maxpool_name;
    ops[n] = "avgpool2d";
    impls[n++] = t->avgpool_name;
    ops[n] = "fc";
    impls[n++] = t->fc_name;
    ops[n] = "fc, int8-stored weights";
    impls[n++] = t->fc_w8_name;
    for (int i = 0; i < n && i < max; i++) {
        if (op) op[i] = ops[i];
        if (impl) impl[i] = impls[i];
    }
    return n;
}

static size_t k_of(const nn_conv_params *p)
{
    return (size_t)p->in_c * (size_t)p->k_h * (size_t)p->k_w;
}

size_t pl_f32_packed_weights_floats(const nn_conv_params *p)
{
    return (size_t)pl_f32_conv_panels(p) * k_of(p) * PL_F32_MR;
}

void pl_f32_pack_weights(const nn_conv_params *p, const float *w, float *dst)
{
    const size_t K = k_of(p);
    const int panels = pl_f32_conv_panels(p);
    for (int pn = 0; pn < panels; pn++) {
        float *d = dst + (size_t)pn * K * PL_F32_MR;
        for (size_t k = 0; k < K; k++) {
            for (int r = 0; r < PL_F32_MR; r++) {
                const int oc = pn * PL_F32_MR + r;
                d[k * PL_F32_MR + (size_t)r] = oc < p->out_c ? w[(size_t)oc * K + k] : 0.0f;
            }
        }
    }
}

size_t pl_f32_conv_scratch_floats(const nn_conv_params *p)
{
    /* a block of B (PL_F32_KC x NR), then per-tile tables: one validity mask of NR int32 per
     * kernel tap (stride 1) or each of the NR pixels' first input index, row and column (other
     * strides) */
    size_t taps = (size_t)p->k_h * (size_t)p->k_w;
    if (taps < 3) taps = 3;
    const size_t n = (PL_F32_KC + taps) * PL_F32_NR;
    return (n + 15) & ~(size_t)15;
}

/* ---- Winograd F(m x m, 3x3) (kernels_f32.h) ----------------------------------------------- */

int pl_f32_wino_fits(const pl_f32_conv *c)
{
    const nn_conv_params *p = &c->p;
    return p->k_h == 3 && p->k_w == 3 && p->stride == 1 && p->pad == 1 && p->in_h == p->out_h &&
           p->in_w == p->out_w && !c->in_scale && !c->in_shift;
}

static int wino_tiles(const nn_conv_params *p, int m)
{
    return ((p->out_h + m - 1) / m) * ((p->out_w + m - 1) / m);
}

int pl_f32_wino_choose(const nn_conv_params *p)
{
    const char *e = getenv("PARLIGHT_WINOGRAD");
    if (e && *e && strcmp(e, "auto")) {
        if (!strcmp(e, "0")) return 0;
        if (!strcmp(e, "2")) return 2;
        if (!strcmp(e, "4")) return 4;
        return -1;
    }
    /* F(4x4) where its tiles fill at least one block of NR (192x256: the 48x64 and 24x32 maps),
     * else F(2x2) where they fill half of one (12x16), else direct (6x8: 12 F(2x2) tiles leave
     * three quarters of the micro-kernel idle). Measured: docs/PERFORMANCE.md. */
    if (wino_tiles(p, 4) >= PL_F32_NR) return 4;
    if (wino_tiles(p, 2) >= PL_F32_NR / 2) return 2;
    return 0;
}

int pl_f32_wino_blocks(const nn_conv_params *p, int m)
{
    return (wino_tiles(p, m) + PL_F32_NR - 1) / PL_F32_NR;
}

size_t pl_f32_wino_weights_floats(const nn_conv_params *p, int m)
{
    const size_t T = (size_t)m + 2;
    return T * T * (size_t)pl_f32_conv_panels(p) * (size_t)p->in_c * PL_F32_MR;
}

void pl_f32_wino_pack_weights(const nn_conv_params *p, int m, const float *w, float *dst)
{
    /* Lavin and Gray's G for F(2x2, 3x3) and F(4x4, 3x3) */
    static const double g2[4][3] = {{1, 0, 0}, {0.5, 0.5, 0.5}, {0.5, -0.5, 0.5}, {0, 0, 1}};
    static const double g4[6][3] = {{1.0 / 4, 0, 0},
                                    {-1.0 / 6, -1.0 / 6, -1.0 / 6},
                                    {-1.0 / 6, 1.0 / 6, -1.0 / 6},
                                    {1.0 / 24, 1.0 / 12, 1.0 / 6},
                                    {1.0 / 24, -1.0 / 12, 1.0 / 6},
                                    {0, 0, 1}};
    const int T = m + 2, panels = pl_f32_conv_panels(p), in_c = p->in_c;
    const double(*G)[3] = m == 4 ? g4 : g2;
    for (int oc = 0; oc < panels * PL_F32_MR; oc++) {
        for (int ic = 0; ic < in_c; ic++) {
            double u[6][6] = {{0}}, gg[6][3] = {{0}};
            if (oc < p->out_c) {
                const float *g = w + ((size_t)oc * (size_t)in_c + (size_t)ic) * 9;
                for (int i = 0; i < T; i++)
                    for (int k = 0; k < 3; k++)
                        for (int r = 0; r < 3; r++)
                            gg[i][k] += G[i][r] * (double)g[r * 3 + k];
                for (int i = 0; i < T; i++)
                    for (int j = 0; j < T; j++)
                        for (int k = 0; k < 3; k++)
                            u[i][j] += gg[i][k] * G[j][k];
            }
            for (int xi = 0; xi < T * T; xi++) {
                const size_t at =
                    (((size_t)xi * (size_t)panels + (size_t)(oc / PL_F32_MR)) * (size_t)in_c +
                     (size_t)ic) *
                        PL_F32_MR +
                    (size_t)(oc % PL_F32_MR);
                dst[at] = (float)u[xi / T][xi % T];
            }
        }
    }
}

size_t pl_f32_wino_scratch_floats(const nn_conv_params *p, int m)
{
    /* V (T*T blocks of KC x NR), M (T*T x panels*MR x NR), the first pass of a transform
     * (T*T x NR), the output tile (m*m x NR) and an input row segment (m*NR + 2 floats and 8
     * to 15 more, within (m + 1) NR) */
    const size_t T = (size_t)m + 2,
                 kc = p->in_c < PL_F32_WINO_KC ? (size_t)p->in_c : PL_F32_WINO_KC;
    const size_t n = (T * T * kc + T * T * (size_t)pl_f32_conv_panels(p) * PL_F32_MR + T * T +
                      (size_t)m * (size_t)m + (size_t)m + 1) *
                     PL_F32_NR;
    return (n + 15) & ~(size_t)15;
}
