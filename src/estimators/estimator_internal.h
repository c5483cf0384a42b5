/* Shared by every estimator: the per-photon contribution test and sum
 * (DESIGN.md §3), so that all exact methods make identical decisions and
 * differ only in summation order. */
#ifndef PGI_ESTIMATOR_INTERNAL_H
#define PGI_ESTIMATOR_INTERNAL_H

#include <string.h>

#include "core/core.h"
#include "scene/bsdf.h"

/* A view sample loaded once per gather. */
typedef struct pgi__vs {
    float px, py, pz, nx, ny, nz;
    pgi__v3 wo, kd, ks;
    float shininess;
    int lambert;
} pgi__vs;

/* Running sums of one gather: Lambertian part as a flux sum (kd/pi applied
 * once at the end), Blinn-Phong part as f*flux. */
typedef struct pgi__acc {
    float fr, fg, fb;    /* sum of flux */
    float sr, sg, sb;    /* sum of specular f * flux */
    uint32_t contributing;
} pgi__acc;

static inline void pgi__vs_load(const pgi_view_samples *vs, size_t i, pgi__vs *v) {
    const float *p = vs->pos + 3 * i, *n = vs->nrm + 3 * i;
    v->px = p[0]; v->py = p[1]; v->pz = p[2];
    v->nx = n[0]; v->ny = n[1]; v->nz = n[2];
    v->wo = v3_load(vs->wo + 3 * i);
    v->kd = v3_load(vs->kd + 3 * i);
    v->ks = v3_load(vs->ks + 3 * i);
    v->shininess = vs->shininess[i];
    v->lambert = (vs->flags[i] & PGI_VS_LAMBERT) != 0;
}

/* Starts the gather of sample i: an invalid sample (sky, lost eye path)
 * gets zero radiance and 0 is returned; otherwise the sample is loaded. */
static inline int pgi__vs_begin(const pgi_view_samples *vs, size_t i, float *out, pgi__vs *v) {
    if (!(vs->flags[i] & PGI_VS_VALID)) {
        out[0] = out[1] = out[2] = 0.f;
        return 0;
    }
    pgi__vs_load(vs, i, v);
    return 1;
}

/* Constant kernel: a photon contributes when it lies strictly inside the
 * sphere of radius r around the sample and arrives from the sample's
 * hemisphere (dot(n, w_p) > 0). */
static inline void pgi__gather(const pgi__vs *v, float r2, float px, float py, float pz, float dx, float dy, float dz,
                               float fr, float fg, float fb, pgi__acc *a) {
    float ex = px - v->px, ey = py - v->py, ez = pz - v->pz;
    float d2 = ex * ex + ey * ey + ez * ez;
    if (!(d2 < r2)) return;
    float c = v->nx * dx + v->ny * dy + v->nz * dz;
    if (!(c > 0.f)) return;
    a->contributing++;
    a->fr += fr; a->fg += fg; a->fb += fb;
    if (!v->lambert) {
        float k, fres;
        pgi__phong_lobe(v3(v->nx, v->ny, v->nz), v3(dx, dy, dz), v->wo, v->shininess, &k, &fres);
        a->sr += k * (v->ks.x + (1.f - v->ks.x) * fres) * fr;
        a->sg += k * (v->ks.y + (1.f - v->ks.y) * fres) * fg;
        a->sb += k * (v->ks.z + (1.f - v->ks.z) * fres) * fb;
    }
}

/* Radiance from the sums: (kd/pi * flux + spec) / (pi r^2). */
static inline void pgi__acc_finish(const pgi__vs *v, const pgi__acc *a, float r2, float *out) {
    float w = 1.f / (PGI_PI * r2);
    out[0] = (v->kd.x * PGI_INV_PI * a->fr + a->sr) * w;
    out[1] = (v->kd.y * PGI_INV_PI * a->fg + a->sg) * w;
    out[2] = (v->kd.z * PGI_INV_PI * a->fb + a->sb) * w;
}

/* ---- Per-photon footprints (radius policies, PGI_EST_CAP_PHOTON_RADIUS) ----
 * A photon with its own footprint contributes f * flux / A_p, A_p = pi r_p^2 (for an ellipsoid
 * r_p^2 = |a x b|: the area of its footprint ellipse on the surface it hit, BVH paper eq. 10).
 * The weight 1/A_p is folded into the flux before the sum, and the sum is finished with
 * pgi__acc_finish_w(.., 1). Spheres use pgi__gather with r_p^2 (same strict test as the fixed
 * radius); ellipsoids test containment in their skewed frame, then call pgi__gather with an
 * infinite radius so that the hemisphere test and the sum are the shared ones. */
