/* One frame, end to end (DESIGN.md §1): view samples, photons, estimator
 * build + estimate, direct light, composite. */
#include <omp.h>
#include <stdio.h>
#include <string.h>

#include "photon/photon.h"
#include "view/view.h"
#include "pipeline/filter.h"

#define PGI_MAX_SIDE 16384
#define PGI_MAX_PIXELS (36u * 1024u * 1024u)   /* 8K UHD fits; buffers take about 140 bytes a pixel */
#define PGI_MAX_PHOTONS 100000000u
#define PGI_MAX_BOUNCES 64

struct pgi_renderer {
    const pgi_scene *scene;
    pgi_rt *rt;
    pgi_photons ph;
    pgi_trace_scratch trace_scratch;
    pgi_view_samples vs;
    float *emit, *direct, *indirect;
    size_t pix_cap;
    pgi_estimator *est;
    char est_name[64];
    pgi_estimator_desc est_desc;
};

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
    *out = r;
    return PGI_OK;
}

void pgi_renderer_destroy(pgi_renderer *r) {
    if (!r) return;
    pgi__rt_destroy(r->rt);
    pgi_photons_free(&r->ph);
    pgi__trace_scratch_free(&r->trace_scratch);
    pgi_view_samples_free(&r->vs);
    pgi__afree(r->emit);
    pgi__afree(r->direct);
    pgi__afree(r->indirect);
    pgi_estimator_destroy(r->est);
    free(r);
}

/* Fills defaults and rejects what cannot be rendered. */
static pgi_status resolve_desc(const pgi_scene *s, const pgi_render_desc *in, pgi_render_desc *d) {
    *d = *in;
    const pgi_scene_defaults *sd = &s->defaults;
    if (!d->estimator || !*d->estimator) d->estimator = "tiled";
    if (!pgi_estimator_find(d->estimator)) return pgi__fail_unknown_estimator(d->estimator);
    if (d->width == 0 && d->height == 0) {
        d->width = sd->width > 0 ? sd->width : 640;
        d->height = sd->height > 0 ? sd->height : 480;
    }
    if (d->width <= 0 || d->height <= 0 || d->width > PGI_MAX_SIDE || d->height > PGI_MAX_SIDE ||
        (uint64_t)d->width * (uint64_t)d->height > PGI_MAX_PIXELS)
        return pgi__fail(PGI_ERR_INVALID_ARG, "image size %dx%d is out of range (1..%d a side, at most %u pixels)",
                         d->width, d->height, PGI_MAX_SIDE, PGI_MAX_PIXELS);
    if (d->photons_set && d->photons == 0)
        return pgi__fail(PGI_ERR_INVALID_ARG, "photon count must be at least 1 (got 0)");
    if (d->photons == 0) d->photons = sd->photons ? sd->photons : 200000;
    if (d->photons > PGI_MAX_PHOTONS)
        return pgi__fail(PGI_ERR_INVALID_ARG, "photon count %u is too large (at most %u)", d->photons, PGI_MAX_PHOTONS);
    if (d->radius_set && !(d->radius > 0.f && isfinite(d->radius)))
        return pgi__fail(PGI_ERR_INVALID_ARG, "photon radius must be a positive finite number, got %g",
                         (double)d->radius);
    if (!d->radius_set || d->radius == 0.f) {
        float diag = v3_len(v3_sub(v3_load(s->bmax), v3_load(s->bmin)));
        d->radius = sd->radius > 0.f ? sd->radius : 0.02f * diag;
    }
    if (d->bounces == 0) d->bounces = sd->bounces > 0 ? sd->bounces : 4;
    if (d->bounces < 1 || d->bounces > PGI_MAX_BOUNCES)
        return pgi__fail(PGI_ERR_INVALID_ARG, "bounces must be in 1..%d, got %d", PGI_MAX_BOUNCES, d->bounces);
    if (d->seed == 0) d->seed = 1;
    if (d->threads < 0) return pgi__fail(PGI_ERR_INVALID_ARG, "threads must be 0 (all) or positive, got %d", d->threads);
    if (d->camera < 0 || (size_t)d->camera >= s->ncams)
        return pgi__fail(PGI_ERR_INVALID_ARG, "camera %d does not exist (the scene has %zu)", d->camera, s->ncams);
    if (d->tile_size == 0) d->tile_size = 32;
    if (d->tile_size < 1 || d->tile_size > 4096)
        return pgi__fail(PGI_ERR_INVALID_ARG, "tile size %d is out of range (1..4096)", d->tile_size);
    if (d->direct_samples == 0) d->direct_samples = 16;
    if (d->direct_samples < 0 || d->direct_samples > 4096)
        return pgi__fail(PGI_ERR_INVALID_ARG, "direct samples %d out of range (1..4096)", d->direct_samples);
    if (d->output < PGI_OUTPUT_ALL || d->output > PGI_OUTPUT_DIRECT)
        return pgi__fail(PGI_ERR_INVALID_ARG, "unknown output mode %d", (int)d->output);
    /* issue 5: kernels, subsampling, reconstruction filter, k-NN, polygon bounds */
    if (d->kernel < 0 || d->kernel >= PGI_KERNEL_COUNT_)
        return pgi__fail(PGI_ERR_INVALID_ARG, "unknown kernel %d (0 constant, 1 cone, 2 epanechnikov)", d->kernel);
    if (d->subsample < 0 || d->subsample > 64)
        return pgi__fail(PGI_ERR_INVALID_ARG, "subsampling factor %d is out of range (1..64)", d->subsample);
    if (d->filter < 0 || d->filter > 16)
        return pgi__fail(PGI_ERR_INVALID_ARG, "filter radius %d is out of range (0..16 pixels)", d->filter);
    if (d->knn < 0 || d->knn > 4096)
        return pgi__fail(PGI_ERR_INVALID_ARG, "k-NN count %d is out of range (1..4096)", d->knn);
    if (d->knn > 0 && strcmp(pgi_estimator_find(d->estimator)->name, "kdtree") != 0)
        return pgi__fail(PGI_ERR_INVALID_ARG, "k-NN (knn %d) needs the kdtree estimator, not '%s'", d->knn,
                         d->estimator);
    if (d->polygon_vertices != 0 && (d->polygon_vertices < 4 || d->polygon_vertices > 64 || d->polygon_vertices % 2))
        return pgi__fail(PGI_ERR_INVALID_ARG, "polygon vertices must be an even number in 4..64, got %d",
                         d->polygon_vertices);
    return PGI_OK;
}

