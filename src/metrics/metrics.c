/* Image metrics: PSNR and SSIM (scikit-image's formulation) on tone-mapped
 * 8-bit sRGB, and an error heat map. See include/photongi/metrics.h. */
#include "photongi/metrics.h"

#include <math.h>
#include <string.h>

#include "core/core.h"
#include "io/io_internal.h"

#define SSIM_RADIUS 5 /* int(3.5 * 1.5 + 0.5): skimage's truncate=3.5, sigma=1.5 */
#define SSIM_SIGMA 1.5

pgi_status pgi_image_read(const char *path, pgi_image *out, int *is_hdr) { return pgi__image_read(path, out, is_hdr); }

static inline int reflect(int i, int n) {
    /* scipy.ndimage mode 'reflect' (d c b a | a b c d); only reached for
     * pixels in the cropped border, kept for a complete map. */
    while (i < 0 || i >= n) i = i < 0 ? -i - 1 : 2 * n - i - 1;
    return i;
}

/* Separable Gaussian filter of `src` into `dst` (tmp: scratch of w*h). */
static void gauss(const double *src, double *tmp, double *dst, int w, int h, const double *k) {
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            double s = 0.0;
            for (int j = -SSIM_RADIUS; j <= SSIM_RADIUS; j++)
                s += k[j + SSIM_RADIUS] * src[(size_t)y * w + reflect(x + j, w)];
            tmp[(size_t)y * w + x] = s;
        }
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            double s = 0.0;
            for (int j = -SSIM_RADIUS; j <= SSIM_RADIUS; j++)
                s += k[j + SSIM_RADIUS] * tmp[(size_t)reflect(y + j, h) * w + x];
            dst[(size_t)y * w + x] = s;
        }
}

double pgi_ssim_plane(const double *x, const double *y, int w, int h, double data_range) {
    const int win = 2 * SSIM_RADIUS + 1;
    if (w < win || h < win) return NAN;
    double k[2 * SSIM_RADIUS + 1], ks = 0.0;
    for (int j = -SSIM_RADIUS; j <= SSIM_RADIUS; j++)
        ks += k[j + SSIM_RADIUS] = exp(-0.5 * j * j / (SSIM_SIGMA * SSIM_SIGMA));
    for (int j = 0; j < win; j++) k[j] /= ks;
    const size_t n = (size_t)w * h;
    double *buf = malloc(8 * n * sizeof *buf);
    if (!buf) return NAN;
    double *tmp = buf, *ux = buf + n, *uy = buf + 2 * n, *uxx = buf + 3 * n, *uyy = buf + 4 * n, *uxy = buf + 5 * n,
           *prod = buf + 6 * n;
    gauss(x, tmp, ux, w, h, k);
    gauss(y, tmp, uy, w, h, k);
    for (size_t i = 0; i < n; i++) prod[i] = x[i] * x[i];
    gauss(prod, tmp, uxx, w, h, k);
    for (size_t i = 0; i < n; i++) prod[i] = y[i] * y[i];
    gauss(prod, tmp, uyy, w, h, k);
    for (size_t i = 0; i < n; i++) prod[i] = x[i] * y[i];
    gauss(prod, tmp, uxy, w, h, k);
    const double C1 = (0.01 * data_range) * (0.01 * data_range), C2 = (0.03 * data_range) * (0.03 * data_range);
    double sum = 0.0;
    for (int yy = SSIM_RADIUS; yy < h - SSIM_RADIUS; yy++) {
        double row = 0.0;
        for (int xx = SSIM_RADIUS; xx < w - SSIM_RADIUS; xx++) {
            size_t i = (size_t)yy * w + xx;
            double vx = uxx[i] - ux[i] * ux[i], vy = uyy[i] - uy[i] * uy[i], vxy = uxy[i] - ux[i] * uy[i];
            double a1 = 2.0 * ux[i] * uy[i] + C1, a2 = 2.0 * vxy + C2;
            double b1 = ux[i] * ux[i] + uy[i] * uy[i] + C1, b2 = vx + vy + C2;
            row += (a1 * a2) / (b1 * b2);
        }
        sum += row;
    }
    free(buf);
    return sum / ((double)(w - 2 * SSIM_RADIUS) * (double)(h - 2 * SSIM_RADIUS));
}

