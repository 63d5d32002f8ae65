/* The packed int8 convolution for avx2 (kernels/x86/nn_conv_packed_s8_tmpl.h). */
#define NN_T_AVX2 1
#define NN_T_NAME nn_conv_packed_s8_4x16c4__avx2
#include "kernels/x86/nn_conv_packed_s8_tmpl.h"