static pgi_status ensure_buffers(pgi_renderer *r, const pgi_render_desc *d) {
    if (r->ph.capacity < d->photons) {
        pgi_photons_free(&r->ph);
        pgi_status st = pgi_photons_alloc(&r->ph, d->photons);
        if (st) return st;
    }
    if (r->vs.width != d->width || r->vs.height != d->height) {
        pgi_view_samples_free(&r->vs);
        pgi_status st = pgi_view_samples_alloc(&r->vs, d->width, d->height);
        if (st) return st;
    }
    size_t n = (size_t)d->width * (size_t)d->height;
    if (r->pix_cap < n) {
        pgi__afree(r->emit);
        pgi__afree(r->direct);
        pgi__afree(r->indirect);
        r->emit = pgi__aalloc(3 * n * sizeof(float));
        r->direct = pgi__aalloc(3 * n * sizeof(float));
        r->indirect = pgi__aalloc(3 * n * sizeof(float));
        r->pix_cap = n;
        if (!r->emit || !r->direct || !r->indirect) {
            r->pix_cap = 0;
            return pgi__fail(PGI_ERR_OOM, "out of memory for %dx%d frame buffers", d->width, d->height);
        }
    }
    pgi_estimator_desc ed = {.radius = d->radius, .tile_size = d->tile_size, .threads = d->threads};
    ed.kernel = (pgi_kernel)d->kernel;
    ed.subsample = d->subsample;
    ed.knn = d->knn;
    ed.polygon_vertices = d->polygon_vertices;
    ed.seed = d->subsample > 1 ? d->seed : 0;
    if (!r->est || strcmp(r->est_name, d->estimator) != 0 || memcmp(&ed, &r->est_desc, sizeof ed) != 0) {
        pgi_estimator_destroy(r->est);
        r->est = NULL;
        pgi_status st = pgi_estimator_create(d->estimator, &ed, &r->est);
        if (st) return st;
        snprintf(r->est_name, sizeof r->est_name, "%s", d->estimator);
        r->est_desc = ed;
    }
    return PGI_OK;
}

