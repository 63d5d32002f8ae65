/* Pooling and clamping compiled for AVX2 (kernels/x86/nn_pool_s8_tmpl.h). */
#define NN_P_SUFFIX __avx2
#include "kernels/x86/nn_pool_s8_tmpl.h"
