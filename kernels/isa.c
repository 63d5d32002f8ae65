/* CPU probing and PARLIGHT_ISA (kernels/isa.h). */
#include "kernels/isa.h"

#include <pthread.h>
#include <stdlib.h>
#include <string.h>

#include "core/util.h"

#if defined(__x86_64__) || defined(__i386__)
#include <cpuid.h>
#include <sys/syscall.h>
#include <unistd.h>
#elif defined(__aarch64__) && defined(__linux__)
#include <sys/auxv.h>
#ifndef HWCAP_ASIMDDP
#define HWCAP_ASIMDDP (1 << 20)
#endif
#ifndef HWCAP2_I8MM
#define HWCAP2_I8MM (1 << 13)
#endif
#endif

static const char *const names[PL_ISA_COUNT] = {"ref", "avx2", "avxvnni", "avx512f", "avx512vnni",
                                                "amx", "neon", "dotprod", "i8mm"};

/* What each path needs beyond its parent (for messages). */
static const char *const needs[PL_ISA_COUNT] = {
    "",
    "x86-64 with AVX2 and FMA (and OS support for the YMM state)",
    "AVX2 and AVX-VNNI",
    "AVX2 and AVX-512F (and OS support for the ZMM state)",
    "AVX-512 F/BW/DQ/VL and AVX512_VNNI (and OS support for the ZMM state)",
    "AVX512_VNNI and AMX-TILE/AMX-INT8 (and the kernel granting the tile state)",
    "AArch64 with Advanced SIMD",
    "Armv8.2 dotprod (SDOT/UDOT)",
    "Armv8.6 i8mm (SMMLA/USMMLA) and dotprod",
};

static int have[PL_ISA_COUNT];
static pthread_once_t probe_once = PTHREAD_ONCE_INIT;

#if defined(__x86_64__)
static unsigned long long xgetbv0(void)
{
    unsigned eax, edx;
    __asm__ volatile("xgetbv" : "=a"(eax), "=d"(edx) : "c"(0));
    return ((unsigned long long)edx << 32) | eax;
}

/* Linux hands out the AMX tile state only on request (arch_prctl ARCH_REQ_XCOMP_PERM). */
static int request_amx(void)
{
    enum { ARCH_REQ_XCOMP_PERM = 0x1023, XFEATURE_XTILEDATA = 18 };
    return syscall(SYS_arch_prctl, ARCH_REQ_XCOMP_PERM, XFEATURE_XTILEDATA) == 0;
}
#endif

void pl_isa_paths_of(const pl_cpu_features *f, int paths[PL_ISA_COUNT])
{
    for (int i = 0; i < PL_ISA_COUNT; i++)
        paths[i] = 0;
    paths[PL_ISA_REF] = 1;
#if defined(__x86_64__)
    paths[PL_ISA_AVX2] = f->avx && f->ymm_os && f->avx2 && f->fma;
    paths[PL_ISA_AVXVNNI] = paths[PL_ISA_AVX2] && f->avxvnni;
    paths[PL_ISA_AVX512F] = paths[PL_ISA_AVX2] && f->zmm_os && f->avx512f;
    paths[PL_ISA_AVX512VNNI] = paths[PL_ISA_AVX512F] && f->avx512dq && f->avx512bw &&
                              f->avx512vl && f->avx512vnni;
    paths[PL_ISA_AMX] = paths[PL_ISA_AVX512VNNI] && f->amx_tile && f->amx_int8 && f->amx_granted;
#elif defined(__aarch64__)
    paths[PL_ISA_NEON] = f->neon;
    paths[PL_ISA_DOTPROD] = paths[PL_ISA_NEON] && f->dotprod;
    paths[PL_ISA_I8MM] = paths[PL_ISA_DOTPROD] && f->i8mm;
#else
    (void)f;
#endif
}

pl_isa pl_isa_best(const int paths[PL_ISA_COUNT])
{
    /* Best first. AMX's tile convolution runs bit-exact on AMX hardware (tests/test_isa_exact.sh,
     * test_kernels_simd_s8) and takes 0.46-0.69x AVX-512 VNNI's time per int8 frame
     * (docs/PERFORMANCE.md, "AMX on hardware"). int8 matters more than fp32, so AVX-VNNI goes
     * before AVX-512F. */
    static const pl_isa order[] = {PL_ISA_AMX,     PL_ISA_AVX512VNNI, PL_ISA_AVXVNNI,
                                   PL_ISA_AVX512F, PL_ISA_AVX2,       PL_ISA_I8MM,
                                   PL_ISA_DOTPROD, PL_ISA_NEON};
    for (size_t i = 0; i < sizeof order / sizeof order[0]; i++)
        if (paths[order[i]]) return order[i];
    return PL_ISA_REF;
}

