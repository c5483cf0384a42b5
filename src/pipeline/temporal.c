/* A picture that stays clean while the camera moves (photongi.h pgi_temporal, docs/temporal.md):
 * progressive frames, the last picture reprojected into the new view when only the camera moved,
 * and an edge-aware filter of the indirect light, both fading out as a still view's frames
 * accumulate, so that it converges to the progressive average itself. */
#include <omp.h>
#include <string.h>

#include "core/core.h"
#include "core/mem.h"
#include "filter/atrous.h"
#include "pipeline/pipeline.h"
#include "scene/scene_internal.h"
#include "view/view.h"

/* A pixel's history record (HS floats): the picture (rgb), the weight in frames, and (H_PLAIN on,
 * kept while the filter is on) its indirect light (rgb), the first two moments of the indirect
 * irradiance's luminance (the filter's temporal variance). */
enum { H_RGB = 0, H_N = 3, H_PLAIN = 4, H_IND = 4, H_M1 = 7, H_M2 = 8, HS = 9 };
/* The guide planes of a frame: primary hit position, normal, albedo, depth, filter mask (1.f/0.f). */
enum { G_PX = 0, G_NX = 3, G_AR = 6, G_DEPTH = 9, G_MASK = 10, GN = 11 };

struct pgi_temporal {
    pgi_renderer *r;
    pgi_progressive *prog;
    int history, passes, filter_frames; /* resolved desc */
    int width, height;                  /* of the buffers below (0: none yet) */
    size_t cap;                         /* pixels allocated */
    int cap_rows;                       /* rows allocated (row_sum, row_kept) */
    int have;                           /* hist and prev hold a picture */
    int carried_on;                     /* carried holds the history reprojected at this picture's start */
    float *hist, *hist_next;            /* HS a pixel: the last picture's history; the one being written */
    float *carried;                     /* HS: the history reprojected at the last camera move */
    float *ind_avg;                     /* 3: the running mean of this picture's frames' indirect light */
    float *m2_avg;                      /* 1: ... and of the square of its irradiance's luminance */
    float *cur;                         /* GN planes: this frame's guides (the filter's) */
    float *geo, *prev_geo;              /* 8 a pixel: this and the last frame's hit, depth, normal */
    float *nrm, *alb, *ind;             /* 3 a pixel: this frame's AOVs (depth goes to cur's plane) */
    float *planes;                      /* 8 planes: the filter's r, g, b, variance and its scratch */
    float *rowbuf;                      /* ROWBUF floats a column for each thread (clamp_bounds) */
    size_t rowbuf_cap;                  /* floats allocated there */
    double *row_sum;                    /* a row's history weight (a deterministic sum) */
    int *row_kept;                      /* a row's pixels that kept a history */
    pgi_camera prev_cam;
    pgi_camera_def prev_cd;
    pgi__picture prev_key;    /* the last step's picture, less the camera (not_camera_of) */
    uint64_t pictures;        /* pictures begun (a camera move or any other change begins one) */
    uint64_t seed;            /* the progressive frames' seed for the picture in progress */
    float shift[2];           /* its sub-pixel offset (pgi_render_desc.shift) */
    float prev_user_shift[2]; /* the caller's offset last step (an engine's jitter: a camera move) */
    pgi_image avg;            /* the progressive average */
};

/* Floats a pixel of the buffers above. */
#define PER_PIXEL (3 * HS + 3 + 1 + GN + 2 * 8 + 9 + 8)

static void free_buffers(pgi_temporal *t) {
    float **b[] = {&t->hist, &t->hist_next, &t->carried, &t->ind_avg, &t->m2_avg, &t->cur,
                   &t->geo,  &t->prev_geo,  &t->nrm,     &t->alb,     &t->ind,    &t->planes};
    for (size_t i = 0; i < sizeof b / sizeof b[0]; i++) {
        free(*b[i]);
        *b[i] = NULL;
    }
    free(t->row_sum), free(t->row_kept), free(t->rowbuf);
    t->rowbuf = NULL, t->rowbuf_cap = 0;
    t->row_sum = NULL, t->row_kept = NULL;
    t->cap = 0, t->cap_rows = 0;
}

