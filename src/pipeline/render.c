/* One frame, end to end, on either device (frame.h; docs/design.md, "One frame"): the desc
 * resolved against the device table, the memory plan, the camera, the host buffers, the image and
 * the stats, written once; the passes from the device's backend. The CPU's backend is here (view
 * samples, photons, estimator build + estimate, direct light, which writes the composite:
 * pgi__direct_sum); the Vulkan device's is frame_gpu.c. */
#include <stdio.h>
#include <string.h>

#include "gpu/gpu_estimator.h"
#include "photon/auto_radius.h"
#include "photon/emission.h"
#include "scene/portal.h"
#include "pipeline/frame.h"
#include "filter/bilateral.h"

#define PGI__MAX_BOUNCES 64

/* The CPU backend's state (pgi_renderer.dev[PGI_DEVICE_CPU]): the estimator, created once per
 * estimator name + resolved options. */
typedef struct cpu_state {
    pgi_estimator *est;
    const pgi_estimator_vtbl *est_vt;
    pgi_estimator_desc est_desc;
} cpu_state;

static const pgi__frame_backend *device_backend(pgi_device dev);

/* The ledger's entries in the order the stats list them. "estimator" is the estimator's total (its
 * own entries are listed instead); entries of features not in use (0 bytes) are left out. */
static const char *const k_mem_entries[] = {"scene",          "textures",      "embree_bvh",      "photons",
                                            "footprints",     "trace_scratch", "view_samples",    "frame_buffers",
                                            "emission_guide", "image",         "progressive_sum", "estimator"};
/* Left out of the stats when 0 (the rest are always listed). */
static int mem_optional(const char *name) {
    return strcmp(name, "footprints") == 0 || strcmp(name, "emission_guide") == 0 ||
           strcmp(name, "progressive_sum") == 0 || strcmp(name, "estimator") == 0;
}

/* Bytes of one photon in pgi_photons: 12 float planes. */
#define PHOTON_BYTES (12 * sizeof(float))
/* Bytes of one view sample: 7 vector planes (pos, nrm, ngeo, wo, kd, ks, weight), shininess, ior,
 * depth, flags. */
#define VIEW_SAMPLE_BYTES ((7 * 3 + 3) * sizeof(float) + sizeof(uint8_t))
/* Bytes a pixel of the emitted and indirect buffers (the direct pass writes the image itself). */
#define FRAME_BUFFER_BYTES (2 * 3 * sizeof(float))
/* The tracer's scratch per photon of a batch (each thread's records, 50 bytes a photon, grown by
 * doubling), for at most the photons of a batch: 2^20 paths of at most `bounces` photons each. */
#define TRACE_BYTES_PER_PHOTON 80
/* ... and the tracer's copy of the triangles: a 64-byte record and 32 bytes of texture
 * coordinates each, two arrays that from 1 MiB on are rounded to whole 2 MiB huge pages
 * (trace.c, tris_alloc). */
/* ... and the emission pre-pass, where the scene has point or spot lights (trace.c start_paths):
 * up to 2^18 paths a batch, a state and sort entries each (80 bytes) and a byte for each thread
 * (whether the path goes on), and their differentials (52) where a radius policy follows the
 * paths; a start mode (1 byte) for each path of a batch. */
static uint64_t trace_prepass_bytes(const pgi_scene *s, uint64_t photons, int diffs, int threads) {
    int point = 0;
    for (size_t i = 0; i < s->nlights; i++) point |= pgi__light_from_point(&s->lights[i]);
    if (!point) return 0;
    const uint64_t paths = photons < (1u << 18) ? photons : (1u << 18);
    return paths * (80 + (uint64_t)threads + (diffs ? 52 : 0)) + (photons < (1u << 20) ? photons : (1u << 20));
}
static uint64_t trace_triangle_bytes(uint64_t ntris) {
    const uint64_t huge = (uint64_t)2 << 20, a = ntris * 64, b = ntris * 32;
    return (a < huge / 2 ? a : (a + huge - 1) / huge * huge) + (b < huge / 2 ? b : (b + huge - 1) / huge * huge);
}

void pgi__renderer_keep_guide(pgi_renderer *r, int keep) { r->guide_keep = keep; }

void pgi__renderer_texture_cone(pgi_renderer *r, float pixels) { r->tex_cone = pixels; }

pgi__mem_ledger *pgi__renderer_mem(pgi_renderer *r) { return &r->mem; }

/* Entries the renderer does not allocate itself: the scene's and Embree's bytes, read now. */
static void mem_update_held(pgi_renderer *r) {
    size_t scene, tex, peak;
    pgi__scene_memory(r->scene, &scene, &tex);
    pgi__mem_set(&r->mem, "scene", scene);
    pgi__mem_set(&r->mem, "textures", tex);
    size_t bvh = pgi__rt_memory(r->rt, &peak);
    /* the build's scratch first, so that the ledger's peak has seen it */
    if (peak > pgi__mem_get(&r->mem, "embree_bvh")) pgi__mem_set(&r->mem, "embree_bvh", peak);
    pgi__mem_set(&r->mem, "embree_bvh", bvh);
}

/* A frame's memory, checked against the budget before anything of it is allocated (vt NULL:
 * pgi_renderer_prepare, no estimator): a photon count that cannot fit is refused here, before
 * tracing. */
static pgi_status mem_plan(pgi_renderer *r, const pgi_render_desc *d, const pgi_estimator_vtbl *vt) {
    mem_update_held(r);
    r->mem.budget = d->max_memory;
    if (d->max_memory == PGI_MEMORY_UNLIMITED) return PGI_OK;
    const uint64_t n = (uint64_t)d->width * (uint64_t)d->height, np = d->photons;
    const uint64_t planes = d->radius_policy == PGI_RADIUS_FIXED ? 0 : d->radius_policy == PGI_RADIUS_PATH ? 1 : 7;
    const uint64_t batch = (uint64_t)d->bounces << 20, traced = np < batch ? np : batch;
    const int unknown = vt && !vt->bytes_per_photon && !vt->bytes_per_sample;
    const uint64_t per_photon = !vt ? 0 : unknown ? 64 : vt->bytes_per_photon;
    const uint64_t per_sample = !vt ? 0 : unknown ? 64 : vt->bytes_per_sample;
    const char *est = vt ? vt->name : "estimator";
    pgi__mem_plan_item it[] = {
        {"scene", pgi__mem_get(&r->mem, "scene"), 0},
        {"textures", pgi__mem_get(&r->mem, "textures"), 0},
        {"embree_bvh", pgi__mem_get(&r->mem, "embree_bvh"), 0},
        {"view_samples", n * VIEW_SAMPLE_BYTES, 0},
        {"frame_buffers", n * FRAME_BUFFER_BYTES, 0},
        {"image", vt ? n * 3 * sizeof(float) : 0, 0},
        {"progressive_sum", pgi__mem_get(&r->mem, "progressive_sum"), 0},
        {est, n * per_sample, 0},
        {"photons", np * PHOTON_BYTES, 1},
        {"footprints", np * planes * sizeof(float), 1},
        {"trace_scratch", traced * TRACE_BYTES_PER_PHOTON, 1},
        {"trace_scratch", trace_triangle_bytes(r->scene->ntris), 0},
        {"trace_scratch",
         trace_prepass_bytes(r->scene, np, d->radius_policy != PGI_RADIUS_FIXED, pgi__threads(d->threads)), 1},
        {"emission_guide",
         d->emission == PGI_EMISSION_GUIDED || d->emission == PGI_EMISSION_AUTO ? np * sizeof(uint16_t) : 0,
         1}, /* a bin a photon (portal emission has no guide) */
        {est, np * per_photon, 1},
    };
    return pgi__mem_plan_check(it, (int)(sizeof it / sizeof it[0]), d->max_memory, np);
}

