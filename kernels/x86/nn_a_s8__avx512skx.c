/* A builders compiled for AVX-512 F/BW/DQ/VL (kernels/x86/nn_a_s8_tmpl.h). */
#define NN_A_SUFFIX __avx512skx
#include "kernels/x86/nn_a_s8_tmpl.h"
