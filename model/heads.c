/* The parametric heads (model/heads.h). */
#include "model/heads.h"

#include <math.h>
#include <string.h>

void pl_heads_bind(pl_binder *b, pl_heads *hd)
{
    const int N = hd->n_lights, fc = hd->fc_n;
    hd->dir_w = pl_bind_f32(b, "head_dir.weight", 2, 3 * N, fc, 0, 0);
    hd->dir_b = pl_bind_f32(b, "head_dir.bias", 1, 3 * N, 0, 0, 0);
    hd->size_w = pl_bind_f32(b, "head_size.weight", 2, N, fc, 0, 0);
    hd->size_b = pl_bind_f32(b, "head_size.bias", 1, N, 0, 0, 0);
    hd->rgb_w = pl_bind_f32(b, "head_rgb.weight", 2, 3 * N, fc, 0, 0);
    hd->rgb_b = pl_bind_f32(b, "head_rgb.bias", 1, 3 * N, 0, 0, 0);
    hd->amb_w = pl_bind_f32(b, "head_ambient.weight", 2, 3, fc, 0, 0);
    hd->amb_b = pl_bind_f32(b, "head_ambient.bias", 1, 3, 0, 0, 0);
}

void pl_heads_bind_dist(pl_binder *b, pl_heads *hd)
{
    const int N = hd->n_lights, H = hd->dist_hidden;
    hd->d1_b = pl_bind_f32(b, "head_dist.fc1.bias", 1, H, 0, 0, 0);
    hd->d2_w = pl_bind_f32(b, "head_dist.fc2.weight", 2, N, H, 0, 0);
    hd->d2_b = pl_bind_f32(b, "head_dist.fc2.bias", 1, N, 0, 0, 0);
}

size_t pl_heads_floats(const pl_heads *hd)
{
    const size_t N = (size_t)hd->n_lights;
    return 3 * N + N + 3 * N + 3 + ((size_t)hd->z_len + 3 * N) + (size_t)hd->dist_hidden + N;
}

float *pl_heads_place(pl_heads *hd, float *p)
{
    const int N = hd->n_lights;
    hd->out_dir = p;
    p += 3 * N;
    hd->out_size = p;
    p += N;
    hd->out_rgb = p;
    p += 3 * N;
    hd->out_amb = p;
    p += 3;
    hd->dist_in = p;
    p += hd->z_len + 3 * N;
    hd->dist_h = p;
    p += hd->dist_hidden;
    hd->out_dist = p;
    return p + N;
}

static float softplus(float x)
{
    return x > 20.0f ? x : log1pf(expf(x)); /* PyTorch's softplus: beta 1, threshold 20 */
}

void pl_heads_run(const pl_heads *hd, const float *z, const float *h, pl_heads_fc_fn fc, void *ctx)
{
    const int N = hd->n_lights, fcn = hd->fc_n;
    fc(ctx, h, fcn, hd->dir_w, hd->dir_b, 3 * N, 0, hd->out_dir);
    fc(ctx, h, fcn, hd->size_w, hd->size_b, N, 0, hd->out_size);
    fc(ctx, h, fcn, hd->rgb_w, hd->rgb_b, 3 * N, 0, hd->out_rgb);
    fc(ctx, h, fcn, hd->amb_w, hd->amb_b, 3, 0, hd->out_amb);
    for (int i = 0; i < N; i++) { /* F.normalize(eps=1e-12) */
        float *d = hd->out_dir + 3 * i;
        const float n = sqrtf(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
        const float inv = 1.0f / (n > 1e-12f ? n : 1e-12f);
        d[0] *= inv;
        d[1] *= inv;
        d[2] *= inv;
    }
    for (int i = 0; i < N; i++)
        hd->out_size[i] = softplus(hd->out_size[i]);
    for (int i = 0; i < 3 * N; i++)
        hd->out_rgb[i] = softplus(hd->out_rgb[i]);
    for (int i = 0; i < 3; i++)
        hd->out_amb[i] = softplus(hd->out_amb[i]);
    memcpy(hd->dist_in, z, (size_t)hd->z_len * sizeof(float));
    memcpy(hd->dist_in + hd->z_len, hd->out_dir, (size_t)(3 * N) * sizeof(float));
    fc(ctx, hd->dist_in, hd->z_len + 3 * N, hd->d1_w, hd->d1_b, hd->dist_hidden, 1, hd->dist_h);
    fc(ctx, hd->dist_h, hd->dist_hidden, hd->d2_w, hd->d2_b, N, 0, hd->out_dist);
    for (int i = 0; i < N; i++)
        hd->out_dist[i] = softplus(hd->out_dist[i]);
}

void pl_heads_lighting(const pl_heads *hd, pl_lighting *out)
{
    memset(out, 0, sizeof *out);
    out->n_lights = hd->n_lights;
    for (int i = 0; i < hd->n_lights; i++) {
        pl_light *L = &out->lights[i];
        memcpy(L->dir, hd->out_dir + 3 * i, sizeof L->dir);
        memcpy(L->rgb, hd->out_rgb + 3 * i, sizeof L->rgb);
        L->distance_m = hd->out_dist[i];
        L->solid_angle_sr = hd->out_size[i];
    }
    memcpy(out->ambient, hd->out_amb, sizeof out->ambient);
}