/* The frame's memory into its stats: the ledger's entries, then the estimator's (es may be NULL). */
static void mem_stats(pgi_renderer *r, const pgi_estimator_stats *es, pgi_frame_stats *fs) {
    size_t est = 0;
    for (int k = 0; es && k < es->memory_count; k++) est += es->memory_bytes[k];
    if (es) pgi__mem_set(&r->mem, "estimator", est);
    mem_update_held(r);
    fs->memory_count = 0;
    for (int i = 0; i < r->mem.n && fs->memory_count < PGI_MAX_STAT_ENTRIES; i++) {
        const pgi__mem_entry *e = &r->mem.e[i];
        if (strcmp(e->name, "estimator") == 0 || (e->cur == 0 && mem_optional(e->name))) continue;
        fs->memory_bytes[fs->memory_count++] = (pgi_named_value){e->name, (double)e->cur};
    }
    for (int k = 0; es && k < es->memory_count && fs->memory_count < PGI_MAX_STAT_ENTRIES; k++)
        fs->memory_bytes[fs->memory_count++] = (pgi_named_value){es->memory_names[k], (double)es->memory_bytes[k]};
    fs->memory_counted_peak = r->mem.peak;
    fs->memory_peak_rss = pgi_memory_peak_rss();
}

const pgi_scene *pgi_renderer_scene(const pgi_renderer *r) { return r ? r->scene : NULL; }

pgi__rt *pgi__renderer_rt(pgi_renderer *r) { return r ? r->rt : NULL; }

pgi_status pgi_renderer_create(const pgi_scene *scene, pgi_renderer **out) {
    *out = NULL;
    if (!scene) return pgi__fail(PGI_ERR_INVALID_ARG, "pgi_renderer_create: no scene");
    pgi_renderer *r = calloc(1, sizeof *r);
    if (!r) return pgi__fail(PGI_ERR_OOM, "out of memory creating a renderer");
    r->scene = scene;
    pgi_status st = pgi__rt_create(scene, &r->rt);
    if (st) {
        free(r);
        return st;
    }
    for (size_t i = 0; i < sizeof k_mem_entries / sizeof k_mem_entries[0]; i++)
        pgi__mem_set(&r->mem, k_mem_entries[i], 0);
    r->mem.budget = PGI_MEMORY_UNLIMITED;
    mem_update_held(r);
    *out = r;
    return PGI_OK;
}

void pgi_renderer_destroy(pgi_renderer *r) {
    if (!r) return;
    for (int i = 0; i < PGI__DEVICE_COUNT; i++)
        if (r->dev[i]) device_backend((pgi_device)i)->release(r);
    pgi__rt_destroy(r->rt);
    pgi_photons_free(&r->ph);
    pgi__trace_scratch_free(&r->trace_scratch);
    pgi_view_samples_free(&r->vs);
    pgi__afree(r->emit);
    pgi__afree(r->indirect);
    pgi__view_fill_free(&r->fill);
    pgi__afree(r->fp_buf);
    pgi__guide_free(&r->guide);
    pgi__view_grid_free(&r->vgrid);
    pgi__view_grid_free(&r->near);
    free(r);
}

pgi_status pgi__check_view(const pgi_camera_def *v) {
    for (int k = 0; k < 3; k++)
        if (!isfinite(v->eye[k]) || !isfinite(v->look_at[k]) || !isfinite(v->up[k]))
            return pgi__fail(PGI_ERR_INVALID_ARG, "view camera has a non-finite eye, look-at or up");
    for (int k = 0; k < 3; k++)
        if (!(fabsf(v->eye[k]) <= PGI_MAX_COORD) || !(fabsf(v->look_at[k]) <= PGI_MAX_COORD) ||
            !(fabsf(v->up[k]) <= PGI_MAX_COORD))
            return pgi__fail(PGI_ERR_INVALID_ARG,
                             "view camera: eye (%g, %g, %g), look-at or up is beyond the coordinate range (-%g..%g)",
                             (double)v->eye[0], (double)v->eye[1], (double)v->eye[2], (double)PGI_MAX_COORD,
                             (double)PGI_MAX_COORD);
    pgi__v3 d = v3_sub(v3_load(v->look_at), v3_load(v->eye));
    if (!(v3_len(d) > 0.f) || !(v3_len(v3_cross(d, v3_load(v->up))) > 0.f))
        return pgi__fail(PGI_ERR_INVALID_ARG, "view camera is degenerate (eye = look-at, or up parallel to the view)");
    if (!(v->fov_y_deg > 0.f && v->fov_y_deg < 180.f))
        return pgi__fail(PGI_ERR_INVALID_ARG, "view camera field of view %g is outside (0, 180) degrees",
                         (double)v->fov_y_deg);
    return PGI_OK;
}

/* Fills defaults and rejects what cannot be rendered (the estimator's own
 * options are resolved and checked by pgi_estimator_desc_resolve). */
/* The automatic radius (d->radius == PGI_RADIUS_AUTO) from this frame's photons and view samples. */
static pgi_status choose_radius(pgi_renderer *r, pgi_render_desc *d, pgi_frame_stats *fs) {
    if (d->radius != PGI_RADIUS_AUTO) return PGI_OK;
    double t0 = pgi__now_ms();
    pgi_status st = pgi__auto_radius_choose(&r->ph, &r->vs, pgi__scene_diagonal(r->scene), d->threads, &d->radius,
                                            &fs->auto_radius);
    /* Within the radius range whatever the scene's size (pi r^2 stays a normal float). */
    if (!st && d->radius > 0.f && d->radius < (float)PGI_MIN_RADIUS) d->radius = (float)PGI_MIN_RADIUS;
    if (!st && d->radius > (float)PGI_MAX_RADIUS) d->radius = (float)PGI_MAX_RADIUS;
    fs->radius_ms = pgi__now_ms() - t0;
    fs->radius = d->radius;
    fs->settings.radius = d->radius;
    return st;
}

