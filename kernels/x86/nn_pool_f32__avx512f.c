/* Max and average pooling, fp32, vectorised for this ISA (kernels/x86/nn_pool_f32_tmpl.h). */
#define MAXPOOL_FN nn_maxpool2d_f32__avx512f
#define AVGPOOL_FN nn_avgpool2d_f32__avx512f
#include "kernels/x86/nn_pool_f32_tmpl.h"
