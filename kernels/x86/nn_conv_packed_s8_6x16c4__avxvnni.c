/* The packed int8 convolution for avxvnni (kernels/x86/nn_conv_packed_s8_tmpl.h). */
#define NN_T_AVXVNNI 1
#define NN_T_NAME nn_conv_packed_s8_6x16c4__avxvnni
#include "kernels/x86/nn_conv_packed_s8_tmpl.h"
