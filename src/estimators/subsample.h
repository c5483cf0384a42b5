#ifndef PGI__EST_SUBSAMPLE_H
#define PGI__EST_SUBSAMPLE_H

#include <string.h>

#include "packed.h"

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
    float inv_log1mp; /* 1 / log2(1 - 1/k^2) */
    uint64_t skip;    /* eligible photons to pass over before the next visit */
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
    v.i = (v.i & 0x7fffffu) | 0x3f800000u; /* mantissa in [1, 2) */
    float t = (v.f - 1.f) / (v.f + 1.f), t2 = t * t;
    return e + 2.8853900817779268f * t * (1.f + t2 * (1.f / 3.f + t2 * (0.2f + t2 * (1.f / 7.f + t2 * (1.f / 9.f)))));
}

static inline uint64_t pgi__sub_step(pgi__sub *s) {
    float u = (float)((pgi_rng_u32(&s->rng) >> 8) + 1u) * (1.f / 16777216.f); /* (0, 1] */
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
 * is the plain pgi__gather_packed loop (pgi__gather_packed_n). */
static inline void pgi__gather_list(const pgi__vs *v, float r2, pgi_kernel kern, pgi__sub *ss,
                                    const pgi__packed_photon *q, uint32_t n, pgi__acc *a) {
    if (!ss->on) {
        ss->eligible += n;
        ss->visited += n;
        if (kern == PGI_KERNEL_CONSTANT) pgi__gather_packed_n(v, r2, q, n, a);
        else
            for (uint32_t k = 0; k < n; k++) pgi__gather_packed_k(v, r2, kern, q + k, a);
        return;
    }
    for (uint32_t k = pgi__sub_begin(ss, n); k < n; k = pgi__sub_next(ss, k, n))
        pgi__gather_packed_k(v, r2, kern, q + k, a);
}

#endif
