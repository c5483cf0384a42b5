/* The Vulkan device's passes of the frame (frame.h; --device vulkan, docs/gpu.md): the view samples
 * (gpu_view.h view.comp), the photons (gpu_trace.h), the estimator on the device's photons and view
 * samples, direct light with the sum (direct.comp); the image is read back. Two command sequences:
 * the view pass, then (after the automatic radius, which reads the view samples and photons back,
 * only when it is asked for) the estimator and direct light. */
#include <stdio.h>
#include <string.h>

#include "gpu/gpu_estimator.h"
#include "gpu/gpu_scene.h"
#include "gpu/gpu_trace.h"
#include "gpu/gpu_view.h"
#include "pipeline/frame.h"

/* The backend's state (pgi_renderer.dev[PGI_DEVICE_VULKAN]). */
typedef struct gpu_state {
    /* the device (made on the first frame, kept; again when the index changes) and the GPU estimator
     * (once per name + options, as the CPU one) */
    pgi__gpu *gpu;
    int index; /* device_index it was made for */
    void *est;
    const pgi__gpu_est_vtbl *est_vt;
    pgi_estimator_desc est_desc;
    /* the scene on the device, the view/direct passes, the photon tracer (the photons stay on the device) */
    pgi__gpu_scene *scene;
    pgi__gpu_view *view;
    pgi__gpu_trace *trace;
    /* test hook PGI_GPU_CPU_PHOTONS=1: the CPU tracer's photons and footprints, uploaded
     * (gpu_photons_cpu) */
    pgi__gpu_buffer *cpu_photons, *cpu_footprints;
    pgi__packed_photon *packed;
    size_t packed_cap;
    pgi__gpu_footprint *packed_fp;
    size_t packed_fp_cap;
    /* this frame's: its photons on the device and their footprints (NULL: the fixed radius;
     * fp_ellipsoids: differentials' ellipsoids), whether r->vs holds its view samples, the device's
     * timings of its sequences and the wall clock of the second one and of the read-back */
    pgi__gpu_buffer *photons, *footprints;
    int fp_ellipsoids;
    size_t np;
    int vs_on_host;
    pgi_named_value t[64];
    int nt;
    double ts, te, td0, td1;
    pgi__gpu_traffic traffic0; /* the device's exchanges with the host before this frame */
} gpu_state;

static gpu_state *state_of(pgi_renderer *r) { return r->dev[PGI_DEVICE_VULKAN]; }

/* Everything on the device (the state itself stays). */
static void release_device(gpu_state *s) {
    if (s->est_vt) s->est_vt->destroy(s->est);
    s->est = NULL;
    s->est_vt = NULL;
    pgi__gpu_trace_destroy(s->trace);
    s->trace = NULL;
    pgi__gpu_view_destroy(s->view);
    s->view = NULL;
    pgi__gpu_scene_destroy(s->scene);
    s->scene = NULL;
    if (s->gpu) {
        pgi__gpu_buffer_destroy(s->gpu, s->cpu_photons);
        pgi__gpu_buffer_destroy(s->gpu, s->cpu_footprints);
    }
    s->cpu_photons = s->cpu_footprints = NULL;
    pgi__gpu_destroy(s->gpu);
    s->gpu = NULL;
}

static void gpu_release(pgi_renderer *r) {
    gpu_state *s = state_of(r);
    if (!s) return;
    release_device(s);
    pgi__afree(s->packed);
    free(s->packed_fp);
    free(s);
    r->dev[PGI_DEVICE_VULKAN] = NULL;
}

/* The device for d: the renderer's while the device index stays the same. */
static pgi_status gpu_ensure_device(pgi_renderer *r, const pgi_render_desc *d) {
    pgi_status st;
    if (!pgi__gpu_available())
        return pgi__fail(PGI_ERR_UNSUPPORTED, "%s",
                         "--device vulkan: this build of photongi has no Vulkan backend (built without "
                         "Vulkan/glslc); use --device cpu");
    gpu_state *s = state_of(r);
    if (!s) {
        if (!(s = calloc(1, sizeof *s))) return pgi__fail(PGI_ERR_OOM, "out of memory for the GPU frame");
        r->dev[PGI_DEVICE_VULKAN] = s;
    }
    if (s->gpu && s->index != d->device_index) release_device(s);
    if (!s->gpu) {
        if ((st = pgi__gpu_create(d->device_index - 1, &s->gpu))) return st;
        s->index = d->device_index;
    }
    pgi__gpu_set_budget(s->gpu, d->max_memory);
    if (!s->scene && (st = pgi__gpu_scene_create(s->gpu, r->scene, &s->scene))) return st;
    if (!s->view && (st = pgi__gpu_view_create(s->gpu, &s->view))) return st;
    if (!s->trace && (st = pgi__gpu_trace_create(s->gpu, s->scene, &s->trace))) return st;
    return PGI_OK;
}

