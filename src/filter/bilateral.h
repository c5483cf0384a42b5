/* Depth/normal-aware bilateral reconstruction filter for the indirect light
 * (tiled paper §2.3.2: subsampled estimates are noisy; a cross-bilateral
 * filter guided by the G-buffer removes the noise without blurring across
 * edges). */
#ifndef PGI__FILTER_BILATERAL_H
#define PGI__FILTER_BILATERAL_H

#include "core/core.h"

/* Filters rgb (3 floats a view sample) in place over a (2R+1)^2 window.
 * Weight of neighbour q for pixel p: Gaussian in pixel distance (sigma R/2),
 * times exp(-(d / (0.05 z_p))^2) with d the distance of q's position from
 * p's tangent plane and z_p p's view depth (depth and geometry edges), times
 * max(0, n_p . n_q)^16 (normal edges). Only valid samples take part; invalid ones keep
 * their value. Deterministic (no summation races). */
pgi_status pgi__bilateral_filter(const pgi_view_samples *vs, int radius, int threads, float *rgb);

#endif