static pgi_status resolve_desc(const pgi_scene *s, const pgi_render_desc *in, pgi_render_desc *d) {
    pgi_status st;
    *d = *in;
    const pgi_scene_defaults *sd = &s->defaults;
    if (!d->estimator || !*d->estimator) d->estimator = PGI_DEFAULT_ESTIMATOR;
    const pgi_estimator_vtbl *vt = pgi_estimator_find(d->estimator);
    if (!vt) return pgi__fail_unknown_estimator(d->estimator);
    d->estimator = vt->name;
    if ((st = pgi_estimator_desc_resolve(vt, &in->est, &d->est))) return st;
    if (d->width == 0 && d->height == 0) {
        d->width = sd->width > 0 ? sd->width : 640;
        d->height = sd->height > 0 ? sd->height : 480;
    }
    if (d->width <= 0 || d->height <= 0 || d->width > PGI__MAX_SIDE || d->height > PGI__MAX_SIDE ||
        (uint64_t)d->width * (uint64_t)d->height > PGI__MAX_PIXELS)
        return pgi__fail(PGI_ERR_INVALID_ARG, "image size %dx%d is out of range (1..%d a side, at most %u pixels)",
                         d->width, d->height, PGI__MAX_SIDE, PGI__MAX_PIXELS);
    if (d->photons == 0) d->photons = sd->photons ? sd->photons : 200000;
    if (d->photons > PGI_MAX_PHOTONS)
        return pgi__fail(PGI_ERR_INVALID_ARG, "photon count %u is too large (at most %u)", d->photons, PGI_MAX_PHOTONS);
    if ((d->radius < 0.f && d->radius != PGI_RADIUS_AUTO) || !isfinite(d->radius))
        return pgi__fail(PGI_ERR_INVALID_ARG,
                         "photon radius must be a positive finite number (or 0: default, -1: automatic), got %g",
                         (double)d->radius);
    /* Progressive frames shrink the radius below the smallest given one (to a tenth after 10^6
     * frames, pgi_progressive_radius): a 16th of PGI_MIN_RADIUS is still far from pi r^2 underflowing. */
    if (d->radius > 0.f && !(d->radius >= (float)(PGI_MIN_RADIUS / 16.0) && d->radius <= PGI_MAX_RADIUS))
        return pgi__fail(PGI_ERR_INVALID_ARG, "photon radius %g is out of range (%g..%g: pi r^2 must stay a float)",
                         (double)d->radius, (double)PGI_MIN_RADIUS, (double)PGI_MAX_RADIUS);
    if (d->radius == 0.f && sd->radius > 0.f) d->radius = sd->radius;
    /* No radius anywhere: automatic with one fixed radius (chosen after the photons are traced, see
       choose_radius); the footprint policies keep 2% of the diagonal, their r_max. */
    if (d->radius == 0.f)
        d->radius = d->radius_policy == PGI_RADIUS_FIXED ? PGI_RADIUS_AUTO : 0.02f * pgi__scene_diagonal(s);
    if (d->radius == PGI_RADIUS_AUTO && d->radius_policy != PGI_RADIUS_FIXED)
        return pgi__fail(PGI_ERR_INVALID_ARG, "%s", "the automatic radius needs the fixed radius policy");
    if (d->bounces == 0) d->bounces = sd->bounces > 0 ? sd->bounces : 4;
    if (d->bounces < 1 || d->bounces > PGI__MAX_BOUNCES)
        return pgi__fail(PGI_ERR_INVALID_ARG, "bounces must be in 1..%d, got %d", PGI__MAX_BOUNCES, d->bounces);
    if (d->seed == 0) d->seed = 1;
    if (d->threads < 0)
        return pgi__fail(PGI_ERR_INVALID_ARG, "threads must be 0 (all) or positive, got %d", d->threads);
    if (d->camera < 0 || (size_t)d->camera >= s->ncams)
        return pgi__fail(PGI_ERR_INVALID_ARG, "camera %d does not exist (the scene has %zu)", d->camera, s->ncams);
    /* Through portals 3 of 4 of the sky's samples go towards an opening: 4 give no more noise than
       the cosine's 16 (docs/emission.md, Portals), on either device (direct.comp samples the
       portals as view.c). */
    if (d->direct_samples == 0)
        d->direct_samples = s->nportals && s->env ? PGI_DIRECT_SAMPLES_PORTALS : PGI_DIRECT_SAMPLES_DEFAULT;
    if (d->direct_samples < 0 || d->direct_samples > 4096)
        return pgi__fail(PGI_ERR_INVALID_ARG, "direct samples %d out of range (1..4096)", d->direct_samples);
    if (d->output < PGI_OUTPUT_ALL || d->output > PGI_OUTPUT_PHOTON_COUNT)
        return pgi__fail(PGI_ERR_INVALID_ARG, "unknown output mode %d", (int)d->output);
    if (d->view && (st = pgi__check_view(d->view))) return st;
    if (!(fabsf(d->shift[0]) <= 0.5f) || !(fabsf(d->shift[1]) <= 0.5f))
        return pgi__fail(PGI_ERR_INVALID_ARG, "sub-pixel shift (%g, %g) is outside [-0.5, 0.5]", (double)d->shift[0],
                         (double)d->shift[1]);
    /* radius policies */
    if (d->radius_policy < PGI_RADIUS_FIXED || d->radius_policy >= PGI_RADIUS_POLICY_COUNT_)
        return pgi__fail(PGI_ERR_INVALID_ARG, "unknown radius policy %d", d->radius_policy);
    if (d->r_min < 0.f || !isfinite(d->r_min) || d->r_max < 0.f || !isfinite(d->r_max) || d->smoothing < 0.f ||
        !isfinite(d->smoothing))
        return pgi__fail(PGI_ERR_INVALID_ARG,
                         "r_min, r_max and smoothing must be positive finite numbers (or 0: "
                         "default), got %g, %g, %g",
                         (double)d->r_min, (double)d->r_max, (double)d->smoothing);
    if ((d->r_min > 0.f && !(d->r_min >= (float)(PGI_MIN_RADIUS / 16.0) && d->r_min <= PGI_MAX_RADIUS)) ||
        (d->r_max > 0.f && !(d->r_max >= (float)(PGI_MIN_RADIUS / 16.0) && d->r_max <= PGI_MAX_RADIUS)))
        return pgi__fail(PGI_ERR_INVALID_ARG, "r_min %g or r_max %g is out of range (%g..%g, or 0: default)",
                         (double)d->r_min, (double)d->r_max, (double)PGI_MIN_RADIUS, (double)PGI_MAX_RADIUS);
    if (d->r_max == 0.f) d->r_max = d->radius > 0.f ? d->radius : 0.02f * pgi__scene_diagonal(s);
    if (d->r_min == 0.f) d->r_min = d->r_max / 8.f;
    if (!(d->r_min <= d->r_max))
        return pgi__fail(PGI_ERR_INVALID_ARG, "r_min (%g) must not exceed r_max (%g)", (double)d->r_min,
                         (double)d->r_max);
    if (d->radius_policy != PGI_RADIUS_FIXED && !(vt->caps & PGI_EST_CAP_PHOTON_RADIUS)) {
        char names[256] = "";
        for (size_t i = 0; i < pgi_estimator_count(); i++)
            if (pgi_estimator_at(i)->caps & PGI_EST_CAP_PHOTON_RADIUS)
                pgi__list_append(names, sizeof names, pgi_estimator_at(i)->name);
        return pgi__fail(PGI_ERR_INVALID_ARG,
                         "radius policy %s needs an estimator with per-photon footprints (%s); '%s' has one "
                         "fixed radius",
                         d->radius_policy == PGI_RADIUS_PATH ? "path" : "differentials", names, d->estimator);
    }
    if (d->jitter < PGI_JITTER_AUTO || d->jitter > PGI_JITTER_ON)
        return pgi__fail(PGI_ERR_INVALID_ARG, "unknown jitter mode %d", (int)d->jitter);
    if (d->jitter == PGI_JITTER_AUTO) d->jitter = PGI_JITTER_OFF; /* one frame: pixel centres */
    if (d->texture_filter < PGI_TEXTURE_FILTER_AUTO || d->texture_filter > PGI_TEXTURE_FILTER_ON)
        return pgi__fail(PGI_ERR_INVALID_ARG, "unknown texture filter %d", (int)d->texture_filter);
    if (d->texture_filter == PGI_TEXTURE_FILTER_AUTO)
        d->texture_filter = d->jitter == PGI_JITTER_OFF ? PGI_TEXTURE_FILTER_ON : PGI_TEXTURE_FILTER_OFF;
    if (d->emission < PGI_EMISSION_UNIFORM || d->emission > PGI_EMISSION_PORTAL)
        return pgi__fail(PGI_ERR_INVALID_ARG, "unknown emission mode %d", (int)d->emission);
    if (d->emission == PGI_EMISSION_PORTAL && !s->nportals)
        return pgi__fail(PGI_ERR_INVALID_ARG,
                         "--emission portal: scene '%s' has no portals (mark its windows with \"portals\" in its "
                         "description, docs/scene-format.md)",
                         s->name);
    if (d->emission == PGI_EMISSION_PORTAL && d->radius_policy != PGI_RADIUS_FIXED)
        return pgi__fail(PGI_ERR_INVALID_ARG, "%s",
                         "--emission portal needs --radius-policy fixed (the footprint policies size a photon from "
                         "the sun's and the sky's disk)");
    if (d->store < PGI_STORE_ALL || d->store > PGI_STORE_VIEW)
        return pgi__fail(PGI_ERR_INVALID_ARG, "unknown store mode %d", (int)d->store);
    if (d->store == PGI_STORE_VIEW && d->radius == PGI_RADIUS_AUTO)
        return pgi__fail(PGI_ERR_INVALID_ARG, "%s",
                         "storing only the photons in view needs a given radius (the automatic one is chosen "
                         "from the stored photons): set one (--radius R)");
    if (d->filter < 0 || d->filter > 16)
        return pgi__fail(PGI_ERR_INVALID_ARG, "filter radius %d is out of range (0..16 pixels)", d->filter);
    if (d->max_memory == 0) d->max_memory = pgi__mem_default_budget();
    if (d->device != PGI_DEVICE_CPU && d->device != PGI_DEVICE_VULKAN)
        return pgi__fail(PGI_ERR_INVALID_ARG, "unknown device %d", (int)d->device);
    if (d->device_index < 0)
        return pgi__fail(PGI_ERR_INVALID_ARG, "device index %d: 0 (automatic) or PGI_DEVICE_INDEX(i)", d->device_index);
    if (d->device == PGI_DEVICE_CPU) d->device_index = 0;
    /* `auto` on the GPU: the uniform emission the device traces (pgi__emission_plan_of) */
    if (d->device == PGI_DEVICE_VULKAN && d->emission == PGI_EMISSION_AUTO) d->emission = PGI_EMISSION_UNIFORM;
    return PGI_OK;
}

