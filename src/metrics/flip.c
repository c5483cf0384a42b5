/* LDR-FLIP (Andersson, Nilsson, Akenine-Möller, Oskarsson, Åström, Fairchild, "FLIP: A
 * Difference Evaluator for Alternating Images", HPG 2020), written from the paper and its
 * separable-filter note. Everything is in float32 in the order the metric's reference
 * implementation uses, so that the error map agrees with it to a few ulps
 * (tests/test_flip.c checks the pairs of ../shared/flip/).
 *
 * Colour pipeline: sRGB8 -> linear RGB -> XYZ -> YCxCz (opponent space, D65); each channel
 * filtered by the contrast sensitivity function (Gaussians in the paper's a, b form; the
 * blue-yellow one is a sum of two, separated as two separable filters); back to linear RGB,
 * clamped to [0,1], to L*a*b*, Hunt-adjusted chroma (a, b scaled by 0.01 L); HyAB distance
 * raised to qc = 0.7 and redistributed to [0,1] (the lower pc = 40 % of the range of the
 * largest distance, green vs blue, onto [0, pt = 0.95]).
 * Feature pipeline: the achromatic channel normalised to [0,1], convolved with first and
 * second derivatives of a Gaussian of std 0.5 * w * PPD (w = 0.082 degrees); edge and point
 * magnitudes; feature difference = (max(|edge diff|, |point diff|) / sqrt 2)^qf, qf = 0.5.
 * FLIP = colour difference ^ (1 - feature difference). Borders replicate the edge pixel. */
#include "photongi/metrics.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/core.h"
#include "magma.h"

#define FLIP_PI 3.14159265358979f
#define FLIP_QC 0.7f
#define FLIP_PC 0.4f
#define FLIP_PT 0.95f
#define FLIP_W 0.082f
#define FLIP_QF 0.5f

/* CSF Gaussians a * sqrt(pi / b) * exp(-pi^2 x^2 / b) of the paper, per channel (Y, Cx, Cz); Cz is
 * the sum of the (a1, b1) and (a2, b2) terms. */
static const float k_a1[3] = {1.0f, 1.0f, 34.1f}, k_b1[3] = {0.0047f, 0.0053f, 0.04f};
static const float k_a2[3] = {0.0f, 0.0f, 13.5f}, k_b2[3] = {1.0e-5f, 1.0e-5f, 0.025f};

/* D65 white and its inverse, as XYZ. */
static const float k_white[3] = {0.950428545f, 1.000000000f, 1.088900371f};
static const float k_inv_white[3] = {1.052156925f, 1.000000000f, 0.918357670f};

float pgi_flip_ppd(float distance_m, float width_px, float width_m) {
    return distance_m * (width_px / width_m) * (FLIP_PI / 180.0f);
}

static inline float srgb_eotf(float c) { return c <= 0.04045f ? c / 12.92f : powf((c + 0.055f) / 1.055f, 2.4f); }

static inline void rgb_to_xyz(const float *c, float *o) {
    const float a11 = 10135552.0f / 24577794.0f, a12 = 8788810.0f / 24577794.0f, a13 = 4435075.0f / 24577794.0f;
    const float a21 = 2613072.0f / 12288897.0f, a22 = 8788810.0f / 12288897.0f, a23 = 887015.0f / 12288897.0f;
    const float a31 = 1425312.0f / 73733382.0f, a32 = 8788810.0f / 73733382.0f, a33 = 70074185.0f / 73733382.0f;
    float x = a11 * c[0] + a12 * c[1] + a13 * c[2];
    float y = a21 * c[0] + a22 * c[1] + a23 * c[2];
    float z = a31 * c[0] + a32 * c[1] + a33 * c[2];
    o[0] = x;
    o[1] = y;
    o[2] = z;
}

static inline void xyz_to_rgb(const float *c, float *o) {
    float r = 3.241003275f * c[0] + -1.537398934f * c[1] + -0.498615861f * c[2];
    float g = -0.969224334f * c[0] + 1.875930071f * c[1] + 0.041554224f * c[2];
    float b = 0.055639423f * c[0] + -0.204011202f * c[1] + 1.057148933f * c[2];
    o[0] = r;
    o[1] = g;
    o[2] = b;
}

static inline void xyz_to_ycxcz(const float *c, float *o) {
    float x = c[0] * k_inv_white[0], y = c[1] * k_inv_white[1], z = c[2] * k_inv_white[2];
    o[0] = 116.0f * y - 16.0f;
    o[1] = 500.0f * (x - y);
    o[2] = 200.0f * (y - z);
}

static inline void ycxcz_to_xyz(const float *c, float *o) {
    const float y = (c[0] + 16.0f) / 116.0f, cx = c[1] / 500.0f, cz = c[2] / 200.0f;
    float x = y + cx, z = y - cz;
    o[0] = x * k_white[0];
    o[1] = y * k_white[1];
    o[2] = z * k_white[2];
}