/* The GPU estimator for d (the device table has checked that it has one, with d's options). */
static pgi_status gpu_ensure_estimator(pgi_renderer *r, const pgi_render_desc *d, int *created) {
    gpu_state *s = state_of(r);
    const pgi__gpu_est_vtbl *vt = pgi__gpu_est_find(d->estimator);
    if (!vt) return pgi__fail(PGI_ERR_UNSUPPORTED, "estimator '%s' has no GPU version", d->estimator);
    if (s->est_vt == vt && memcmp(&d->est, &s->est_desc, sizeof d->est) == 0) return PGI_OK;
    if (s->est_vt) s->est_vt->destroy(s->est);
    s->est = NULL;
    s->est_vt = NULL;
    pgi_status st = vt->create(s->gpu, &d->est, &s->est);
    if (st) return st;
    s->est_vt = vt;
    s->est_desc = d->est;
    (*created)++;
    return PGI_OK;
}

static const char *gpu_device_name(pgi_renderer *r) { return pgi__gpu_device_name(state_of(r)->gpu); }

/* Test hook PGI_GPU_CPU_PHOTONS=1: the CPU tracer's photons (pgi__photons_trace into r->ph), packed
 * and uploaded (a buffer also named "gpu_photons"; pass "gpu_upload"), with their footprints under
 * a radius policy ("gpu_footprints"), so that tests can compare the device's other passes with the
 * CPU's frame on the same photons (test_gpu, test_gpu_cli). */
static pgi_status gpu_photons_cpu(pgi_renderer *r, const pgi_render_desc *d, const pgi__progress *pc,
                                  pgi_frame_stats *fs) {
    gpu_state *s = state_of(r);
    pgi_status st;
    if (pgi__rt_needs_update(r->rt, r->scene)) { /* the CPU tracer's Embree scene (only this hook uses it) */
        double tu = pgi__now_ms();
        if ((st = pgi__rt_update(r->rt, r->scene))) return st;
        fs->rt_update_ms += pgi__now_ms() - tu;
    }
    double t0 = pgi__now_ms();
    pgi__trace_desc td = {.photons = d->photons,
                          .bounces = d->bounces,
                          .seed = d->seed,
                          .threads = d->threads,
                          .radius_policy = d->radius_policy,
                          .r_min = d->r_min,
                          .r_max = d->r_max,
                          .smoothing = d->smoothing,
                          .footprint_hist = fs->footprint_hist};
    if ((st = pgi__frame_footprints(r, d))) return st;
    if (d->progress) {
        td.progress = pgi__frame_report_trace;
        td.progress_ctx = (void *)pc;
    }
    pgi__rt_capture_pass(r->rt, PGI__PASS_TRACE);
    st = pgi__photons_trace(r->scene, r->rt, &td, &r->ph, &r->trace_scratch, &fs->photon_rays);
    pgi__rt_capture_pass(r->rt, PGI__PASS_NONE);
    pgi__mem_set(&r->mem, "trace_scratch", pgi__trace_scratch_bytes(&r->trace_scratch));
    if (st) return st;
    double t1 = pgi__now_ms();
    fs->trace_ms = t1 - t0;
    fs->photons_emitted = r->ph.emitted;
    fs->photons_stored = r->ph.count;
    fs->photon_paths_discarded = r->trace_scratch.paths_traced - r->ph.emitted - r->trace_scratch.paths_pilot;
    const size_t np = r->ph.count;
    if ((st = pgi__ensure((void **)&s->packed, &s->packed_cap, np + 1, sizeof(pgi__packed_photon)))) return st;
#pragma omp parallel for schedule(static) num_threads(pgi__threads(d->threads))
    for (long long j = 0; j < (long long)np; j++) pgi__pack_photon(&r->ph, (size_t)j, &s->packed[j]);
    if ((st = pgi__gpu_buffer_reserve(s->gpu, &s->cpu_photons, (np + 1) * sizeof(pgi__packed_photon), "gpu_photons")) ||
        (st = pgi__gpu_upload(s->gpu, s->cpu_photons, 0, s->packed, np * sizeof(pgi__packed_photon))))
        return st;
    s->fp_ellipsoids = d->radius_policy == PGI_RADIUS_DIFFERENTIALS;
    double fp_area;
    if (d->radius_policy != PGI_RADIUS_FIXED &&
        (st = pgi__gpu_est_upload_footprints(s->gpu, &r->ph, d->threads, "gpu_footprints", &s->packed_fp,
                                             &s->packed_fp_cap, &s->cpu_footprints, &fp_area)))
        return st;
    pgi__frame_pass(fs, "gpu_upload", pgi__now_ms() - t1);
    s->photons = s->cpu_photons;
    s->footprints = d->radius_policy != PGI_RADIUS_FIXED ? s->cpu_footprints : NULL;
    s->np = np;
    return PGI_OK;
}