static inline float pgi__footprint_weight(float r) { return 1.f / (PGI_PI * r * r); }

static inline void pgi__acc_finish_w(const pgi__vs *v, const pgi__acc *a, float w, float *out) {
    out[0] = (v->kd.x * PGI_INV_PI * a->fr + a->sr) * w;
    out[1] = (v->kd.y * PGI_INV_PI * a->fg + a->sg) * w;
    out[2] = (v->kd.z * PGI_INV_PI * a->fb + a->sb) * w;
}

/* Inverse (row-major, 9 floats) of the ellipsoid frame M = [a | b | c*n]: u = inv * (x - p) are the
 * ellipsoid coordinates of x. Returns 0 (and a zero matrix: nothing is inside) when degenerate.
 * Every estimator computes inv with this function, so all of them take the same decisions. */
static inline int pgi__ellipsoid_inverse(float ax, float ay, float az, float bx, float by, float bz, float cx,
                                         float cy, float cz, float inv[9]) {
    /* rows of M^-1 are (b x c, c x a, a x b) / det */
    float r0x = by * cz - bz * cy, r0y = bz * cx - bx * cz, r0z = bx * cy - by * cx;
    float r1x = cy * az - cz * ay, r1y = cz * ax - cx * az, r1z = cx * ay - cy * ax;
    float r2x = ay * bz - az * by, r2y = az * bx - ax * bz, r2z = ax * by - ay * bx;
    float det = ax * r0x + ay * r0y + az * r0z;
    if (!(fabsf(det) > 0.f) || !isfinite(det)) {
        for (int k = 0; k < 9; k++) inv[k] = 0.f;
        return 0;
    }
    float id = 1.f / det;
    inv[0] = r0x * id; inv[1] = r0y * id; inv[2] = r0z * id;
    inv[3] = r1x * id; inv[4] = r1y * id; inv[5] = r1z * id;
    inv[6] = r2x * id; inv[7] = r2y * id; inv[8] = r2z * id;
    return 1;
}

/* x - p strictly inside the ellipsoid (|u|^2 < 1). A degenerate (zero) inverse accepts nothing. */
static inline int pgi__ellipsoid_contains(const float inv[9], float ex, float ey, float ez) {
    float u = inv[0] * ex + inv[1] * ey + inv[2] * ez;
    float w = inv[3] * ex + inv[4] * ey + inv[5] * ez;
    float t = inv[6] * ex + inv[7] * ey + inv[8] * ez;
    float q = u * u + w * w + t * t;
    return q < 1.f && (inv[0] != 0.f || inv[1] != 0.f || inv[2] != 0.f);
}

/* Ellipsoid footprint: flux already multiplied by pgi__footprint_weight(r_p). */
static inline void pgi__gather_ellipsoid(const pgi__vs *v, const float inv[9], float px, float py, float pz, float dx,
                                         float dy, float dz, float fr, float fg, float fb, pgi__acc *a) {
    if (!pgi__ellipsoid_contains(inv, v->px - px, v->py - py, v->pz - pz)) return;
    pgi__gather(v, INFINITY, px, py, pz, dx, dy, dz, fr, fg, fb, a);
}

/* Axis-aligned half extents of photon j's ellipsoid [a | b | r n]. */
static inline void pgi__ellipsoid_extent(const pgi_photons *ph, size_t j, float h[3]) {
    float r = ph->radius[j];
    float cx = r * ph->nx[j], cy = r * ph->ny[j], cz = r * ph->nz[j];
    h[0] = sqrtf(ph->sax[j] * ph->sax[j] + ph->sbx[j] * ph->sbx[j] + cx * cx);
    h[1] = sqrtf(ph->say[j] * ph->say[j] + ph->sby[j] * ph->sby[j] + cy * cy);
    h[2] = sqrtf(ph->saz[j] * ph->saz[j] + ph->sbz[j] * ph->sbz[j] + cz * cz);
}

/* pgi__ellipsoid_inverse for photon j. */
static inline int pgi__photon_ellipsoid_inverse(const pgi_photons *ph, size_t j, float inv[9]) {
    float r = ph->radius[j];
    return pgi__ellipsoid_inverse(ph->sax[j], ph->say[j], ph->saz[j], ph->sbx[j], ph->sby[j], ph->sbz[j],
                                  r * ph->nx[j], r * ph->ny[j], r * ph->nz[j], inv);
}

