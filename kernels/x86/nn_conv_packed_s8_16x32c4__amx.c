/* The packed int8 convolution on AMX tiles (kernels/x86/nn_conv_packed_s8_tmpl.h, NN_T_AMX):
 * tdpbusd accumulates 16 pixels x 32 channels, AVX-512 requantises. Run only on the amx path
 * (PARLIGHT_ISA=amx), which is never chosen by itself: it has not yet run on AMX hardware. */
#define NN_T_AMX 1
#define NN_T_NAME nn_conv_packed_s8_16x32c4__amx
#include "kernels/x86/nn_conv_packed_s8_tmpl.h"
