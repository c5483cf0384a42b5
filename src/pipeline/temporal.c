/* A picture that stays clean while the camera moves (photongi.h pgi_temporal, docs/temporal.md):
 * progressive frames, the last picture reprojected into the new view when only the camera moved,
 * and an edge-aware filter of the indirect light, both fading out as a still view's frames
 * accumulate, so that it converges to the progressive average itself. */
#include <string.h>

#include "core/core.h"
#include "core/mem.h"
#include "filter/atrous.h"
#include "pipeline/pipeline.h"
#include "scene/scene_internal.h"
#include "view/view.h"

struct pgi_temporal {
    pgi_renderer *r;
    pgi_progressive *prog;
    int history, passes, filter_frames; /* resolved desc */
    int width, height;                  /* of the buffers below (0: none yet) */
    size_t cap;                         /* pixels allocated */
    int have;                           /* hist and prev_* hold a picture */
    float *hist;                        /* 3 a pixel: the last picture */
    float *hist_n;                      /* its history weight in frames */
    float *carried, *carried_n;         /* the history reprojected at the last camera move (and its weight) */
    float *ind_avg;                     /* 3: the running mean of the frames' indirect light since that move */
    float *prev_depth, *prev_nrm;
    float *depth, *nrm, *alb, *ind, *pos; /* this frame's AOVs and primary hit positions */
    uint8_t *mask;
    float *work; /* 3 a pixel: the filtered indirect light; then 6 a pixel of filter scratch */
    float *scratch;
    pgi_camera prev_cam;
    pgi_camera_def prev_cd;
    pgi__picture prev_key;    /* the last step's picture, less the camera (not_camera_of) */
    uint64_t pictures;        /* pictures begun (a camera move or any other change begins one) */
    uint64_t seed;            /* the progressive frames' seed for the picture in progress */
    float shift[2];           /* its sub-pixel offset (pgi_render_desc.shift) */
    float prev_user_shift[2]; /* the caller's offset last step (an engine's jitter: a camera move) */
    pgi_image avg;            /* the progressive average */
};

static void free_buffers(pgi_temporal *t) {
    float **b[] = {&t->hist,  &t->hist_n, &t->carried, &t->carried_n, &t->ind_avg, &t->prev_depth, &t->prev_nrm,
                   &t->depth, &t->nrm,    &t->alb,     &t->ind,       &t->pos,     &t->work,       &t->scratch};
    for (size_t i = 0; i < sizeof b / sizeof b[0]; i++) {
        free(*b[i]);
        *b[i] = NULL;
    }
    free(t->mask);
    t->mask = NULL;
    t->cap = 0;
}

/* Buffers for n pixels (kept while they fit). */
static pgi_status ensure_buffers(pgi_temporal *t, size_t n) {
    if (t->cap >= n) return PGI_OK;
    free_buffers(t);
    struct {
        float **p;
        size_t per;
    } b[] = {{&t->hist, 3},       {&t->hist_n, 1},   {&t->carried, 3}, {&t->carried_n, 1}, {&t->ind_avg, 3},
             {&t->prev_depth, 1}, {&t->prev_nrm, 3}, {&t->depth, 1},   {&t->nrm, 3},       {&t->alb, 3},
             {&t->ind, 3},        {&t->pos, 3},      {&t->work, 3},    {&t->scratch, 6}};
    int ok = 1;
    for (size_t i = 0; i < sizeof b / sizeof b[0]; i++) ok &= (*b[i].p = malloc(n * b[i].per * sizeof(float))) != NULL;
    ok &= (t->mask = malloc(n)) != NULL;
    if (!ok) {
        free_buffers(t);
        return pgi__fail(PGI_ERR_OOM, "out of memory for the temporal buffers of %zu pixels", n);
    }
    t->cap = n;
    return PGI_OK;
}

