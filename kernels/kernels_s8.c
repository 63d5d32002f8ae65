/* int8 kernel slots (kernels/kernels_s8.h): the table, packed-convolution geometry and the
 * weight packers (run once at load, so plain C). */
#include "kernels/kernels_s8.h"

#include <stdlib.h>
#include <string.h>

#if defined(__x86_64__)
#include "kernels/x86/nn_s8_x86.h"
#elif defined(__aarch64__)
#include "kernels/arm/nn_s8_arm.h"
#endif

static int round4(int v)
{
    return (v + 3) & ~3;
}

static int blocks_of(int out_c)
{
    return (out_c + PL_S8_OCB - 1) / PL_S8_OCB;
}

void pl_s8_conv_init(pl_s8_conv *c, const nn_conv_s8_params *p, const nn_per_channel_quant *q,
                     const nn_dims *in_dims, const nn_dims *filter_dims, const nn_dims *out_dims,
                     pl_s8_a_kind kind)
{
    memset(c, 0, sizeof *c);
    c->n = out_dims->n;
    c->out_h = out_dims->h;
    c->out_w = out_dims->w;
    c->out_c = out_dims->c;
    c->in_c = in_dims->c;
    c->cs = round4(in_dims->c);
    c->input_offset = p->input_offset;
    c->output_offset = p->output_offset;
    c->act_min = p->act_min;
    c->act_max = p->act_max;
    c->multiplier = q->multiplier;
    c->shift = q->shift;
    if (kind == PL_S8_A_PACK) {
        c->a_h = out_dims->h;
        c->a_w = out_dims->w;
        c->k_h = c->k_w = 1;
        c->stride_h = c->stride_w = c->dilation_h = c->dilation_w = 1;
    } else if (kind == PL_S8_A_ROWS) {
        c->in_c = filter_dims->w * in_dims->c;
        c->cs = round4(c->in_c);
        c->k_h = filter_dims->h;
        c->k_w = 1;
        c->stride_h = p->stride_h;
        c->stride_w = 1;
        c->dilation_h = p->dilation_h;
        c->dilation_w = 1;
        c->a_h = (out_dims->h - 1) * p->stride_h + (c->k_h - 1) * p->dilation_h + 1;
        c->a_w = out_dims->w;
    } else {
        c->k_h = filter_dims->h;
        c->k_w = filter_dims->w;
        c->stride_h = p->stride_h;
        c->stride_w = p->stride_w;
        c->dilation_h = p->dilation_h;
        c->dilation_w = p->dilation_w;
        /* rows / columns the output reaches, in padded coordinates */
        c->a_h = (out_dims->h - 1) * p->stride_h + (c->k_h - 1) * p->dilation_h + 1;
        c->a_w = (out_dims->w - 1) * p->stride_w + (c->k_w - 1) * p->dilation_w + 1;
    }
}

size_t pl_s8_conv_packed_size(const pl_s8_conv *c, pl_s8_layout layout)
{
    const size_t groups = (size_t)c->k_h * (size_t)c->k_w * (size_t)(c->cs / 4);
    const size_t nb = (size_t)blocks_of(c->out_c);
    size_t per_group;
    switch (layout) {
    case PL_S8_LAYOUT_VNNI: per_group = PL_S8_OCB * 4; break;
    case PL_S8_LAYOUT_AVX2: per_group = PL_S8_OCB * 4 * 2; break;
    case PL_S8_LAYOUT_SDOT: per_group = PL_S8_OCB * 4; break;
    case PL_S8_LAYOUT_I8MM: /* groups of 8 channels per tap */
        return nb * (size_t)c->k_h * (size_t)c->k_w * (size_t)((c->cs + 7) / 8) * PL_S8_OCB * 8 +
               6 * nb * PL_S8_OCB * sizeof(int32_t);
    default: return 0;
    }
    return nb * groups * per_group + 6 * nb * PL_S8_OCB * sizeof(int32_t);
}

size_t pl_s8_conv_a_size(const pl_s8_conv *c)
{
    return (size_t)c->n * (size_t)c->a_h * (size_t)c->a_w * (size_t)c->cs + 64;
}

