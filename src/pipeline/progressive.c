/* Progressive photon mapping in the probabilistic form of Knaus & Zwicker
 * (2011): frame k is an independent photon-mapping frame with fresh photons
 * (seed stream k) and radius r_k, where
 *     r_{k+1}^2 = r_k^2 (k + 1 + alpha) / (k + 2),   alpha = 2/3
 * (their eq. 9 with 1-based i = k + 1), and the image is the running average
 * of the frames. Variance and bias both vanish as frames accumulate, so the
 * average converges to the path-traced solution (for exact estimators; an
 * approximate one keeps its own bias). Frame 0 is exactly the ordinary
 * single-frame render of the same desc. */
#include <stdio.h>
#include <string.h>

#include "core/core.h"
#include "pipeline/pipeline.h"
#include "scene/scene_internal.h"

#define PGI__ALPHA (2.0 / 3.0)


struct pgi_progressive {
    pgi_renderer *r;
    double *sum;   /* 3 per pixel: the finished blocks' sums, in block order (PGI_PROGRESSIVE_BLOCK) */
    double *block; /* 3 per pixel: the frames of the block in progress */
    size_t cap;    /* pixels */
    int frames, width, height;
    float r0;                     /* resolved radius of frame 0 */
    pgi_auto_radius_stats r0_how; /* how it was chosen (automatic radius), for later frames' stats */
    uint64_t seed0;
    pgi_image frame;      /* scratch for one frame */
    pgi__picture made_of; /* what the average was made of; any change restarts it */
    int keep_guide;       /* pgi_progressive_keep_guide */
};

pgi_status pgi_progressive_create(pgi_renderer *r, pgi_progressive **out) {
    *out = NULL;
    if (!r) return pgi__fail(PGI_ERR_INVALID_ARG, "pgi_progressive_create: no renderer");
    pgi_progressive *p = calloc(1, sizeof *p);
    if (!p) return pgi__fail(PGI_ERR_OOM, "out of memory for the progressive accumulator");
    p->r = r;
    *out = p;
    return PGI_OK;
}

void pgi_progressive_destroy(pgi_progressive *a) {
    if (!a) return;
    pgi__mem_set(pgi__renderer_mem(a->r), "progressive_sum", 0);
    free(a->sum);
    free(a->block);
    pgi_image_free(&a->frame);
    free(a);
}

float pgi_progressive_radius(float r0, int k) {
    double r2 = (double)r0 * (double)r0;
    for (int i = 0; i < k; i++) r2 *= ((double)i + 1.0 + PGI__ALPHA) / ((double)i + 2.0);
    return (float)sqrt(r2);
}

/* FNV-1a over the scene's light records: a light moved or changed (point and spot lights move
 * without touching geometry) changes it. */
static uint64_t lights_hash(const pgi_scene *s) {
    uint64_t h = 1469598103934665603ULL;
    const unsigned char *p = (const unsigned char *)s->lights;
    for (size_t i = 0; i < s->nlights * sizeof *s->lights; i++) h = (h ^ p[i]) * 1099511628211ULL;
    return h;
}

void pgi_progressive_reset(pgi_progressive *p) {
    if (p) p->frames = 0;
}

void pgi_progressive_keep_guide(pgi_progressive *p, int on) {
    if (p) p->keep_guide = on != 0;
}

void pgi__picture_of(const pgi_render_desc *d, const pgi_scene *s, pgi__picture *p) {
    memset(p, 0, sizeof *p);
    p->key = *d;
    p->key.estimator = NULL;
    p->key.view = NULL;
    p->key.aovs = NULL;
    p->key.threads = 0; /* the image does not depend on the thread count */
    p->key.progress = NULL;
    p->key.progress_user = NULL;
    p->key.cancel = NULL;
    p->key.max_memory = 0; /* a budget does not change the picture */
    snprintf(p->est, sizeof p->est, "%s", d->estimator ? d->estimator : "");
    p->has_view = d->view != NULL;
    if (d->view) p->view = *d->view;
    p->static_version = s->static_version;
    p->dynamic_version = s->dynamic_version;
    p->time = s->time;
    p->lights_hash = lights_hash(s);
}

void pgi_block_sum_add(double *block, const float *frame, size_t values, int first) {
    if (first)
        for (size_t i = 0; i < values; i++) block[i] = (double)frame[i];
    else
        for (size_t i = 0; i < values; i++) block[i] += (double)frame[i];
}

void pgi_block_sum_merge(double *total, const double *block, size_t values) {
    for (size_t i = 0; i < values; i++) total[i] += block[i];
}

void pgi_block_sum_round(double *total, size_t values, uint64_t count) {
    const double inv = 1.0 / (double)count, c = (double)count;
    for (size_t i = 0; i < values; i++) total[i] = (double)(float)(total[i] * inv) * c;
}

