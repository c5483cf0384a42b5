/* Edge-aware a-trous filter of the indirect light (Dammertz et al. 2010, "Edge-avoiding a-trous
 * wavelet transform for fast global illumination filtering", in the variance-guided form of Schied
 * et al. 2017, SVGF): the picture stays clean while the camera moves (pgi_temporal). */
#ifndef PGI__FILTER_ATROUS_H
#define PGI__FILTER_ATROUS_H

#include "core/core.h"

/* The guides of a W x H frame as planes, one float a pixel each (row-major from the top-left), so
 * that a row's pixels vectorize. A pixel with mask 0 (no surface, or no albedo to divide by) takes
 * no part and keeps its value; mask is 1 otherwise. */
typedef struct pgi__atrous_guide {
    int width, height;
    const float *pos[3];    /* world position of the primary hit */
    const float *nrm[3];    /* unit shading normal */
    const float *albedo[3]; /* diffuse albedo */
    const float *depth;     /* view depth of the primary hit */
    const float *mask;      /* 1: filtered, 0: kept */
} pgi__atrous_guide;

/* Filters the planes rgb[0..2] (irradiance: the albedo divided out) with `passes` (1..5) passes of
 * the 3x3 B-spline kernel (1/4, 1/2, 1/4 along each axis: a third of the 5x5 kernel's reads, the
 * same reach after one more pass) at steps 1, 2, 4, 8, 16 pixels. Neighbour q of pixel p weighs the
 * kernel's weight times
 *   max(0, n_p . n_q)^64                                   (normal edges),
 *   exp(-(|n_p . (x_q - x_p)| / (0.01 z_p step)            (depth edges: q off p's tangent plane)
 *         + |l_p - l_q| / (4 sqrt(v_p) + 1e-6)             (luminance, by p's variance v_p)
 *         + |a_p - a_q|_1 / 0.25))                          (albedo edges: another material),
 * exp(-e) taken as 1 / (1 + e + e^2/2 + e^3/6). rgb[3] is the variance plane v of the luminance
 * (of the value filtered, e.g. a temporal mean's); a negative entry is replaced by the luminance
 * variance of the pixel's 3x3 neighbourhood (a spatial estimate for a young history). v is filtered
 * along with the squared weights. The result's planes are put in res[0..2]: rgb's or scratch's.
 * Every pixel is computed on its own: the same bytes for any thread count. `scratch` holds 4
 * floats a pixel; rgb[3] is overwritten. */
pgi_status pgi__atrous_filter(const pgi__atrous_guide *g, int passes, int threads, float *const rgb[4], float *scratch,
                              float *res[3]);

/* The same passes from inside a parallel region, which every thread of it calls (its loops are
 * shared among them; passes 1..5, not checked); after the last pass's row y, row_done (when not
 * NULL) is called by the thread that made it with the result's planes (rgb's or scratch's), so
 * that a caller may finish the row without a pass of its own. */
void pgi__atrous_filter_team(const pgi__atrous_guide *g, int passes, float *const rgb[4], float *scratch,
                             void (*row_done)(void *ctx, int y, float *const res[3]), void *ctx);

#endif
