/* Edge-aware a-trous filter (atrous.h). Planes of floats, a row at a time: the interior of a row
 * (every neighbour in the image) runs a vector of pixels at a time, each with its 8 neighbours in
 * turn, without bounds checks or branches; the border columns take pixel() with clamped indices
 * and zero weights, the border rows zero weights for the rows outside. */
#include "filter/atrous.h"

#include <string.h>

static inline float lum(float r, float g, float b) { return 0.2126f * r + 0.7152f * g + 0.0722f * b; }

/* max(x, 0) for a finite x, without a branch or fmaxf's NaN rules: it vectorizes */
static inline float pos0(float x) { return 0.5f * (x + fabsf(x)); }

/* exp(-e) for e >= 0, closely enough for edge stopping and far cheaper: 1 / (1 + e + e^2/2 + e^3/6). */
static inline float soft_exp(float e) { return 1.f / (1.f + e * (1.f + e * (0.5f + e * (1.f / 6.f)))); }

/* Negative entries of v: the luminance variance of the pixel's 3x3 neighbourhood (masked pixels). */
static void spatial_variance(const pgi__atrous_guide *g, const float *const rgb[3], float *restrict v, int y) {
    const int W = g->width, H = g->height;
    for (int x = 0; x < W; x++) {
        const size_t p = (size_t)y * (size_t)W + (size_t)x;
        if (v[p] >= 0.f) continue;
        float s = 0.f, s2 = 0.f, n = 0.f;
        if (g->mask[p] > 0.f)
            for (int qy = y > 0 ? y - 1 : 0; qy <= y + 1 && qy < H; qy++)
                for (int qx = x > 0 ? x - 1 : 0; qx <= x + 1 && qx < W; qx++) {
                    const size_t q = (size_t)qy * (size_t)W + (size_t)qx;
                    if (!(g->mask[q] > 0.f)) continue;
                    const float l = lum(rgb[0][q], rgb[1][q], rgb[2][q]);
                    s += l, s2 += l * l, n += 1.f;
                }
        v[p] = n > 1.f ? fmaxf(0.f, s2 / n - (s / n) * (s / n)) : 0.f;
    }
}

/* One pixel p of a pass: its neighbours in rows row[0..2] (start indices; weight kr) and columns
 * col[0..2] (weight kc); a neighbour outside the image has weight 0 and a valid index. */
static inline void pixel(const pgi__atrous_guide *restrict g, const float *restrict ir, const float *restrict ig,
                         const float *restrict ib, const float *restrict iv, float *restrict or_, float *restrict og,
                         float *restrict ob, float *restrict ov, size_t p, const size_t row[3], const float kr[3],
                         const long col[3], const float kc[3], float step) {
    const float *restrict nx = g->nrm[0], *restrict ny = g->nrm[1], *restrict nz = g->nrm[2];
    const float *restrict px = g->pos[0], *restrict py = g->pos[1], *restrict pz = g->pos[2];
    const float *restrict ar = g->albedo[0], *restrict ag = g->albedo[1], *restrict ab = g->albedo[2];
    const float *restrict mk = g->mask;
    const float n0 = nx[p], n1 = ny[p], n2 = nz[p];
    const float lp = lum(ir[p], ig[p], ib[p]), il = 1.f / (4.f * sqrtf(iv[p]) + 1e-6f);
    const float iz = 1.f / (0.01f * g->depth[p] * step + 1e-6f);
    const float pd = n0 * px[p] + n1 * py[p] + n2 * pz[p]; /* p's tangent plane: n.x = pd */
    const float a0 = ar[p], a1 = ag[p], a2 = ab[p];
    float sw = 0.f, sw2v = 0.f, sr = 0.f, sg = 0.f, sb = 0.f;
    for (int j = 0; j < 3; j++)
        for (int i = 0; i < 3; i++) {
            const size_t q = row[j] + (size_t)col[i];
            const float nd = fmaxf(0.f, n0 * nx[q] + n1 * ny[q] + n2 * nz[q]);
            float wn = nd * nd; /* nd^64 by squaring */
            wn *= wn, wn *= wn, wn *= wn, wn *= wn, wn *= wn;
            const float plane = fabsf(n0 * px[q] + n1 * py[q] + n2 * pz[q] - pd);
            const float da = fabsf(ar[q] - a0) + fabsf(ag[q] - a1) + fabsf(ab[q] - a2);
            const float r = ir[q], gg = ig[q], b = ib[q];
            const float e = plane * iz + fabsf(lum(r, gg, b) - lp) * il + da * 4.f;
            const float w = kr[j] * kc[i] * mk[q] * wn * soft_exp(e);
            sw += w;
            sw2v += w * w * iv[q];
            sr += w * r, sg += w * gg, sb += w * b;
        }
    /* a masked p weighs itself 1/4 > 0; an unmasked one keeps its value */
    const float m = mk[p], inv = 1.f / (sw + (1.f - m));
    or_[p] = m > 0.f ? sr * inv : ir[p];
    og[p] = m > 0.f ? sg * inv : ig[p];
    ob[p] = m > 0.f ? sb * inv : ib[p];
    ov[p] = m > 0.f ? sw2v * inv * inv : iv[p];
}

