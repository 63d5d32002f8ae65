/* The packed int8 convolution for dotprod (kernels/arm/nn_conv_packed_s8_tmpl.h). */
#define NN_T_DOTPROD 1
#define NN_T_NAME nn_conv_packed_s8_4x16c4__neondot
#include "kernels/arm/nn_conv_packed_s8_tmpl.h"
