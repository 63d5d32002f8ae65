/* int8 pooling and clamping for the packed path (kernels/kernels_s8.h): plain C written so the
 * compiler vectorises it with the including file's ISA flags (channels innermost, in chunks, no
 * aliasing). Included once per ISA with NN_P_SUFFIX set. Results equal nn_maxpool2d_s8__ref,
 * nn_avgpool2d_s8__ref (of the clamped input) and nn_clamp_s8__ref bit for bit. */
#include <string.h>

#include "kernels/x86/nn_s8_x86.h"

#define NN_P_CAT2(a, b) a##b
#define NN_P_CAT(a, b) NN_P_CAT2(a, b)
#define NN_P_CHUNK 256

/* The window of output pixel (oy, ox) clipped to the input. */
static inline void window(const nn_pool_s8_params *p, const nn_dims *in_dims, int oy, int ox,
                          int *y_lo, int *y_hi, int *x_lo, int *x_hi)
{
    const int iy0 = oy * p->stride_h - p->pad_h, ix0 = ox * p->stride_w - p->pad_w;
    *y_lo = iy0 < 0 ? 0 : iy0;
    *x_lo = ix0 < 0 ? 0 : ix0;
    *y_hi = iy0 + p->kernel_h < in_dims->h ? iy0 + p->kernel_h : in_dims->h;
    *x_hi = ix0 + p->kernel_w < in_dims->w ? ix0 + p->kernel_w : in_dims->w;
}

void NN_P_CAT(nn_maxpool2d_s8, NN_P_SUFFIX)(const nn_pool_s8_params *p, const nn_dims *in_dims,
                                            const int8_t *in, int in_c_stride,
                                            const nn_dims *out_dims, int8_t *out,
                                            int out_c_stride, int pix_begin, int pix_end)
{
    const int ow = out_dims->w, oh = out_dims->h, C = out_dims->c;
    const int8_t amin = (int8_t)p->act_min, amax = (int8_t)p->act_max;
    for (int pix = pix_begin; pix < pix_end; pix++) {
        const int ox = pix % ow, row = pix / ow, oy = row % oh, b = row / oh;
        int y_lo, y_hi, x_lo, x_hi;
        window(p, in_dims, oy, ox, &y_lo, &y_hi, &x_lo, &x_hi);
        int8_t *restrict o = out + (size_t)pix * (size_t)out_c_stride;
        for (int c0 = 0; c0 < C; c0 += NN_P_CHUNK) {
            const int n = C - c0 < NN_P_CHUNK ? C - c0 : NN_P_CHUNK;
            int8_t m[NN_P_CHUNK];
            memset(m, 0x80, sizeof m);
            for (int iy = y_lo; iy < y_hi; iy++)
                for (int ix = x_lo; ix < x_hi; ix++) {
                    const int8_t *restrict x =
                        in + nn_pixel_offset(in_dims, b, iy, ix, in_c_stride) + c0;
                    for (int c = 0; c < n; c++)
                        m[c] = x[c] > m[c] ? x[c] : m[c];
                }
            for (int c = 0; c < n; c++) {
                int8_t v = m[c] < amin ? amin : m[c];
                o[c0 + c] = v > amax ? amax : v;
            }
        }
    }
}

void NN_P_CAT(nn_avgpool2d_s8, NN_P_SUFFIX)(const nn_pool_s8_params *p, const nn_dims *in_dims,
                                            const int8_t *in, int in_c_stride, const int8_t *lo,
                                            const int8_t *hi, const nn_dims *out_dims,
                                            uint8_t *out, int out_c_stride, uint8_t out_xor,
                                            int pix_begin, int pix_end)
{
    const int ow = out_dims->w, oh = out_dims->h, C = out_dims->c;
    for (int pix = pix_begin; pix < pix_end; pix++) {
        const int ox = pix % ow, row = pix / ow, oy = row % oh, b = row / oh;
        int y_lo, y_hi, x_lo, x_hi;
        window(p, in_dims, oy, ox, &y_lo, &y_hi, &x_lo, &x_hi);
        const int32_t count = (int32_t)(y_hi - y_lo) * (x_hi - x_lo), half = count / 2;
        const int pow2 = (count & (count - 1)) == 0;
        const int k = pow2 ? __builtin_ctz((unsigned)count) : 0;
        uint8_t *restrict o = out + (size_t)pix * (size_t)out_c_stride;
        for (int c0 = 0; c0 < C; c0 += NN_P_CHUNK) {
            const int n = C - c0 < NN_P_CHUNK ? C - c0 : NN_P_CHUNK;
            int32_t sum[NN_P_CHUNK];
            memset(sum, 0, sizeof sum);
            for (int iy = y_lo; iy < y_hi; iy++)
                for (int ix = x_lo; ix < x_hi; ix++) {
                    const int8_t *restrict x =
                        in + nn_pixel_offset(in_dims, b, iy, ix, in_c_stride) + c0;
                    if (lo) {
                        const int8_t *restrict l = lo + c0, *restrict h = hi + c0;
                        for (int c = 0; c < n; c++) {
                            int8_t v = x[c] < l[c] ? l[c] : x[c];
                            sum[c] += v > h[c] ? h[c] : v;
                        }
                    } else {
                        for (int c = 0; c < n; c++)
                            sum[c] += x[c];
                    }
                }
            int32_t avg[NN_P_CHUNK];
            if (pow2) { /* the same rounding, with shifts the compiler vectorises */
                for (int c = 0; c < n; c++)
                    avg[c] = sum[c] > 0 ? (sum[c] + half) >> k : -((half - sum[c]) >> k);
            } else {
                for (int c = 0; c < n; c++)
                    avg[c] = sum[c] > 0 ? (sum[c] + half) / count : (sum[c] - half) / count;
            }
            for (int c = 0; c < n; c++) {
                int32_t v = avg[c] < p->act_min ? p->act_min : avg[c];
                v = v > p->act_max ? p->act_max : v;
                o[c0 + c] = (uint8_t)((uint8_t)(int8_t)v ^ out_xor);
            }
        }
    }
}

void NN_P_CAT(nn_clamp_s8, NN_P_SUFFIX)(const nn_dims *d, int8_t *data, int c_stride,
                                        const int8_t *lo, const int8_t *hi, int pix_begin,
                                        int pix_end)
{
    const int C = d->c;
    for (int pix = pix_begin; pix < pix_end; pix++) {
        int8_t *restrict x = data + (size_t)pix * (size_t)c_stride;
        const int8_t *restrict l = lo, *restrict h = hi;
        for (int c = 0; c < C; c++) {
            int8_t v = x[c] < l[c] ? l[c] : x[c];
            x[c] = v > h[c] ? h[c] : v;
        }
    }
}