/* Neighbour t of pixel x (interior()'s): its weight (the kernel's kw[t] times the edge terms against
 * x's normal, plane, luminance and albedo) and its values added to x's sums. Written out for each
 * neighbour, so that the loop over the row's pixels vectorizes with the sums in registers. */
#define PGI__ATROUS_TAP(t)                                                                                             \
    do {                                                                                                               \
        const long q = (long)x + off[t];                                                                               \
        const float nd = pos0(n0 * nx[q] + n1 * ny[q] + n2 * nz[q]);                                                   \
        float wn = nd * nd; /* nd^64 by squaring */                                                                    \
        wn *= wn, wn *= wn, wn *= wn, wn *= wn, wn *= wn;                                                              \
        const float plane = fabsf(n0 * px[q] + n1 * py[q] + n2 * pz[q] - pd);                                          \
        const float da = fabsf(ar[q] - a0) + fabsf(ag[q] - a1) + fabsf(ab[q] - a2);                                    \
        const float r = ir[q], gg = ig[q], b = ib[q];                                                                  \
        const float e = plane * iz + fabsf(lum(r, gg, b) - lp) * il + da * 4.f;                                        \
        const float w = kw[t] * mk[q] * wn * soft_exp(e);                                                              \
        sw += w;                                                                                                       \
        sw2v += w * w * iv[q];                                                                                         \
        sr += w * r, sg += w * gg, sb += w * b;                                                                        \
    } while (0)

/* Pixels [x0, x0 + m) of row y in the interior (every neighbour in the image): the
 * same sums as pixel(), in vectors of pixels, each with its 8 neighbours in turn (a row outside
 * the image weighs 0 and reads row y: the same sums as without it) and its sums in registers,
 * on contiguous loads (an AVX2 clone where the CPU has it: the same bits). */
PGI__AVX2_CLONES static void interior(const pgi__atrous_guide *restrict g, const float *const in[4],
                                      float *const out[4], size_t base, int m, const size_t row[3], const float kr[3],
                                      int step) {
    static const float k[3] = {0.25f, 0.5f, 0.25f};
    const float *restrict nx = g->nrm[0] + base, *restrict ny = g->nrm[1] + base, *restrict nz = g->nrm[2] + base;
    const float *restrict px = g->pos[0] + base, *restrict py = g->pos[1] + base, *restrict pz = g->pos[2] + base;
    const float *restrict ar = g->albedo[0] + base, *restrict ag = g->albedo[1] + base,
                          *restrict ab = g->albedo[2] + base;
    const float *restrict ir = in[0] + base, *restrict ig = in[1] + base, *restrict ib = in[2] + base,
                          *restrict iv = in[3] + base, *restrict mk = g->mask + base, *restrict dz = g->depth + base;
    float *restrict or_ = out[0] + base, *restrict og = out[1] + base, *restrict ob = out[2] + base,
                    *restrict ov = out[3] + base;
    long off[8]; /* q - p of the neighbours */
    float kw[8];
    for (int j = 0, t = 0; j < 3; j++)
        for (int i = 0; i < 3; i++) {
            if (i == 1 && j == 1) continue;
            off[t] = (long)row[j] - (long)row[1] + (long)(i - 1) * step;
            kw[t++] = kr[j] * k[i];
        }
    const float c0 = kr[1] * k[1], fs = 0.01f * (float)step;
#pragma omp simd
    for (int x = 0; x < m; x++) {
        const float n0 = nx[x], n1 = ny[x], n2 = nz[x], a0 = ar[x], a1 = ag[x], a2 = ab[x];
        const float lp = lum(ir[x], ig[x], ib[x]), il = 1.f / (4.f * sqrtf(iv[x]) + 1e-6f);
        const float iz = 1.f / (fs * dz[x] + 1e-6f), pd = n0 * px[x] + n1 * py[x] + n2 * pz[x];
        const float w0 = c0 * mk[x]; /* p itself: every edge term 1 */
        float sw = w0, sw2v = w0 * w0 * iv[x], sr = w0 * ir[x], sg = w0 * ig[x], sb = w0 * ib[x];
        PGI__ATROUS_TAP(0);
        PGI__ATROUS_TAP(1);
        PGI__ATROUS_TAP(2);
        PGI__ATROUS_TAP(3);
        PGI__ATROUS_TAP(4);
        PGI__ATROUS_TAP(5);
        PGI__ATROUS_TAP(6);
        PGI__ATROUS_TAP(7);
        /* mask 1: the weighted mean exactly; 0: the value kept exactly */
        const float mm = mk[x], km = 1.f - mm, inv = mm / (sw + km);
        or_[x] = sr * inv + km * ir[x];
        og[x] = sg * inv + km * ig[x];
        ob[x] = sb * inv + km * ib[x];
        ov[x] = sw2v * inv * inv + km * iv[x];
    }
}