void pl_s8_a_fill_pad(const pl_s8_conv *c, uint8_t *a)
{
    memset(a, pl_s8_pad_u(c->input_offset),
           (size_t)c->n * (size_t)c->a_h * (size_t)c->a_w * (size_t)c->cs);
}

void pl_s8_a_read_s8(const pl_s8_conv *c, const uint8_t *a, int y0, int x0, int h, int w,
                     int8_t *out)
{
    const size_t row = (size_t)w * (size_t)c->cs;
    for (int y = 0; y < h; y++) {
        const uint8_t *src = a + ((size_t)(y0 + y) * (size_t)c->a_w + (size_t)x0) * (size_t)c->cs;
        for (size_t i = 0; i < row; i++)
            out[(size_t)y * row + i] = (int8_t)(src[i] ^ PL_S8_A_XOR);
    }
}

/* Weight of output channel o, group g (of K/4), element e (0..3) in tap-major order, with zeros
 * for the padded channels and output channels. */
static int8_t w_at(const pl_s8_conv *c, const int8_t *weights, int o, int g, int e)
{
    const int gpt = c->cs / 4, tap = g / gpt, ch = (g % gpt) * 4 + e;
    if (o >= c->out_c || ch >= c->in_c) return 0;
    return weights[((size_t)o * (size_t)(c->k_h * c->k_w) + (size_t)tap) * (size_t)c->in_c +
                   (size_t)ch];
}

/* bias + (input_offset - 128) * sum(w), modulo 2^32 (see kernels_s8.h), then the multipliers
 * and the left and right shifts. signed_a: the kernel multiplies the signed x = u ^ 0x80 (Arm
 * sdot/smull), so the correction is input_offset * sum(w). */
static void fold_bias(pl_s8_conv *c, const int8_t *weights, const int32_t *bias, int signed_a,
                      int32_t *dst)
{
    const size_t per_oc = (size_t)c->k_h * (size_t)c->k_w * (size_t)c->in_c;
    const int nb = blocks_of(c->out_c), np = nb * PL_S8_OCB;
    c->any_left_shift = 0;
    c->short_requant = c->act_min == -128 && c->act_max == 127;
    for (int o = 0; o < np; o++) {
        if (o >= c->out_c) {
            for (int r = 0; r < 6; r++)
                dst[r * np + o] = 0;
            continue;
        }
        const int32_t sh = c->shift[o], e = sh < 0 ? -sh : 0;
        const int32_t mask = (int32_t)(((int64_t)1 << e) - 1);
        dst[np + o] = c->multiplier[o];
        dst[2 * np + o] = sh > 0 ? sh : 0;
        dst[3 * np + o] = e;
        dst[4 * np + o] = mask;
        dst[5 * np + o] = mask >> 1;
        if (sh > 0) c->any_left_shift = 1;
        int64_t sum = 0, sum_abs = 0;
        for (size_t i = 0; i < per_oc; i++) {
            const int8_t wi = weights[(size_t)o * per_oc + i];
            sum += wi;
            sum_abs += wi < 0 ? -wi : wi;
        }
        /* |x + input_offset| <= 255 for every s8 x and input_offset in [-127, 128] */
        const int64_t bound = (bias ? llabs((int64_t)bias[o]) : 0) + 255 * sum_abs;
        if (sh > 0 || bound >= (int64_t)1 << 30) c->short_requant = 0;
        const uint32_t corr =
            (uint32_t)((int64_t)(c->input_offset - (signed_a ? 0 : 128)) * sum);
        dst[o] = (int32_t)((bias ? (uint32_t)bias[o] : 0u) + corr);
    }
}

/* The VNNI layout: per block of 16 output channels and group of 4 input channels, each channel's
 * 4 weights in a row. `signed_a` says how the bias is folded: for u8 A (x86 VNNI) or s8 A (Arm
 * sdot and NEON). */
static void pack_groups4(pl_s8_conv *c, const int8_t *weights, const int32_t *bias, void *mem,
                         int signed_a)
{
    const int groups = c->k_h * c->k_w * (c->cs / 4), nb = blocks_of(c->out_c);
    int8_t *w = mem;
    for (int b = 0; b < nb; b++)
        for (int g = 0; g < groups; g++)
            for (int j = 0; j < PL_S8_OCB; j++)
                for (int e = 0; e < 4; e++)
                    *w++ = w_at(c, weights, b * PL_S8_OCB + j, g, e);
    c->w = mem;
    c->bias = (const int32_t *)(void *)w;
    fold_bias(c, weights, bias, signed_a, (int32_t *)(void *)w);
}

