/* The packed int8 convolution for avx512vnni (kernels/x86/nn_conv_packed_s8_tmpl.h). */
#define NN_T_AVX512VNNI 1
#define NN_T_NAME nn_conv_packed_s8_14x32c4__avx512vnni
#include "kernels/x86/nn_conv_packed_s8_tmpl.h"
