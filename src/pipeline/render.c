/* One frame, end to end (DESIGN.md §1): view samples, photons, estimator
 * build + estimate, direct light, composite. */
#include <omp.h>
#include <stdio.h>
#include <string.h>

#include "photon/photon.h"
#include "pipeline/pipeline.h"
#include "view/view.h"
#include "filter/bilateral.h"

#define PGI_MAX_SIDE 16384
#define PGI_MAX_PIXELS (36u * 1024u * 1024u)   /* 8K UHD fits; buffers take about 140 bytes a pixel */
#define PGI_MAX_PHOTONS 100000000u
#define PGI_MAX_BOUNCES 64

struct pgi_renderer {
    const pgi_scene *scene;
    pgi__rt *rt;
    pgi_photons ph;
    pgi__trace_scratch trace_scratch;
    pgi_view_samples vs;
    float *emit, *direct, *indirect;
    size_t pix_cap;
    pgi_estimator *est;
    char est_name[64];
    pgi_estimator_desc est_desc;
    pgi__accum *acc;         /* progressive running average (progressive.c); NULL until used */
    /* radius policies: per-photon footprint arrays (radius, then 6 ellipsoid axis planes) */
    float *fp_buf;
    size_t fp_cap;
    double scene_area;   /* total triangle area, for the bvh's T_auto */
};

pgi__accum **pgi__renderer_accum(pgi_renderer *r) { return &r->acc; }
const pgi_scene *pgi__renderer_scene(const pgi_renderer *r) { return r->scene; }

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
    pgi__accum_free(r->acc);
    pgi__afree(r->fp_buf);
    free(r);
}

