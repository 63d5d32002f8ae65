/* Max and average pooling, fp32, for every Arm path (kernels/x86/nn_pool_f32_tmpl.h: plain C,
 * vectorised for the AArch64 baseline, bit-exact to the reference). */
#include "kernels/arm/nn_f32_arm.h"

#define MAXPOOL_FN nn_maxpool2d_f32__neon
#define AVGPOOL_FN nn_avgpool2d_f32__neon
#include "kernels/x86/nn_pool_f32_tmpl.h"