static void pack_vnni(pl_s8_conv *c, const int8_t *weights, const int32_t *bias, void *mem)
{
    pack_groups4(c, weights, bias, mem, 0);
}

static void pack_avx2(pl_s8_conv *c, const int8_t *weights, const int32_t *bias, void *mem)
{
    const int groups = c->k_h * c->k_w * (c->cs / 4), nb = blocks_of(c->out_c);
    int16_t *w = mem;
    for (int b = 0; b < nb; b++)
        for (int g = 0; g < groups; g++)
            for (int half = 0; half < 2; half++)
                for (int j = 0; j < PL_S8_OCB; j++)
                    for (int e = 0; e < 2; e++)
                        *w++ = w_at(c, weights, b * PL_S8_OCB + j, g, 2 * half + e);
    c->w = mem;
    c->bias = (const int32_t *)(void *)w;
    fold_bias(c, weights, bias, 0, (int32_t *)(void *)w);
}

/* Arm NEON / dotprod: the VNNI layout with the bias folded for signed A (kernels/arm). */
static void pack_sdot(pl_s8_conv *c, const int8_t *weights, const int32_t *bias, void *mem)
{
    pack_groups4(c, weights, bias, mem, 1);
}

/* Arm i8mm: per block, tap and group of 8 channels (zero weights for [in_c, round8(cs))), the
 * 16 output channels' 8 weights in a row: usmmla's B operand is 2 channels x 8 (u8 A, so the
 * x86 bias folding). */
static void pack_i8mm(pl_s8_conv *c, const int8_t *weights, const int32_t *bias, void *mem)
{
    const int taps = c->k_h * c->k_w, g8 = (c->cs + 7) / 8, nb = blocks_of(c->out_c);
    int8_t *w = mem;
    for (int b = 0; b < nb; b++)
        for (int t = 0; t < taps; t++)
            for (int g = 0; g < g8; g++)
                for (int j = 0; j < PL_S8_OCB; j++)
                    for (int e = 0; e < 8; e++) {
                        const int o = b * PL_S8_OCB + j, ch = 8 * g + e;
                        *w++ = o < c->out_c && ch < c->in_c
                                   ? weights[((size_t)o * (size_t)taps + (size_t)t) *
                                                 (size_t)c->in_c +
                                             (size_t)ch]
                                   : 0;
                    }
    c->w = mem;
    c->bias = (const int32_t *)(void *)w;
    fold_bias(c, weights, bias, 0, (int32_t *)(void *)w);
}

/* One path's slots; `a` names the instruction set of the A builders, pools and clamp (the
 * suffix of their files), `run` the packed convolution with its tile. */
#define PL_S8_TABLE(layout_, pack_, a_, run_)                                                     \
    (pl_kernels_s8)                                                                               \
    {                                                                                             \
        .packed = 1, .layout = layout_, .pack = pack_, .a_pack = nn_a_pack_s8__##a_,             \
        .a_pad = nn_a_pad_s8__##a_, .a_rows = nn_a_rows_s8__##a_,                                 \
        .a_rows_name = "nn_a_rows_s8__" #a_, .run = run_, .maxpool = nn_maxpool2d_s8__##a_,       \
        .avgpool = nn_avgpool2d_s8__##a_, .clamp = nn_clamp_s8__##a_, .pack_name = #pack_,       \
        .a_pack_name = "nn_a_pack_s8__" #a_, .a_pad_name = "nn_a_pad_s8__" #a_,                   \
        .run_name = #run_, .maxpool_name = "nn_maxpool2d_s8__" #a_,                               \
        .avgpool_name = "nn_avgpool2d_s8__" #a_, .clamp_name = "nn_clamp_s8__" #a_               \
    }

/* Each path takes the kernels whose instructions it guarantees (kernels/isa.h): amx the AMX
 * convolution and avx512vnni's other kernels; avx512vnni the
 * AVX-512 F/BW/DQ/VL A builders and pools and the VNNI convolution; avxvnni, and avx512f (AVX-512
 * without VNNI: no int8 kernel of its own), the AVX2 ones. */
