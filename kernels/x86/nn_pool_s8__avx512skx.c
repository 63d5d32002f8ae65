/* Pooling and clamping compiled for AVX-512 F/BW/DQ/VL (kernels/x86/nn_pool_s8_tmpl.h). */
#define NN_P_SUFFIX __avx512skx
#include "kernels/x86/nn_pool_s8_tmpl.h"