/* Progress reports (pgi_render_desc.progress): on the calling thread, between passes and
 * between the tracer's batches, never inside a parallel region. A pass starts with report(),
 * which is also where a cancel request (pgi_render_desc.cancel) ends the frame. */
typedef pgi__progress progress_ctx;

static pgi_status report(const progress_ctx *pc, const char *pass, uint64_t done, uint64_t total) {
    if (pgi__cancelled(pc->d->cancel)) return pgi__fail_cancelled(pass);
    if (!pc->d->progress) return PGI_OK;
    pgi_progress p = {.pass = pass,
                      .done = done,
                      .total = total,
                      .frame = 0,
                      .frames = 1,
                      .elapsed_ms = pgi__now_ms() - pc->t_start,
                      .radius = pc->d->radius > 0.f && !pc->radius_unknown ? pc->d->radius : 0.f};
    pc->d->progress(pc->d->progress_user, &p);
    return pgi__cancelled(pc->d->cancel) ? pgi__fail_cancelled(pass) : PGI_OK; /* asked from the callback */
}

static void report_trace(void *ctx, uint64_t stored, uint64_t total) {
    (void)report(ctx, "trace", stored, total); /* the tracer checks the cancel token itself */
}

pgi_status pgi__frame_report(const pgi__progress *pc, const char *pass, uint64_t done, uint64_t total) {
    return report(pc, pass, done, total);
}

void pgi__frame_report_trace(void *ctx, uint64_t stored, uint64_t total) { report_trace(ctx, stored, total); }

/* Points the photon buffer at the footprint arrays the policy needs (NULL for fixed). */
static pgi_status ensure_footprints(pgi_renderer *r, const pgi_render_desc *d) {
    pgi_photons *ph = &r->ph;
    ph->radius = ph->sax = ph->say = ph->saz = ph->sbx = ph->sby = ph->sbz = NULL;
    if (d->radius_policy == PGI_RADIUS_FIXED) return PGI_OK;
    size_t n = d->photons ? d->photons : 1, planes = d->radius_policy == PGI_RADIUS_DIFFERENTIALS ? 7 : 1;
    if (r->fp_cap < n * planes) {
        char what[64];
        snprintf(what, sizeof what, "%zu photon footprints", n);
        pgi_status st = pgi__mem_reserve(&r->mem, "footprints", n * planes * sizeof(float), what);
        if (st) return st;
        pgi__afree(r->fp_buf);
        r->fp_buf = pgi__aalloc(n * planes * sizeof(float));
        r->fp_cap = r->fp_buf ? n * planes : 0;
        pgi__mem_set(&r->mem, "footprints", r->fp_cap * sizeof(float));
        if (!r->fp_buf) return pgi__fail(PGI_ERR_OOM, "out of memory for %zu photon footprints", n);
    }
    ph->radius = r->fp_buf;
    if (planes == 7) {
        float **a[] = {&ph->sax, &ph->say, &ph->saz, &ph->sbx, &ph->sby, &ph->sbz};
        for (int k = 0; k < 6; k++) *a[k] = r->fp_buf + (size_t)(k + 1) * n;
    }
    return PGI_OK;
}

pgi_status pgi__frame_footprints(pgi_renderer *r, const pgi_render_desc *d) { return ensure_footprints(r, d); }

/* The host buffers of a frame of d (photons, view samples, emitted and indirect light). */
static pgi_status ensure_buffers(pgi_renderer *r, const pgi_render_desc *d) {
    char what[96];
    pgi_status st;
    if (r->ph.capacity < d->photons) {
        snprintf(what, sizeof what, "%u photons", d->photons);
        if ((st = pgi__mem_reserve(&r->mem, "photons", (size_t)d->photons * PHOTON_BYTES, what))) return st;
        pgi_photons_free(&r->ph);
        st = pgi_photons_alloc(&r->ph, d->photons);
        pgi__mem_set(&r->mem, "photons", r->ph.capacity * PHOTON_BYTES);
        if (st) return st;
    }
    size_t n = (size_t)d->width * (size_t)d->height;
    if (r->vs.width != d->width || r->vs.height != d->height) {
        snprintf(what, sizeof what, "the view samples of %dx%d pixels", d->width, d->height);
        if ((st = pgi__mem_reserve(&r->mem, "view_samples", n * VIEW_SAMPLE_BYTES, what))) return st;
        pgi__view_fill_forget(&r->fill);
        pgi_view_samples_free(&r->vs);
        st = pgi_view_samples_alloc(&r->vs, d->width, d->height);
        pgi__mem_set(&r->mem, "view_samples", r->vs.count * VIEW_SAMPLE_BYTES);
        if (st) return st;
    }
    if (r->pix_cap < n) {
        snprintf(what, sizeof what, "the emitted and indirect buffers of %dx%d pixels", d->width, d->height);
        if ((st = pgi__mem_reserve(&r->mem, "frame_buffers", n * FRAME_BUFFER_BYTES, what))) return st;
        pgi__view_fill_forget(&r->fill);
        pgi__afree(r->emit);
        pgi__afree(r->indirect);
        r->emit = pgi__aalloc(3 * n * sizeof(float));
        r->indirect = pgi__aalloc(3 * n * sizeof(float));
        r->pix_cap = n;
        if (!r->emit || !r->indirect) {
            r->pix_cap = 0;
            pgi__mem_set(&r->mem, "frame_buffers", 0);
            return pgi__fail(PGI_ERR_OOM, "out of memory for %dx%d frame buffers", d->width, d->height);
        }
    }
    if (r->scene_area == 0.0) r->scene_area = pgi__scene_area(r->scene);
    return PGI_OK;
}

