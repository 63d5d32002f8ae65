/* The kernel table: which implementation each operation uses, filled once from the selected
 * instruction-set path (kernels/isa.h). The int8 operations are described in
 * kernels/kernels_s8.h, the fp32 ones in kernels/kernels_f32.h; every slot is always filled
 * (the reference kernel where a path has no faster one), and each slot carries the name of the
 * implementation it holds so `parlight info` can print it. */
#ifndef PL_KERNELS_DISPATCH_H
#define PL_KERNELS_DISPATCH_H

#include "kernels/isa.h"
#include "kernels/kernels_f32.h"
#include "kernels/kernels_s8.h"

typedef struct pl_kernels {
    pl_isa isa;
    pl_kernels_s8 s8;
    pl_kernels_f32 f32;
} pl_kernels;

/* The table for pl_isa_select()'s path, filled on first use; thread-safe. Errors as
 * pl_isa_select (a PARLIGHT_ISA this CPU cannot run). */
int pl_kernels_get(const pl_kernels **out);

/* A table for a given path (tests and benchmarks compare paths in one process).
 * PL_E_UNSUPPORTED when the CPU or build cannot run it. */
int pl_kernels_for(pl_isa isa, pl_kernels *out);

#endif