/* The frame's photons on the device (gpu_trace.h: traced there, pgi__packed_photon, s->np of them,
 * in the tracer's buffer "gpu_photons"; under a radius policy their footprints, "gpu_footprints");
 * fs gets trace_ms (the device's "gpu_trace" timestamps), the photon counts and the pass
 * "gpu_trace". The CPU tracer does not run. The photons are read back into r->ph (with their
 * footprints: the host's footprint arrays are made ready here) only when the automatic radius or
 * pgi_renderer_prepare needs them (pass "gpu_trace_download"); otherwise r->ph holds none after
 * the pass. */
static pgi_status gpu_photons(pgi_renderer *r, const pgi_render_desc *d, const pgi__progress *pc, pgi_frame_stats *fs) {
    const char *hook = getenv("PGI_GPU_CPU_PHOTONS");
    if (hook && strcmp(hook, "1") == 0) return gpu_photons_cpu(r, d, pc, fs);
    gpu_state *s = state_of(r);
    pgi_status st;
    const pgi__gpu_trace_desc td = {.photons = d->photons,
                                    .bounces = d->bounces,
                                    .seed = d->seed,
                                    .radius_policy = d->radius_policy,
                                    .r_min = d->r_min,
                                    .r_max = d->r_max,
                                    .smoothing = d->smoothing,
                                    .emission = (int)d->emission,
                                    .store = (int)d->store};
    if (d->progress) pgi__frame_report_trace((void *)pc, 0, d->photons);
    if ((st = pgi__frame_footprints(r, d))) return st;
    pgi__gpu_trace_result tr;
    if ((st = pgi__gpu_trace_run(s->trace, r->scene, &td, &tr))) return st;
    if (d->progress) pgi__frame_report_trace((void *)pc, tr.count, d->photons);
    fs->trace_ms = tr.trace_ms;
    fs->photons_emitted = tr.emitted;
    fs->photons_stored = tr.count;
    fs->photon_rays = tr.rays;
    fs->photon_paths_discarded = tr.paths_discarded;
    memcpy(fs->footprint_hist, tr.footprint_hist, sizeof fs->footprint_hist);
    pgi__frame_pass(fs, "gpu_trace", tr.trace_ms);
    r->ph.count = 0;
    r->ph.emitted = tr.emitted;
    if (d->radius == PGI_RADIUS_AUTO) { /* the automatic radius reads the photons on the host */
        double t0 = pgi__now_ms();
        if ((st = pgi__gpu_trace_download(s->trace, &r->ph))) return st;
        pgi__frame_pass(fs, "gpu_trace_download", pgi__now_ms() - t0);
    }
    s->photons = pgi__gpu_trace_photons(s->trace);
    s->footprints = pgi__gpu_trace_footprints(s->trace, &s->fp_ellipsoids);
    s->np = tr.count;
    return PGI_OK;
}

static double timing_of(const pgi_named_value *t, int nt, const char *name) {
    double ms = 0.0;
    for (int i = 0; i < nt; i++)
        if (strcmp(t[i].name, name) == 0) ms += t[i].value;
    return ms;
}

/* Photons first (their own sequences: batches sized by the yield), then the view pass (sequence 1);
 * the automatic radius reads both on the host. */