pgi_status pgi_temporal_create(pgi_renderer *r, const pgi_temporal_desc *desc, pgi_temporal **out) {
    if (!out) return pgi__fail(PGI_ERR_INVALID_ARG, "pgi_temporal_create: NULL argument");
    *out = NULL;
    if (!r) return pgi__fail(PGI_ERR_INVALID_ARG, "pgi_temporal_create: no renderer");
    const pgi_temporal_desc d = desc ? *desc : (pgi_temporal_desc){0};
    if (d.history != PGI_TEMPORAL_OFF && (d.history < 0 || d.history > 256))
        return pgi__fail(PGI_ERR_INVALID_ARG, "temporal history %d: 1..256 frames, 0 (16) or off", d.history);
    if (d.filter != PGI_TEMPORAL_OFF && (d.filter < 0 || d.filter > 5))
        return pgi__fail(PGI_ERR_INVALID_ARG, "temporal filter %d: 1..5 passes, 0 (4) or off", d.filter);
    if (d.filter_frames < 0 || d.filter_frames > 256)
        return pgi__fail(PGI_ERR_INVALID_ARG, "temporal filter_frames %d: 1..256, 0 (8)", d.filter_frames);
    pgi_temporal *t = calloc(1, sizeof *t);
    if (!t) return pgi__fail(PGI_ERR_OOM, "out of memory for the temporal accumulator");
    t->r = r;
    t->history = d.history == PGI_TEMPORAL_OFF ? 0 : d.history ? d.history : 16;
    t->passes = d.filter == PGI_TEMPORAL_OFF ? 0 : d.filter ? d.filter : 4;
    t->filter_frames = d.filter_frames ? d.filter_frames : 8;
    pgi_status st = pgi_progressive_create(r, &t->prog);
    if (st) {
        free(t);
        return st;
    }
    pgi_progressive_keep_guide(t->prog, d.keep_guide);
    *out = t;
    return PGI_OK;
}

void pgi_temporal_reset(pgi_temporal *t) {
    if (!t) return;
    t->have = 0;
    pgi_progressive_reset(t->prog);
}

void pgi_temporal_destroy(pgi_temporal *t) {
    if (!t) return;
    free_buffers(t);
    pgi_image_free(&t->avg);
    pgi_progressive_destroy(t->prog);
    free(t);
}

/* Catmull-Rom weights of the 4 samples at -1, 0, 1, 2 for a point at a in [0, 1) (they sum to 1). */
static void catmull_rom(float a, float w[4]) {
    w[0] = a * (-0.5f + a * (1.f - 0.5f * a));
    w[1] = 1.f + a * a * (-2.5f + 1.5f * a);
    w[2] = a * (0.5f + a * (2.f - 1.5f * a));
    w[3] = a * a * (-0.5f + 0.5f * a);
}

/* Point i of the radical-inverse sequence in base b, in [0, 1). */
static float halton(uint64_t i, unsigned b) {
    float f = 1.f, r = 0.f;
    for (; i; i /= b) {
        f /= (float)b;
        r += f * (float)(i % b);
    }
    return r;
}

/* Everything but the camera that the picture depends on (a change restarts the history): the
 * progressive picture without its camera, by view or by index, and the caller's sub-pixel offset
 * (an engine's jitter moves the camera, as a camera move). */
static void not_camera_of(const pgi_render_desc *d, const pgi_scene *s, pgi__picture *k) {
    pgi__picture_of(d, s, k);
    memset(&k->view, 0, sizeof k->view);
    k->has_view = 0;
    k->key.camera = 0;
    k->key.shift[0] = k->key.shift[1] = 0.f;
}

/* Direction through the centre of pixel (x, y) (its component along forward is 1). */
void pgi__temporal_pixel_dir(const pgi_camera *c, int x, int y, float d[3]) {
    v3_store(d, pgi__camera_ray_at(c, x, y, 0.5f, 0.5f));
}

/* Where world point (or, `dir`, direction) q lands in camera c: continuous pixel coordinates (the
 * centre of pixel (x, y) is (x, y)) and its depth along c's forward; 0 when behind the camera. */
int pgi__temporal_project(const pgi_camera *c, const float q[3], int dir, float *px, float *py, float *z) {
    float v[3];
    for (int k = 0; k < 3; k++) v[k] = dir ? q[k] : q[k] - c->eye[k];
    const float f = v[0] * c->forward[0] + v[1] * c->forward[1] + v[2] * c->forward[2];
    if (!(f > 1e-6f)) return 0;
    const float r = (v[0] * c->right[0] + v[1] * c->right[1] + v[2] * c->right[2]) / f;
    const float u = (v[0] * c->up[0] + v[1] * c->up[1] + v[2] * c->up[2]) / f;
    *px = (r / (c->tan_half_fov_y * c->aspect) + 1.f) * 0.5f * (float)c->width - 0.5f;
    *py = (1.f - u / c->tan_half_fov_y) * 0.5f * (float)c->height - 0.5f;
    *z = f;
    return 1;
}

