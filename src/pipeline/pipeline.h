/* Pipeline internals shared by render.c (and frame_gpu.c), counts.c and progressive.c.
 * progressive.c sits above the renderer: the public API, the scene's change
 * counters and pgi__renderer_render_frame. */
#ifndef PGI__PIPELINE_H
#define PGI__PIPELINE_H

#include "core/core.h"
#include "core/mem.h"
#include "rt/rt.h"

/* pgi_renderer_render with the view samples' sub-pixel positions (when
 * jittered) taken from point `index` of the sequence of `seq_seed`
 * (pgi__pixel_jitter; seq_seed 0: the frame's own seed): progressive frame k
 * passes (frame 0's seed, k), so that the positions of frames 0..N-1 cover
 * each pixel evenly. pgi_renderer_render is (0, 0). */
pgi_status pgi__renderer_render_frame(pgi_renderer *r, const pgi_render_desc *desc, uint64_t seq_seed, uint32_t index,
                                      pgi_image *out, pgi_frame_stats *stats);

/* pgi__renderer_render_frame for a radius known only after the view samples and photons
 * (pgi_progressive_frame_await_r0): desc->radius is ignored; once the photons are traced,
 * radius_fn(user, k) gives the frame's radius (it is called first when they depend on it). */
typedef float (*pgi__late_radius_fn)(void *user, int k);
pgi_status pgi__renderer_render_frame_late(pgi_renderer *r, const pgi_render_desc *desc, uint64_t seq_seed,
                                           uint32_t index, pgi__late_radius_fn radius_fn, void *user, pgi_image *out,
                                           pgi_frame_stats *stats);

/* With keep != 0 the renderer's next frames keep their guided emission's guide from the frame
 * before (pgi__trace_desc.guide_keep; pgi_progressive_keep_guide): progressive.c sets it around a
 * frame k > 0 of one picture. */
void pgi__renderer_keep_guide(pgi_renderer *r, int keep);

/* The width of the view samples' texture cones in pixels (pgi__subpixel.tex_scale; 0 or 1: a
 * pixel's) for the renderer's next frames: temporal.c sets it around a picture whose sub-pixel
 * offset is its own (its history integrates the pixel: the texture's filter need not). */
void pgi__renderer_texture_cone(pgi_renderer *r, float pixels);

/* The renderer's memory ledger (render.c): progressive.c reports its accumulator there. */
pgi__mem_ledger *pgi__renderer_mem(pgi_renderer *r);

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

/* The temporal step's camera geometry (temporal.c), for tests: the direction through the centre of
 * pixel (x, y) (its component along forward is 1); where world point q (or direction q, `dir`)
 * lands in camera c, as continuous pixel coordinates (pixel (x, y)'s centre is (x, y)) and depth
 * along forward (0 returned when behind the camera). */
void pgi__temporal_pixel_dir(const pgi_camera *c, int x, int y, float d[3]);
int pgi__temporal_project(const pgi_camera *c, const float q[3], int dir, float *px, float *py, float *z);
/* The primary hit of pixel (x, y) of camera c whose sample passed `shift` pixels from the centre
 * (pgi_render_desc.shift) at depth z along c's forward (the depth AOV). */
void pgi__temporal_hit(const pgi_camera *c, int x, int y, const float shift[2], float z, float pos[3]);
/* Where in camera `prev` the history of the pixel whose sample at `shift` hit q is read: q
 * projected (pgi__temporal_project), less the shift (back to the pixel's centre); 0 when behind. */
int pgi__temporal_land(const pgi_camera *prev, const float q[3], const float shift[2], float *px, float *py);

/* Everything that changes the picture: the desc (less the estimator name,
 * view pointer and thread count), the estimator, the view camera and the
 * scene's state. Built zeroed, so that two of them compare with memcmp. */
typedef struct pgi__picture {
    pgi_render_desc key;
    char est[64];
    pgi_camera_def view;
    int has_view;
    uint64_t static_version, dynamic_version, lights_hash;
    double time;
} pgi__picture;
/* The picture of desc d on scene s (pgi_progressive_step restarts when it changes; pgi_temporal
 * compares it without the camera). */
void pgi__picture_of(const pgi_render_desc *d, const pgi_scene *s, pgi__picture *p);

#endif