/* ------------------------------------------------------------------ the CPU backend */

static cpu_state *cpu_of(pgi_renderer *r) { return r->dev[PGI_DEVICE_CPU]; }

/* The CPU is always there: its state, made once. */
static pgi_status cpu_ensure_device(pgi_renderer *r, const pgi_render_desc *d) {
    (void)d;
    if (!r->dev[PGI_DEVICE_CPU] && !(r->dev[PGI_DEVICE_CPU] = calloc(1, sizeof(cpu_state))))
        return pgi__fail(PGI_ERR_OOM, "out of memory creating a renderer");
    return PGI_OK;
}

static void cpu_release(pgi_renderer *r) {
    cpu_state *c = cpu_of(r);
    if (!c) return;
    pgi_estimator_destroy(c->est);
    free(c);
    r->dev[PGI_DEVICE_CPU] = NULL;
}

static const char *cpu_device_name(pgi_renderer *r) {
    (void)r;
    return "cpu";
}

/* The estimator for `d`: the one of the last frame while its name and options stay the same. */
static pgi_status ensure_estimator(pgi_renderer *r, const pgi_render_desc *d, int *created) {
    cpu_state *c = cpu_of(r);
    const pgi_estimator_vtbl *vt = pgi_estimator_find(d->estimator);
    if (c->est && c->est_vt == vt && memcmp(&d->est, &c->est_desc, sizeof d->est) == 0) return PGI_OK;
    pgi_estimator_destroy(c->est);
    c->est = NULL;
    pgi_status st = pgi_estimator_create(d->estimator, &d->est, &c->est);
    if (st) return st;
    c->est_vt = vt;
    c->est_desc = d->est;
    (*created)++;
    return PGI_OK;
}

/* View samples and photons of one frame (d resolved; jittered view samples take point `index` of
 * the sub-pixel sequence of `seq_seed`); fs gets the view and trace passes. */
static pgi_status prepare(pgi_renderer *r, const pgi_render_desc *d, uint64_t seq_seed, uint32_t index,
                          const progress_ctx *pc, pgi_frame_stats *fs) {
    pgi_status st;
    const pgi_scene *s = r->scene;
    if (pgi__rt_needs_update(r->rt, s)) {
        /* Animated objects or a moved area light: update the BVH before any ray. */
        double tu = pgi__now_ms();
        if ((st = pgi__rt_update(r->rt, s))) return st;
        fs->rt_update_ms = pgi__now_ms() - tu;
    }
    if ((st = report(pc, "view", 0, 0))) return st;
    double t0 = pgi__now_ms();
    pgi__rt_capture_pass(r->rt, PGI__PASS_VIEW); /* ray capture tags (a no-op unless a bench captures) */
    const pgi__subpixel sp = {.jitter = d->jitter == PGI_JITTER_ON,
                              .seed = seq_seed,
                              .index = index,
                              .shift = {d->shift[0], d->shift[1]},
                              .tex_filter = d->texture_filter == PGI_TEXTURE_FILTER_ON,
                              .tex_scale = r->tex_cone};
    if ((st = pgi__view_build(s, r->rt, &r->trace_scratch.tc, &r->cam, d->seed, &sp, d->threads, &r->vs, r->emit,
                              &r->fill, &fs->primary_rays)))
        return st;
    double t1 = pgi__now_ms();
    pgi__trace_desc td = {.photons = d->photons,
                          .bounces = d->bounces,
                          .seed = d->seed,
                          .threads = d->threads,
                          .cancel = d->cancel};
    if ((st = ensure_footprints(r, d))) return st;
    td.radius_policy = d->radius_policy;
    td.r_min = d->r_min;
    td.r_max = d->r_max;
    td.smoothing = d->smoothing;
    td.footprint_hist = fs->footprint_hist;
    if (d->progress) {
        td.progress = report_trace;
        td.progress_ctx = (void *)pc;
    }
    /* how the photons leave the lights (`auto`'s choice: src/photon/emission.c) */
    pgi__emission_plan ep;
    pgi__emission_plan_of(s, d, &ep);
    fs->emission.portals = s->nportals;
    fs->emission.portal_share = ep.portal_share;
    td.portals = ep.portal;
    fs->emission.portal = ep.portal;
    if (ep.guide) {
        /* the cells the camera sees: the radius when it is known now, else 1/256 of the diagonal */
        const float diag = pgi__scene_diagonal(s);
        float h = d->radius > 0.f ? d->radius : diag / 256.f;
        h = fminf(fmaxf(h, diag / 4096.f), diag / 32.f);
        double tg = pgi__now_ms();
        if ((st = pgi__view_grid_build(&r->vgrid, &r->vs, s->bmin, h))) return st;
        fs->emission.grid_ms = pgi__now_ms() - tg;
        fs->emission.cells = r->vgrid.count;
        fs->emission.cell = h;
        td.guide = &r->guide;
        td.vgrid = &r->vgrid;
        /* no stale figures if the tracer returns before the guide starts (no light, no bounce) */
        r->guide.on = 0;
        r->guide.gain = r->guide.value = 1.0;
        r->guide.yield = r->guide.yield_uniform = 0.0;
        r->guide.in_view = r->guide.useful_uniform = 0.0;
        td.min_gain = ep.min_value;
        td.guide_keep = r->guide_keep;
    }
    if (d->store == PGI_STORE_VIEW) {
        /* every cell a photon closer than the radius to a view sample can be in */
        const float rr = d->radius_policy == PGI_RADIUS_FIXED ? d->radius : d->r_max;
        const float h = fmaxf(2.f * rr, pgi__scene_diagonal(s) / 65536.f);
        double tg = pgi__now_ms();
        if ((st = pgi__view_grid_build_near(&r->near, &r->vs, s->bmin, h, rr))) return st;
        fs->emission.grid_ms += pgi__now_ms() - tg;
        td.near = &r->near;
    }
    pgi__rt_capture_pass(r->rt, PGI__PASS_TRACE);
    st = pgi__photons_trace(s, r->rt, &td, &r->ph, &r->trace_scratch, &fs->photon_rays);
    pgi__rt_capture_pass(r->rt, PGI__PASS_NONE);
    pgi__mem_set(&r->mem, "trace_scratch", pgi__trace_scratch_bytes(&r->trace_scratch));
    if (td.guide || td.near)
        pgi__mem_set(&r->mem, "emission_guide",
                     pgi__guide_bytes(&r->guide) + pgi__view_grid_bytes(&r->vgrid) + pgi__view_grid_bytes(&r->near));
    if (st) return st;
    fs->view_ms = t1 - t0;
    fs->trace_ms = pgi__now_ms() - t1;
    fs->photons_emitted = r->ph.emitted;
    fs->photons_stored = r->ph.count;
    fs->photon_paths_discarded = r->trace_scratch.paths_traced - r->ph.emitted - r->trace_scratch.paths_pilot;
    fs->emission.pilot_paths = r->trace_scratch.paths_pilot;
    fs->emission.culled = r->trace_scratch.culled;
    if (d->radius_policy != PGI_RADIUS_FIXED) fs->footprint_bin_width = d->r_max / 14.f;
    if (td.guide) {
        const pgi__guide *g = td.guide;
        fs->emission.guided = g->on;
        fs->emission.bins = g->nbins;
        fs->emission.gain = g->gain;
        fs->emission.paths_per_stored = g->yield > 0 ? 1.0 / g->yield : 0.0;
        fs->emission.paths_per_stored_uniform = g->yield_uniform > 0 ? 1.0 / g->yield_uniform : 0.0;
        fs->emission.value = g->value;
        fs->emission.in_view = g->in_view;
        fs->emission.in_view_uniform = g->useful_uniform;
    }
    fs->emission.used = pgi__emission_used(d, &ep, td.guide, &fs->emission.reason);
    return PGI_OK;
}

