/* Image quality metrics against a reference (compare tool, quality benchmark).
 *
 * Both images are tone-mapped with the operator of `render` (exposure, then
 * sRGB, quantised to 8 bits: exactly the PNG that `render` writes) and scaled
 * to [0, 1]; an 8-bit PNG therefore compares by its own bytes.
 *   PSNR = 10 log10(1 / MSE), MSE over all pixels and the three channels.
 *   SSIM after Wang et al. 2004 as scikit-image computes it with
 *   gaussian_weights=True, sigma=1.5, use_sample_covariance=False,
 *   data_range=1: 11x11 Gaussian window (truncated at 3.5 sigma), K1=0.01,
 *   K2=0.03, mean of the SSIM map without the 5-pixel border.
 *   `ssim` is on luma Y = 0.2126 R' + 0.7152 G' + 0.0722 B' of the sRGB
 *   values; `ssim_rgb` the mean of the three per-channel SSIMs.
 *   LDR-FLIP after Andersson et al. 2020 (HPG), as the NVlabs reference tool
 *   computes it for 8-bit images: per-pixel error in [0,1] at a viewing
 *   distance given in pixels per degree (default PGI_FLIP_DEFAULT_PPD: 0.7 m
 *   from a 0.7 m wide 3840-pixel monitor), pooled as the mean, the weighted
 *   median and quartiles (each value weighted by itself), min and max.
 */
#ifndef PHOTONGI_METRICS_H
#define PHOTONGI_METRICS_H

#include "photongi/photongi.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Pooled LDR-FLIP values of an error map. */
typedef struct pgi_flip_stats {
    double mean;            /* mean over the pixels (summed in double) */
    double weighted_median; /* the tool's weighted percentiles: the first value, in ascending order, */
    double weighted_q1;     /* at which the running sum exceeds 50 % (25 %, 75 %) of the total */
    double weighted_q3;
    double min, max;
    float ppd; /* the pixels per degree it was computed at */
} pgi_flip_stats;

/* 67.020645: 0.7 m from a 0.7 m wide monitor of 3840 pixels, FLIP's default. */
#define PGI_FLIP_DEFAULT_PPD 67.020645f

typedef struct pgi_metrics {
    int width, height;
    double mse;      /* on [0,1] sRGB values, all channels */
    double psnr;     /* dB; INFINITY when the images are identical */
    double ssim;     /* on luma */
    double ssim_rgb; /* mean of ssim_channel */
    double ssim_channel[3];
    double max_abs;      /* largest absolute channel difference */
    pgi_flip_stats flip; /* LDR-FLIP at PGI_FLIP_DEFAULT_PPD */
    double relmse;       /* relative MSE on linear values (before tone mapping): see pgi_relmse */
} pgi_metrics;

/* Compares `a` (test) with `b` (reference). Sizes must match and be at least
 * 11x11 (the SSIM window): otherwise PGI_ERR_INVALID_ARG naming both sizes. */
pgi_status pgi_metrics_compute(const pgi_image *a, const pgi_image *b, float exposure, pgi_metrics *out);
/* The same with FLIP at `ppd` pixels per degree, its per-pixel map written to `flip_map` (width x
 * height floats; may be NULL). pgi_metrics_compute is this at PGI_FLIP_DEFAULT_PPD without a map. */
pgi_status pgi_metrics_compute_flip(const pgi_image *a, const pgi_image *b, float exposure, float ppd, float *flip_map,
                                    pgi_metrics *out);

/* Relative MSE of `a` (test) against `b` (reference) on linear RGB times `exposure`, before tone
 * mapping: the mean over pixels and channels of (a - b)^2 / (b^2 + PGI_RELMSE_EPS). Scale-free
 * where the reference is bright, so dark and bright regions weigh alike. NAN if sizes differ. */
#define PGI_RELMSE_EPS 0.01
double pgi_relmse(const pgi_image *a, const pgi_image *b, float exposure);

/* FLIP of `a` (test) against `b` (reference), tone-mapped as above, at `ppd` pixels per degree
 * (pgi_flip_ppd; PGI_FLIP_DEFAULT_PPD). Writes the per-pixel error map to `map` (width x height
 * floats, row-major; may be NULL) and the pooled values to `out`. Sizes must match. */
pgi_status pgi_metrics_flip(const pgi_image *a, const pgi_image *b, float exposure, float ppd, float *map,
                            pgi_flip_stats *out);

/* LDR-FLIP error map of two 8-bit sRGB RGB images (3 bytes a pixel, row-major; `ref` is the
 * reference) at `ppd` pixels per degree, in [1, 1000]; `map` gets w x h floats in [0,1]. */
pgi_status pgi_flip_map_srgb8(const unsigned char *ref, const unsigned char *test, int w, int h, float ppd, float *map);
/* Pooled values of an error map of n values. */
pgi_status pgi_flip_pool(const float *map, size_t n, pgi_flip_stats *out);
/* Pixels per degree for an observer `distance_m` from a monitor `width_m` wide of `width_px` pixels. */
float pgi_flip_ppd(float distance_m, float width_px, float width_m);
/* FLIP's colour-mapped error map: each value through matplotlib's magma map, 3 bytes a pixel. */
void pgi_flip_colorize(const float *map, size_t n, unsigned char *rgb8);

/* SSIM (mean over the map, border cropped as above) of two planes of
 * `w` x `h` doubles in [0, data_range]. Returns NAN if smaller than 11x11. */
double pgi_ssim_plane(const double *x, const double *y, int w, int h, double data_range);

/* Error heat map: per pixel the largest absolute channel difference of the
 * tone-mapped images, divided by `max_err` (clamped to 1) through a
 * black-red-yellow-white ramp; 3 bytes a pixel into `rgb8` (caller-owned). */
pgi_status pgi_metrics_heatmap(const pgi_image *a, const pgi_image *b, float exposure, float max_err,
                               unsigned char *rgb8);

/* Reads a PNG/EXR/HDR image (format from the content) into linear RGB;
 * PNG is decoded from sRGB so that tone mapping gives back its bytes.
 * *is_hdr (may be NULL) tells whether the file held linear floats. */
pgi_status pgi_image_read(const char *path, pgi_image *out, int *is_hdr);

#ifdef __cplusplus
}
#endif

#endif