void pgi_block_sum_mean(const double *total, const double *partial, size_t values, uint64_t count, float *out) {
    const double inv = 1.0 / (double)count;
    if (partial)
        for (size_t i = 0; i < values; i++) out[i] = (float)((total[i] + partial[i]) * inv);
    else
        for (size_t i = 0; i < values; i++) out[i] = (float)(total[i] * inv);
}

/* The desc of frame k > 0 but its radius (pgi_progressive_frame sets it from r0): its seed stream,
 * jittered view samples; seq_seed gets the sequence of the view samples' sub-pixel positions. */
static pgi_status frame_desc(const pgi_render_desc *in, int k, pgi_render_desc *d, uint64_t *seq_seed) {
    *d = *in;
    *seq_seed = 0;
    if (k < 0) return pgi__fail(PGI_ERR_INVALID_ARG, "progressive frame %d: frames count from 0", k);
    if (k == 0) return PGI_OK;
    const pgi_estimator_vtbl *vt =
        pgi_estimator_find(in->estimator && *in->estimator ? in->estimator : PGI_DEFAULT_ESTIMATOR);
    if (!vt) return pgi__fail_unknown_estimator(in->estimator);
    if (!vt->exact)
        return pgi__fail(PGI_ERR_INVALID_ARG,
                         "progressive mode needs an exact estimator; '%s' is approximate (its bias does not "
                         "vanish)",
                         vt->name);
    const uint64_t seed0 = in->seed ? in->seed : 1;
    /* Fresh, deterministic photons and direct-light samples for frame k. */
    d->seed = pgi__mix64(seed0 ^ (0x9e3779b97f4a7c15ULL * (uint64_t)k));
    if (d->seed == 0) d->seed = 1;
    /* ... and view samples anywhere in their pixel, so the average converges to the pixel integral. */
    if (d->jitter == PGI_JITTER_AUTO) d->jitter = PGI_JITTER_ON;
    /* Jittered view samples: point k of one sequence per pixel (seed of frame 0), which covers the
       pixel more evenly over the frames than independent points would. */
    *seq_seed = seed0;
    return PGI_OK;
}

static pgi_status bad_r0(int k, float r0) {
    return pgi__fail(PGI_ERR_INVALID_ARG, "progressive frame %d needs frame 0's radius (> 0), got %g", k, (double)r0);
}

pgi_status pgi_progressive_frame(pgi_renderer *r, const pgi_render_desc *in, float r0, int k, pgi_image *frame,
                                 pgi_frame_stats *stats) {
    if (!r || !in || !frame) return pgi__fail(PGI_ERR_INVALID_ARG, "pgi_progressive_frame: NULL argument");
    pgi_render_desc d;
    uint64_t seq_seed;
    pgi_status st = frame_desc(in, k, &d, &seq_seed);
    if (st) return st;
    if (k > 0) {
        if (!(r0 > 0.f) || !isfinite(r0)) return bad_r0(k, r0);
        d.radius = pgi_progressive_radius(r0, k);
    }
    pgi_frame_stats fs;
    st = pgi__renderer_render_frame(r, &d, seq_seed, (uint32_t)k, frame, &fs);
    if (st) return st;
    if (stats) *stats = fs;
    return PGI_OK;
}

/* pgi_progressive_frame_await_r0: the caller's r0, asked for once the photons are traced. */
typedef struct await_r0 {
    pgi_radius_fn fn;
    void *user;
    float r0;
    int asked;
} await_r0;

static float late_radius(void *user, int k) {
    await_r0 *a = user;
    a->r0 = a->fn(a->user);
    a->asked = 1;
    return a->r0 > 0.f && isfinite(a->r0) ? pgi_progressive_radius(a->r0, k) : NAN; /* NAN: refused */
}

pgi_status pgi_progressive_frame_await_r0(pgi_renderer *r, const pgi_render_desc *in, pgi_radius_fn r0_fn, void *user,
                                          int k, pgi_image *frame, pgi_frame_stats *stats) {
    if (!r || !in || !r0_fn || !frame)
        return pgi__fail(PGI_ERR_INVALID_ARG, "pgi_progressive_frame_await_r0: NULL argument");
    if (k < 1) return pgi__fail(PGI_ERR_INVALID_ARG, "pgi_progressive_frame_await_r0: frame %d (it is for k > 0)", k);
    pgi_render_desc d;
    uint64_t seq_seed;
    pgi_status st = frame_desc(in, k, &d, &seq_seed);
    if (st) return st;
    await_r0 a = {r0_fn, user, 0.f, 0};
    pgi_frame_stats fs;
    st = pgi__renderer_render_frame_late(r, &d, seq_seed, (uint32_t)k, late_radius, &a, frame, &fs);
    if (st) return a.asked && (!(a.r0 > 0.f) || !isfinite(a.r0)) ? bad_r0(k, a.r0) : st;
    if (stats) *stats = fs;
    return PGI_OK;
}