/* Whether the previous frame's pixel q = (qx, qy) shows the surface that this frame's pixel p shows
 * (0 depth for both: the sky): q's hit, on the ray through its centre at its depth, lies on p's
 * tangent plane (within 2 % of the depth: a jittered sample sits up to half a pixel off the centre),
 * with a normal like p's. The albedo is not compared: a textured surface's neighbouring samples
 * differ in it, and under sub-pixel offsets that rejected a third of the history of a still wall. */
static int same_surface(const pgi_temporal *t, size_t p, int qx, int qy, int sky) {
    const size_t q = (size_t)qy * (size_t)t->width + (size_t)qx;
    const float dq = t->prev_depth[q];
    if (sky || dq == 0.f) return sky && dq == 0.f;
    const float *n0 = t->nrm + 3 * p, *n1 = t->prev_nrm + 3 * q;
    float dir[3], off = 0.f;
    pgi__temporal_pixel_dir(&t->prev_cam, qx, qy, dir);
    for (int k = 0; k < 3; k++) off += n0[k] * (t->prev_cam.eye[k] + dq * dir[k] - t->pos[3 * p + k]);
    if (fabsf(off) > 0.02f * dq + 1e-6f) return 0; /* another surface: occluded or disoccluded */
    return n0[0] * n1[0] + n0[1] * n1[1] + n0[2] * n1[2] >= 0.9f;
}

/* The last picture reprojected into camera `cam` (pixel p's primary hit found in the previous
 * camera; bilinear over the previous pixels that show the same surface) into carried and carried_n,
 * clamped to the mean +- 1.25 sigma of the new picture D's 3x3 neighbourhood. Returns the pixels
 * that kept a history. */
static size_t reproject(pgi_temporal *t, const pgi_camera *cam, const float *D, int threads) {
    const int W = t->width, H = t->height;
    size_t kept = 0;
#pragma omp parallel for schedule(static) reduction(+ : kept) num_threads(pgi__threads(threads))
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            const size_t p = (size_t)y * (size_t)W + (size_t)x;
            float *c = t->carried + 3 * p;
            t->carried_n[p] = 0.f;
            c[0] = c[1] = c[2] = 0.f;
            const int sky = t->depth[p] == 0.f;
            float dir[3], fx, fy, zq;
            pgi__temporal_pixel_dir(cam, x, y, dir);
            if (!pgi__temporal_project(&t->prev_cam, sky ? dir : t->pos + 3 * p, sky, &fx, &fy, &zq)) continue;
            if (!sky) fx -= t->shift[0], fy -= t->shift[1]; /* the hit is the shifted sample's: back to p's centre */
            const int x0 = (int)floorf(fx), y0 = (int)floorf(fy);
            const float ax = fx - (float)x0, ay = fy - (float)y0;
            double w = 0.0, n = 0.0, acc[3] = {0.0, 0.0, 0.0};
            /* Catmull-Rom over the 4x4 previous pixels around it when all show this surface (bilinear
               weights would blur the history a little more at every move), else bilinear over those
               of the 2x2 that do */
            float cx[4], cy[4];
            catmull_rom(ax, cx);
            catmull_rom(ay, cy);
            int all = x0 >= 1 && y0 >= 1 && x0 + 2 < W && y0 + 2 < H;
            for (int j = -1; all && j <= 2; j++)
                for (int i = -1; all && i <= 2; i++) all = same_surface(t, p, x0 + i, y0 + j, sky);
            for (int j = -1; all && j <= 2; j++)
                for (int i = -1; i <= 2; i++) {
                    const size_t q = (size_t)(y0 + j) * (size_t)W + (size_t)(x0 + i);
                    const double b = (double)cx[i + 1] * cy[j + 1];
                    w += b;
                    n += b * t->hist_n[q];
                    for (int k = 0; k < 3; k++) acc[k] += b * t->hist[3 * q + k];
                }
            for (int j = 0; !all && j < 2; j++)
                for (int i = 0; i < 2; i++) {
                    const int qx = x0 + i, qy = y0 + j;
                    if (qx < 0 || qy < 0 || qx >= W || qy >= H) continue;
                    const size_t q = (size_t)qy * (size_t)W + (size_t)qx;
                    if (!same_surface(t, p, qx, qy, sky)) continue;
                    const double b = (i ? ax : 1.f - ax) * (j ? ay : 1.f - ay);
                    w += b;
                    n += b * t->hist_n[q];
                    for (int k = 0; k < 3; k++) acc[k] += b * t->hist[3 * q + k];
                }
            if (w < 0.05) continue; /* nothing of it was seen: disoccluded */
            /* the neighbourhood clamp: a history that the new frame's neighbours do not support
               (a moved object, a light) is pulled to their range instead of leaving a ghost */
            double m[3] = {0.0, 0.0, 0.0}, m2[3] = {0.0, 0.0, 0.0};
            int cnt = 0;
            for (int dy = -1; dy <= 1; dy++)
                for (int dx = -1; dx <= 1; dx++) {
                    const int qx = x + dx, qy = y + dy;
                    if (qx < 0 || qy < 0 || qx >= W || qy >= H) continue;
                    const float *dq = D + 3 * ((size_t)qy * (size_t)W + (size_t)qx);
                    for (int k = 0; k < 3; k++) m[k] += dq[k], m2[k] += (double)dq[k] * dq[k];
                    cnt++;
                }
            for (int k = 0; k < 3; k++) {
                const double mean = m[k] / cnt, sd = sqrt(fmax(0.0, m2[k] / cnt - mean * mean));
                c[k] = (float)fmax(0.0, fmin(fmax(acc[k] / w, mean - 1.25 * sd), mean + 1.25 * sd));
            }
            t->carried_n[p] = (float)(n / w);
            kept++;
        }
    return kept;
}