/* Row y of a pass at `step` from planes in[0..3] (r, g, b, variance) to out[0..3]. */
static void pass_row(const pgi__atrous_guide *restrict g, int step, int y, const float *const in[4],
                     float *const out[4]) {
    static const float k[3] = {0.25f, 0.5f, 0.25f};
    const int W = g->width, H = g->height;
    size_t row[3];
    float kr[3];
    for (int j = 0; j < 3; j++) {
        const int qy = y + (j - 1) * step;
        const int ok = qy >= 0 && qy < H;
        row[j] = (size_t)(ok ? qy : y) * (size_t)W;
        kr[j] = ok ? k[j] : 0.f;
    }
    const float *restrict ir = in[0], *restrict ig = in[1], *restrict ib = in[2], *restrict iv = in[3];
    float *restrict or_ = out[0], *restrict og = out[1], *restrict ob = out[2], *restrict ov = out[3];
    const size_t base = (size_t)y * (size_t)W;
    const int lo = step < W ? step : W, hi = W - step > lo ? W - step : lo;
    const float fs = (float)step;
    for (int x = 0; x < W; x++) {
        if (x == lo) x = hi; /* the interior below */
        if (x >= W) break;
        long col[3];
        float kc[3];
        for (int i = 0; i < 3; i++) {
            const int qx = x + (i - 1) * step;
            const int ok = qx >= 0 && qx < W;
            col[i] = ok ? qx : x;
            kc[i] = ok ? k[i] : 0.f;
        }
        pixel(g, ir, ig, ib, iv, or_, og, ob, ov, base + (size_t)x, row, kr, col, kc, fs);
    }
    if (hi > lo) interior(g, in, out, base + (size_t)lo, hi - lo, row, kr, step);
}

/* Rows of the passes at a time a thread takes (rows cost alike, but a thread of a machine shared
 * with other work may lose its core for a while: the others take its rows meanwhile). */
enum { ROWS = 4 };

void pgi__atrous_filter_team(const pgi__atrous_guide *g, int passes, float *const rgb[4], float *scratch,
                             void (*row_done)(void *ctx, int y, float *const res[3]), void *ctx) {
    const size_t n = (size_t)g->width * (size_t)g->height;
    const int H = g->height;
    float *const tmp[4] = {scratch, scratch + n, scratch + 2 * n, scratch + 3 * n};
    float *const res[3] = {passes % 2 ? tmp[0] : rgb[0], passes % 2 ? tmp[1] : rgb[1], passes % 2 ? tmp[2] : rgb[2]};
#pragma omp for schedule(dynamic, ROWS)
    for (int y = 0; y < H; y++) spatial_variance(g, (const float *const *)rgb, rgb[3], y);
    for (int k = 0; k < passes; k++) {
        const float *const *in = (const float *const *)(k % 2 ? tmp : rgb);
        float *const *out = k % 2 ? rgb : tmp;
        const int last = k + 1 == passes && row_done;
#pragma omp for schedule(dynamic, ROWS)
        for (int y = 0; y < H; y++) {
            pass_row(g, 1 << k, y, in, out);
            if (last) row_done(ctx, y, res);
        }
    }
}

pgi_status pgi__atrous_filter(const pgi__atrous_guide *g, int passes, int threads, float *const rgb[4], float *scratch,
                              float *res[3]) {
    if (passes < 1 || passes > 5) return pgi__fail(PGI_ERR_INVALID_ARG, "a-trous filter: %d passes (1..5)", passes);
    const size_t n = (size_t)g->width * (size_t)g->height;
#pragma omp parallel num_threads(pgi__threads(threads))
    pgi__atrous_filter_team(g, passes, rgb, scratch, NULL, NULL);
    for (int c = 0; c < 3; c++) res[c] = passes % 2 ? scratch + (size_t)c * n : rgb[c];
    return PGI_OK;
}
