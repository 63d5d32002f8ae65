/* The packed int8 convolution on AMX tiles (kernels/x86/nn_conv_packed_s8_tmpl.h, NN_T_AMX):
 * tdpbusd accumulates 16 pixels x 32 channels, AVX-512 requantises. Run on the amx path, the
 * first choice where the CPU has AMX-INT8 and Linux grants the tile state (kernels/isa.c). */
#define NN_T_AMX 1
#define NN_T_NAME nn_conv_packed_s8_16x32c4__amx
#include "kernels/x86/nn_conv_packed_s8_tmpl.h"
