/* Edge-aware a-trous filter (atrous.h). */
#include "filter/atrous.h"

#include <string.h>

static inline float lum(const float *c) { return 0.2126f * c[0] + 0.7152f * c[1] + 0.0722f * c[2]; }

/* The luminance variance of each masked pixel's 3x3 neighbourhood (masked pixels only). */
static void local_variance(const pgi__atrous_guide *g, const float *rgb, int threads, float *var) {
    const int W = g->width, H = g->height;
#pragma omp parallel for schedule(static) num_threads(pgi__threads(threads))
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            const size_t p = (size_t)y * (size_t)W + (size_t)x;
            double s = 0.0, s2 = 0.0;
            int n = 0;
            if (g->mask[p])
                for (int dy = -1; dy <= 1; dy++)
                    for (int dx = -1; dx <= 1; dx++) {
                        const int qx = x + dx, qy = y + dy;
                        if (qx < 0 || qy < 0 || qx >= W || qy >= H) continue;
                        const size_t q = (size_t)qy * (size_t)W + (size_t)qx;
                        if (!g->mask[q]) continue;
                        const double l = lum(rgb + 3 * q);
                        s += l, s2 += l * l, n++;
                    }
            var[p] = n > 1 ? (float)fmax(0.0, s2 / n - (s / n) * (s / n)) : 0.f;
        }
}

/* exp(-e) for e >= 0, closely enough for edge stopping and far cheaper: 1 / (1 + e + e^2/2 + e^3/6). */
static inline float soft_exp(float e) { return 1.f / (1.f + e * (1.f + e * (0.5f + e * (1.f / 6.f)))); }

/* One pass at `step` pixels from in/vin to out/vout; lin: the luminance of in. */
static void atrous_pass(const pgi__atrous_guide *g, int step, int threads, const float *in, const float *lin,
                        const float *vin, float *out, float *vout) {
    static const float k[3] = {0.25f, 0.5f, 0.25f};
    const int W = g->width, H = g->height;
#pragma omp parallel for schedule(static) num_threads(pgi__threads(threads))
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            const size_t p = (size_t)y * (size_t)W + (size_t)x;
            if (!g->mask[p]) {
                memcpy(out + 3 * p, in + 3 * p, 3 * sizeof(float));
                vout[p] = vin[p];
                continue;
            }
            const float *np = g->nrm + 3 * p, *xp = g->pos + 3 * p, *ap = g->albedo + 3 * p;
            const float lp = lin[p], il = 1.f / (4.f * sqrtf(vin[p]) + 1e-6f);
            const float iz = 1.f / (0.01f * g->depth[p] * (float)step + 1e-6f);
            const float pd = np[0] * xp[0] + np[1] * xp[1] + np[2] * xp[2]; /* p's tangent plane: n.x = pd */
            float sw = 0.f, sw2v = 0.f, a0 = 0.f, a1 = 0.f, a2 = 0.f;
            for (int j = 0; j < 3; j++) {
                const int qy = y + (j - 1) * step;
                if (qy < 0 || qy >= H) continue;
                for (int i = 0; i < 3; i++) {
                    const int qx = x + (i - 1) * step;
                    if (qx < 0 || qx >= W) continue;
                    const size_t q = (size_t)qy * (size_t)W + (size_t)qx;
                    if (!g->mask[q]) continue;
                    const float *nq = g->nrm + 3 * q, *xq = g->pos + 3 * q, *aq = g->albedo + 3 * q;
                    const float nd = fmaxf(0.f, np[0] * nq[0] + np[1] * nq[1] + np[2] * nq[2]);
                    float wn = nd * nd; /* nd^64 by squaring */
                    wn *= wn, wn *= wn, wn *= wn, wn *= wn, wn *= wn;
                    const float plane = fabsf(np[0] * xq[0] + np[1] * xq[1] + np[2] * xq[2] - pd);
                    const float da = fabsf(aq[0] - ap[0]) + fabsf(aq[1] - ap[1]) + fabsf(aq[2] - ap[2]);
                    const float e = plane * iz + fabsf(lin[q] - lp) * il + da * 4.f;
                    const float w = k[i] * k[j] * wn * soft_exp(e);
                    sw += w;
                    sw2v += w * w * vin[q];
                    a0 += w * in[3 * q], a1 += w * in[3 * q + 1], a2 += w * in[3 * q + 2];
                }
            }
            /* p itself always weighs k[1]^2 > 0 */
            const float inv = 1.f / sw;
            out[3 * p] = a0 * inv, out[3 * p + 1] = a1 * inv, out[3 * p + 2] = a2 * inv;
            vout[p] = sw2v * inv * inv;
        }
}

pgi_status pgi__atrous_filter(const pgi__atrous_guide *g, int passes, int threads, float *rgb, float *scratch) {
    if (passes < 1 || passes > 5) return pgi__fail(PGI_ERR_INVALID_ARG, "a-trous filter: %d passes (1..5)", passes);
    const size_t n = (size_t)g->width * (size_t)g->height;
    /* 3 floats a pixel, two variances, the luminance */
    float *tmp = scratch, *va = scratch + 3 * n, *vb = scratch + 4 * n, *lin = scratch + 5 * n;
    local_variance(g, rgb, threads, va);
    float *in = rgb, *out = tmp, *vin = va, *vout = vb;
    for (int k = 0; k < passes; k++) {
#pragma omp parallel for schedule(static) num_threads(pgi__threads(threads))
        for (long i = 0; i < (long)n; i++) lin[i] = lum(in + 3 * i);
        atrous_pass(g, 1 << k, threads, in, lin, vin, out, vout);
        float *t = in;
        in = out, out = t;
        t = vin, vin = vout, vout = t;
    }
    if (in != rgb) memcpy(rgb, in, 3 * n * sizeof(float));
    return PGI_OK;
}