static pgi_status gpu_inputs(pgi_renderer *r, const pgi_render_desc *d, uint64_t seq_seed, uint32_t index,
                             const pgi__progress *pc, pgi_frame_stats *fs) {
    gpu_state *s = state_of(r);
    pgi__gpu *g = s->gpu;
    pgi_status st;
    pgi__view_fill_forget(&r->fill); /* the view samples may come from the device (pgi__gpu_view_download) */
    s->traffic0 = pgi__gpu_traffic_get(g);
    s->vs_on_host = 0;
    s->nt = 0;
    if (pgi__gpu_scene_needs_update(s->scene, r->scene)) {
        double tu = pgi__now_ms();
        if ((st = pgi__gpu_scene_update(s->scene, r->scene))) return st;
        fs->rt_update_ms += pgi__now_ms() - tu;
    }
    if ((st = pgi__frame_report(pc, "trace", 0, 0))) return st;
    if ((st = gpu_photons(r, d, pc, fs))) return st;

    if ((st = pgi__frame_report(pc, "view", 0, 0))) return st;
    const pgi__subpixel sp = {.jitter = d->jitter == PGI_JITTER_ON,
                              .seed = seq_seed,
                              .index = index,
                              .tex_filter = d->texture_filter == PGI_TEXTURE_FILTER_ON};
    if ((st = pgi__gpu_view_prepare(s->view, &r->cam, d->seed, &sp))) return st;
    if ((st = pgi__gpu_begin(g))) return st;
    pgi__gpu_timestamp(g, "start");
    if ((st = pgi__gpu_view_record(s->view, s->scene))) {
        (void)pgi__gpu_submit_wait(g);
        return st;
    }
    if ((st = pgi__gpu_submit_wait(g))) return st;
    s->nt = pgi__gpu_timings(g, s->t, 64);
    fs->view_ms = timing_of(s->t, s->nt, "gpu_view");
    if (d->radius == PGI_RADIUS_AUTO) {
        /* the automatic radius reads the view samples on the host: the one read-back of the G-buffer */
        s->vs_on_host = 1;
        double tr = pgi__now_ms();
        if ((st = pgi__gpu_view_download(s->view, r->scene, &r->vs, NULL))) return st;
        pgi__frame_pass(fs, "gpu_view_download", pgi__now_ms() - tr);
    }
    return PGI_OK;
}

/* The frame's photons and view samples into r->ph and r->vs, unless they are there already (the
 * automatic radius, the test hook's photons); pass `pass`. */
static pgi_status read_back(pgi_renderer *r, pgi_frame_stats *fs, const char *pass) {
    gpu_state *s = state_of(r);
    pgi_status st;
    double t0 = pgi__now_ms();
    if (!s->vs_on_host && (st = pgi__gpu_view_download(s->view, r->scene, &r->vs, NULL))) return st;
    s->vs_on_host = 1;
    if (r->ph.count != s->np && (st = pgi__gpu_trace_download(s->trace, &r->ph))) return st;
    pgi__frame_pass(fs, pass, pgi__now_ms() - t0);
    return PGI_OK;
}

/* pgi_renderer_prepare: the view pass's time, then the inputs read back (pass "gpu_readback"). */
static pgi_status gpu_to_host(pgi_renderer *r, const pgi_render_desc *d, pgi_frame_stats *fs) {
    (void)d;
    gpu_state *s = state_of(r);
    pgi__frame_pass(fs, "gpu_view", timing_of(s->t, s->nt, "gpu_view"));
    return read_back(r, fs, "gpu_readback");
}

/* Sequence 2: the estimator on the device's photons and view samples, direct light and the sum
 * (direct.comp writes the image on the device: compose reads it back). */
