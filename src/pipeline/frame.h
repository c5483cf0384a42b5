/* One frame on either device (docs/architecture.md, "One frame"): the renderer, and the table of
 * passes a device supplies to the frame (pgi__frame_backend).
 *
 * render.c writes the frame once: it resolves the desc (and refuses what the device lacks, from the
 * one device table), plans the memory, sets up the camera and the host buffers, reports progress,
 * allocates the image and fills the stats. A backend runs the passes on its device: the CPU's
 * (render.c) and the Vulkan device's (frame_gpu.c). Their order in a frame:
 *
 *   ensure_device, ensure_estimator        once per device / estimator name + options (kept)
 *   inputs                                 view samples and photons
 *   (the automatic radius, on the host)
 *   indirect                               the estimator: indirect radiance of every view sample
 *   compose                                direct light and the sum, into the image (the CPU's
 *                                          photon counts instead, PGI_OUTPUT_PHOTON_COUNT)
 *   finish                                 the backend's stats, after the common ones
 *
 * pgi_renderer_prepare runs ensure_device, inputs and to_host (the inputs into the renderer's host
 * arrays). */
#ifndef PGI__FRAME_H
#define PGI__FRAME_H

#include "core/mem.h"
#include "estimators/estimator_internal.h"
#include "photon/guide.h"
#include "photon/photon.h"
#include "pipeline/pipeline.h"
#include "view/view.h"

/* The devices of the table, indexed by pgi_device. */
#define PGI__DEVICE_COUNT 2

struct pgi_renderer {
    const pgi_scene *scene;
    pgi__rt *rt;         /* the CPU's rays (Embree) */
    pgi__mem_ledger mem; /* what the large allocations of the renderer (and its scene) hold */
    double scene_area;   /* total triangle area, for the bvh's T_auto */
    pgi_camera cam;      /* this frame's */
    /* The frame's data on the host: the CPU's passes write it; a device frame reads back into it
     * what the host needs (the automatic radius, pgi_renderer_prepare, an estimator on host inputs). */
    pgi_photons ph;
    pgi__trace_scratch trace_scratch;
    pgi_view_samples vs;
    float *emit, *indirect;
    size_t pix_cap;
    pgi__view_fill fill; /* what vs and emit hold already (pgi__view_build skips those stores) */
    /* radius policies: per-photon footprint arrays (radius, then 6 ellipsoid axis planes) */
    float *fp_buf;
    size_t fp_cap;
    /* the CPU tracer's guided emission: the guide's tables and the cells the camera sees (kept
     * between frames); PGI_STORE_VIEW: the cells within the radius of a view sample */
    pgi__guide guide;
    int guide_keep; /* pgi__renderer_keep_guide: the next frames keep the guide's evidence */
    float tex_cone; /* pgi__renderer_texture_cone: the texture cones' width in pixels (0: 1) */
    pgi__view_grid vgrid;
    pgi__view_grid near;
    /* each backend's own state (its device, its estimator), made by its first frame and kept until
     * pgi_renderer_destroy (pgi__frame_backend.release) */
    void *dev[PGI__DEVICE_COUNT];
};

/* Progress reports (pgi_render_desc.progress) of one frame. */
typedef struct pgi__progress {
    const pgi_render_desc *d;
    double t_start;
    int radius_unknown; /* d->radius is a stand-in (pgi__renderer_render_frame_late, until it is asked for) */
} pgi__progress;

/* The passes of one device. Each returns PGI_OK or fails with a message (pgi__fail); d is resolved
 * and was accepted by the device table (render.c, device_check). */
typedef struct pgi__frame_backend {
    /* The device for d: made on its first frame and kept (again when d->device_index changes). */
    pgi_status (*ensure_device)(pgi_renderer *r, const pgi_render_desc *d);
    /* The estimator for d: the last frame's while its name and options stay the same; *created is
     * incremented when one is made. */
    pgi_status (*ensure_estimator)(pgi_renderer *r, const pgi_render_desc *d, int *created);
    /* The stats' device name (pgi_frame_stats.device): lives as long as the renderer's device. */
    const char *(*device_name)(pgi_renderer *r);
    /* Whether view samples and photons of d can be made before its radius is known
     * (pgi__renderer_render_frame_late). NULL: never. */
    int (*late_radius)(const pgi_render_desc *d);
    /* The view samples and photons (r->cam set, the host buffers sized for d: ensure_buffers). With
     * the automatic radius (d->radius == PGI_RADIUS_AUTO) both are in r->ph and r->vs after it. */
    pgi_status (*inputs)(pgi_renderer *r, const pgi_render_desc *d, uint64_t seq_seed, uint32_t index,
                         const pgi__progress *pc, pgi_frame_stats *fs);
    /* The inputs in r->ph and r->vs (pgi_renderer_prepare): read back from a device. */
    pgi_status (*to_host)(pgi_renderer *r, const pgi_render_desc *d, pgi_frame_stats *fs);
    /* The estimator's build and gather; es gets its stats. */
    pgi_status (*indirect)(pgi_renderer *r, const pgi_render_desc *d, const pgi__progress *pc, pgi_frame_stats *fs,
                           pgi_estimator_stats *es);
    /* Direct light and the composite into img (d's size; allocated by the frame). */
    pgi_status (*compose)(pgi_renderer *r, const pgi_render_desc *d, const pgi__progress *pc, pgi_frame_stats *fs,
                          pgi_image *img);
    /* The backend's stats, after the frame's (total time, memory ledger, counters). */
    void (*finish)(pgi_renderer *r, const pgi_render_desc *d, const pgi_estimator_stats *es, pgi_frame_stats *fs);
    /* Frees the backend's state r->dev[...] (NULL-safe). */
    void (*release)(pgi_renderer *r);
} pgi__frame_backend;

extern const pgi__frame_backend pgi__frame_cpu;    /* render.c */
extern const pgi__frame_backend pgi__frame_vulkan; /* frame_gpu.c */

/* For the backends (render.c). A pass starts with a report: the progress callback, and where a
 * cancel request ends the frame. */
pgi_status pgi__frame_report(const pgi__progress *pc, const char *pass, uint64_t done, uint64_t total);
/* The photon tracer's progress (pgi__trace_desc.progress, ctx a pgi__progress). */
void pgi__frame_report_trace(void *ctx, uint64_t stored, uint64_t total);
/* Appends a pass to the frame's stats (the list is bounded). */
void pgi__frame_pass(pgi_frame_stats *fs, const char *name, double ms);
/* Points r->ph at the footprint arrays d's radius policy needs (none for fixed). */
pgi_status pgi__frame_footprints(pgi_renderer *r, const pgi_render_desc *d);

#endif
