/* kernels/isa.c's path selection and the kernel tables it fills, for CPUs this machine is not:
 * pl_isa_paths_of and pl_isa_best are pure, so a test can feed them a Skylake-SP (AVX-512
 * F/BW/DQ/VL without VNNI), a Cascade Lake (with VNNI), an Alder Lake (AVX2 + AVX-VNNI, no
 * AVX-512), a CPU whose OS does not save the ZMM state, and Arm cores. Each path must take
 * exactly the kernels whose instructions (the suffix after "__") its features guarantee: the
 * AVX-512 fp32 kernels need only AVX-512F, so the Skylake-SP path runs them, with the AVX2 int8
 * kernels (the int8 AVX-512 ones need VNNI and BW). Also the forced path PARLIGHT_ISA=avx512f,
 * where this CPU has it. */
#include <stdio.h>
#include <string.h>

#include "core/status.h"
#include "kernels/dispatch.h"
#include "kernels/isa.h"
#include "tests/check.h"

/* The suffix after "__" of a kernel name. */
static const char *isa_of(const char *name)
{
    const char *p = strstr(name, "__");
    return p ? p + 2 : "";
}

/* Every slot of the tables for `isa` names a kernel with one of the allowed suffixes. */
static void check_suffixes(pl_isa isa, const char *const *allowed, int n_allowed)
{
    pl_kernels_f32 f;
    pl_kernels_s8 s;
    pl_kernels_f32_fill(&f, isa);
    pl_kernels_s8_fill(&s, isa);
    const char *names[32];
    int nf = pl_kernels_f32_list(&f, NULL, names, 16);
    nf = nf < 16 ? nf : 16;
    int ns = pl_kernels_s8_list(&s, NULL, names + nf, 16);
    const int n = nf + (ns < 16 ? ns : 16);
    for (int i = 0; i < n; i++) {
        if (strncmp(names[i], "nn_", 3)) continue; /* packing at load, "off (...)" notes */
        int ok = 0;
        for (int a = 0; a < n_allowed; a++)
            ok |= !strcmp(isa_of(names[i]), allowed[a]);
        CHECK(ok, "path %s runs %s, whose instructions the path does not guarantee",
              pl_isa_name(isa), names[i]);
    }
}