static pgi_status check_pair(const pgi_image *a, const pgi_image *b) {
    if (!a || !b || !a->rgb || !b->rgb || a->width <= 0 || a->height <= 0 || b->width <= 0 || b->height <= 0)
        return pgi__fail(PGI_ERR_INVALID_ARG, "compare: empty image");
    if (a->width != b->width || a->height != b->height)
        return pgi__fail(PGI_ERR_INVALID_ARG, "compare: image sizes differ (%dx%d vs %dx%d)", a->width, a->height,
                         b->width, b->height);
    return PGI_OK;
}

/* Tone-maps both images to 8-bit sRGB (the PNG of `render`). */
static pgi_status tonemap_pair(const pgi_image *a, const pgi_image *b, float exposure, unsigned char **ta,
                               unsigned char **tb) {
    size_t n3 = (size_t)a->width * a->height * 3;
    *ta = malloc(n3);
    *tb = malloc(n3);
    if (!*ta || !*tb) {
        free(*ta);
        free(*tb);
        return pgi__fail(PGI_ERR_OOM, "compare: out of memory for %dx%d images", a->width, a->height);
    }
    pgi_tonemap_srgb8(a, exposure, *ta);
    pgi_tonemap_srgb8(b, exposure, *tb);
    return PGI_OK;
}

double pgi_relmse(const pgi_image *a, const pgi_image *b, float exposure) {
    if (!a || !b || !a->rgb || !b->rgb || a->width != b->width || a->height != b->height) return NAN;
    const size_t n3 = (size_t)a->width * a->height * 3;
    double sum = 0.0;
    for (size_t i = 0; i < n3; i++) {
        double x = (double)a->rgb[i] * exposure, y = (double)b->rgb[i] * exposure;
        sum += (x - y) * (x - y) / (y * y + PGI_RELMSE_EPS);
    }
    return n3 ? sum / (double)n3 : NAN;
}

/* FLIP of the tone-mapped test `ta` against the reference `tb`; map may be NULL. */
static pgi_status flip_tonemapped(const unsigned char *ta, const unsigned char *tb, int w, int h, float ppd, float *map,
                                  pgi_flip_stats *out) {
    const size_t n = (size_t)w * h;
    float *m = map ? map : malloc(n * sizeof *m);
    if (!m) return pgi__fail(PGI_ERR_OOM, "compare: out of memory for the FLIP map of %dx%d images", w, h);
    pgi_status st = pgi_flip_map_srgb8(tb, ta, w, h, ppd, m);
    if (!st) st = pgi_flip_pool(m, n, out);
    out->ppd = ppd;
    if (m != map) free(m);
    return st;
}

pgi_status pgi_metrics_compute(const pgi_image *a, const pgi_image *b, float exposure, pgi_metrics *out) {
    return pgi_metrics_compute_flip(a, b, exposure, PGI_FLIP_DEFAULT_PPD, NULL, out);
}