/* A photon copied into an estimator's own structure (hash-grid cell order,
 * tile lists): position, incoming direction, flux; 36 bytes. */
typedef struct pgi__packed_photon {
    float px, py, pz, dx, dy, dz, fr, fg, fb;
} pgi__packed_photon;

static inline void pgi__pack_photon(const pgi_photons *ph, size_t j, pgi__packed_photon *o) {
    o->px = ph->px[j]; o->py = ph->py[j]; o->pz = ph->pz[j];
    o->dx = ph->dx[j]; o->dy = ph->dy[j]; o->dz = ph->dz[j];
    o->fr = ph->fr[j]; o->fg = ph->fg[j]; o->fb = ph->fb[j];
}

static inline void pgi__gather_packed(const pgi__vs *v, float r2, const pgi__packed_photon *q, pgi__acc *a) {
    pgi__gather(v, r2, q->px, q->py, q->pz, q->dx, q->dy, q->dz, q->fr, q->fg, q->fb, a);
}

/* ---------------------------------------------------------------- kernels
 * Kernel-weighted variants of pgi__gather (same per-photon decision: d^2 < r^2
 * strictly, dot(n, w_p) > 0). The weight w(d) is the kernel without its
 * normalisation; pgi__acc_finish_k applies norm / (pi r^2):
 *   constant     1                     norm 1
 *   cone         1 - d/r               norm 3
 *   Epanechnikov 1 - d^2/r^2           norm 2
 * so that each kernel integrates to 1 over its disk (tests check this). */
static inline float pgi__kernel_weight(pgi_kernel k, float d2, float r2) {
    if (k == PGI_KERNEL_CONE) return 1.f - sqrtf(d2 / r2);
    if (k == PGI_KERNEL_EPANECHNIKOV) return 1.f - d2 / r2;
    return 1.f;
}
static inline float pgi__kernel_norm(pgi_kernel k) {
    return k == PGI_KERNEL_CONE ? 3.f : k == PGI_KERNEL_EPANECHNIKOV ? 2.f : 1.f;
}

/* Adds one photon with weight w, unconditionally (k-NN uses it for the
 * photons it selected). */
static inline void pgi__acc_add(const pgi__vs *v, float w, float dx, float dy, float dz, float fr, float fg, float fb,
                                pgi__acc *a) {
    a->contributing++;
    a->fr += w * fr; a->fg += w * fg; a->fb += w * fb;
    if (!v->lambert) {
        float k, fres;
        pgi__phong_lobe(v3(v->nx, v->ny, v->nz), v3(dx, dy, dz), v->wo, v->shininess, &k, &fres);
        a->sr += k * (v->ks.x + (1.f - v->ks.x) * fres) * (w * fr);
        a->sg += k * (v->ks.y + (1.f - v->ks.y) * fres) * (w * fg);
        a->sb += k * (v->ks.z + (1.f - v->ks.z) * fres) * (w * fb);
    }
}

/* pgi__gather with a kernel; the constant kernel takes pgi__gather itself. */
static inline void pgi__gather_k(const pgi__vs *v, float r2, pgi_kernel kern, float px, float py, float pz, float dx,
                                 float dy, float dz, float fr, float fg, float fb, pgi__acc *a) {
    if (kern == PGI_KERNEL_CONSTANT) {
        pgi__gather(v, r2, px, py, pz, dx, dy, dz, fr, fg, fb, a);
        return;
    }
    float ex = px - v->px, ey = py - v->py, ez = pz - v->pz;
    float d2 = ex * ex + ey * ey + ez * ez;
    if (!(d2 < r2)) return;
    float c = v->nx * dx + v->ny * dy + v->nz * dz;
    if (!(c > 0.f)) return;
    pgi__acc_add(v, pgi__kernel_weight(kern, d2, r2), dx, dy, dz, fr, fg, fb, a);
}

static inline void pgi__gather_packed_k(const pgi__vs *v, float r2, pgi_kernel kern, const pgi__packed_photon *q,
                                        pgi__acc *a) {
    pgi__gather_k(v, r2, kern, q->px, q->py, q->pz, q->dx, q->dy, q->dz, q->fr, q->fg, q->fb, a);
}