pgi_status pgi_progressive_step(pgi_progressive *a, const pgi_render_desc *in, pgi_image *out, pgi_frame_stats *stats) {
    if (!a || !in || !out) return pgi__fail(PGI_ERR_INVALID_ARG, "pgi_progressive_step: NULL argument");
    const pgi_scene *s = pgi_renderer_scene(a->r);
    const pgi_estimator_vtbl *vt =
        pgi_estimator_find(in->estimator && *in->estimator ? in->estimator : PGI_DEFAULT_ESTIMATOR);
    if (!vt) return pgi__fail_unknown_estimator(in->estimator);
    pgi__picture now;
    pgi__picture_of(in, s, &now);
    if (a->frames > 0 && (!vt->exact || memcmp(&now, &a->made_of, sizeof now) != 0)) a->frames = 0;

    const int k = a->frames;
    pgi_frame_stats fs;
    /* frames after the first of one picture steer by the guide of the frames before (asked for) */
    pgi__renderer_keep_guide(a->r, a->keep_guide && k > 0);
    pgi_status st = pgi_progressive_frame(a->r, in, a->r0, k, &a->frame, &fs);
    pgi__renderer_keep_guide(a->r, 0);
    if (st) {
        if (st != PGI_ERR_CANCELLED) a->frames = 0; /* a cancelled frame adds nothing and breaks nothing */
        return st;
    }
    size_t n = (size_t)fs.width * (size_t)fs.height;
    pgi__mem_ledger *mem = pgi__renderer_mem(a->r);
    if (k == 0) {
        if (a->cap < n) {
            /* the finished blocks' sum and the block in progress (doubles) and the average handed out */
            char what[64];
            snprintf(what, sizeof what, "a %dx%d accumulation buffer", fs.width, fs.height);
            if ((st = pgi__mem_reserve(mem, "progressive_sum", n * 3 * (2 * sizeof(double) + sizeof(float)), what))) {
                a->frames = 0;
                return st;
            }
            free(a->sum);
            free(a->block);
            a->sum = malloc(3 * n * sizeof *a->sum);
            a->block = malloc(3 * n * sizeof *a->block);
            a->cap = a->sum && a->block ? n : 0;
            if (!a->cap) {
                free(a->sum);
                free(a->block);
                a->sum = a->block = NULL;
                return pgi__fail(PGI_ERR_OOM, "out of memory for a %dx%d accumulation buffer", fs.width, fs.height);
            }
        }
        a->r0 = fs.radius;
        a->r0_how = fs.auto_radius;
        a->seed0 = in->seed ? in->seed : 1;
        a->width = fs.width;
        a->height = fs.height;
        a->made_of = now;
    }
    /* The fixed summation order (photongi.h, PGI_PROGRESSIVE_BLOCK): frames into their block's sum,
       finished blocks into the total. */
    const int first = k % PGI_PROGRESSIVE_BLOCK == 0, last = (k + 1) % PGI_PROGRESSIVE_BLOCK == 0;
    if (!out->rgb || out->width != fs.width || out->height != fs.height) {
        pgi_image_free(out);
        out->rgb = malloc(3 * n * sizeof(float));
        if (!out->rgb) {
            a->frames = 0;
            return pgi__fail(PGI_ERR_OOM, "out of memory for the output image");
        }
        out->width = fs.width;
        out->height = fs.height;
    }
    a->frames = k + 1;
    if (k == 0 && !last) {
        /* a picture's first frame (every frame of a moving temporal picture): the sum cleared, the
           block and the average the frame itself (the mean of one: the same bits), in one pass
           over the values shared by the frame's threads */
        const long nv = (long)(3 * n);
        double *restrict sum = a->sum, *restrict block = a->block;
        const float *restrict f = a->frame.rgb;
        float *restrict o = out->rgb;
#pragma omp parallel for schedule(static) num_threads(pgi__threads(in->threads))
        for (long i = 0; i < nv; i++) {
            sum[i] = 0.0;
            block[i] = (double)f[i];
            o[i] = f[i];
        }
    } else {
        if (k == 0) memset(a->sum, 0, 3 * n * sizeof *a->sum);
        pgi_block_sum_add(a->block, a->frame.rgb, 3 * n, first);
        if (last) pgi_block_sum_merge(a->sum, a->block, 3 * n);
        pgi_block_sum_mean(a->sum, last ? NULL : a->block, 3 * n, (uint64_t)a->frames, out->rgb);
    }
    fs.frames = a->frames;
    /* the accumulator's buffers in the frame's memory (the frame's stats were taken before them) */
    const size_t acc = a->cap * 3 * (2 * sizeof(double) + sizeof(float));
    pgi__mem_set(mem, "progressive_sum", acc);
    pgi__stats_mem_put(&fs, "progressive_sum", acc);
    fs.memory_counted_peak = mem->peak;
    if (k > 0) {
        fs.settings.radius = a->r0;
        fs.auto_radius = a->r0_how;      /* frame k's radius derives from frame 0's choice */
        fs.settings.jitter = in->jitter; /* AUTO: frame 0 at pixel centres, the others jittered */
        fs.settings.seed = a->seed0;     /* the caller's, not frame k's seed stream */
    }
    if (stats) *stats = fs;
    return PGI_OK;
}

