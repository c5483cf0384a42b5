/* Pipeline internals shared by render.c, progressive.c and counts.c. */
#ifndef PGI_PIPELINE_H
#define PGI_PIPELINE_H

#include "core/core.h"

typedef struct pgi__accum pgi__accum;

/* The renderer's accumulation slot and its scene (render.c). */
pgi__accum **pgi__renderer_accum(pgi_renderer *r);
const pgi_scene *pgi__renderer_scene(const pgi_renderer *r);
void pgi__accum_free(pgi__accum *a);

/* pgi_renderer_render with desc->progressive > 1 (progressive.c). */
pgi_status pgi__render_progressive(pgi_renderer *r, const pgi_render_desc *desc, pgi_image *out,
                                   pgi_frame_stats *stats);

/* Rejects a view camera that is not finite or degenerate (progressive.c). */
pgi_status pgi__check_view(const pgi_camera_def *v);

/* Photons that pass the estimator's own per-photon test at each view sample
 * (counts.c): the estimator is built again over unit-flux copies of the
 * photons, with every sample made Lambertian of albedo pi, so its radiance
 * output is count / (pi r^2). Writes the count to all 3 channels of out_rgb. */
pgi_status pgi__photon_counts(pgi_estimator *e, const pgi_estimate_args *a, float radius, float *out_rgb);

#endif
