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
    pgi_v3 wo, kd, ks;
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

/* Stats helpers for the per-method state. */
typedef struct pgi__est_common {
    pgi_estimator_desc desc;
    pgi_estimator_stats st;
} pgi__est_common;

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
extern const pgi_estimator_vtbl pgi__est_cluster, pgi__est_cluster_cone, pgi__est_cluster_trivial,
    pgi__est_directional;

#endif
