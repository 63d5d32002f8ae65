/* Building A for the packed int8 path (kernels/kernels_s8.h): plain C the compiler vectorises
 * with the including file's ISA flags. Included once per ISA with NN_A_SUFFIX set. */
#include <string.h>

#include "kernels/x86/nn_s8_x86.h"

#define NN_A_CAT2(a, b) a##b
#define NN_A_CAT(a, b) NN_A_CAT2(a, b)

void NN_A_CAT(nn_a_pack_s8, NN_A_SUFFIX)(const nn_dims *in_dims, const int8_t *in,
                                         int in_c_stride, const int8_t *lo, const int8_t *hi,
                                         int stride_h, int stride_w, const nn_dims *out_dims,
                                         uint8_t *a, int cs, int pix_begin, int pix_end)
{
    const int in_c = in_dims->c, ow = out_dims->w, oh = out_dims->h;
    /* the output position steps with p (no division per pixel) */
    int ox = pix_begin % ow, oy = pix_begin / ow % oh, b = pix_begin / ow / oh;
    for (int p = pix_begin; p < pix_end; p++) {
        const int8_t *restrict x =
            in + nn_pixel_offset(in_dims, b, oy * stride_h, ox * stride_w, in_c_stride);
        uint8_t *restrict d = a + (size_t)p * (size_t)cs;
        if (++ox == ow) {
            ox = 0;
            if (++oy == oh) {
                oy = 0;
                b++;
            }
        }
        if (lo) {
            for (int ch = 0; ch < in_c; ch++) {
                int8_t v = x[ch];
                v = v < lo[ch] ? lo[ch] : v;
                v = v > hi[ch] ? hi[ch] : v;
                d[ch] = (uint8_t)((uint8_t)v ^ 0x80u);
            }
        } else {
            for (int ch = 0; ch < in_c; ch++)
                d[ch] = (uint8_t)((uint8_t)x[ch] ^ 0x80u);
        }
        for (int ch = in_c; ch < cs; ch++)
            d[ch] = 0;
    }
}

void NN_A_CAT(nn_a_pad_s8, NN_A_SUFFIX)(const nn_dims *in_dims, const int8_t *in, int in_c_stride,
                                        int pad_h, int pad_w, uint8_t pad_u, int a_h, int a_w,
                                        uint8_t *a, int cs, int row_begin, int row_end)
{
    const int in_c = in_dims->c, ih = in_dims->h, iw = in_dims->w;
    for (int r = row_begin; r < row_end; r++) {
        const int b = r / a_h, iy = r % a_h - pad_h;
        uint8_t *d = a + (size_t)r * (size_t)a_w * (size_t)cs;
        if (iy < 0 || iy >= ih) {
            memset(d, pad_u, (size_t)a_w * (size_t)cs);
            continue;
        }
        for (int xx = 0; xx < a_w; xx++, d += cs) {
            const int ix = xx - pad_w;
            if (ix < 0 || ix >= iw) {
                memset(d, pad_u, (size_t)cs);
                continue;
            }
            const int8_t *restrict x = in + nn_pixel_offset(in_dims, b, iy, ix, in_c_stride);
            uint8_t *restrict dd = d;
            for (int ch = 0; ch < in_c; ch++)
                dd[ch] = (uint8_t)((uint8_t)x[ch] ^ 0x80u);
            for (int ch = in_c; ch < cs; ch++)
                dd[ch] = 0;
        }
    }
}

void NN_A_CAT(nn_a_rows_s8, NN_A_SUFFIX)(const nn_dims *in_dims, const int8_t *in,
                                         int in_c_stride, int pad_h, int pad_w, uint8_t pad_u,
                                         int k_w, int stride_w, int dilation_w, int a_h, int a_w,
                                         uint8_t *a, int cs, int row_begin, int row_end)
{
    const int in_c = in_dims->c, ih = in_dims->h, iw = in_dims->w;
    for (int r = row_begin; r < row_end; r++) {
        const int b = r / a_h, iy = r % a_h - pad_h;
        uint8_t *d = a + (size_t)r * (size_t)a_w * (size_t)cs;
        for (int xx = 0; xx < a_w; xx++, d += cs) {
            const int ix0 = xx * stride_w - pad_w;
            if (iy >= 0 && iy < ih && ix0 >= 0 && ix0 + (k_w - 1) * dilation_w < iw &&
                dilation_w == 1 && in_c_stride == in_c) {
                /* the k_w pixels are contiguous: one run of k_w*in_c bytes */
                const int8_t *x = in + nn_pixel_offset(in_dims, b, iy, ix0, in_c_stride);
                const int n = k_w * in_c;
                if (n >= 8) { /* 8-byte words, the last one overlapping: no byte loop */
                    for (int i = 0;; i += 8) {
                        const int at = i + 8 <= n ? i : n - 8;
                        uint64_t v;
                        memcpy(&v, x + at, 8);
                        v ^= 0x8080808080808080ull;
                        memcpy(d + at, &v, 8);
                        if (at + 8 >= n) break;
                    }
                } else {
                    for (int ch = 0; ch < n; ch++)
                        d[ch] = (uint8_t)((uint8_t)x[ch] ^ 0x80u);
                }
                for (int ch = n; ch < cs; ch++)
                    d[ch] = 0;
                continue;
            }
            for (int kx = 0; kx < k_w; kx++) {
                const int ix = xx * stride_w - pad_w + kx * dilation_w;
                uint8_t *restrict dd = d + (size_t)kx * (size_t)in_c;
                if (iy < 0 || iy >= ih || ix < 0 || ix >= iw) {
                    memset(dd, pad_u, (size_t)in_c);
                    continue;
                }
                const int8_t *restrict x = in + nn_pixel_offset(in_dims, b, iy, ix, in_c_stride);
                for (int ch = 0; ch < in_c; ch++)
                    dd[ch] = (uint8_t)((uint8_t)x[ch] ^ 0x80u);
            }
            for (int ch = k_w * in_c; ch < cs; ch++)
                d[ch] = 0;
        }
    }
}
