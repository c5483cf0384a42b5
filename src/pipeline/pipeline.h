/* Pipeline internals shared by render.c and counts.c. progressive.c sits
 * above the renderer and uses only the public API plus the scene's change
 * counters. */
#ifndef PGI_PIPELINE_H
#define PGI_PIPELINE_H

#include "core/core.h"
#include "rt/rt.h"

/* Rejects a view camera that is not finite or degenerate (render.c). */
pgi_status pgi__check_view(const pgi_camera_def *v);

/* Photons that pass the estimator's own per-photon test at each view sample
 * (counts.c): the estimator is built again over unit-flux copies of the
 * photons, with every sample made Lambertian of albedo pi, so its radiance
 * output is count / (pi r^2). Writes the count to all 3 channels of out_rgb. */
pgi_status pgi__photon_counts(pgi_estimator *e, const pgi_estimate_args *a, float *out_rgb);

/* The renderer's ray tracer (render.c), for benches that capture and replay
 * its rays (photongi-bench --limits; src/rt/ray_log.h). */
pgi__rt *pgi__renderer_rt(pgi_renderer *r);

#endif
