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

#include "pipeline/pipeline.h"
#include "scene/scene_internal.h"

#define PGI_ALPHA (2.0 / 3.0)

struct pgi__accum {
    double *sum;            /* 3 per pixel */
    size_t cap;             /* pixels */
    int frames, width, height;
    float r0;               /* resolved radius of frame 0 */
    uint64_t seed0;
    pgi_image frame;        /* scratch for one frame */
    /* What the average was made of; any change restarts it. */
    pgi_render_desc key;
    char est[64];
    pgi_camera_def view;
    int has_view;
    uint64_t static_version, dynamic_version, lights_hash;
    double time;
};

void pgi__accum_free(pgi__accum *a) {
    if (!a) return;
    free(a->sum);
    pgi_image_free(&a->frame);
    free(a);
}

float pgi_progressive_radius(float r0, int k) {
    double r2 = (double)r0 * (double)r0;
    for (int i = 0; i < k; i++) r2 *= ((double)i + 1.0 + PGI_ALPHA) / ((double)i + 2.0);
    return (float)sqrt(r2);
}

pgi_status pgi__check_view(const pgi_camera_def *v) {
    for (int k = 0; k < 3; k++)
        if (!isfinite(v->eye[k]) || !isfinite(v->look_at[k]) || !isfinite(v->up[k]))
            return pgi__fail(PGI_ERR_INVALID_ARG, "view camera has a non-finite eye, look-at or up");
    pgi__v3 d = v3_sub(v3_load(v->look_at), v3_load(v->eye));
    if (!(v3_len(d) > 0.f) || !(v3_len(v3_cross(d, v3_load(v->up))) > 0.f))
        return pgi__fail(PGI_ERR_INVALID_ARG, "view camera is degenerate (eye = look-at, or up parallel to the view)");
    if (!(v->fov_y_deg > 0.f && v->fov_y_deg < 180.f))
        return pgi__fail(PGI_ERR_INVALID_ARG, "view camera field of view %g is outside (0, 180) degrees",
                         (double)v->fov_y_deg);
    return PGI_OK;
}

/* FNV-1a over the lights (point/spot positions move without touching geometry). */
static uint64_t lights_hash(const pgi_scene *s) {
    uint64_t h = 1469598103934665603ULL;
    const unsigned char *p = (const unsigned char *)s->lights;
    for (size_t i = 0; i < s->nlights * sizeof *s->lights; i++) h = (h ^ p[i]) * 1099511628211ULL;
    return h;
}

void pgi_renderer_reset_accumulation(pgi_renderer *r) {
    if (!r) return;
    pgi__accum *a = *pgi__renderer_accum(r);
    if (a) a->frames = 0;
}

/* 1 if the average in `a` was made from the same picture as `d` would give. */
static int same_picture(const pgi__accum *a, const pgi_render_desc *d, const pgi_scene *s) {
    pgi_render_desc k = *d;
    k.estimator = NULL;
    k.view = NULL;
    k.progressive = 0;
    k.threads = 0;   /* the image does not depend on the thread count */
    const char *est = d->estimator ? d->estimator : "";
    if (memcmp(&k, &a->key, sizeof k) != 0 || strcmp(est, a->est) != 0) return 0;
    if ((d->view != NULL) != a->has_view || (d->view && memcmp(d->view, &a->view, sizeof a->view) != 0)) return 0;
    return a->static_version == s->static_version && a->dynamic_version == s->dynamic_version &&
           a->time == s->time && a->lights_hash == lights_hash(s);
}

static void remember(pgi__accum *a, const pgi_render_desc *d, const pgi_scene *s) {
    memset(&a->key, 0, sizeof a->key);
    a->key = *d;
    a->key.estimator = NULL;
    a->key.view = NULL;
    a->key.progressive = 0;
    a->key.threads = 0;
    snprintf(a->est, sizeof a->est, "%s", d->estimator ? d->estimator : "");
    a->has_view = d->view != NULL;
    if (d->view) a->view = *d->view;
    a->static_version = s->static_version;
    a->dynamic_version = s->dynamic_version;
    a->time = s->time;
    a->lights_hash = lights_hash(s);
}