/* The caller's progress callback, told which frame of how many and the time since the start. */
typedef struct frame_progress {
    pgi_progress_fn fn;
    void *user;
    int frame, frames;
    double t_start;
} frame_progress;

static void report_frame(void *user, const pgi_progress *in) {
    const frame_progress *fp = user;
    pgi_progress p = *in;
    p.frame = fp->frame;
    p.frames = fp->frames;
    p.elapsed_ms = pgi__now_ms() - fp->t_start;
    fp->fn(fp->user, &p);
}

/* Times and counters add up over the frames; the rest is the last frame's. */
static void stats_add(pgi_frame_stats *sum, const pgi_frame_stats *fs) {
    pgi_frame_stats t = *fs;
    t.view_ms += sum->view_ms, t.trace_ms += sum->trace_ms, t.build_ms += sum->build_ms;
    t.estimate_ms += sum->estimate_ms, t.direct_ms += sum->direct_ms, t.total_ms += sum->total_ms;
    t.rt_update_ms += sum->rt_update_ms, t.radius_ms += sum->radius_ms;
    t.photons_emitted += sum->photons_emitted, t.photons_stored += sum->photons_stored;
    t.photon_rays += sum->photon_rays, t.photon_paths_discarded += sum->photon_paths_discarded,
        t.primary_rays += sum->primary_rays, t.shadow_rays += sum->shadow_rays;
    t.reads += sum->reads, t.contributing += sum->contributing, t.nodes_visited += sum->nodes_visited;
    t.reads_bulk += sum->reads_bulk;
    t.estimators_created += sum->estimators_created;
    for (int i = 0; i < t.pass_count && i < sum->pass_count; i++) t.passes_ms[i].value += sum->passes_ms[i].value;
    *sum = t;
}

pgi_status pgi_render_progressive(pgi_renderer *r, const pgi_render_desc *in, int frames, pgi_image *out,
                                  pgi_frame_stats *stats) {
    return pgi_render_progressive_until(r, in, frames, NULL, NULL, out, stats);
}

pgi_status pgi_render_progressive_until(pgi_renderer *r, const pgi_render_desc *in, int frames, int (*stop)(void *),
                                        void *stop_user, pgi_image *out, pgi_frame_stats *stats) {
    if (!r || !in || !out) return pgi__fail(PGI_ERR_INVALID_ARG, "pgi_render_progressive: NULL argument");
    const pgi_estimator_vtbl *vt =
        pgi_estimator_find(in->estimator && *in->estimator ? in->estimator : PGI_DEFAULT_ESTIMATOR);
    if (!vt) return pgi__fail_unknown_estimator(in->estimator);
    if (frames > 1 && !vt->exact)
        return pgi__fail(PGI_ERR_INVALID_ARG,
                         "progressive mode needs an exact estimator; '%s' is approximate (its bias does not vanish)",
                         vt->name);
    if (frames < 1 || frames > PGI_MAX_PROGRESSIVE_FRAMES)
        return pgi__fail(PGI_ERR_INVALID_ARG, "progressive frame count %d is out of range (1..%d)", frames,
                         PGI_MAX_PROGRESSIVE_FRAMES);
    if (frames > 1 && in->output == PGI_OUTPUT_PHOTON_COUNT)
        return pgi__fail(PGI_ERR_INVALID_ARG, "progressive mode cannot average photon counts");
    pgi_progressive *p;
    pgi_status st = pgi_progressive_create(r, &p);
    if (st) return st;
    pgi_frame_stats sum;
    memset(&sum, 0, sizeof sum);
    frame_progress fp = {in->progress, in->progress_user, 0, frames, pgi__now_ms()};
    pgi_render_desc d = *in;
    if (in->progress) {
        d.progress = report_frame;
        d.progress_user = &fp;
    }
    for (int k = 0; k < frames && !st; k++) {
        pgi_frame_stats fs;
        fp.frame = k;
        if ((st = pgi_progressive_step(p, &d, out, &fs))) break;
        if (k == 0) sum = fs;
        else stats_add(&sum, &fs);
        if (stop && k + 1 < frames && stop(stop_user)) break;
    }
    pgi_progressive_destroy(p);
    if (!st && stats) *stats = sum;
    return st;
}