int main(void)
{
    int have[PL_ISA_COUNT];
#if defined(__x86_64__)
    const pl_cpu_features avx2 = {.avx = 1, .fma = 1, .avx2 = 1, .ymm_os = 1};
    pl_cpu_features skx = avx2; /* Skylake-SP: AVX-512 F/BW/DQ/VL, no VNNI */
    skx.zmm_os = skx.avx512f = skx.avx512bw = skx.avx512dq = skx.avx512vl = 1;
    pl_cpu_features clx = skx; /* Cascade Lake: + AVX512_VNNI */
    clx.avx512vnni = 1;
    pl_cpu_features adl = avx2; /* Alder Lake: AVX-VNNI, no AVX-512 */
    adl.avxvnni = 1;
    pl_cpu_features no_zmm = clx; /* the OS does not save the ZMM state */
    no_zmm.zmm_os = 0;
    pl_cpu_features spr = clx; /* Sapphire Rapids, tile state granted */
    spr.avxvnni = spr.amx_tile = spr.amx_int8 = spr.amx_granted = 1;

    pl_isa_paths_of(&skx, have);
    CHECK(have[PL_ISA_AVX512F] && !have[PL_ISA_AVX512VNNI] && have[PL_ISA_AVX2],
          "Skylake-SP: paths avx512f %d avx512vnni %d avx2 %d", have[PL_ISA_AVX512F],
          have[PL_ISA_AVX512VNNI], have[PL_ISA_AVX2]);
    CHECK(pl_isa_best(have) == PL_ISA_AVX512F, "Skylake-SP picks %s, expected avx512f",
          pl_isa_name(pl_isa_best(have)));
    pl_kernels_f32 f;
    pl_kernels_s8 s;
    pl_kernels_f32_fill(&f, PL_ISA_AVX512F);
    pl_kernels_s8_fill(&s, PL_ISA_AVX512F);
    CHECK(!strcmp(f.conv_name, "nn_conv_gemm_f32_8x48__avx512f") &&
              !strcmp(f.fc_name, "nn_fc_f32__avx512f") &&
              !strcmp(f.bn_relu_name, "nn_bn_relu_f32__avx512f"),
          "avx512f: fp32 conv %s, fc %s, bn_relu %s: expected the AVX-512F kernels", f.conv_name,
          f.fc_name, f.bn_relu_name);
    CHECK(!strcmp(s.run_name, "nn_conv_packed_s8_4x16c4__avx2"),
          "avx512f: int8 conv %s, expected the AVX2 one", s.run_name);

    pl_isa_paths_of(&clx, have);
    CHECK(pl_isa_best(have) == PL_ISA_AVX512VNNI && have[PL_ISA_AVX512F],
          "Cascade Lake picks %s, expected avx512vnni", pl_isa_name(pl_isa_best(have)));
    pl_isa_paths_of(&adl, have);
    CHECK(pl_isa_best(have) == PL_ISA_AVXVNNI && !have[PL_ISA_AVX512F],
          "Alder Lake picks %s, expected avxvnni", pl_isa_name(pl_isa_best(have)));
    pl_isa_paths_of(&no_zmm, have);
    CHECK(pl_isa_best(have) == PL_ISA_AVX2 && !have[PL_ISA_AVX512F],
          "without the ZMM state: %s, expected avx2", pl_isa_name(pl_isa_best(have)));
    pl_isa_paths_of(&spr, have);
    CHECK(have[PL_ISA_AMX] && pl_isa_best(have) == PL_ISA_AMX, "Sapphire Rapids: amx %d, picks %s",
          have[PL_ISA_AMX], pl_isa_name(pl_isa_best(have)));
    pl_cpu_features spr_denied = spr; /* Linux refused the tile state (ARCH_REQ_XCOMP_PERM) */
    spr_denied.amx_granted = 0;
    pl_isa_paths_of(&spr_denied, have);
    CHECK(!have[PL_ISA_AMX] && pl_isa_best(have) == PL_ISA_AVX512VNNI,
          "Sapphire Rapids without the tile state: amx %d, picks %s, expected avx512vnni",
          have[PL_ISA_AMX], pl_isa_name(pl_isa_best(have)));
    const pl_cpu_features none = {0};
    pl_isa_paths_of(&none, have);
    CHECK(pl_isa_best(have) == PL_ISA_REF, "no AVX: %s", pl_isa_name(pl_isa_best(have)));

    static const char *const s_avx2[] = {"ref", "avx2"};
    static const char *const s_avxvnni[] = {"ref", "avx2", "avxvnni"};
    static const char *const s_avx512f[] = {"ref", "avx2", "avx512f"};
    static const char *const s_avx512vnni[] = {"ref", "avx2", "avx512f", "avx512skx", "avx512vnni"};
    check_suffixes(PL_ISA_AVX2, s_avx2, 2);
    check_suffixes(PL_ISA_AVXVNNI, s_avxvnni, 3);
    check_suffixes(PL_ISA_AVX512F, s_avx512f, 3);
    check_suffixes(PL_ISA_AVX512VNNI, s_avx512vnni, 5);

    /* the forced path on this CPU, when it has AVX-512F */
    pl_kernels k;
    if (pl_kernels_for(PL_ISA_AVX512F, &k) == 0) {
        CHECK(!strcmp(k.f32.conv_name, "nn_conv_gemm_f32_8x48__avx512f"),
              "forced avx512f: fp32 conv %s", k.f32.conv_name);
        printf("forced avx512f here: fp32 %s, int8 %s\n", k.f32.conv_name, k.s8.run_name);
    } else {
        printf("forced avx512f: not on this CPU (%s)\n", pl_last_error());
    }
#elif defined(__aarch64__)
    const pl_cpu_features a72 = {.neon = 1}, a76 = {.neon = 1, .dotprod = 1},
                          v2 = {.neon = 1, .dotprod = 1, .i8mm = 1};
    pl_isa_paths_of(&a72, have);
    CHECK(pl_isa_best(have) == PL_ISA_NEON, "Cortex-A72 picks %s", pl_isa_name(pl_isa_best(have)));
    pl_isa_paths_of(&a76, have);
    CHECK(pl_isa_best(have) == PL_ISA_DOTPROD, "Cortex-A76 picks %s",
          pl_isa_name(pl_isa_best(have)));
    pl_isa_paths_of(&v2, have);
    CHECK(pl_isa_best(have) == PL_ISA_I8MM, "Neoverse-V2 picks %s", pl_isa_name(pl_isa_best(have)));
    static const char *const s_neon[] = {"ref", "neon"};
    static const char *const s_dot[] = {"ref", "neon", "neondot"};
    static const char *const s_i8mm[] = {"ref", "neon", "neoni8mm"};
    check_suffixes(PL_ISA_NEON, s_neon, 2);
    check_suffixes(PL_ISA_DOTPROD, s_dot, 3);
    check_suffixes(PL_ISA_I8MM, s_i8mm, 3);
#else
    pl_isa_paths_of(&(pl_cpu_features){0}, have);
    CHECK(pl_isa_best(have) == PL_ISA_REF, "portable build picks %s",
          pl_isa_name(pl_isa_best(have)));
#endif
    printf("%s\n", failures ? "FAILED" : "ok");
    return failures ? 1 : 0;
}