pgi_status pgi_renderer_accumulate(pgi_renderer *r, const pgi_render_desc *in, pgi_image *out,
                                   pgi_frame_stats *stats) {
    if (!r || !in || !out) return pgi__fail(PGI_ERR_INVALID_ARG, "pgi_renderer_accumulate: NULL argument");
    pgi__accum **slot = pgi__renderer_accum(r);
    if (!*slot) {
        *slot = calloc(1, sizeof **slot);
        if (!*slot) return pgi__fail(PGI_ERR_OOM, "out of memory for the progressive accumulator");
    }
    pgi__accum *a = *slot;
    const pgi_scene *s = pgi__renderer_scene(r);
    const pgi_estimator_vtbl *vt = pgi_estimator_find(in->estimator && *in->estimator ? in->estimator : "tiled");
    if (!vt) return pgi__fail_unknown_estimator(in->estimator);
    if (a->frames > 0 && (!vt->exact || !same_picture(a, in, s))) a->frames = 0;

    pgi_render_desc d = *in;
    d.progressive = 0;
    const int k = a->frames;
    if (k > 0) {
        /* Fresh, deterministic photons and direct-light samples for frame k. */
        d.seed = pgi__mix64(a->seed0 ^ (0x9e3779b97f4a7c15ULL * (uint64_t)k));
        if (d.seed == 0) d.seed = 1;
        d.radius = pgi_progressive_radius(a->r0, k);
        d.radius_set = 1;
    }
    pgi_frame_stats fs;
    pgi_status st = pgi_renderer_render(r, &d, &a->frame, &fs);
    if (st) {
        a->frames = 0;
        return st;
    }
    size_t n = (size_t)fs.width * (size_t)fs.height;
    if (k == 0) {
        if (a->cap < n) {
            free(a->sum);
            a->sum = malloc(3 * n * sizeof *a->sum);
            a->cap = a->sum ? n : 0;
            if (!a->sum) return pgi__fail(PGI_ERR_OOM, "out of memory for a %dx%d accumulation buffer", fs.width,
                                          fs.height);
        }
        memset(a->sum, 0, 3 * n * sizeof *a->sum);
        a->r0 = fs.radius;
        a->seed0 = in->seed ? in->seed : 1;
        a->width = fs.width;
        a->height = fs.height;
        remember(a, in, s);
    }
    const float *f = a->frame.rgb;
    for (size_t i = 0; i < 3 * n; i++) a->sum[i] += f[i];
    a->frames = k + 1;
    if (!out->rgb || out->width != fs.width || out->height != fs.height) {
        pgi_image_free(out);
        out->rgb = malloc(3 * n * sizeof(float));
        if (!out->rgb) return pgi__fail(PGI_ERR_OOM, "out of memory for the output image");
        out->width = fs.width;
        out->height = fs.height;
    }
    const double inv = 1.0 / (double)a->frames;
    for (size_t i = 0; i < 3 * n; i++) out->rgb[i] = (float)(a->sum[i] * inv);
    fs.frames = a->frames;
    if (stats) *stats = fs;
    return PGI_OK;
}

pgi_status pgi__render_progressive(pgi_renderer *r, const pgi_render_desc *in, pgi_image *out,
                                   pgi_frame_stats *stats) {
    const pgi_estimator_vtbl *vt = pgi_estimator_find(in->estimator && *in->estimator ? in->estimator : "tiled");
    if (!vt) return pgi__fail_unknown_estimator(in->estimator);
    if (!vt->exact)
        return pgi__fail(PGI_ERR_INVALID_ARG,
                         "progressive mode needs an exact estimator; '%s' is approximate (its bias does not vanish)",
                         vt->name);
    if (in->progressive > 1000000)
        return pgi__fail(PGI_ERR_INVALID_ARG, "progressive frame count %d is too large (at most 1000000)",
                         in->progressive);
    if (in->output == PGI_OUTPUT_PHOTON_COUNT)
        return pgi__fail(PGI_ERR_INVALID_ARG, "progressive mode cannot average photon counts");
    pgi_render_desc d = *in;
    d.progressive = 0;
    pgi_renderer_reset_accumulation(r);
    pgi_frame_stats sum;
    memset(&sum, 0, sizeof sum);
    for (int k = 0; k < in->progressive; k++) {
        pgi_frame_stats fs;
        pgi_status st = pgi_renderer_accumulate(r, &d, out, &fs);
        if (st) return st;
        if (k == 0) sum = fs;
        else {
            /* Times and counters add up over the frames; the rest is the last frame's. */
            double v = sum.view_ms + fs.view_ms, t = sum.trace_ms + fs.trace_ms, b = sum.build_ms + fs.build_ms,
                   e = sum.estimate_ms + fs.estimate_ms, di = sum.direct_ms + fs.direct_ms,
                   to = sum.total_ms + fs.total_ms, ru = sum.rt_update_ms + fs.rt_update_ms;
            uint64_t pe = sum.photons_emitted + fs.photons_emitted, ps = sum.photons_stored + fs.photons_stored,
                     pr = sum.photon_rays + fs.photon_rays, pri = sum.primary_rays + fs.primary_rays,
                     sr = sum.shadow_rays + fs.shadow_rays, rd = sum.reads + fs.reads,
                     co = sum.contributing + fs.contributing, nv = sum.nodes_visited + fs.nodes_visited;
            for (int i = 0; i < fs.pass_count && i < sum.pass_count; i++) fs.passes_ms[i].value += sum.passes_ms[i].value;
            sum = fs;
            sum.view_ms = v, sum.trace_ms = t, sum.build_ms = b, sum.estimate_ms = e, sum.direct_ms = di;
            sum.total_ms = to, sum.rt_update_ms = ru;
            sum.photons_emitted = pe, sum.photons_stored = ps, sum.photon_rays = pr, sum.primary_rays = pri;
            sum.shadow_rays = sr, sum.reads = rd, sum.contributing = co, sum.nodes_visited = nv;
        }
    }
    if (stats) *stats = sum;
    return PGI_OK;
}