static pgi_status gpu_indirect(pgi_renderer *r, const pgi_render_desc *d, const pgi__progress *pc, pgi_frame_stats *fs,
                               pgi_estimator_stats *es) {
    (void)pc;
    gpu_state *s = state_of(r);
    pgi__gpu *g = s->gpu;
    pgi_status st;
    pgi__gpu_buffer *indirect = NULL;
    const int need_indirect = d->output != PGI_OUTPUT_DIRECT;
    const pgi__gpu_est_inputs in = {.photons = s->photons,
                                    .nphotons = s->np,
                                    .samples = pgi__gpu_view_samples(s->view),
                                    .lobes = pgi__gpu_scene_lobes(s->scene),
                                    .extra = pgi__gpu_view_extra(s->view),
                                    .camera = &r->cam,
                                    .width = d->width,
                                    .height = d->height,
                                    .radius = d->radius,
                                    .scene_area = r->scene_area,
                                    .jitter = d->jitter == PGI_JITTER_ON ? 0.5f : 0.f,
                                    .footprints = s->footprints,
                                    .footprint_ellipsoids = s->footprints ? s->fp_ellipsoids : 0};
    if (need_indirect && (st = s->est_vt->device_reserve(s->est, &in, &indirect))) return st;
    if ((st = pgi__gpu_begin(g))) return st;
    pgi__gpu_timestamp(g, "start");
    if ((need_indirect && (st = s->est_vt->device_record(s->est, &in))) ||
        (st = pgi__gpu_direct_record(s->view, s->scene, indirect, d->direct_samples, d->seed, d->output))) {
        (void)pgi__gpu_submit_wait(g);
        return st;
    }
    s->ts = pgi__now_ms();
    if ((st = pgi__gpu_submit_wait(g))) return st;
    s->te = pgi__now_ms();
    s->nt += pgi__gpu_timings(g, s->t + s->nt, 64 - s->nt);
    if (need_indirect && (st = s->est_vt->device_finish(s->est, s->t, s->nt, es))) return st;
    return pgi__gpu_view_counters(s->view, &fs->primary_rays, &fs->shadow_rays);
}

/* The image, read back. */
static pgi_status gpu_compose(pgi_renderer *r, const pgi_render_desc *d, const pgi__progress *pc, pgi_frame_stats *fs,
                              pgi_image *img) {
    (void)pc, (void)fs;
    gpu_state *s = state_of(r);
    const size_t n = (size_t)d->width * d->height;
    s->td0 = pgi__now_ms();
    pgi_status st = pgi__gpu_download(s->gpu, pgi__gpu_view_image(s->view), 0, img->rgb, 3 * n * sizeof(float));
    s->td1 = pgi__now_ms();
    return st;
}

/* The device's passes from its timestamps (the CPU-timed sequence when it has none), its memory. */
static void gpu_finish(pgi_renderer *r, const pgi_render_desc *d, const pgi_estimator_stats *es, pgi_frame_stats *fs) {
    (void)d;
    gpu_state *s = state_of(r);
    if (pgi__gpu_has_timestamps(s->gpu)) {
        fs->direct_ms = timing_of(s->t, s->nt, "gpu_direct");
        fs->build_ms = es->build_ms;
        fs->estimate_ms = es->estimate_ms;
    } else fs->direct_ms = s->te - s->ts; /* estimator and direct light in one CPU-timed entry */
    pgi__frame_pass(fs, "gpu_view", timing_of(s->t, s->nt, "gpu_view"));
    for (int k = 0; k < es->pass_count; k++) pgi__frame_pass(fs, es->pass_names[k], es->pass_ms[k]);
    pgi__frame_pass(fs, "gpu_direct", timing_of(s->t, s->nt, "gpu_direct"));
    pgi__frame_pass(fs, "gpu_download", s->td1 - s->td0);
    pgi_named_value gm[PGI_MAX_STAT_ENTRIES];
    int ng = pgi__gpu_memory(s->gpu, gm, PGI_MAX_STAT_ENTRIES);
    for (int k = 0; k < ng && fs->memory_count < PGI_MAX_STAT_ENTRIES; k++)
        fs->memory_bytes[fs->memory_count++] = gm[k];
    const pgi__gpu_traffic t0 = s->traffic0, t1 = pgi__gpu_traffic_get(s->gpu);
    fs->traffic = (pgi_device_traffic){.submits = t1.submits - t0.submits,
                                       .dispatches = t1.dispatches - t0.dispatches,
                                       .uploads = t1.uploads - t0.uploads,
                                       .upload_bytes = t1.upload_bytes - t0.upload_bytes,
                                       .downloads = t1.downloads - t0.downloads,
                                       .download_bytes = t1.download_bytes - t0.download_bytes};
}

const pgi__frame_backend pgi__frame_vulkan = {
    .ensure_device = gpu_ensure_device,
    .ensure_estimator = gpu_ensure_estimator,
    .device_name = gpu_device_name,
    .inputs = gpu_inputs,
    .to_host = gpu_to_host,
    .indirect = gpu_indirect,
    .compose = gpu_compose,
    .finish = gpu_finish,
    .release = gpu_release,
};