/* This frame's primary hit positions (through the pixel centres moved by `shift`) and the filter's
 * mask from the AOVs. */
static void positions(pgi_temporal *t, const pgi_camera *cam, const float shift[2], int threads) {
    const int W = t->width, H = t->height;
#pragma omp parallel for schedule(static) num_threads(pgi__threads(threads))
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            const size_t p = (size_t)y * (size_t)W + (size_t)x;
            v3_store(t->pos + 3 * p,
                     v3_madd(v3_load(cam->eye), pgi__camera_ray_at(cam, x, y, 0.5f + shift[0], 0.5f + shift[1]),
                             t->depth[p]));
            const float *a = t->alb + 3 * p;
            t->mask[p] = t->depth[p] > 0.f && (a[0] > 1e-4f || a[1] > 1e-4f || a[2] > 1e-4f);
        }
}

/* The filtered indirect light of ind_avg into work (irradiance: the albedo divided out and back). */
static pgi_status filter_indirect(pgi_temporal *t, int threads) {
    const size_t n = (size_t)t->width * (size_t)t->height;
    for (size_t p = 0; p < n; p++)
        for (int k = 0; k < 3; k++) {
            const float a = t->alb[3 * p + k];
            t->work[3 * p + k] = t->mask[p] && a > 1e-4f ? t->ind_avg[3 * p + k] / a : t->ind_avg[3 * p + k];
        }
    const pgi__atrous_guide g = {t->width, t->height, t->pos, t->nrm, t->alb, t->depth, t->mask};
    pgi_status st = pgi__atrous_filter(&g, t->passes, threads, t->work, t->scratch);
    if (st) return st;
    for (size_t p = 0; p < n; p++)
        for (int k = 0; k < 3; k++) {
            const float a = t->alb[3 * p + k];
            if (t->mask[p] && a > 1e-4f) t->work[3 * p + k] *= a;
        }
    return PGI_OK;
}

static void add_pass(pgi_frame_stats *fs, const char *name, double ms) {
    if (fs->pass_count < PGI_MAX_STAT_ENTRIES) fs->passes_ms[fs->pass_count++] = (pgi_named_value){name, ms};
    fs->total_ms += ms;
}

