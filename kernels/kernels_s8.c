/* int8 kernel slots (kernels/kernels_s8.h). */
#include "kernels/kernels_s8.h"

void pl_kernels_s8_fill(pl_kernels_s8 *t, pl_isa isa)
{
    (void)isa;
    t->conv2d = nn_conv2d_s8__ref;
    t->conv2d_name = "ref";
}
