/* A builders compiled for AVX2 (kernels/x86/nn_a_s8_tmpl.h). */
#define NN_A_SUFFIX __avx2
#include "kernels/x86/nn_a_s8_tmpl.h"
