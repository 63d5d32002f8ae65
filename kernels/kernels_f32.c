/* fp32 kernel slots (kernels/kernels_f32.h): the table, the packed-convolution geometry and the
 * weight packer (run once at load, so plain C). */
#include "kernels/kernels_f32.h"

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
#if defined(__x86_64__)
    if (pl_isa_includes(isa, PL_ISA_AVX512VNNI)) {
        t->packed = 1;
        SLOT(conv, nn_conv_gemm_f32_8x48__avx512vnni);
        SLOT(bn_relu, nn_bn_relu_f32__avx512vnni);
        SLOT(fc, nn_fc_f32__avx512vnni);
        SLOT(maxpool, nn_maxpool2d_f32__avx512vnni);
        SLOT(avgpool, nn_avgpool2d_f32__avx512vnni);
    } else if (pl_isa_includes(isa, PL_ISA_AVX2)) {
        t->packed = 1;
        SLOT(conv, nn_conv_gemm_f32_4x24__avx2);
        SLOT(bn_relu, nn_bn_relu_f32__avx2);
        SLOT(fc, nn_fc_f32__avx2);
        SLOT(maxpool, nn_maxpool2d_f32__avx2);
        SLOT(avgpool, nn_avgpool2d_f32__avx2);
    }
#elif defined(__aarch64__)
    /* NEON for every Arm path (dotprod and i8mm add nothing to fp32); bn_relu stays the
     * reference loop, which gcc already vectorises for the AArch64 baseline */
    if (pl_isa_includes(isa, PL_ISA_NEON)) {
        t->packed = 1;
        SLOT(conv, nn_conv_gemm_f32_8x12__neon);
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
    const char *ops[6], *impls[6];
    int n = 0;
    if (t->packed) {
        ops[n] = "conv (7x7, 1x1+bn, 3x3)";
        impls[n++] = t->conv_name;
        ops[n] = "pack weights (load)";
        impls[n++] = "pl_f32_pack_weights";
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
    for (int i = 0; i < n && i < max; i++) {
        if (op) op[i] = ops[i];
        if (impl) impl[i] = impls[i];
    }
    return n;
}

int pl_f32_conv_panels(const nn_conv_params *p)
{
    return (p->out_c + PL_F32_MR - 1) / PL_F32_MR;
}

int pl_f32_conv_tiles(const nn_conv_params *p)
{
    return (p->out_h * p->out_w + PL_F32_NR - 1) / PL_F32_NR;
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