static inline float lab_f(float t) {
    const float delta = 6.0f / 29.0f, delta2 = delta * delta, delta3 = delta * delta2;
    const float factor = 1.0f / (3.0f * delta2), term = 4.0f / 29.0f;
    return t > delta3 ? powf(t, 1.0f / 3.0f) : factor * t + term;
}

static inline void xyz_to_lab(const float *c, float *o) {
    float x = lab_f(c[0] * k_inv_white[0]), y = lab_f(c[1] * k_inv_white[1]), z = lab_f(c[2] * k_inv_white[2]);
    o[0] = 116.0f * y - 16.0f;
    o[1] = 500.0f * (x - y);
    o[2] = 200.0f * (y - z);
}

/* L*a*b* of a linear RGB colour with Hunt-adjusted chroma. */
static inline void rgb_to_lab_hunt(const float *rgb, float *o) {
    float xyz[3];
    rgb_to_xyz(rgb, xyz);
    xyz_to_lab(xyz, o);
    o[1] = 0.01f * o[0] * o[1];
    o[2] = 0.01f * o[0] * o[2];
}

static inline float hyab(const float *a, const float *b) {
    float dl = fabsf(a[0] - b[0]);
    float da = a[1] - b[1], db = a[2] - b[2];
    return dl + sqrtf(da * da + db * db);
}

/* The largest colour distance: green against blue, after the same steps. */
static float max_distance(void) {
    const float g[3] = {0.0f, 1.0f, 0.0f}, b[3] = {0.0f, 0.0f, 1.0f};
    float lg[3], lb[3];
    rgb_to_lab_hunt(g, lg);
    rgb_to_lab_hunt(b, lb);
    return powf(hyab(lg, lb), FLIP_QC);
}

static inline float csf_gauss(float x2, float a, float b) {
    const float pi_sq = FLIP_PI * FLIP_PI;
    return a * sqrtf(FLIP_PI / b) * expf(-pi_sq * x2 / b);
}

/* The square root of a term's weight, so that the 2-D sum of two Gaussians separates into two
 * separable filters (one per term). */
static inline float csf_gauss_sqrt(float x2, float a, float b) {
    const float pi_sq = FLIP_PI * FLIP_PI;
    return sqrtf(a * sqrtf(FLIP_PI / b)) * expf(-pi_sq * x2 / b);
}

static int spatial_radius(float ppd) {
    const float pi_sq = FLIP_PI * FLIP_PI;
    float bmax = 0.f;
    for (int c = 0; c < 3; c++) bmax = fmaxf(bmax, fmaxf(k_b1[c], k_b2[c]));
    return (int)ceilf(3.0f * sqrtf(bmax / (2.0f * pi_sq)) * ppd);
}

/* 1-D weights of the spatial filters: w[i] = (Y, Cx, Cz term 1, Cz term 2), 2r+1 of them. */
static void spatial_filters(float ppd, int r, float (*w)[4]) {
    const float dx = 1.0f / ppd;
    float sum[4] = {0.f, 0.f, 0.f, 0.f};
    for (int i = 0; i <= 2 * r; i++) {
        float x = (float)(i - r) * dx, x2 = x * x;
        w[i][0] = csf_gauss(x2, k_a1[0], k_b1[0]);
        w[i][1] = csf_gauss(x2, k_a1[1], k_b1[1]);
        w[i][2] = csf_gauss_sqrt(x2, k_a1[2], k_b1[2]);
        w[i][3] = csf_gauss_sqrt(x2, k_a2[2], k_b2[2]);
        for (int k = 0; k < 4; k++) sum[k] += w[i][k];
    }
    const float ny = 1.0f / sum[0], ncx = 1.0f / sum[1];
    const float ncz = 1.0f / sqrtf(sum[2] * sum[2] + sum[3] * sum[3]);
    for (int i = 0; i <= 2 * r; i++) {
        w[i][0] *= ny;
        w[i][1] *= ncx;
        w[i][2] *= ncz;
        w[i][3] *= ncz;
    }
}

static float feature_sigma(float ppd) { return 0.5f * FLIP_W * ppd; }

/* 1-D feature weights (Gaussian, its first and second derivative), 2r+1 of them: the Gaussian
 * sums to 1, the derivatives' positive and negative parts to +1 and -1. */
