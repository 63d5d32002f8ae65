/* The packed int8 convolution for neon (kernels/arm/nn_conv_packed_s8_tmpl.h). */
#define NN_T_NEON 1
#define NN_T_NAME nn_conv_packed_s8_1x16c4__neon
#include "kernels/arm/nn_conv_packed_s8_tmpl.h"
