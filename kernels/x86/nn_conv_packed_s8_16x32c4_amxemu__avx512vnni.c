/* The AMX convolution with its tile operations emulated in C (kernels/x86/nn_conv_packed_s8_tmpl.h,
 * NN_T_AMX_EMU): the same packing, tile configuration, accumulation order and AVX-512
 * requantisation as nn_conv_packed_s8_16x32c4__amx, runnable on any AVX-512 VNNI CPU. For the
 * tests only: it is far slower than the VNNI kernel, so the Makefile links it into
 * tests/test_kernels_simd_s8 and keeps it out of the library (KERNEL_TEST_C). */
#define NN_T_AMX 1
#define NN_T_AMX_EMU 1
#define NN_T_NAME nn_conv_packed_s8_16x32c4_amxemu__avx512vnni
#include "kernels/x86/nn_conv_packed_s8_tmpl.h"
