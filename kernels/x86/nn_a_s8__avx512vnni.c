/* A builders compiled for AVX-512 (kernels/x86/nn_a_s8_tmpl.h). */
#define NN_A_SUFFIX __avx512vnni
#include "kernels/x86/nn_a_s8_tmpl.h"