pgi_status pgi_temporal_step(pgi_temporal *t, const pgi_render_desc *in, pgi_image *out, pgi_frame_stats *stats) {
    if (!t || !in || !out) return pgi__fail(PGI_ERR_INVALID_ARG, "pgi_temporal_step: NULL argument");
    if (in->aovs) return pgi__fail(PGI_ERR_INVALID_ARG, "pgi_temporal_step: the step takes the AOVs itself");
    if (in->device != PGI_DEVICE_CPU)
        return pgi__fail(PGI_ERR_UNSUPPORTED,
                         "temporal reuse and the a-trous filter run on the CPU device only (they read the frame's "
                         "AOVs); render without them on the GPU");
    const pgi_scene *s = pgi_renderer_scene(t->r);
    /* the frame's size first: the AOV buffers must fit it */
    pgi_render_desc d = *in;
    const int w = d.width > 0 ? d.width : s->defaults.width > 0 ? s->defaults.width : 640;
    const int h = d.height > 0 ? d.height : s->defaults.height > 0 ? s->defaults.height : 480;
    if (w < 1 || h < 1 || w > PGI_MAX_IMAGE_SIDE || h > PGI_MAX_IMAGE_SIDE ||
        (uint64_t)w * (uint64_t)h > PGI_MAX_IMAGE_PIXELS)
        return pgi__fail(PGI_ERR_INVALID_ARG, "temporal step: image size %dx%d is out of range", w, h);
    const size_t n = (size_t)w * (size_t)h;
    pgi_status st = ensure_buffers(t, n);
    if (st) return st;
    /* What changed since the last step: the camera only (the history is reprojected), anything else
     * (it starts afresh), or nothing (the progressive average goes on). Each new picture takes
     * fresh photons, a seed of its own from the caller's, so that the history of a moving camera
     * averages independent photon maps; the first picture takes the caller's seed itself. */
    pgi_camera_def cd;
    if (in->view) cd = *in->view;
    else if ((st = pgi_scene_get_camera(s, (size_t)(in->camera > 0 ? in->camera : 0), &cd))) return st;
    pgi__picture key;
    not_camera_of(in, s, &key);
    const int size_same = t->have && t->width == w && t->height == h;
    const int same_key = size_same && memcmp(&key, &t->prev_key, sizeof key) == 0;
    const int same_cam = t->have && memcmp(&cd, &t->prev_cd, sizeof cd) == 0 && in->shift[0] == t->prev_user_shift[0] &&
                         in->shift[1] == t->prev_user_shift[1];
    /* A moving camera's pictures also take a sub-pixel offset each (Halton 2, 3), so that their
     * history averages the whole pixel as the progressive frames do (temporal anti-aliasing); when
     * the camera stops, one more picture begins without it, whose progressive average is then the
     * plain one. A caller's own offset (an engine's jitter) is left as it is. */
    const int own_shift = in->shift[0] == 0.f && in->shift[1] == 0.f;
    const int stopping = same_key && same_cam && own_shift && (t->shift[0] != 0.f || t->shift[1] != 0.f);
    const int new_picture = !(same_key && same_cam) || stopping;
    const int only_camera = same_key && (!same_cam || stopping);
    const uint64_t base = in->seed ? in->seed : 1, pictures = t->pictures + (uint64_t)new_picture;
    uint64_t seed = !new_picture    ? t->seed
                    : pictures <= 1 ? base
                                    : pgi__mix64(base ^ (0xd1b54a32d192ed03ULL * pictures));
    if (seed == 0) seed = 1;
    d.seed = seed;
    float shift[2] = {0.f, 0.f};
    if (!own_shift) shift[0] = in->shift[0], shift[1] = in->shift[1];
    else if (!new_picture) shift[0] = t->shift[0], shift[1] = t->shift[1];
    else if (only_camera && !same_cam) shift[0] = halton(pictures, 2) - 0.5f, shift[1] = halton(pictures, 3) - 0.5f;
    d.shift[0] = shift[0], d.shift[1] = shift[1];
    pgi_aovs aovs = {.albedo = t->alb, .normal = t->nrm, .depth = t->depth, .indirect = t->ind};
    d.aovs = &aovs;
    pgi_frame_stats fs;
    st = pgi_progressive_step(t->prog, &d, &t->avg, &fs);
    if (st) return st; /* cancelled: the average, the history and the previous frame are as they were */
    if (fs.width != w || fs.height != h)
        return pgi__fail(PGI_ERR_INTERNAL, "temporal step: a %dx%d frame for %dx%d buffers", fs.width, fs.height, w, h);
    t->pictures = pictures;
    t->seed = seed;
    t->shift[0] = shift[0], t->shift[1] = shift[1];
    t->prev_user_shift[0] = in->shift[0], t->prev_user_shift[1] = in->shift[1];

    const double t0 = pgi__now_ms();
    pgi_camera cam;
    pgi_camera_look_at(&cam, cd.eye, cd.look_at, cd.up, cd.fov_y_deg, w, h);
    const int k = fs.frames; /* frames in the progressive average: 1 right after a change */
    t->width = w, t->height = h;
    /* the filter's weight fades over filter_frames still frames, and once it is 0 it stays 0 until
       the next picture: the indirect light's running mean is kept only while it is needed */
    const float fw = t->passes > 0 ? fmaxf(0.f, 1.f - (float)(k - 1) / (float)t->filter_frames) : 0.f;
    const int reproject_now = k == 1 && t->history > 0 && only_camera;
    if (reproject_now || fw > 0.f) positions(t, &cam, shift, d.threads); /* the hits both read */
    pgi_temporal_stats ts = {.on = 1};
    if (k == 1) {
        /* the picture restarted: the history carried over, if only the camera moved */
        if (reproject_now) {
            const size_t kept = reproject(t, &cam, t->avg.rgb, d.threads);
            ts.reused = (double)kept / (double)n;
        } else {
            memset(t->carried_n, 0, n * sizeof *t->carried_n);
            ts.restarted = 1;
        }
        if (fw > 0.f) memcpy(t->ind_avg, t->ind, 3 * n * sizeof(float));
    } else if (fw > 0.f)
        for (size_t i = 0; i < 3 * n; i++) t->ind_avg[i] += (t->ind[i] - t->ind_avg[i]) / (float)k;
    const double t1 = pgi__now_ms();

    /* D: the progressive average with (part of) its indirect light filtered */
    if (fw > 0.f) {
        if ((st = filter_indirect(t, d.threads))) return st;
        ts.filter_passes = t->passes;
    }
    ts.filter_weight = fw;
    const double t2 = pgi__now_ms();

    /* the picture: D and the carried history, whose weight fades over `history` still frames */
    if (!out->rgb || out->width != w || out->height != h) {
        pgi_image_free(out);
        out->rgb = malloc(3 * n * sizeof(float));
        if (!out->rgb) return pgi__fail(PGI_ERR_OOM, "out of memory for the output image");
        out->width = w, out->height = h;
    }
    const float fade = t->history > 0 ? fmaxf(0.f, 1.f - (float)(k - 1) / (float)t->history) : 0.f;
    const float cap = (float)(t->history > 0 ? t->history : 1);
    double hsum = 0.0;
    for (size_t p = 0; p < n; p++) {
        const float wh = fminf(t->carried_n[p], cap) * fade, wk = (float)k;
        for (int c = 0; c < 3; c++) {
            const size_t i = 3 * p + (size_t)c;
            const float D = fw > 0.f ? t->avg.rgb[i] + fw * (t->work[i] - t->ind_avg[i]) : t->avg.rgb[i];
            out->rgb[i] = wh > 0.f ? (t->carried[i] * wh + D * wk) / (wh + wk) : D;
            t->hist[i] = out->rgb[i];
        }
        t->hist_n[p] = fminf(wh + wk, cap);
        hsum += t->hist_n[p];
    }
    memcpy(t->prev_depth, t->depth, n * sizeof(float));
    memcpy(t->prev_nrm, t->nrm, 3 * n * sizeof(float));
    t->prev_cam = cam;
    t->prev_cd = cd;
    t->prev_key = key;
    t->have = 1;
    ts.history = hsum / (double)n;
    ts.reproject_ms = t1 - t0 + (pgi__now_ms() - t2);
    ts.filter_ms = t2 - t1;
    fs.temporal = ts;
    fs.settings.seed = base; /* the caller's: the frame's own is derived from it */
    fs.settings.aovs = NULL;
    pgi__stats_mem_put(&fs, "temporal", t->cap * (37 * sizeof(float) + 1)); /* the buffers above */
    add_pass(&fs, "temporal", ts.reproject_ms);
    if (ts.filter_passes) add_pass(&fs, "denoise", ts.filter_ms);
    if (stats) *stats = fs;
    return PGI_OK;
}