/* pgi__acc_finish times the kernel normalisation and `scale` (subsampling). */
static inline void pgi__acc_finish_k(const pgi__vs *v, const pgi__acc *a, float r2, pgi_kernel kern, float scale,
                                     float *out) {
    pgi__acc_finish(v, a, r2, out);
    float m = pgi__kernel_norm(kern) * scale;
    if (m != 1.f) out[0] *= m, out[1] *= m, out[2] *= m;
}

/* ------------------------------------------------- stochastic subsampling
 * Tiled paper §2.3.2: walk the eligible photons of a pixel (its cells, its
 * tile list, the kd-tree nodes it reaches) with geometrically distributed
 * steps (trials until the first success of a Bernoulli(1/k^2)), so that about
 * 1/k^2 of them are visited, and scale the sum by eligible/visited. The walk
 * continues across lists (a cell's leftover step carries to the next).
 * Random stream: (seed, pixel index), so the result does not depend on the
 * thread count. k <= 1: off (every photon visited, scale 1). */
typedef struct pgi__sub {
    pgi__rng rng;
    float inv_log1mp;      /* 1 / log2(1 - 1/k^2) */
    uint64_t skip;         /* eligible photons to pass over before the next visit */
    uint64_t eligible, visited;
    int on;
} pgi__sub;

/* log2 for the step: exponent + atanh series of the mantissa (|error| < 2e-5,
 * so the steps follow the geometric law to that accuracy); logf made the
 * step cost more than the photon test it saves. */
static inline float pgi__sub_log2(float x) {
    union {
        float f;
        uint32_t i;
    } v = {x};
    float e = (float)((int)(v.i >> 23) - 127);
    v.i = (v.i & 0x7fffffu) | 0x3f800000u;   /* mantissa in [1, 2) */
    float t = (v.f - 1.f) / (v.f + 1.f), t2 = t * t;
    return e + 2.8853900817779268f * t * (1.f + t2 * (1.f / 3.f + t2 * (0.2f + t2 * (1.f / 7.f + t2 * (1.f / 9.f)))));
}

static inline uint64_t pgi__sub_step(pgi__sub *s) {
    float u = (float)((pgi_rng_u32(&s->rng) >> 8) + 1u) * (1.f / 16777216.f);   /* (0, 1] */
    float g = floorf(pgi__sub_log2(u) * s->inv_log1mp);
    return 1u + (g < 1e9f ? (uint64_t)g : 1000000000u);
}

static inline void pgi__sub_init(pgi__sub *s, int k, uint64_t seed, size_t pixel) {
    memset(s, 0, sizeof *s);
    s->on = k > 1;
    if (!s->on) return;
    float p = 1.f / ((float)k * (float)k);
    s->inv_log1mp = 1.f / log2f(1.f - p);
    pgi_rng_seed(&s->rng, seed ^ 0x5ab5a3b1e5ull, (uint64_t)pixel);
    s->skip = pgi__sub_step(s) - 1;
}

/* First index to visit in a list of n eligible photons (n: none). */
static inline uint32_t pgi__sub_begin(pgi__sub *s, uint32_t n) {
    s->eligible += n;
    if (s->skip >= n) {
        s->skip -= n;
        return n;
    }
    s->visited++;
    return (uint32_t)s->skip;
}
/* Next index after k in the same list (n: none; the rest carries over). */
static inline uint32_t pgi__sub_next(pgi__sub *s, uint32_t k, uint32_t n) {
    uint64_t nk = (uint64_t)k + pgi__sub_step(s);
    if (nk >= n) {
        s->skip = nk - n;
        return n;
    }
    s->visited++;
    return (uint32_t)nk;
}
/* One eligible photon at a time (tree walks): 1 if it is to be visited. */
static inline int pgi__sub_take(pgi__sub *s) {
    s->eligible++;
    if (!s->on) {
        s->visited++;
        return 1;
    }
    if (s->skip) {
        s->skip--;
        return 0;
    }
    s->skip = pgi__sub_step(s) - 1;
    s->visited++;
    return 1;
}
/* eligible / visited (1 when off; 0 when nothing was visited). */
static inline float pgi__sub_scale(const pgi__sub *s) {
    if (!s->on) return 1.f;
    return s->visited ? (float)((double)s->eligible / (double)s->visited) : 0.f;
}

/* A list of packed photons with a kernel and subsampling; without either it
 * is the plain pgi__gather_packed loop. */
