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
 */
#ifndef PHOTONGI_METRICS_H
#define PHOTONGI_METRICS_H

#include "photongi/photongi.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct pgi_metrics {
    int width, height;
    double mse;      /* on [0,1] sRGB values, all channels */
    double psnr;     /* dB; INFINITY when the images are identical */
    double ssim;     /* on luma */
    double ssim_rgb; /* mean of ssim_channel */
    double ssim_channel[3];
    double max_abs; /* largest absolute channel difference */
} pgi_metrics;

/* Compares `a` (test) with `b` (reference). Sizes must match and be at least
 * 11x11 (the SSIM window): otherwise PGI_ERR_INVALID_ARG naming both sizes. */
pgi_status pgi_metrics_compute(const pgi_image *a, const pgi_image *b, float exposure, pgi_metrics *out);

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
