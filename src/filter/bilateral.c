/* Bilateral reconstruction filter (see bilateral.h). */
#include "filter/bilateral.h"

#include <stdlib.h>
#include <string.h>

pgi_status pgi__bilateral_filter(const pgi_view_samples *vs, int radius, int threads, float *rgb) {
    if (radius <= 0) return PGI_OK;
    const int W = vs->width, H = vs->height;
    const size_t n = vs->count;
    float *src = malloc(3 * n * sizeof *src), *dist = malloc(n * sizeof *dist);
    if (!src || !dist) {
        free(src);
        free(dist);
        return pgi__fail(PGI_ERR_OOM, "out of memory for the reconstruction filter (%dx%d)", W, H);
    }
    memcpy(src, rgb, 3 * n * sizeof *src);
    /* scale for the plane-distance term: the primary hit's view depth */
    for (size_t i = 0; i < n; i++) dist[i] = vs->depth[i] > 0.f ? vs->depth[i] : 1.f;
    const float inv2s2 = 1.f / (2.f * (0.5f * (float)radius) * (0.5f * (float)radius));
#pragma omp parallel for schedule(dynamic, 4) num_threads(pgi__threads(threads))
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            size_t i = (size_t)y * W + (size_t)x;
            if (!(vs->flags[i] & PGI_VS_VALID)) continue;
            const float *ni = vs->nrm + 3 * i, *pi = vs->pos + 3 * i;
            float zi = dist[i];
            float sr = 0.f, sg = 0.f, sb = 0.f, sw = 0.f;
            for (int dy = -radius; dy <= radius; dy++) {
                int yy = y + dy;
                if (yy < 0 || yy >= H) continue;
                for (int dx = -radius; dx <= radius; dx++) {
                    int xx = x + dx;
                    if (xx < 0 || xx >= W) continue;
                    size_t j = (size_t)yy * W + (size_t)xx;
                    if (!(vs->flags[j] & PGI_VS_VALID)) continue;
                    const float *nj = vs->nrm + 3 * j, *pj = vs->pos + 3 * j;
                    float c = ni[0] * nj[0] + ni[1] * nj[1] + ni[2] * nj[2];
                    if (!(c > 0.f)) continue;
                    float c2 = c * c, c4 = c2 * c2, c8 = c4 * c4, wn = c8 * c8;
                    /* world distance between the samples relative to the depth */
                    float ex = pj[0] - pi[0], ey = pj[1] - pi[1], ez = pj[2] - pi[2];
                    float pd = (ex * ni[0] + ey * ni[1] + ez * ni[2]) / (0.05f * zi); /* off the tangent plane */
                    float w = expf(-(float)(dx * dx + dy * dy) * inv2s2 - pd * pd) * wn;
                    const float *v = src + 3 * j;
                    sr += w * v[0];
                    sg += w * v[1];
                    sb += w * v[2];
                    sw += w;
                }
            }
            if (sw > 0.f) {
                rgb[3 * i] = sr / sw;
                rgb[3 * i + 1] = sg / sw;
                rgb[3 * i + 2] = sb / sw;
            }
        }
    free(src);
    free(dist);
    return PGI_OK;
}
