/* The packed int8 convolution for i8mm (kernels/arm/nn_conv_packed_s8_tmpl.h). */
#define NN_T_I8MM 1
#define NN_T_NAME nn_conv_packed_s8_4x16c8__neoni8mm
#include "kernels/arm/nn_conv_packed_s8_tmpl.h"