/* Stats every frame has: settings, size, threads. */
static void stats_begin(pgi_frame_stats *fs, const pgi_render_desc *d) {
    memset(fs, 0, sizeof *fs);
    fs->settings = *d;
    fs->settings.view = NULL;
    fs->settings.aovs = NULL;
    fs->settings.shift[0] = fs->settings.shift[1] = 0.f;
    fs->settings.progress = NULL;
    fs->settings.progress_user = NULL;
    fs->settings.cancel = NULL;
    fs->estimator = d->estimator;
    fs->width = d->width;
    fs->height = d->height;
    fs->threads = pgi__threads(d->threads);
    fs->radius = d->radius;
    fs->radius_policy = d->radius_policy;
    fs->frames = 1;
    fs->device = "cpu";
}

/* Appends a pass to the frame's stats (the list is bounded). */
void pgi__frame_pass(pgi_frame_stats *fs, const char *name, double ms) {
    if (fs->pass_count < PGI_MAX_STAT_ENTRIES) fs->passes_ms[fs->pass_count++] = (pgi_named_value){name, ms};
}

/* The arguments of the CPU estimator's calls. */
static pgi_estimate_args cpu_args(pgi_renderer *r, const pgi_render_desc *d) {
    return (pgi_estimate_args){.photons = &r->ph,
                               .samples = &r->vs,
                               .camera = &r->cam,
                               .out_rgb = r->indirect,
                               .radius = d->radius,
                               .seed = d->seed,
                               .threads = d->threads,
                               .scene_area = (float)r->scene_area,
                               .cancel = d->cancel};
}

/* The part of a frame before the radius (view samples, photons) does not read it. */
static int cpu_late_radius(const pgi_render_desc *in) {
    return in->radius_policy == PGI_RADIUS_FIXED && in->emission == PGI_EMISSION_UNIFORM && in->store == PGI_STORE_ALL;
}

/* The inputs are on the host already. */
static pgi_status cpu_to_host(pgi_renderer *r, const pgi_render_desc *d, pgi_frame_stats *fs) {
    (void)r, (void)d, (void)fs;
    return PGI_OK;
}

/* The estimator's build and gather into r->indirect, then the reconstruction filter (a pass of
 * its own, "filter", not the estimator's time). */
static pgi_status cpu_indirect(pgi_renderer *r, const pgi_render_desc *d, const progress_ctx *pc, pgi_frame_stats *fs,
                               pgi_estimator_stats *es) {
    cpu_state *c = cpu_of(r);
    const pgi_estimate_args ea = cpu_args(r, d);
    pgi_status st;
    /* the direct light alone reads no indirect light (as on the GPU): no gather */
    if (d->output == PGI_OUTPUT_DIRECT && !d->aovs) return PGI_OK;
    double t2 = pgi__now_ms();
    if ((st = pgi_estimator_build(c->est, &ea))) return st;
    double t3 = pgi__now_ms();
    if ((st = report(pc, "estimate", 0, 0))) return st;
    if ((st = pgi_estimator_estimate(c->est, &ea))) return st;
    const double t_est = pgi__now_ms();
    if (d->filter > 0 && (st = pgi__bilateral_filter(&r->vs, d->filter, d->threads, r->indirect))) return st;
    const double filter_ms = d->filter > 0 ? pgi__now_ms() - t_est : 0.0;
    pgi_estimator_get_stats(c->est, es);
    fs->build_ms = t3 - t2;
    fs->estimate_ms = t_est - t3;
    for (int k = 0; k < es->pass_count; k++) pgi__frame_pass(fs, es->pass_names[k], es->pass_ms[k]);
    if (d->filter > 0) pgi__frame_pass(fs, "filter", filter_ms);
    return PGI_OK;
}

/* The direct pass writes the image itself (emitted + direct + weight x indirect: the composite), so
 * that the direct light never makes a trip through memory. The indirect light alone needs no direct
 * light: no shadow ray. The photon counts (PGI_OUTPUT_PHOTON_COUNT) overwrite the image last. */
static pgi_status cpu_compose(pgi_renderer *r, const pgi_render_desc *d, const progress_ctx *pc, pgi_frame_stats *fs,
                              pgi_image *img) {
    const size_t n = (size_t)d->width * d->height;
    pgi_status st;
    double t4 = pgi__now_ms();
    const pgi__direct_sum sum = {.emit = r->emit,
                                 .indirect = r->indirect,
                                 .output = d->output,
                                 .direct = d->aovs ? d->aovs->direct : NULL,
                                 .cancel = d->cancel};
    if (d->output == PGI_OUTPUT_INDIRECT) {
        pgi__indirect_image(&r->vs, r->indirect, d->threads, img->rgb);
        if (sum.direct) memset(sum.direct, 0, 3 * n * sizeof(float));
        st = PGI_OK;
    } else {
        if ((st = report(pc, "direct", 0, 0))) return st;
        pgi__rt_capture_pass(r->rt, PGI__PASS_DIRECT);
        st = pgi__direct(r->scene, r->rt, &r->vs, &r->fill, &sum, d->direct_samples, d->seed, d->threads, img->rgb,
                         &fs->shadow_rays);
        pgi__rt_capture_pass(r->rt, PGI__PASS_NONE);
    }
    if (!st && d->aovs) pgi__view_aovs(&r->vs, r->indirect, d->threads, d->aovs);
    if (st) return st;
    fs->direct_ms = pgi__now_ms() - t4;
    if (d->output == PGI_OUTPUT_PHOTON_COUNT) {
        const pgi_estimate_args ea = cpu_args(r, d);
        return pgi__photon_counts(cpu_of(r)->est, &ea, img->rgb);
    }
    return PGI_OK;
}

static void cpu_finish(pgi_renderer *r, const pgi_render_desc *d, const pgi_estimator_stats *es, pgi_frame_stats *fs) {
    (void)r, (void)d;
    fs->reads_bulk = es->reads_bulk;
    fs->leaf_size = es->leaf_size;
}

const pgi__frame_backend pgi__frame_cpu = {
    .ensure_device = cpu_ensure_device,
    .ensure_estimator = ensure_estimator,
    .device_name = cpu_device_name,
    .late_radius = cpu_late_radius,
    .inputs = prepare,
    .to_host = cpu_to_host,
    .indirect = cpu_indirect,
    .compose = cpu_compose,
    .finish = cpu_finish,
    .release = cpu_release,
};

/* ------------------------------------------------------------------ the devices
 * One row a device: the backend that runs its passes, the settings it has, the estimators it runs
 * and the options they take there. The one table behind every "not supported on this device"
 * refusal (device_check) and the lists of what each device runs (pgi_device_estimators). */

/* The settings not every device has: whether d uses one, and its name as the command line spells it. */
enum { F_SHIFT, F_AOVS, F_COUNTS, F_RADIUS_POLICY, F_EMISSION, F_STORE_VIEW, F_FILTER, F_COUNT };