static void probe(void)
{
    pl_cpu_features f = {0};
#if defined(__x86_64__)
    unsigned a, b, c, d;
    if (__get_cpuid(1, &a, &b, &c, &d) && ((c >> 27) & 1) /* OSXSAVE */) {
        f.fma = (c >> 12) & 1;
        f.avx = (c >> 28) & 1;
        const unsigned long long xcr0 = xgetbv0();
        f.ymm_os = (xcr0 & 0x6) == 0x6;
        f.zmm_os = (xcr0 & 0xe6) == 0xe6;
        const int amx_os = (xcr0 & 0x60000) == 0x60000;
        if (__get_cpuid_max(0, NULL) >= 7) {
            __cpuid_count(7, 0, a, b, c, d);
            f.avx2 = (b >> 5) & 1;
            f.avx512f = (b >> 16) & 1;
            f.avx512dq = (b >> 17) & 1;
            f.avx512bw = (b >> 30) & 1;
            f.avx512vl = (b >> 31) & 1;
            f.avx512vnni = (c >> 11) & 1;
            f.amx_tile = (d >> 24) & 1;
            f.amx_int8 = (d >> 25) & 1;
            __cpuid_count(7, 1, a, b, c, d);
            f.avxvnni = (a >> 4) & 1;
            /* ask for the tile state only where AMX could run */
            f.amx_granted = amx_os && f.amx_tile && f.amx_int8 && f.avx512vnni && f.zmm_os &&
                            request_amx();
        }
    }
#elif defined(__aarch64__)
    f.neon = 1; /* mandatory in AArch64 */
#if defined(__linux__)
    const unsigned long hw = getauxval(AT_HWCAP), hw2 = getauxval(AT_HWCAP2);
    f.dotprod = (hw & HWCAP_ASIMDDP) != 0;
    f.i8mm = (hw2 & HWCAP2_I8MM) != 0;
#endif
#endif
    pl_isa_paths_of(&f, have);
}

const char *pl_isa_name(pl_isa isa)
{
    return (unsigned)isa < PL_ISA_COUNT ? names[isa] : "?";
}

int pl_isa_supported(pl_isa isa)
{
    if ((unsigned)isa >= PL_ISA_COUNT) return 0;
    pthread_once(&probe_once, probe);
    return have[isa];
}

int pl_isa_includes(pl_isa isa, pl_isa base)
{
    if (base == PL_ISA_REF) return 1;
    switch (isa) {
    case PL_ISA_AVX2: return base == PL_ISA_AVX2;
    case PL_ISA_AVXVNNI: return base == PL_ISA_AVX2 || base == PL_ISA_AVXVNNI;
    case PL_ISA_AVX512F: return base == PL_ISA_AVX2 || base == PL_ISA_AVX512F;
    case PL_ISA_AVX512VNNI:
        return base == PL_ISA_AVX2 || base == PL_ISA_AVX512F || base == PL_ISA_AVX512VNNI;
    case PL_ISA_AMX:
        return base == PL_ISA_AVX2 || base == PL_ISA_AVX512F || base == PL_ISA_AVX512VNNI ||
               base == PL_ISA_AMX;
    case PL_ISA_NEON: return base == PL_ISA_NEON;
    case PL_ISA_DOTPROD: return base == PL_ISA_NEON || base == PL_ISA_DOTPROD;
    case PL_ISA_I8MM: return base == PL_ISA_NEON || base == PL_ISA_DOTPROD || base == PL_ISA_I8MM;
    default: return 0;
    }
}

int pl_isa_select(pl_isa *out)
{
    pthread_once(&probe_once, probe);
    const char *env = getenv("PARLIGHT_ISA");
    if (env && *env) {
        for (int i = 0; i < PL_ISA_COUNT; i++) {
            if (strcmp(env, names[i])) continue;
            if (!have[i])
                return pl_error(PL_E_UNSUPPORTED,
                                "PARLIGHT_ISA=%s: this CPU or build cannot run it (needs %s)", env,
                                needs[i]);
            *out = (pl_isa)i;
            return PL_OK;
        }
        return pl_error(PL_E_ARG,
                        "PARLIGHT_ISA=%s: unknown path (ref, avx2, avxvnni, avx512f, avx512vnni, "
                        "amx, neon, dotprod, i8mm)",
                        env);
    }
    *out = pl_isa_best(have);
    return PL_OK;
}
