/* Edge-aware a-trous filter of the indirect light (Dammertz et al. 2010, "Edge-avoiding a-trous
 * wavelet transform for fast global illumination filtering", in the variance-guided form of Schied
 * et al. 2017, SVGF): the picture stays clean while the camera moves (pgi_temporal). */
#ifndef PGI__FILTER_ATROUS_H
#define PGI__FILTER_ATROUS_H

#include "core/core.h"

/* The guides of a W x H frame, one entry a pixel (row-major from the top-left). A pixel with
 * mask[i] == 0 (no surface, or no albedo to divide by) takes no part and keeps its value. */
typedef struct pgi__atrous_guide {
    int width, height;
    const float *pos;    /* 3 floats: world position of the primary hit */
    const float *nrm;    /* 3 floats: unit shading normal */
    const float *albedo; /* 3 floats: diffuse albedo */
    const float *depth;  /* 1 float: view depth of the primary hit */
    const uint8_t *mask; /* 1: filtered */
} pgi__atrous_guide;

/* Filters rgb (3 floats a pixel, irradiance: the albedo divided out) in place: `passes` (1..5)
 * passes of the 3x3 B-spline kernel (1/4, 1/2, 1/4 along each axis: a third of the 5x5 kernel's
 * reads, the same reach after one more pass) at steps 1, 2, 4, 8, 16 pixels. Neighbour q of
 * pixel p weighs the kernel's weight times
 *   max(0, n_p . n_q)^64                                   (normal edges),
 *   exp(-(|n_p . (x_q - x_p)| / (0.01 z_p step)            (depth edges: q off p's tangent plane)
 *         + |l_p - l_q| / (4 sqrt(v_p) + 1e-6)             (luminance, by p's local variance v_p)
 *         + |a_p - a_q|_1 / 0.25))                          (albedo edges: another material),
 * exp(-e) taken as 1 / (1 + e + e^2/2 + e^3/6). v starts as the luminance variance of each pixel's
 * 3x3 neighbourhood and is filtered along with the squared weights. Deterministic for any thread count. `scratch` holds 6 floats a pixel. */
pgi_status pgi__atrous_filter(const pgi__atrous_guide *g, int passes, int threads, float *rgb, float *scratch);

#endif