pgi_status pgi_metrics_compute_flip(const pgi_image *a, const pgi_image *b, float exposure, float ppd, float *flip_map,
                                    pgi_metrics *out) {
    memset(out, 0, sizeof *out);
    pgi_status st = check_pair(a, b);
    if (st) return st;
    const int w = a->width, h = a->height;
    if (w < 11 || h < 11)
        return pgi__fail(PGI_ERR_INVALID_ARG, "compare: images of %dx%d are smaller than the 11x11 SSIM window", w, h);
    unsigned char *ta, *tb;
    if ((st = tonemap_pair(a, b, exposure, &ta, &tb))) return st;
    const size_t n = (size_t)w * h;
    double *pa = malloc(2 * n * sizeof *pa);
    if (!pa) {
        free(ta);
        free(tb);
        return pgi__fail(PGI_ERR_OOM, "compare: out of memory for %dx%d images", w, h);
    }
    double *pb = pa + n;
    double se = 0.0, mx = 0.0;
    for (size_t i = 0; i < 3 * n; i++) {
        double d = ((double)ta[i] - (double)tb[i]) / 255.0;
        se += d * d;
        if (fabs(d) > mx) mx = fabs(d);
    }
    out->width = w;
    out->height = h;
    out->mse = se / (double)(3 * n);
    out->psnr = out->mse > 0.0 ? 10.0 * log10(1.0 / out->mse) : INFINITY;
    out->max_abs = mx;
    for (int c = 0; c < 3; c++) {
        for (size_t i = 0; i < n; i++) {
            pa[i] = ta[3 * i + c] / 255.0;
            pb[i] = tb[3 * i + c] / 255.0;
        }
        out->ssim_channel[c] = pgi_ssim_plane(pa, pb, w, h, 1.0);
    }
    out->ssim_rgb = (out->ssim_channel[0] + out->ssim_channel[1] + out->ssim_channel[2]) / 3.0;
    for (size_t i = 0; i < n; i++) {
        pa[i] = (0.2126 * ta[3 * i] + 0.7152 * ta[3 * i + 1] + 0.0722 * ta[3 * i + 2]) / 255.0;
        pb[i] = (0.2126 * tb[3 * i] + 0.7152 * tb[3 * i + 1] + 0.0722 * tb[3 * i + 2]) / 255.0;
    }
    out->ssim = pgi_ssim_plane(pa, pb, w, h, 1.0);
    free(pa);
    if (isnan(out->ssim) || isnan(out->ssim_rgb)) {
        free(ta);
        free(tb);
        return pgi__fail(PGI_ERR_OOM, "compare: out of memory for SSIM");
    }
    out->relmse = pgi_relmse(a, b, exposure);
    st = flip_tonemapped(ta, tb, w, h, ppd, flip_map, &out->flip);
    free(ta);
    free(tb);
    return st;
}

pgi_status pgi_metrics_flip(const pgi_image *a, const pgi_image *b, float exposure, float ppd, float *map,
                            pgi_flip_stats *out) {
    memset(out, 0, sizeof *out);
    pgi_status st = check_pair(a, b);
    if (st) return st;
    unsigned char *ta, *tb;
    if ((st = tonemap_pair(a, b, exposure, &ta, &tb))) return st;
    st = flip_tonemapped(ta, tb, a->width, a->height, ppd, map, out);
    free(ta);
    free(tb);
    return st;
}

pgi_status pgi_metrics_heatmap(const pgi_image *a, const pgi_image *b, float exposure, float max_err,
                               unsigned char *rgb8) {
    pgi_status st = check_pair(a, b);
    if (st) return st;
    if (!(max_err > 0.f)) return pgi__fail(PGI_ERR_INVALID_ARG, "compare: heat-map scale must be positive");
    unsigned char *ta, *tb;
    if ((st = tonemap_pair(a, b, exposure, &ta, &tb))) return st;
    const size_t n = (size_t)a->width * a->height;
    for (size_t i = 0; i < n; i++) {
        int m = 0;
        for (int c = 0; c < 3; c++) {
            int d = abs((int)ta[3 * i + c] - (int)tb[3 * i + c]);
            if (d > m) m = d;
        }
        float t = (float)m / 255.f / max_err;
        t = t > 1.f ? 1.f : t;
        /* black -> red -> yellow -> white */
        float r = fminf(1.f, 3.f * t), g = fminf(1.f, fmaxf(0.f, 3.f * t - 1.f)), bl = fmaxf(0.f, 3.f * t - 2.f);
        rgb8[3 * i] = (unsigned char)lrintf(255.f * r);
        rgb8[3 * i + 1] = (unsigned char)lrintf(255.f * g);
        rgb8[3 * i + 2] = (unsigned char)lrintf(255.f * bl);
    }
    free(ta);
    free(tb);
    return PGI_OK;
}
