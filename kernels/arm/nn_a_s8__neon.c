/* A builders for every Arm path: the x86 paths' plain C (kernels/x86/nn_a_s8_tmpl.h), which gcc
 * vectorises for the AArch64 baseline (NEON is mandatory there). */
#include "kernels/arm/nn_s8_arm.h"

#define NN_A_SUFFIX __neon
#include "kernels/x86/nn_a_s8_tmpl.h"