static int uses_feature(const pgi_render_desc *d, int f, char *name, size_t size) {
    static const char *const emission[] = {"uniform", "guided", "auto", "portal"};
    switch (f) {
    case F_SHIFT:
        snprintf(name, size, "a sub-pixel shift (pgi_render_desc.shift)");
        return d->shift[0] != 0.f || d->shift[1] != 0.f;
    case F_AOVS: snprintf(name, size, "AOVs (pgi_render_desc.aovs)"); return d->aovs != NULL;
    case F_COUNTS: snprintf(name, size, "--output counts"); return d->output == PGI_OUTPUT_PHOTON_COUNT;
    case F_RADIUS_POLICY:
        snprintf(name, size, "--radius-policy %s", d->radius_policy == PGI_RADIUS_PATH ? "path" : "differentials");
        return d->radius_policy != PGI_RADIUS_FIXED;
    case F_EMISSION:
        snprintf(name, size, "--emission %s",
                 d->emission >= PGI_EMISSION_UNIFORM && d->emission <= PGI_EMISSION_PORTAL ? emission[d->emission]
                                                                                           : "?");
        return d->emission != PGI_EMISSION_UNIFORM;
    case F_STORE_VIEW: snprintf(name, size, "--store view"); return d->store == PGI_STORE_VIEW;
    case F_FILTER: snprintf(name, size, "--filter (the bilateral filter)"); return d->filter > 0;
    default: return 0;
    }
}
/* The settings the view samples or photons depend on (pgi_renderer_prepare checks only these). */
#define INPUT_FEATURES (1u << F_SHIFT | 1u << F_RADIUS_POLICY | 1u << F_EMISSION | 1u << F_STORE_VIEW)

/* The PGI_EST_CAP_* options estimator vt takes on a device; -1: it does not run there. */
static long cpu_est_caps(const pgi_estimator_vtbl *vt) { return (long)vt->caps; }
static long vulkan_est_caps(const pgi_estimator_vtbl *vt) {
    return pgi__gpu_est_find(vt->name) ? (long)(vt->caps & pgi__gpu_est_caps(vt->name)) : -1;
}

typedef struct device_row {
    const char *name;      /* as --device spells it */
    const char *label;     /* in a refusal: "... is not supported on the GPU device" */
    const char *est_label; /* "estimator 'kdtree' has no GPU version" */
    const pgi__frame_backend *backend;
    unsigned has; /* the settings (1 << F_*) it runs */
    long (*est_caps)(const pgi_estimator_vtbl *vt);
} device_row;

static const device_row k_devices[PGI__DEVICE_COUNT] = {
    [PGI_DEVICE_CPU] = {"cpu", "the CPU", "CPU", &pgi__frame_cpu, (1u << F_COUNT) - 1, cpu_est_caps},
    [PGI_DEVICE_VULKAN] = {"vulkan", "the GPU device", "GPU", &pgi__frame_vulkan, 1u << F_RADIUS_POLICY,
                           vulkan_est_caps},
};

static const pgi__frame_backend *device_backend(pgi_device dev) {
    return (int)dev >= 0 && (int)dev < PGI__DEVICE_COUNT ? k_devices[dev].backend : NULL;
}

/* "hashgrid, tiled, ...": the registered estimators that run on dev and there take every option
 * of caps (PGI_EST_CAP_*; 0: any), in the registry's order. */
static void device_estimators(const device_row *dev, long caps, char *buf, size_t size) {
    if (size) buf[0] = 0;
    for (size_t i = 0; i < pgi_estimator_count(); i++) {
        const long c = dev->est_caps(pgi_estimator_at(i));
        if (c >= 0 && (c & caps) == caps) pgi__list_append(buf, size, pgi_estimator_at(i)->name);
    }
}

/* The first device that has setting f (every setting is on the CPU). */
static const char *device_with(unsigned f) {
    for (int i = 0; i < PGI__DEVICE_COUNT; i++)
        if (k_devices[i].has & 1u << f) return k_devices[i].name;
    return k_devices[PGI_DEVICE_CPU].name;
}

/* Refuses by name (PGI_ERR_UNSUPPORTED) what d's device does not run: its estimator, the
 * estimator's options there, the frame's settings. frame 0 (pgi_renderer_prepare): only the
 * settings of the view samples and photons. d resolved (its device valid). */
static pgi_status device_check(const pgi_render_desc *d, int frame) {
    const device_row *dev = &k_devices[d->device];
    char what[96];
    if (frame) {
        const pgi_estimator_vtbl *vt = pgi_estimator_find(d->estimator);
        const long caps = dev->est_caps(vt);
        if (caps < 0) {
            char names[256];
            device_estimators(dev, 0, names, sizeof names);
            return pgi__fail(PGI_ERR_UNSUPPORTED, "estimator '%s' has no %s version; on --device %s: %s", d->estimator,
                             dev->est_label, dev->name, names);
        }
        const char *opt = NULL;
        if (d->est.kernel != PGI_KERNEL_CONSTANT && !(caps & PGI_EST_CAP_KERNELS)) opt = "kernel";
        else if (d->est.subsample > 1 && !(caps & PGI_EST_CAP_SUBSAMPLE)) opt = "subsample";
        if (d->radius_policy != PGI_RADIUS_FIXED && !(caps & PGI_EST_CAP_PHOTON_RADIUS)) {
            /* the device traces the footprints; the estimator must read them there */
            char names[256];
            device_estimators(dev, PGI_EST_CAP_PHOTON_RADIUS, names, sizeof names);
            uses_feature(d, F_RADIUS_POLICY, what, sizeof what);
            return pgi__fail(PGI_ERR_UNSUPPORTED,
                             "%s with estimator '%s' is not supported on %s: its %s version has one fixed radius "
                             "(per-photon footprints there: %s; use --device %s)",
                             what, d->estimator, dev->label, dev->est_label, names[0] ? names : "none",
                             k_devices[PGI_DEVICE_CPU].name);
        }
        if (opt) {
            char value[32];
            pgi_option_format(pgi_option_find(opt), &d->est, value, sizeof value);
            return pgi__fail(PGI_ERR_UNSUPPORTED,
                             "--%s %s with estimator '%s' is not supported on %s (use --device %s)", opt, value,
                             d->estimator, dev->label, k_devices[PGI_DEVICE_CPU].name);
        }
    }
    for (int f = 0; f < F_COUNT; f++)
        if ((frame || (INPUT_FEATURES & 1u << f)) && !(dev->has & 1u << f) && uses_feature(d, f, what, sizeof what))
            return pgi__fail(PGI_ERR_UNSUPPORTED, "%s is not supported on %s (use --device %s)", what, dev->label,
                             device_with((unsigned)f));
    return PGI_OK;
}

/* ------------------------------------------------------------------ the frame */

/* The camera of d and the host buffers of its size: what the inputs of every device start from. */
static pgi_status frame_begin(pgi_renderer *r, const pgi_render_desc *d) {
    pgi_status st = ensure_buffers(r, d);
    if (st) return st;
    const pgi_camera_def *cd = d->view ? d->view : &r->scene->cams[d->camera];
    pgi_camera_look_at(&r->cam, cd->eye, cd->look_at, cd->up, cd->fov_y_deg, d->width, d->height);
    return PGI_OK;
}

/* The output image: the caller's when it already has this size (steady-state frames then allocate
 * nothing). */
static pgi_status frame_image(pgi_renderer *r, const pgi_render_desc *d, const pgi_image *out, pgi_image *img) {
    const size_t n = (size_t)d->width * d->height;
    *img = *out;
    if (img->rgb && img->width == d->width && img->height == d->height) return PGI_OK;
    char what[64];
    snprintf(what, sizeof what, "the %dx%d output image", d->width, d->height);
    pgi_status st = pgi__mem_reserve(&r->mem, "image", 3 * n * sizeof(float), what);
    if (st) return st;
    *img = (pgi_image){d->width, d->height, malloc(3 * n * sizeof(float))};
    if (!img->rgb) return pgi__fail(PGI_ERR_OOM, "out of memory for the output image");
    return PGI_OK;
}

