/* Instruction-set paths and their run-time selection. The CPU is probed once (cpuid + xgetbv on
 * x86, getauxval on Arm); PARLIGHT_ISA=ref|avx2|avxvnni|avx512f|avx512vnni|amx|neon|dotprod|i8mm
 * forces a path, with an error when this CPU (or this build) lacks it. Kernel tables
 * (kernels/dispatch.h) are filled from the selected path: a path takes exactly the kernels whose
 * instructions (the suffix of their file, see the Makefile) its features guarantee. */
#ifndef PL_KERNELS_ISA_H
#define PL_KERNELS_ISA_H

typedef enum pl_isa {
    PL_ISA_REF, /* portable C, the reference every other path must equal (int8) or approach (fp32) */
    PL_ISA_AVX2,       /* x86-64-v3: AVX2 + FMA */
    PL_ISA_AVXVNNI,    /* AVX2 + AVX-VNNI (VEX-encoded vpdpbusd) */
    PL_ISA_AVX512F,    /* AVX2 + AVX-512F: the fp32 AVX-512 kernels (a Skylake-SP, no VNNI) */
    PL_ISA_AVX512VNNI, /* AVX2 + AVX-512 F/BW/DQ/VL + AVX512_VNNI */
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
 * (avx512vnni includes avx512f and avx2, dotprod includes neon, everything includes ref). */
int pl_isa_includes(pl_isa isa, pl_isa base);

/* The CPU features the paths are made of, as cpuid/xgetbv or getauxval report them (the *_os
 * fields: the OS saves that register state; amx_granted: Linux granted the tile state). */
typedef struct pl_cpu_features {
    int avx, fma, avx2, ymm_os, zmm_os;
    int avx512f, avx512bw, avx512dq, avx512vl, avx512vnni, avxvnni;
    int amx_tile, amx_int8, amx_granted;
    int neon, dotprod, i8mm;
} pl_cpu_features;

/* The paths a CPU with `f` runs (paths[i] for pl_isa i; ref always) and the best of them, as
 * pl_isa_select picks it without PARLIGHT_ISA. Pure: tests feed it CPUs this machine is not. */
void pl_isa_paths_of(const pl_cpu_features *f, int paths[PL_ISA_COUNT]);
pl_isa pl_isa_best(const int paths[PL_ISA_COUNT]);

#endif