pgi_status pgi_renderer_render(pgi_renderer *r, const pgi_render_desc *in, pgi_image *out, pgi_frame_stats *stats) {
    if (!r || !in || !out) return pgi__fail(PGI_ERR_INVALID_ARG, "pgi_renderer_render: NULL argument");
    pgi__clear_error();
    pgi_render_desc d;
    pgi_status st = resolve_desc(r->scene, in, &d);
    if (st) return st;
    if (d.threads > 0) omp_set_num_threads(d.threads);
    double t_start = pgi__now_ms();
    if ((st = ensure_buffers(r, &d))) return st;
    const pgi_scene *s = r->scene;
    const pgi_camera_def *cd = &s->cams[d.camera];
    pgi_camera cam;
    pgi_camera_look_at(&cam, cd->eye, cd->look_at, cd->up, cd->fov_y_deg, d.width, d.height);

    pgi_frame_stats fs;
    memset(&fs, 0, sizeof fs);
    fs.estimator = pgi_estimator_find(d.estimator)->name;
    fs.width = d.width;
    fs.height = d.height;
    fs.threads = d.threads > 0 ? d.threads : omp_get_max_threads();
    fs.radius = d.radius;

    double t0 = pgi__now_ms();
    if ((st = pgi__view_build(s, r->rt, &cam, d.seed, &r->vs, r->emit, &fs.primary_rays))) return st;
    double t1 = pgi__now_ms();
    pgi_trace_desc td = {d.photons, d.bounces, d.seed};
    if ((st = pgi__photons_trace(s, r->rt, &td, &r->ph, &r->trace_scratch, &fs.photon_rays))) return st;
    double t2 = pgi__now_ms();
    pgi_estimate_args ea = {&r->ph, &r->vs, &cam, r->indirect};
    if ((st = pgi_estimator_build(r->est, &ea))) return st;
    double t3 = pgi__now_ms();
    if ((st = pgi_estimator_estimate(r->est, &ea))) return st;
    if (d.filter > 0 && (st = pgi__bilateral_filter(&r->vs, d.filter, r->indirect))) return st;
    double t4 = pgi__now_ms();
    if ((st = pgi__direct(s, r->rt, &r->vs, d.direct_samples, d.seed, r->direct, &fs.shadow_rays))) return st;
    double t5 = pgi__now_ms();

    size_t n = (size_t)d.width * d.height;
    /* Reuse the caller's image when it already has this size (steady-state
     * frames then allocate nothing). */
    pgi_image img = *out;
    if (!img.rgb || img.width != d.width || img.height != d.height) {
        img = (pgi_image){d.width, d.height, malloc(3 * n * sizeof(float))};
        if (!img.rgb) return pgi__fail(PGI_ERR_OOM, "out of memory for the output image");
        pgi_image_free(out);
    }
    const float *w = r->vs.weight;
    for (size_t i = 0; i < 3 * n; i++) {
        float ind = w[i] * r->indirect[i];
        float dir = r->emit[i] + r->direct[i];
        img.rgb[i] = d.output == PGI_OUTPUT_INDIRECT ? ind : d.output == PGI_OUTPUT_DIRECT ? dir : dir + ind;
    }
    double t6 = pgi__now_ms();

    pgi_estimator_stats es;
    pgi_estimator_get_stats(r->est, &es);
    fs.photons_emitted = r->ph.emitted;
    fs.photons_stored = r->ph.count;
    fs.view_ms = t1 - t0;
    fs.trace_ms = t2 - t1;
    fs.build_ms = t3 - t2;
    fs.estimate_ms = t4 - t3;
    fs.direct_ms = t5 - t4;
    fs.total_ms = t6 - t_start;
    for (int k = 0; k < es.pass_count && k < PGI_MAX_STAT_ENTRIES; k++)
        fs.passes_ms[fs.pass_count++] = (pgi_named_value){es.pass_names[k], es.pass_ms[k]};
    fs.memory_bytes[fs.memory_count++] = (pgi_named_value){"photons", (double)(r->ph.count * 12 * sizeof(float))};
    /* 7 vector planes (pos, nrm, ngeo, wo, kd, ks, weight), shininess, depth, flags. */
    fs.memory_bytes[fs.memory_count++] =
        (pgi_named_value){"view_samples", (double)(n * ((7 * 3 + 2) * sizeof(float) + sizeof(uint8_t)))};
    for (int k = 0; k < es.memory_count && fs.memory_count < PGI_MAX_STAT_ENTRIES; k++)
        fs.memory_bytes[fs.memory_count++] = (pgi_named_value){es.memory_names[k], (double)es.memory_bytes[k]};
    fs.reads = es.reads;
    fs.contributing = es.contributing;
    fs.nodes_visited = es.nodes_visited;
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