static void feature_filter(float ppd, int r, float (*w)[3]) {
    const float sd = feature_sigma(ppd);
    float gsum = 0.f, dpos = 0.f, dneg = 0.f, ddpos = 0.f, ddneg = 0.f;
    for (int i = 0; i <= 2 * r; i++) {
        float x = (float)(i - r);
        float g = expf(-(x * x) / (2.0f * sd * sd));
        float dg = -x * g;
        float ddg = (x * x / (sd * sd) - 1.0f) * g;
        gsum += g;
        if (dg > 0.f) dpos += dg;
        else dneg -= dg;
        if (ddg > 0.f) ddpos += ddg;
        else ddneg -= ddg;
        w[i][0] = g;
        w[i][1] = dg;
        w[i][2] = ddg;
    }
    for (int i = 0; i <= 2 * r; i++) {
        w[i][0] /= gsum;
        w[i][1] /= w[i][1] > 0.f ? dpos : dneg;
        w[i][2] /= w[i][2] > 0.f ? ddpos : ddneg;
    }
}

static inline int clampi(int v, int lo, int hi) { return v < lo ? lo : v > hi ? hi : v; }

/* The image in YCxCz, planar: yc[0..n) Y, [n..2n) Cx, [2n..3n) Cz. */
static void to_ycxcz(const unsigned char *srgb8, size_t n, float *yc) {
    for (size_t i = 0; i < n; i++) {
        float lin[3], xyz[3], o[3];
        for (int c = 0; c < 3; c++) {
            float v = srgb_eotf((float)srgb8[3 * i + c] / 255.0f);
            lin[c] = v < 0.f ? 0.f : v > 1.f ? 1.f : v;
        }
        rgb_to_xyz(lin, xyz);
        xyz_to_ycxcz(xyz, o);
        yc[i] = o[0];
        yc[n + i] = o[1];
        yc[2 * n + i] = o[2];
    }
}

pgi_status pgi_flip_map_srgb8(const unsigned char *ref, const unsigned char *test, int w, int h, float ppd,
                              float *map) {
    if (!ref || !test || !map || w <= 0 || h <= 0)
        return pgi__fail(PGI_ERR_INVALID_ARG, "flip: empty image or no output map");
    if (!(ppd >= 1.f && ppd <= 1000.f))
        return pgi__fail(PGI_ERR_INVALID_ARG, "flip: pixels per degree must be in [1, 1000], got %g", (double)ppd);
    const size_t n = (size_t)w * h;
    const int rs = spatial_radius(ppd), rf = (int)ceilf(3.0f * feature_sigma(ppd));
    float(*ws)[4] = malloc((size_t)(2 * rs + 1) * sizeof *ws);
    float(*wf)[3] = malloc((size_t)(2 * rf + 1) * sizeof *wf);
    /* YCxCz of both (6n), the spatial x pass (4 values: Y, Cx, Cz1, Cz2 for both: 8n), the
     * feature x pass (3 values for both: 6n). */
    float *buf = malloc(20 * n * sizeof *buf);
    if (!ws || !wf || !buf) {
        free(ws);
        free(wf);
        free(buf);
        return pgi__fail(PGI_ERR_OOM, "flip: out of memory for %dx%d images", w, h);
    }
    float *yc[2] = {buf, buf + 3 * n};
    float *sx[2] = {buf + 6 * n, buf + 10 * n};
    float *fx[2] = {buf + 14 * n, buf + 17 * n};
    spatial_filters(ppd, rs, ws);
    feature_filter(ppd, rf, wf);
    to_ycxcz(ref, n, yc[0]);
    to_ycxcz(test, n, yc[1]);
    const float cmax = max_distance(), pccmax = FLIP_PC * cmax;
    const float one116 = 1.0f / 116.0f, sixteen116 = 16.0f / 116.0f;

    /* x passes: spatial (CSF) and feature filters of each row. */
#pragma omp parallel for schedule(static)
    for (int y = 0; y < h; y++) {
        for (int k = 0; k < 2; k++) {
            const float *Y = yc[k], *Cx = yc[k] + n, *Cz = yc[k] + 2 * n;
            float *o = sx[k], *f = fx[k];
            for (int x = 0; x < w; x++) {
                float a0 = 0.f, a1 = 0.f, a2 = 0.f, a3 = 0.f;
                for (int i = -rs; i <= rs; i++) {
                    size_t s = (size_t)y * w + clampi(x + i, 0, w - 1);
                    const float *wt = ws[i + rs];
                    a0 += wt[0] * Y[s];
                    a1 += wt[1] * Cx[s];
                    a2 += wt[2] * Cz[s];
                    a3 += wt[3] * Cz[s];
                }
                size_t d = (size_t)y * w + x;
                o[d] = a0;
                o[n + d] = a1;
                o[2 * n + d] = a2;
                o[3 * n + d] = a3;
                float dx = 0.f, ddx = 0.f, g = 0.f;
                for (int i = -rf; i <= rf; i++) {
                    size_t s = (size_t)y * w + clampi(x + i, 0, w - 1);
                    const float *wt = wf[i + rf];
                    float v = Y[s] * one116 + sixteen116;
                    dx += wt[1] * v;
                    ddx += wt[2] * v;
                    g += wt[0] * v;
                }
                f[d] = dx;
                f[n + d] = ddx;
                f[2 * n + d] = g;
            }
        }
    }

    /* y passes, then the colour and feature differences and their combination. */
    const float norm = 1.0f / sqrtf(2.0f);
#pragma omp parallel for schedule(static)
    for (int y = 0; y < h; y++) {
        for (int x = 0; x < w; x++) {
            float lab[2][3], edge[2], point[2];
            for (int k = 0; k < 2; k++) {
                const float *o = sx[k];
                float a0 = 0.f, a1 = 0.f, a2 = 0.f, a3 = 0.f;
                for (int i = -rs; i <= rs; i++) {
                    size_t s = (size_t)clampi(y + i, 0, h - 1) * w + x;
                    const float *wt = ws[i + rs];
                    a0 += wt[0] * o[s];
                    a1 += wt[1] * o[n + s];
                    a2 += wt[2] * o[2 * n + s];
                    a3 += wt[3] * o[3 * n + s];
                }
                float ycc[3] = {a0, a1, a2 + a3}, xyz[3], rgb[3];
                ycxcz_to_xyz(ycc, xyz);
                xyz_to_rgb(xyz, rgb);
                for (int c = 0; c < 3; c++) rgb[c] = fminf(fmaxf(rgb[c], 0.0f), 1.0f);
                rgb_to_lab_hunt(rgb, lab[k]);

                const float *f = fx[k];
                float dx = 0.f, ddx = 0.f, dy = 0.f, ddy = 0.f;
                for (int i = -rf; i <= rf; i++) {
                    size_t s = (size_t)clampi(y + i, 0, h - 1) * w + x;
                    const float *wt = wf[i + rf];
                    dx += wt[0] * f[s];
                    ddx += wt[0] * f[n + s];
                    dy += wt[1] * f[2 * n + s];
                    ddy += wt[2] * f[2 * n + s];
                }
                edge[k] = sqrtf(dx * dx + dy * dy);
                point[k] = sqrtf(ddx * ddx + ddy * ddy);
            }
            float cd = powf(hyab(lab[0], lab[1]), FLIP_QC);
            if (cd < pccmax) cd *= FLIP_PT / pccmax;
            else cd = FLIP_PT + ((cd - pccmax) / (cmax - pccmax)) * (1.0f - FLIP_PT);
            float fd = powf(norm * fmaxf(fabsf(edge[0] - edge[1]), fabsf(point[0] - point[1])), FLIP_QF);
            map[(size_t)y * w + x] = powf(cd, 1.0f - fd);
        }
    }
    free(ws);
    free(wf);
    free(buf);
    return PGI_OK;
}

