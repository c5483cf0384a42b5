/* View samples (G-buffer) from primary rays, and direct light. */
#ifndef PGI_VIEW_H
#define PGI_VIEW_H

#include "rt/rt.h"

/* Casts primary rays in 8-wide packets through pixel centres, follows
 * perfect mirrors and glass (up to 8 specular bounces; glass picks reflection
 * or refraction by Fresnel with a per-pixel RNG) to the first non-specular
 * hit, and fills `vs`. `emit` (3 floats a pixel) receives emitted radiance
 * seen along the eye path. */
pgi_status pgi__view_build(const pgi_scene *s, const pgi_rt *rt, const pgi_camera *cam, uint64_t seed,
                           pgi_view_samples *vs, float *emit, uint64_t *rays);

/* Direct light at every valid view sample with shadow rays (point, spot, sun:
 * one ray each; emissive triangles: `area_samples` samples picked by power).
 * Writes weight-multiplied radiance (3 floats a pixel). */
pgi_status pgi__direct(const pgi_scene *s, const pgi_rt *rt, const pgi_view_samples *vs, int area_samples,
                       uint64_t seed, float *out, uint64_t *rays);

#endif