static inline void pgi__gather_list(const pgi__vs *v, float r2, pgi_kernel kern, pgi__sub *ss,
                                    const pgi__packed_photon *q, uint32_t n, pgi__acc *a) {
    if (!ss->on) {
        ss->eligible += n;
        ss->visited += n;
        if (kern == PGI_KERNEL_CONSTANT)
            for (uint32_t k = 0; k < n; k++) pgi__gather_packed(v, r2, q + k, a);
        else
            for (uint32_t k = 0; k < n; k++) pgi__gather_packed_k(v, r2, kern, q + k, a);
        return;
    }
    for (uint32_t k = pgi__sub_begin(ss, n); k < n; k = pgi__sub_next(ss, k, n)) pgi__gather_packed_k(v, r2, kern, q + k, a);
}

/* World to view space of a pinhole camera (x right, y up, z forward) and
 * the screen scale: view (x, y, z) projects to x / (z sx), y / (z sy) in
 * [-1, 1]. Shared by the screen-space methods (tiled, bounds). */
typedef struct pgi__view_xf {
    pgi__v3 eye, right, up, fwd;
    float sx, sy;   /* tan(fov/2) * aspect, tan(fov/2) */
    int W, H;
} pgi__view_xf;

static inline pgi__view_xf pgi__view_xf_make(const pgi_camera *cam, int W, int H) {
    pgi__view_xf x = {v3_load(cam->eye), v3_load(cam->right), v3_load(cam->up), v3_load(cam->forward),
                      cam->tan_half_fov_y * cam->aspect, cam->tan_half_fov_y, W, H};
    return x;
}

static inline pgi__v3 pgi__to_view(const pgi__view_xf *x, float px, float py, float pz) {
    pgi__v3 d = v3_sub(v3(px, py, pz), x->eye);
    return v3(v3_dot(d, x->right), v3_dot(d, x->up), v3_dot(d, x->fwd));
}

/* Stats helpers for the per-method state. */
typedef struct pgi__est_common {
    pgi_estimator_desc desc;   /* resolved: defaults filled in, ranges checked */
    pgi_estimator_stats st;
    /* this frame's arguments (pgi__est_frame) */
    float radius;
    uint64_t seed;
    int threads;               /* for num_threads(): never 0 */
    float scene_area;
} pgi__est_common;

/* Takes the per-frame values of build/estimate into the state. */
static inline void pgi__est_frame(pgi__est_common *c, const pgi_estimate_args *a) {
    c->radius = a->radius;
    c->seed = a->seed;
    c->threads = pgi__threads(a->threads);
    c->scene_area = a->scene_area;
}

static inline void pgi__stats_pass(pgi_estimator_stats *st, const char *name, double ms) {
    if (st->pass_count < PGI_EST_MAX_ENTRIES) {
        st->pass_names[st->pass_count] = name;
        st->pass_ms[st->pass_count++] = ms;
    }
}
static inline void pgi__stats_mem(pgi_estimator_stats *st, const char *name, size_t bytes) {
    if (st->memory_count < PGI_EST_MAX_ENTRIES) {
        st->memory_names[st->memory_count] = name;
        st->memory_bytes[st->memory_count++] = bytes;
    }
}

/* Records the gather pass: its time since t0 and the read counters. */
static inline void pgi__stats_estimated(pgi_estimator_stats *st, double t0, uint64_t reads, uint64_t contributing) {
    st->estimate_ms = pgi__now_ms() - t0;
    pgi__stats_pass(st, "gather", st->estimate_ms);
    st->reads = reads;
    st->contributing = contributing;
}

/* Grows *p to hold n elements of `size` bytes (64-byte aligned); keeps the
 * allocation when it is large enough. */
pgi_status pgi__ensure(void **p, size_t *cap, size_t n, size_t size);

extern const pgi_estimator_vtbl pgi__est_brute, pgi__est_hashgrid, pgi__est_tiled;
/* The tile-edge option of tiled, bounds3d and bounds25d (est_tiled.c). */
extern const pgi_option pgi__opt_tile;
extern const pgi_estimator_vtbl pgi__est_cluster, pgi__est_cluster_cone, pgi__est_cluster_trivial,
    pgi__est_directional;
extern const pgi_estimator_vtbl pgi__est_bvh;
extern const pgi_estimator_vtbl pgi__est_kdtree, pgi__est_bounds3d, pgi__est_bounds25d;

#endif