pgi_status pgi_flip_pool(const float *map, size_t n, pgi_flip_stats *out) {
    memset(out, 0, sizeof *out);
    if (!map || n == 0) return pgi__fail(PGI_ERR_INVALID_ARG, "flip: empty error map");
    float *v = malloc(n * sizeof *v);
    if (!v) return pgi__fail(PGI_ERR_OOM, "flip: out of memory pooling %zu values", n);
    double sum = 0.0;
    float mn = map[0], mx = map[0];
    for (size_t i = 0; i < n; i++) {
        sum += map[i];
        mn = fminf(mn, map[i]);
        mx = fmaxf(mx, map[i]);
        v[i] = map[i];
    }
    out->mean = sum / (double)n;
    out->min = mn;
    out->max = mx;
    /* Weighted percentiles (each value weighted by itself), as the metric's tool reports them: in
     * ascending order, the first value at which the running sum exceeds p of the total, both sums
     * in float (the total in row-major order), so that the same value is picked. */
    float total = 0.f;
    for (size_t i = 0; i < n; i++) total += map[i];
    qsort(v, n, sizeof *v, pgi__cmp_float);
    const float p[3] = {0.25f, 0.5f, 0.75f};
    double *dst[3] = {&out->weighted_q1, &out->weighted_median, &out->weighted_q3};
    float run = 0.f;
    size_t i = 0;
    for (int k = 0; k < 3; k++) {
        while (i < n && !(run + v[i] > p[k] * total)) run += v[i++];
        *dst[k] = i < n ? v[i] : 0.0;
    }
    free(v);
    return PGI_OK;
}

void pgi_flip_colorize(const float *map, size_t n, unsigned char *rgb8) {
    for (size_t i = 0; i < n; i++) {
        float t = map[i];
        int k = t > 0.f ? (int)(fminf(t, 1.f) * 255.0f + 0.5f) : 0;
        memcpy(rgb8 + 3 * i, pgi__magma[k], 3);
    }
}