/* Fills defaults and rejects what cannot be rendered. */
static pgi_status resolve_desc(const pgi_scene *s, const pgi_render_desc *in, pgi_render_desc *d) {
    pgi_status st;
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
    if (d->output < PGI_OUTPUT_ALL || d->output > PGI_OUTPUT_PHOTON_COUNT)
        return pgi__fail(PGI_ERR_INVALID_ARG, "unknown output mode %d", (int)d->output);
    if (d->view && (st = pgi__check_view(d->view))) return st;
    /* radius policies */
    if (d->radius_policy < PGI_RADIUS_FIXED || d->radius_policy >= PGI_RADIUS_POLICY_COUNT_)
        return pgi__fail(PGI_ERR_INVALID_ARG, "unknown radius policy %d", d->radius_policy);
    if (d->r_min < 0.f || !isfinite(d->r_min) || d->r_max < 0.f || !isfinite(d->r_max) || d->smoothing < 0.f ||
        !isfinite(d->smoothing))
        return pgi__fail(PGI_ERR_INVALID_ARG, "r_min, r_max and smoothing must be positive finite numbers (or 0: "
                                              "default), got %g, %g, %g",
                         (double)d->r_min, (double)d->r_max, (double)d->smoothing);
    if (d->r_max == 0.f) d->r_max = d->radius;
    if (d->r_min == 0.f) d->r_min = d->r_max / 8.f;
    if (!(d->r_min <= d->r_max))
        return pgi__fail(PGI_ERR_INVALID_ARG, "r_min (%g) must not exceed r_max (%g)", (double)d->r_min,
                         (double)d->r_max);
    if (d->radius_policy != PGI_RADIUS_FIXED &&
        !(pgi_estimator_find(d->estimator)->caps & PGI_EST_CAP_PHOTON_RADIUS))
        return pgi__fail(PGI_ERR_INVALID_ARG,
                         "radius policy %s needs an estimator with per-photon footprints (brute, bvh); '%s' has one "
                         "fixed radius",
                         d->radius_policy == PGI_RADIUS_PATH ? "path" : "differentials", d->estimator);
    if (d->bvh_build != PGI_BVH_LINEAR && d->bvh_build != PGI_BVH_VVH)
        return pgi__fail(PGI_ERR_INVALID_ARG, "unknown BVH build %d (0 linear, 1 vvh)", d->bvh_build);
    if (d->leaf_size < 0 || d->leaf_size > 65536)
        return pgi__fail(PGI_ERR_INVALID_ARG, "BVH leaf size %d is out of range (0 = T_auto, 1..65536)", d->leaf_size);
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

/* Points the photon buffer at the footprint arrays the policy needs (NULL for fixed). */
static pgi_status ensure_footprints(pgi_renderer *r, const pgi_render_desc *d) {
    pgi_photons *ph = &r->ph;
    ph->radius = ph->sax = ph->say = ph->saz = ph->sbx = ph->sby = ph->sbz = NULL;
    if (d->radius_policy == PGI_RADIUS_FIXED) return PGI_OK;
    size_t n = d->photons ? d->photons : 1, planes = d->radius_policy == PGI_RADIUS_DIFFERENTIALS ? 7 : 1;
    if (r->fp_cap < n * planes) {
        pgi__afree(r->fp_buf);
        r->fp_buf = pgi__aalloc(n * planes * sizeof(float));
        r->fp_cap = r->fp_buf ? n * planes : 0;
        if (!r->fp_buf) return pgi__fail(PGI_ERR_OOM, "out of memory for %zu photon footprints", n);
    }
    ph->radius = r->fp_buf;
    if (planes == 7) {
        float **a[] = {&ph->sax, &ph->say, &ph->saz, &ph->sbx, &ph->sby, &ph->sbz};
        for (int k = 0; k < 6; k++) *a[k] = r->fp_buf + (size_t)(k + 1) * n;
    }
    return PGI_OK;
}

static double scene_area(const pgi_scene *s) {
    double a = 0.0;
    for (size_t t = 0; t < s->ntris; t++) {
        const uint32_t *v = s->tri + 3 * t;
        pgi__v3 p0 = pgi__scene_vertex(s, v[0]), p1 = pgi__scene_vertex(s, v[1]), p2 = pgi__scene_vertex(s, v[2]);
        a += 0.5 * (double)v3_len(v3_cross(v3_sub(p1, p0), v3_sub(p2, p0)));
    }
    return a;
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
    ed.cluster_tile = d->cluster_tile;
    ed.directional_level = d->directional_level;
    ed.directional_blur = d->directional_blur;
    if (r->scene_area == 0.0) r->scene_area = scene_area(r->scene);
    ed.bvh_build = d->bvh_build;
    ed.leaf_size = d->leaf_size;
    ed.scene_area = (float)r->scene_area;
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
    if (in->progressive > 1) return pgi__render_progressive(r, in, out, stats);
    pgi__clear_error();
    pgi_render_desc d;
    pgi_status st = resolve_desc(r->scene, in, &d);
    if (st) return st;
    if (d.threads > 0) omp_set_num_threads(d.threads);
    double t_start = pgi__now_ms();
    if ((st = ensure_buffers(r, &d))) return st;
    const pgi_scene *s = r->scene;
    const pgi_camera_def *cd = d.view ? d.view : &s->cams[d.camera];
    pgi_camera cam;
    pgi_camera_look_at(&cam, cd->eye, cd->look_at, cd->up, cd->fov_y_deg, d.width, d.height);

    pgi_frame_stats fs;
    memset(&fs, 0, sizeof fs);
    fs.estimator = pgi_estimator_find(d.estimator)->name;
    fs.width = d.width;
    fs.height = d.height;
    fs.threads = d.threads > 0 ? d.threads : omp_get_max_threads();
    fs.radius = d.radius;
    fs.frames = 1;
    if (pgi__rt_needs_update(r->rt, s)) {
        /* Animated objects or a moved area light: update the BVH before any ray. */
        double tu = pgi__now_ms();
        if ((st = pgi__rt_update(r->rt, s))) return st;
        fs.rt_update_ms = pgi__now_ms() - tu;
    }

    double t0 = pgi__now_ms();
    if ((st = pgi__view_build(s, r->rt, &cam, d.seed, &r->vs, r->emit, &fs.primary_rays))) return st;
    double t1 = pgi__now_ms();
    pgi__trace_desc td = {.photons = d.photons, .bounces = d.bounces, .seed = d.seed};
    uint64_t hist[PGI_FOOTPRINT_BINS] = {0};
    if ((st = ensure_footprints(r, &d))) return st;
    td.radius_policy = d.radius_policy;
    td.r_min = d.r_min;
    td.r_max = d.r_max;
    td.smoothing = d.smoothing;
    td.footprint_hist = hist;
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
    if (d.output == PGI_OUTPUT_PHOTON_COUNT && (st = pgi__photon_counts(r->est, &ea, d.radius, img.rgb))) {
        if (img.rgb != out->rgb) free(img.rgb);
        return st;
    }
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
    fs.radius_policy = d.radius_policy;
    fs.leaf_size = es.leaf_size;
    if (d.radius_policy != PGI_RADIUS_FIXED) {
        fs.footprint_bin_width = d.r_max / 14.f;
        memcpy(fs.footprint_hist, hist, sizeof hist);
        if (fs.memory_count < PGI_MAX_STAT_ENTRIES)
            fs.memory_bytes[fs.memory_count++] =
                (pgi_named_value){"footprints", (double)(r->ph.count * (r->ph.sax ? 7 : 1) * sizeof(float))};
    }
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