void pl_kernels_s8_fill(pl_kernels_s8 *t, pl_isa isa)
{
    memset(t, 0, sizeof *t);
    t->layout = PL_S8_LAYOUT_NONE;
#if defined(__x86_64__)
    if (pl_isa_includes(isa, PL_ISA_AMX))
        *t = PL_S8_TABLE(PL_S8_LAYOUT_VNNI, pack_vnni, avx512skx, nn_conv_packed_s8_16x32c4__amx);
    else if (pl_isa_includes(isa, PL_ISA_AVX512VNNI))
        *t = PL_S8_TABLE(PL_S8_LAYOUT_VNNI, pack_vnni, avx512skx,
                         nn_conv_packed_s8_14x32c4__avx512vnni);
    else if (pl_isa_includes(isa, PL_ISA_AVXVNNI))
        *t = PL_S8_TABLE(PL_S8_LAYOUT_VNNI, pack_vnni, avx2, nn_conv_packed_s8_6x16c4__avxvnni);
    else if (pl_isa_includes(isa, PL_ISA_AVX2))
        *t = PL_S8_TABLE(PL_S8_LAYOUT_AVX2, pack_avx2, avx2, nn_conv_packed_s8_4x16c4__avx2);
    (void)pack_sdot;
    (void)pack_i8mm;
#elif defined(__aarch64__)
    /* the A builders, pools and clamp are NEON for every Arm path */
    if (pl_isa_includes(isa, PL_ISA_I8MM))
        *t = PL_S8_TABLE(PL_S8_LAYOUT_I8MM, pack_i8mm, neon, nn_conv_packed_s8_4x16c8__neoni8mm);
    else if (pl_isa_includes(isa, PL_ISA_DOTPROD))
        *t = PL_S8_TABLE(PL_S8_LAYOUT_SDOT, pack_sdot, neon, nn_conv_packed_s8_4x16c4__neondot);
    else if (pl_isa_includes(isa, PL_ISA_NEON))
        *t = PL_S8_TABLE(PL_S8_LAYOUT_SDOT, pack_sdot, neon, nn_conv_packed_s8_1x16c4__neon);
    (void)pack_vnni;
    (void)pack_avx2;
#else
    (void)isa;
    (void)pack_vnni;
    (void)pack_avx2;
    (void)pack_sdot;
    (void)pack_i8mm;
#endif
}

int pl_kernels_s8_list(const pl_kernels_s8 *t, const char **op, const char **impl, int max)
{
    static const char *const ref_ops[] = {"conv2d", "conv1x1", "conv1x1_clamp", "fc",
                                          "maxpool2d", "avgpool2d", "clamp"};
    static const char *const ref_impl[] = {"nn_conv2d_s8__ref",        "nn_conv1x1_s8__ref",
                                           "nn_conv1x1_clamp_s8__ref", "nn_fc_s8__ref",
                                           "nn_maxpool2d_s8__ref",     "nn_avgpool2d_s8__ref",
                                           "nn_clamp_s8__ref"};
    const char *ops[10], *impls[10];
    int n = 0;
    if (t->packed) {
        ops[n] = "pack (load)";
        impls[n++] = t->pack_name;
        ops[n] = "a_pack (1x1, fc input)";
        impls[n++] = t->a_pack_name;
        ops[n] = "a_pad (kxk input)";
        impls[n++] = t->a_pad_name;
        ops[n] = "a_rows (stem input)";
        impls[n++] = t->a_rows_name;
        ops[n] = "conv (kxk, 1x1, fc)";
        impls[n++] = t->run_name;
        ops[n] = "maxpool2d";
        impls[n++] = t->maxpool_name;
        ops[n] = "avgpool2d (+clamp)";
        impls[n++] = t->avgpool_name;
        ops[n] = "clamp";
        impls[n++] = t->clamp_name;
    } else {
        for (int i = 0; i < 7; i++) {
            ops[n] = ref_ops[i];
            impls[n++] = ref_impl[i];
        }
    }
    for (int i = 0; i < n && i < max; i++) {
        if (op) op[i] = ops[i];
        if (impl) impl[i] = impls[i];
    }
    return n;
}
