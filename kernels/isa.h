/* Instruction-set paths and their run-time selection. The CPU is probed once (cpuid + xgetbv on
 * x86, getauxval on Arm); PARLIGHT_ISA=ref|avx2|avxvnni|avx512vnni|amx|neon|dotprod|i8mm forces a
 * path, with an error when this CPU (or this build) lacks it. Kernel tables (kernels/dispatch.h)
 * are filled from the selected path. */
#ifndef PL_KERNELS_ISA_H
#define PL_KERNELS_ISA_H

typedef enum pl_isa {
    PL_ISA_REF, /* portable C, the reference every other path must equal (int8) or approach (fp32) */
    PL_ISA_AVX2,       /* x86-64-v3: AVX2 + FMA */
    PL_ISA_AVXVNNI,    /* AVX2 + AVX-VNNI (VEX-encoded vpdpbusd) */
    PL_ISA_AVX512VNNI, /* x86-64-v4 + AVX512_VNNI */
    PL_ISA_AMX,        /* AVX512_VNNI + AMX-INT8 (the OS must grant the tile state) */
    PL_ISA_NEON,       /* AArch64 Advanced SIMD */
    PL_ISA_DOTPROD,    /* NEON + SDOT/UDOT (Armv8.2 dotprod) */
    PL_ISA_I8MM,       /* dotprod + SMMLA/USMMLA (Armv8.6 i8mm) */
    PL_ISA_COUNT
} pl_isa;

/* "ref", "avx2", ... as PARLIGHT_ISA spells them; "?" out of range. */
const char *pl_isa_name(pl_isa isa);

/* Whether this CPU, OS and build can run the path (the x86 paths only on x86 builds, ...). */
int pl_isa_supported(pl_isa isa);

/* The path to use: PARLIGHT_ISA when set, else the best supported one. Probed once; thread-safe.
 * PL_E_ARG for an unknown PARLIGHT_ISA name, PL_E_UNSUPPORTED when the CPU or build lacks it
 * (the message names the path and what is missing). */
int pl_isa_select(pl_isa *out);

/* Whether `isa` includes `base`: every kernel of `base` may run under `isa`
 * (avx512vnni includes avx2, dotprod includes neon, everything includes ref). */
int pl_isa_includes(pl_isa isa, pl_isa base);

#endif
