/* fp32 kernel slots (kernels/kernels_f32.h). */
#include "kernels/kernels_f32.h"

void pl_kernels_f32_fill(pl_kernels_f32 *t, pl_isa isa)
{
    (void)isa;
    t->conv2d = nn_conv2d_f32__ref;
    t->conv2d_name = "ref";
}