pgi_status pgi_renderer_prepare(pgi_renderer *r, const pgi_render_desc *in, pgi_frame_inputs *out,
                                pgi_frame_stats *stats) {
    if (!r || !in || !out) return pgi__fail(PGI_ERR_INVALID_ARG, "pgi_renderer_prepare: NULL argument");
    pgi__clear_error();
    pgi_render_desc d;
    pgi_status st = resolve_desc(r->scene, in, &d);
    if (st || (st = device_check(&d, 0))) return st;
    pgi_frame_stats fs;
    stats_begin(&fs, &d);
    if ((st = mem_plan(r, &d, NULL))) return st;
    const pgi__frame_backend *be = device_backend(d.device);
    if ((st = be->ensure_device(r, &d))) return st;
    fs.device = be->device_name(r);
    double t0 = pgi__now_ms();
    const progress_ctx pc = {&d, t0, 0};
    if ((st = frame_begin(r, &d)) || (st = be->inputs(r, &d, d.seed, 0, &pc, &fs))) return st;
    if ((st = choose_radius(r, &d, &fs)) || (st = be->to_host(r, &d, &fs))) return st;
    fs.total_ms = pgi__now_ms() - t0;
    mem_stats(r, NULL, &fs);
    *out = (pgi_frame_inputs){.photons = &r->ph,
                              .samples = &r->vs,
                              .camera = r->cam,
                              .radius = d.radius,
                              .scene_area = (float)r->scene_area,
                              .seed = d.seed};
    if (stats) *stats = fs;
    return PGI_OK;
}

pgi_status pgi_renderer_render(pgi_renderer *r, const pgi_render_desc *in, pgi_image *out, pgi_frame_stats *stats) {
    return pgi__renderer_render_frame(r, in, 0, 0, out, stats);
}

pgi_status pgi__renderer_render_frame(pgi_renderer *r, const pgi_render_desc *in, uint64_t seq_seed, uint32_t index,
                                      pgi_image *out, pgi_frame_stats *stats) {
    return pgi__renderer_render_frame_late(r, in, seq_seed, index, NULL, NULL, out, stats);
}

/* The one frame function: every pgi_renderer_render, progressive and temporal step, on either device. */
pgi_status pgi__renderer_render_frame_late(pgi_renderer *r, const pgi_render_desc *in, uint64_t seq_seed,
                                           uint32_t index, pgi__late_radius_fn radius_fn, void *user, pgi_image *out,
                                           pgi_frame_stats *stats) {
    if (!r || !in || !out) return pgi__fail(PGI_ERR_INVALID_ARG, "pgi_renderer_render: NULL argument");
    pgi__clear_error();
    pgi_render_desc given = *in, d;
    int late = 0;
    if (radius_fn) {
        const pgi__frame_backend *be = device_backend(in->device);
        if (be && be->late_radius && be->late_radius(in)) {
            late = 1;
            given.radius = 1.f; /* a stand-in: nothing before the radius reads it */
        } else given.radius = radius_fn(user, (int)index);
    }
    pgi_status st = resolve_desc(r->scene, &given, &d);
    if (st || (st = device_check(&d, 1))) return st;
    if (seq_seed == 0) seq_seed = d.seed; /* a lone frame: the sequence of its own seed */
    double t_start = pgi__now_ms();
    pgi_frame_stats fs;
    stats_begin(&fs, &d);
    if ((st = mem_plan(r, &d, pgi_estimator_find(d.estimator)))) return st;
    const pgi__frame_backend *be = device_backend(d.device);
    if ((st = be->ensure_device(r, &d)) || (st = be->ensure_estimator(r, &d, &fs.estimators_created))) return st;
    fs.device = be->device_name(r);
    if (d.device == PGI_DEVICE_VULKAN)
        fs.emission.reason = in->emission == PGI_EMISSION_AUTO ? "the GPU traces uniform emission only" : "asked for";
    progress_ctx pc = {&d, t_start, late};
    if ((st = frame_begin(r, &d)) || (st = be->inputs(r, &d, seq_seed, index, &pc, &fs))) return st;
    if (late) {
        /* the radius now: the desc resolved with it, as pgi__renderer_render_frame would have
           (only the radius and what derives from it differ from the stand-in's) */
        double tw = pgi__now_ms();
        given.radius = radius_fn(user, (int)index);
        pgi_render_desc d2;
        if ((st = resolve_desc(r->scene, &given, &d2))) return st;
        d.radius = d2.radius;
        d.r_min = d2.r_min;
        d.r_max = d2.r_max;
        fs.settings.radius = d.radius;
        fs.settings.r_min = d.r_min;
        fs.settings.r_max = d.r_max;
        fs.radius = d.radius;
        const double waited = pgi__now_ms() - tw; /* the caller's wait is not the frame's time */
        t_start += waited;
        pc.t_start = t_start;
        pc.radius_unknown = 0;
    }
    if ((st = choose_radius(r, &d, &fs))) return st;
    pgi_estimator_stats es;
    memset(&es, 0, sizeof es);
    if ((st = report(&pc, "build", 0, 0)) || (st = be->indirect(r, &d, &pc, &fs, &es))) return st;
    pgi_image img;
    if ((st = frame_image(r, &d, out, &img))) return st;
    if ((st = be->compose(r, &d, &pc, &fs, &img))) {
        if (img.rgb != out->rgb) free(img.rgb);
        return st;
    }
    if (img.rgb != out->rgb) pgi_image_free(out);
    fs.total_ms = pgi__now_ms() - t_start;
    pgi__mem_set(&r->mem, "image", 3 * (size_t)d.width * d.height * sizeof(float));
    mem_stats(r, &es, &fs);
    fs.reads = es.reads;
    fs.contributing = es.contributing;
    fs.nodes_visited = es.nodes_visited;
    be->finish(r, &d, &es, &fs);
    if (stats) *stats = fs;
    *out = img;
    return PGI_OK;
}

pgi_status pgi_render(const pgi_scene *scene, const pgi_render_desc *desc, pgi_image *out, pgi_frame_stats *stats) {
    pgi_renderer *r;
    pgi_status st = pgi_renderer_create(scene, &r);
    if (st) return st;
    st = pgi_renderer_render(r, desc, out, stats);
    pgi_renderer_destroy(r);
    return st;
}

int pgi_vulkan_available(void) { return pgi__gpu_available(); }

int pgi_device_count(void) { return pgi__gpu_device_count(); }

pgi_status pgi_device_name(int i, char *buf, size_t size) { return pgi__gpu_device_name_at(i, buf, size); }

pgi_status pgi_device_driver(int i, char *buf, size_t size) { return pgi__gpu_device_driver_at(i, buf, size); }

void pgi_device_estimators(char *buf, size_t size) { device_estimators(&k_devices[PGI_DEVICE_VULKAN], 0, buf, size); }

int pgi_estimator_runs_on(const pgi_estimator_vtbl *vt, pgi_device device) {
    return vt && device_backend(device) && k_devices[device].est_caps(vt) >= 0;
}

int pgi_estimator_takes_on(const pgi_estimator_vtbl *vt, const pgi_option *o, pgi_device device) {
    if (!o || !pgi_estimator_runs_on(vt, device) || !pgi_estimator_takes(vt, o)) return 0;
    return !o->caps || (k_devices[device].est_caps(vt) & (long)o->caps) != 0;
}