/* Buffers for n pixels in h rows (kept while they fit). */
static pgi_status ensure_buffers(pgi_temporal *t, size_t n, int h) {
    if (t->cap >= n && t->cap_rows >= h) return PGI_OK;
    free_buffers(t);
    struct {
        float **p;
        size_t per;
    } b[] = {{&t->hist, HS},  {&t->hist_next, HS}, {&t->carried, HS}, {&t->ind_avg, 3},
             {&t->m2_avg, 1}, {&t->cur, GN},       {&t->geo, 8},      {&t->prev_geo, 8},
             {&t->nrm, 3},    {&t->alb, 3},        {&t->ind, 3},      {&t->planes, 8}};
    int ok = 1;
    for (size_t i = 0; i < sizeof b / sizeof b[0]; i++) ok &= (*b[i].p = malloc(n * b[i].per * sizeof(float))) != NULL;
    ok &= (t->row_sum = malloc((size_t)h * sizeof(double))) != NULL;
    ok &= (t->row_kept = malloc((size_t)h * sizeof(int))) != NULL;
    if (!ok) {
        free_buffers(t);
        return pgi__fail(PGI_ERR_OOM, "out of memory for the temporal buffers of %zu pixels", n);
    }
    t->cap = n, t->cap_rows = h;
    t->have = 0; /* a new size: nothing to carry */
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

/* The width in pixels of the texture cones of a picture under the step's own sub-pixel offset
 * (pgi__renderer_texture_cone). Sibenik 320x180, 12 frames (docs/temporal.md): 1 (a pixel's)
 * 0.3 dB below 0.5, 0.25 0.1 dB below it. */
#define TAA_TEXTURE_CONE 0.5f

/* The mean history (frames) from which the filter runs half its passes: its luminance tolerance
 * follows the history's own variance, which a long history has made small, and the wide passes
 * found little left to take (Sibenik, docs/temporal.md). */
#define LONG_HISTORY 6.0

/* Rows a thread takes at a time (rows cost alike, but a thread of a machine shared with other
 * work may lose its core for a while: the others take its rows meanwhile). */
enum { ROWS = 4 };

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
static inline __attribute__((always_inline)) void pixel_dir(const pgi_camera *c, int x, int y, float d[3]) {
    v3_store(d, pgi__camera_ray_at(c, x, y, 0.5f, 0.5f));
}

void pgi__temporal_pixel_dir(const pgi_camera *c, int x, int y, float d[3]) { pixel_dir(c, x, y, d); }

/* Where world point (or, `dir`, direction) q lands in camera c: continuous pixel coordinates (the
 * centre of pixel (x, y) is (x, y)) and its depth along c's forward; 0 when behind the camera. */
static inline __attribute__((always_inline)) int project(const pgi_camera *c, const float q[3], int dir, float *px,
                                                         float *py, float *z) {
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

int pgi__temporal_project(const pgi_camera *c, const float q[3], int dir, float *px, float *py, float *z) {
    return project(c, q, dir, px, py, z);
}

static inline __attribute__((always_inline)) void hit_at(const pgi_camera *c, int x, int y, const float shift[2],
                                                         float z, float pos[3]) {
    v3_store(pos, v3_madd(v3_load(c->eye), pgi__camera_ray_at(c, x, y, 0.5f + shift[0], 0.5f + shift[1]), z));
}

void pgi__temporal_hit(const pgi_camera *c, int x, int y, const float shift[2], float z, float pos[3]) {
    hit_at(c, x, y, shift, z, pos);
}

/* pgi__temporal_land, inlined where it is called (the AVX2 clone of the blend: no call between
 * builds of different vector widths) */
static inline __attribute__((always_inline)) int land(const pgi_camera *prev, const float q[3], const float shift[2],
                                                      float *px, float *py) {
    float z;
    if (!project(prev, q, 0, px, py, &z)) return 0;
    *px -= shift[0], *py -= shift[1];
    return 1;
}

int pgi__temporal_land(const pgi_camera *prev, const float q[3], const float shift[2], float *px, float *py) {
    return land(prev, q, shift, px, py);
}

static inline float lum(float r, float g, float b) { return 0.2126f * r + 0.7152f * g + 0.0722f * b; }

/* fmaxf and fminf for values that are not NaN (0 for a NaN x in pos0, as fmaxf(0, x)), without
 * fmaxf's call: one instruction */
static inline float maxf(float a, float b) { return a > b ? a : b; }
static inline float minf(float a, float b) { return a < b ? a : b; }
static inline float pos0(float x) { return x > 0.f ? x : 0.f; }

/* Irradiance: radiance over the albedo where there is one to divide by. */
static inline float irradiance(float v, float a) { return a > 1e-4f ? v / a : v; }

/* Row y of this frame's guide planes (primary hit positions through the pixel centres moved by
 * `shift`, normals, albedo, filter mask) from the AOVs, and (filter != 0) the running means of the
 * picture's k frames' indirect light and its irradiance's squared luminance. */
static inline __attribute__((always_inline)) void prepare_row(pgi_temporal *t, const pgi_camera *cam,
                                                              const float shift[2], int k, int filter, int y) {
    const int W = t->width;
    const size_t n = (size_t)W * (size_t)t->height;
    float *restrict g = t->cur;
    const float *restrict nrm = t->nrm, *restrict alb = t->alb, *restrict ind = t->ind;
    const float ik = 1.f / (float)k;
    for (int x = 0; x < W; x++) {
        const size_t p = (size_t)y * (size_t)W + (size_t)x;
        const float z = g[G_DEPTH * n + p];
        float pos[3];
        hit_at(cam, x, y, shift, z, pos);
        float *restrict geo = t->geo + 8 * p;
        for (int c = 0; c < 3; c++) {
            g[(G_PX + c) * n + p] = geo[c] = pos[c];
            g[(G_NX + c) * n + p] = geo[4 + c] = nrm[3 * p + c];
            g[(G_AR + c) * n + p] = alb[3 * p + c];
        }
        geo[3] = z, geo[7] = 0.f;
        const float *a = alb + 3 * p;
        const int m = z > 0.f && (a[0] > 1e-4f || a[1] > 1e-4f || a[2] > 1e-4f);
        g[G_MASK * n + p] = m ? 1.f : 0.f;
        if (!filter) continue;
        const float *i = ind + 3 * p;
        const float l = m ? lum(irradiance(i[0], a[0]), irradiance(i[1], a[1]), irradiance(i[2], a[2])) : 0.f;
        if (k == 1) {
            for (int c = 0; c < 3; c++) t->ind_avg[3 * p + c] = i[c];
            t->m2_avg[p] = l * l;
        } else {
            for (int c = 0; c < 3; c++) t->ind_avg[3 * p + c] += (i[c] - t->ind_avg[3 * p + c]) * ik;
            t->m2_avg[p] += (l * l - t->m2_avg[p]) * ik;
        }
    }
}

/* Whether the previous frame's pixel q shows the surface that this frame's pixel p shows (0 depth
 * for both: the sky): q's hit lies on p's tangent plane (within 2 % of the depth), with a normal
 * like p's. The albedo is not compared: a textured surface's neighbouring samples differ in it. */
static inline int same_surface(const float *restrict prev_geo, size_t q, const float n0[3], const float x0[3],
                               int sky) {
    const float *g = prev_geo + 8 * q, dq = g[3];
    if (sky || dq == 0.f) return sky && dq == 0.f;
    float off = 0.f, nd = 0.f;
    for (int k = 0; k < 3; k++) {
        off += n0[k] * (g[k] - x0[k]);
        nd += n0[k] * g[4 + k];
    }
    return fabsf(off) <= 0.02f * dq + 1e-6f && nd >= 0.9f;
}

/* How far (in previous pixels) from where a pixel lands its surface must show in the previous
 * frame for its history to be kept. A pixel's samples land anywhere in it (the pictures' sub-pixel
 * offsets): at an edge its last sample and its neighbours' hit either side, and its history is
 * the mix of both that the pixel integral is, so the test asks whether the surface was seen near
 * there at all (a disocclusion: it was not). Measured on Sibenik (docs/temporal.md): 0 (the
 * nearest pixel alone) kept too little at the edges, 2 was 0.5 dB better than 1. */
#define SEEN_RADIUS 2

/* The 4x4 taps of Catmull-Rom weights wx (along the row) and wy at h0 (the top-left tap's record,
 * rows W records apart): the first nk floats of the records summed into acc, the weights into *w
 * (nk a constant where it is inlined: the loops unroll). */
static inline __attribute__((always_inline)) void catmull_rom_taps(const float *restrict h0, int W, const float wx[4],
                                                                   const float wy[4], int nk, float *restrict acc,
                                                                   float *restrict w) {
    for (int j = 0; j < 4; j++)
        for (int i = 0; i < 4; i++) {
            const float b = wx[i] * wy[j];
            const float *h = h0 + HS * ((size_t)j * (size_t)W + (size_t)i);
            *w += b;
            for (int k = 0; k < nk; k++) acc[k] += b * h[k];
        }
}

/* Floats a column of a thread's row scratch: the new picture's sums over 3 rows (3 channels and
 * their squares), and the clamp's bounds (3 low, 3 high). */
enum { ROWBUF = 12 };

/* The neighbourhood clamp's bounds of row y's pixels (lo[k][x], hi[k][x] = lo + 3W...: mean -+ 1.25
 * sigma of each channel of the new picture D over the pixel's 3x3 neighbourhood in the image),
 * for the whole row at once in planes (column sums, then sums of three columns: it vectorizes).
 * buf holds ROWBUF floats a column. */
static inline __attribute__((always_inline)) void clamp_bounds(const float *restrict D, int W, int H, int y,
                                                               float *restrict buf) {
    const int ya = y > 0 ? y - 1 : 0, yb = y + 1 < H ? y + 1 : y;
    const size_t w = (size_t)W;
    float *restrict cs = buf;         /* 6 planes: sums of channel k, then of its square */
    float *restrict lo = buf + 6 * w; /* 3 planes, then hi's 3 */
    for (int k = 0; k < 6; k++)
        for (int x = 0; x < W; x++) cs[k * w + (size_t)x] = 0.f;
    for (int qy = ya; qy <= yb; qy++) {
        const float *restrict d = D + 3 * (size_t)qy * w;
        for (int k = 0; k < 3; k++)
            for (int x = 0; x < W; x++) {
                const float v = d[3 * (size_t)x + (size_t)k];
                cs[k * w + (size_t)x] += v, cs[(3 + k) * w + (size_t)x] += v * v;
            }
    }
    const float rows = (float)(yb - ya + 1);
    for (int k = 0; k < 3; k++) {
        const float *restrict s1 = cs + k * w, *restrict s2 = cs + (3 + k) * w;
        float *restrict l = lo + k * w, *restrict h = lo + (3 + k) * w;
        const float ic = 1.f / (rows * 3.f);
        for (int x = 1; x < W - 1; x++) {
            const float mean = (s1[x - 1] + s1[x] + s1[x + 1]) * ic;
            const float sd = sqrtf(pos0((s2[x - 1] + s2[x] + s2[x + 1]) * ic - mean * mean));
            l[x] = mean - 1.25f * sd, h[x] = mean + 1.25f * sd;
        }
        for (int e = 0; e < 2; e++) { /* the first and the last column: their neighbours in the image */
            const int x = e ? W - 1 : 0, xa = x > 0 ? x - 1 : 0, xb = x + 1 < W ? x + 1 : x;
            float m1 = 0.f, m2 = 0.f;
            for (int q = xa; q <= xb; q++) m1 += s1[q], m2 += s2[q];
            const float ie = 1.f / (rows * (float)(xb - xa + 1));
            const float mean = m1 * ie, sd = sqrtf(pos0(m2 * ie - mean * mean));
            l[x] = mean - 1.25f * sd, h[x] = mean + 1.25f * sd;
        }
    }
}

/* The last picture's history reprojected to pixel (x, y) of camera `cam` into c (HS floats; pixel
 * p's primary hit found in the previous camera, moved back by this picture's sub-pixel offset to
 * p's centre: Catmull-Rom over the 4x4 previous pixels around it, bilinear over the 2x2 at the
 * image's border) when p's surface shows within SEEN_RADIUS previous pixels of there, the picture
 * clamped to the mean +- 1.25 sigma of the new picture's 3x3 neighbourhood (the row's `bounds`,
 * clamp_bounds'). Returns whether anything was kept (else c's weight is 0). */
static inline __attribute__((always_inline)) int reproject_pixel(const pgi_temporal *t, const pgi_camera *cam,
                                                                 const float *restrict bounds, int x, int y,
                                                                 float *restrict c) {
    const int W = t->width, H = t->height;
    const size_t n = (size_t)W * (size_t)H, p = (size_t)y * (size_t)W + (size_t)x;
    const float *restrict cur = t->cur, *restrict hist = t->hist;
    c[H_N] = 0.f;
    const int sky = cur[G_DEPTH * n + p] == 0.f;
    const float x0[3] = {cur[G_PX * n + p], cur[(G_PX + 1) * n + p], cur[(G_PX + 2) * n + p]};
    const float n0[3] = {cur[G_NX * n + p], cur[(G_NX + 1) * n + p], cur[(G_NX + 2) * n + p]};
    float dir[3], fx, fy, zq;
    if (sky) pixel_dir(cam, x, y, dir);
    if (sky ? !project(&t->prev_cam, dir, 1, &fx, &fy, &zq)
            : !land(&t->prev_cam, x0, t->shift, &fx, &fy)) /* the shifted sample's hit: p's centre */
        return 0;
    if (!(fx > -2.f && fy > -2.f && fx < (float)W + 1.f && fy < (float)H + 1.f)) return 0;
    /* seen: the nearest previous pixel first, then the others within SEEN_RADIUS */
    const int cx = (int)floorf(fx + 0.5f), cy = (int)floorf(fy + 0.5f);
    int seen = cx >= 0 && cy >= 0 && cx < W && cy < H &&
               same_surface(t->prev_geo, (size_t)cy * (size_t)W + (size_t)cx, n0, x0, sky);
    for (int j = -SEEN_RADIUS; !seen && j <= SEEN_RADIUS; j++)
        for (int i = -SEEN_RADIUS; !seen && i <= SEEN_RADIUS; i++) {
            const int qx = cx + i, qy = cy + j;
            if (qx < 0 || qy < 0 || qx >= W || qy >= H) continue;
            seen = same_surface(t->prev_geo, (size_t)qy * (size_t)W + (size_t)qx, n0, x0, sky);
        }
    if (!seen) return 0; /* disoccluded (or turned away) */
    const int xi = (int)floorf(fx), yi = (int)floorf(fy);
    const float ax = fx - (float)xi, ay = fy - (float)yi;
    float w = 0.f, acc[HS] = {0.f};
    /* Catmull-Rom over the 4x4 previous pixels around it (bilinear weights would blur the history
       a little more at every move), bilinear at the border; without the filter, the picture and
       its weight alone */
    if (xi >= 1 && yi >= 1 && xi + 2 < W && yi + 2 < H) {
        float wx[4], wy[4];
        catmull_rom(ax, wx);
        catmull_rom(ay, wy);
        const float *h0 = hist + HS * ((size_t)(yi - 1) * (size_t)W + (size_t)(xi - 1));
        if (t->passes > 0) catmull_rom_taps(h0, W, wx, wy, HS, acc, &w);
        else catmull_rom_taps(h0, W, wx, wy, H_PLAIN, acc, &w);
    } else {
        const int nk = t->passes > 0 ? HS : H_PLAIN;
        for (int j = 0; j < 2; j++)
            for (int i = 0; i < 2; i++) {
                const int qx = xi + i, qy = yi + j;
                if (qx < 0 || qy < 0 || qx >= W || qy >= H) continue;
                const float b = (i ? ax : 1.f - ax) * (j ? ay : 1.f - ay);
                const float *h = hist + HS * ((size_t)qy * (size_t)W + (size_t)qx);
                w += b;
                for (int k = 0; k < nk; k++) acc[k] += b * h[k];
            }
    }
    if (w < 0.05f) return 0; /* nothing of it was seen: disoccluded */
    /* the neighbourhood clamp (bounds: clamp_bounds'): a history that the new frame's neighbours
       do not support (a moved object, a light) is pulled to their range instead of leaving a ghost */
    const float iw = 1.f / w;
    for (int k = 0; k < 3; k++) {
        const float lo = bounds[(size_t)k * (size_t)W + (size_t)x],
                    hi = bounds[(size_t)(3 + k) * (size_t)W + (size_t)x];
        c[H_RGB + k] = pos0(minf(maxf(acc[H_RGB + k] * iw, lo), hi));
        c[H_IND + k] = pos0(acc[H_IND + k] * iw);
    }
    c[H_M1] = pos0(acc[H_M1] * iw);
    c[H_M2] = pos0(acc[H_M2] * iw);
    c[H_N] = pos0(acc[H_N] * iw);
    return 1;
}

/* Row y of the picture: (reproject) the history carried to this view, the progressive average and
 * the carried history (weighing wh = min(n, cap) * fade frames against the average's k) blended
 * into hist_next, and out; with the filter on, its input planes (the blended indirect light's
 * irradiance and its variance: the temporal moments' once 4 frames are held, else unknown, -1: the
 * filter's spatial estimate). Returns the pixels that kept a history. */
static inline __attribute__((always_inline)) int blend_row(pgi_temporal *t, const pgi_camera *cam, int reproject, int k,
                                                           float fade, int filter, float *out, int y) {
    const int W = t->width;
    const size_t n = (size_t)W * (size_t)t->height;
    const float cap = (float)(t->history > 0 ? t->history : 1), wk = (float)k;
    const float *restrict avg = t->avg.rgb, *restrict alb = t->alb, *restrict ind_avg = t->ind_avg;
    float *restrict fr = t->planes, *restrict fg = fr + n, *restrict fb = fg + n, *restrict fv = fb + n;
    int kept = 0;
    double sum = 0.0;
    float *const buf = t->rowbuf + (size_t)omp_get_thread_num() * ROWBUF * (size_t)W;
    if (reproject) clamp_bounds(avg, W, t->height, y, buf);
    for (int x = 0; x < W; x++) {
        const size_t p = (size_t)y * (size_t)W + (size_t)x;
        float *restrict c = t->carried + HS * p, *restrict h = t->hist_next + HS * p;
        if (reproject) kept += reproject_pixel(t, cam, buf + 6 * (size_t)W, x, y, c);
        const float wh = t->carried_on ? minf(c[H_N], cap) * fade : 0.f, iw = 1.f / (wh + wk);
        for (int i = 0; i < 3; i++) {
            const float D = avg[3 * p + i];
            out[3 * p + i] = h[H_RGB + i] = wh > 0.f ? (c[H_RGB + i] * wh + D * wk) * iw : D;
        }
        h[H_N] = minf(wh + wk, cap);
        sum += h[H_N];
        if (!filter) continue;
        const float *a = alb + 3 * p;
        const float ia[3] = {irradiance(ind_avg[3 * p], a[0]), irradiance(ind_avg[3 * p + 1], a[1]),
                             irradiance(ind_avg[3 * p + 2], a[2])};
        const float m1 = lum(ia[0], ia[1], ia[2]), m2 = t->m2_avg[p];
        for (int i = 0; i < 3; i++)
            h[H_IND + i] = wh > 0.f ? (c[H_IND + i] * wh + ind_avg[3 * p + i] * wk) * iw : ind_avg[3 * p + i];
        h[H_M1] = wh > 0.f ? (c[H_M1] * wh + m1 * wk) * iw : m1;
        h[H_M2] = wh > 0.f ? (c[H_M2] * wh + m2 * wk) * iw : m2;
        fr[p] = irradiance(h[H_IND], a[0]), fg[p] = irradiance(h[H_IND + 1], a[1]);
        fb[p] = irradiance(h[H_IND + 2], a[2]);
        const float nf = wh + wk;
        fv[p] = nf >= 4.f ? pos0(h[H_M2] - h[H_M1] * h[H_M1]) / nf : -1.f;
    }
    t->row_sum[y] = sum;
    return kept;
}

/* Row y of this frame's guides and of the picture, blended with the history (prepare_row, then
 * blend_row; an AVX2 clone where the CPU has it: the same bits). Returns the pixels that kept a
 * history. */
PGI__AVX2_CLONES static int step_row(pgi_temporal *t, const pgi_camera *cam, const float shift[2], int reproject, int k,
                                     float fade, int filter, float *out, int y) {
    prepare_row(t, cam, shift, k, filter, y);
    return blend_row(t, cam, reproject, k, fade, filter, out, y);
}

/* Row y of the filtered picture: out + fw (the filtered indirect light - the unfiltered). */
static void compose_row(const pgi_temporal *t, float *const res[3], float fw, float *out, int y) {
    const int W = t->width;
    const size_t n = (size_t)W * (size_t)t->height;
    const float *restrict alb = t->alb, *restrict h = t->hist_next, *restrict mk = t->cur + G_MASK * n;
    for (int x = 0; x < W; x++) {
        const size_t p = (size_t)y * (size_t)W + (size_t)x;
        if (!(mk[p] > 0.f)) continue;
        for (int i = 0; i < 3; i++) {
            const float a = alb[3 * p + i], f = a > 1e-4f ? res[i][p] * a : res[i][p];
            out[3 * p + i] += fw * (f - h[HS * p + H_IND + i]);
        }
    }
}

/* A frame's finishing of a filtered row (pgi__atrous_filter_team's row_done). */
typedef struct compose_ctx {
    const pgi_temporal *t;
    float fw, *out;
} compose_ctx;

static void compose(void *ctx, int y, float *const res[3]) {
    const compose_ctx *c = ctx;
    compose_row(c->t, res, c->fw, c->out, y);
}

/* The picture's history weight summed over its h rows (in order: the same sum on every thread). */
static double history_sum(const pgi_temporal *t, int h) {
    double hsum = 0.0;
    for (int y = 0; y < h; y++) hsum += t->row_sum[y];
    return hsum;
}

/* The filter's passes: half of them (rounded up) once the picture's history holds LONG_HISTORY
 * frames on the mean. */
static int filter_passes(const pgi_temporal *t, int h, size_t n) {
    return history_sum(t, h) >= LONG_HISTORY * (double)n ? (t->passes + 1) / 2 : t->passes;
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
    pgi_status st = ensure_buffers(t, n, h);
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
     * plain one. Filtered textures (the default) take cones of half a pixel's width under the
     * offset (TAA_TEXTURE_CONE): the history integrates the pixel, and a whole pixel's cone would
     * blur the texture twice. A caller's own offset (an engine's jitter) is left as it is. */
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
    const int own = own_shift && (shift[0] != 0.f || shift[1] != 0.f);
    pgi_aovs aovs = {.albedo = t->alb, .normal = t->nrm, .depth = t->cur + G_DEPTH * n, .indirect = t->ind};
    d.aovs = &aovs;
    pgi_frame_stats fs;
    pgi__renderer_texture_cone(t->r, own ? TAA_TEXTURE_CONE : 0.f);
    st = pgi_progressive_step(t->prog, &d, &t->avg, &fs);
    pgi__renderer_texture_cone(t->r, 0.f);
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
    const int reproject_now = k == 1 && t->history > 0 && only_camera && t->have;
    if (k == 1) t->carried_on = reproject_now;
    t->width = w, t->height = h;
    /* the filter's weight fades over filter_frames still frames; while the filter is on at all,
       the indirect light's history is kept (a camera move may bring it back) */
    const float fw = t->passes > 0 ? fmaxf(0.f, 1.f - (float)(k - 1) / (float)t->filter_frames) : 0.f;
    const int filter = t->passes > 0 && t->history > 0 ? 1 : fw > 0.f;
    const float fade = t->history > 0 ? fmaxf(0.f, 1.f - (float)(k - 1) / (float)t->history) : 0.f;
    if (!out->rgb || out->width != w || out->height != h) {
        pgi_image_free(out);
        out->rgb = malloc(3 * n * sizeof(float));
        if (!out->rgb) return pgi__fail(PGI_ERR_OOM, "out of memory for the output image");
        out->width = w, out->height = h;
    }
    const int nthreads = pgi__threads(d.threads);
    if (t->rowbuf_cap < (size_t)nthreads * ROWBUF * (size_t)w) {
        free(t->rowbuf);
        t->rowbuf_cap = 0;
        if (!(t->rowbuf = malloc((size_t)nthreads * ROWBUF * (size_t)w * sizeof(float))))
            return pgi__fail(PGI_ERR_OOM, "out of memory for the temporal step's rows");
        t->rowbuf_cap = (size_t)nthreads * ROWBUF * (size_t)w;
    }
    pgi_temporal_stats ts = {.on = 1, .restarted = k == 1 && !reproject_now};
    int kept = 0;
    double t1 = t0;
    float *const planes[4] = {t->planes, t->planes + n, t->planes + 2 * n, t->planes + 3 * n};
    const float *g = t->cur;
    const pgi__atrous_guide guide = {w,
                                     h,
                                     {g + G_PX * n, g + (G_PX + 1) * n, g + (G_PX + 2) * n},
                                     {g + G_NX * n, g + (G_NX + 1) * n, g + (G_NX + 2) * n},
                                     {g + G_AR * n, g + (G_AR + 1) * n, g + (G_AR + 2) * n},
                                     g + G_DEPTH * n,
                                     g + G_MASK * n};
    compose_ctx cc = {t, fw, out->rgb};
    /* One parallel region: the guides and the history carried (at a camera move) and blended with
       the new average, one pass over the rows; then the blended indirect light filtered (as
       irradiance), the last pass putting fw of each filtered row into the picture. Rows are taken
       a few at a time as threads come free (a thread of a shared machine may lose its core a
       while); every pixel is computed on its own, the same bytes for any thread count. */
#pragma omp parallel num_threads(nthreads)
    {
#pragma omp for schedule(dynamic, ROWS) reduction(+ : kept)
        for (int y = 0; y < h; y++) kept += step_row(t, &cam, shift, reproject_now, k, fade, filter, out->rgb, y);
#pragma omp master
        t1 = pgi__now_ms();
        if (fw > 0.f) pgi__atrous_filter_team(&guide, filter_passes(t, h, n), planes, t->planes + 4 * n, compose, &cc);
    }
    if (reproject_now) ts.reused = (double)kept / (double)n;
    if (fw > 0.f) ts.filter_passes = filter_passes(t, h, n);
    ts.filter_weight = fw;
    const double t2 = pgi__now_ms();
    if (!(fw > 0.f)) t1 = t2; /* no filter: the region's end is the blend's */

    float *sw = t->hist;
    t->hist = t->hist_next, t->hist_next = sw;
    sw = t->prev_geo;
    t->prev_geo = t->geo, t->geo = sw;
    t->prev_cam = cam;
    t->prev_cd = cd;
    t->prev_key = key;
    t->have = 1;
    ts.history = history_sum(t, h) / (double)n;
    ts.reproject_ms = t1 - t0;
    ts.filter_ms = t2 - t1;
    fs.temporal = ts;
    fs.settings.seed = base; /* the caller's: the frame's own is derived from it */
    fs.settings.aovs = NULL;
    /* the buffers above, and the step's per-thread rows */
    pgi__stats_mem_put(&fs, "temporal", t->cap * PER_PIXEL * sizeof(float) + t->rowbuf_cap * sizeof(float));
    add_pass(&fs, "temporal", ts.reproject_ms);
    if (ts.filter_passes) add_pass(&fs, "denoise", ts.filter_ms);
    if (stats) *stats = fs;
    return PGI_OK;
}
