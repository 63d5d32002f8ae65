/* int8 pooling and clamping for every Arm path: the x86 paths' plain C
 * (kernels/x86/nn_pool_s8_tmpl.h, bit-exact to the reference), vectorised for the AArch64
 * baseline. */
#include "kernels/arm/nn_s8_arm.h"

#define NN_P_SUFFIX __neon
#include "kernels/x86/nn_pool_s8_tmpl.h"
