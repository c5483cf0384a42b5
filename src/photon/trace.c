/* Photon tracing: emission from lights picked by power, BSDF sampling,
 * flux-preserving Russian roulette (cluster paper eq. 1; none at the first hit of a path
 * through a portal, which stores nothing), storage from the
 * second hit on (the first hit is direct light, done with shadow rays; a path
 * whose first hits are all specular stores at its first non-specular hit:
 * a caustic). Optionally steered towards where the camera looks (guide.h) and
 * storing only the photons near a view sample (trace desc `near`).
 *
 * Compiled three times on x86-64 (GCC, clang): here for the baseline; by trace_v3.c (which
 * includes this file with PGI__TRACE_V3) with AVX2, FMA, BMI1/2 and POPCNT enabled, whose
 * pgi__photons_trace_v3 pgi__photons_trace calls where the CPU has them (pgi__trace_v3_ok); and
 * by trace_v4.c (PGI__TRACE_V3 and PGI__TRACE_V4) with AVX-512 too (pgi__trace_v4_ok). The same
 * operations each way (no contraction: -ffp-contract=off), so the same bits (test_trace); the
 * wider instruction sets take time off the tracer's own code (docs/performance.md; the history in
 * docs/history/performance.md). */
#include "photon.h"

#include <omp.h>
#include <string.h>

#include "guide.h"
#include "radius.h"
#include "trace_simd.h"
#include "scene/bsdf.h"
#include "scene/portal.h"

#include <stdint.h>
#if defined(__SSE2__)
#include <emmintrin.h> /* record: streaming stores */
#endif

#ifndef PGI__TRACE_V3
int pgi__trace_room_cap = 0;
#endif

/* The paths of a wave (a thread carries two in turn, trace_chunk): the rays of a wave are cast
 * together and the texels of its hits are prefetched before any is shaded, so that their cache
 * misses overlap instead of following one another (photon rays are incoherent: each hit is a
 * miss). */
#define WAVE 16 /* = the packet width of pgi__rt_intersect16 */
_Static_assert(WAVE == 16, "a wave is one pgi__rt_intersect16 packet");
/* Paths a scheduling unit: a thread traces a chunk's paths and sorts their photons into path
 * order, so that the result is the same whatever the thread count. */
#define CHUNK 1024
/* The emission pre-pass (start_paths, first_hits): paths from point and spot lights are sorted by
 * direction and cast 16 at a time as coherent packets when a batch has at least COHERENT_MIN of
 * them (fewer, spread over the sphere, are not coherent enough: single rays are faster); a batch
 * holds at most PREPASS_BATCH paths (its states take 80 bytes a path). */
#define COHERENT_MIN 32768
#define PREPASS_BATCH (1u << 18)


typedef struct stored_photon {
    float p[3], d[3], f[3], n[3];
} stored_photon;

/* A thread's photons: `rec` (+ `rec_fp`, `rec_path`: the path within its chunk) collect the
 * thread's chunks of the current batch, each in the order the wave produced them. The gather
 * puts them into path order as it copies them into the photon map. */
typedef struct pgi__trace_tbuf {
    _Alignas(64) stored_photon *rec; /* a cache line each: each thread counts its photons in its own */
    pgi__footprint *rec_fp;
    uint16_t *rec_path;
    size_t nrec, rec_cap;
    uint64_t culled; /* photons not stored: no view sample near */
} pgi__trace_tbuf;

typedef struct chunk_info {
    int tid;      /* thread whose `rec` holds the chunk */
    size_t off;   /* its first photon there */
    size_t total; /* photons of the chunk */
    size_t count; /* of these, the photons taken: the first in path order */
    size_t keyed; /* paths that start in start_paths (from point and spot lights) */
    size_t kofs;  /* ... and the first one's place among the batch's (sort_paths) */
} chunk_info;

typedef struct tracer {
    const pgi_scene *s;
    const pgi__rt *rt;
    const pgi__tri_rec *tris; /* the scene's triangles as shaded (pgi__tri_cache_update) */
    const float *tri_uv;      /* and their texture coordinates, PGI__TRI_UV floats each (NULL: none) */
    const float *cdf;         /* light CDF by luminance of power */
    size_t nl;
    int bounces;
    uint64_t seed_mix; /* pgi__rng_seed_mix(seed): each path's stream from it (pick_light) */
    float eps;
    pgi__v3 centre;
    float radius;      /* bounding-sphere radius, for the sun's disk */
    pgi__fp_params fp; /* radius policy */
    int fp_track;      /* a radius policy follows the paths (the hooks are no-ops otherwise) */
    int fp_on;         /* footprints are stored */
    /* view-importance emission (guide.h): NULL, or the guide; sampling from it when G->on, else
       uniform with its evidence counted (vg: the cells the camera sees) */
    const pgi__guide *G;
    const pgi__view_grid *vg;
    const pgi__view_grid *near; /* store only photons in its cells (NULL: all) */
    int fast_sincos;            /* pgi__trace_sincos_fast: a wave's azimuths together */
    int lambert_simd;           /* pgi__trace_lambert_avx2 is there (pgi__cpu_avx2) */
    int keep_first;             /* portal emission: no roulette at a path's first hit (wave_hits) */
    /* portal emission (scene/portal.h): NULL, or the sky's table; the sun and the sky start on
       the portals */
    const pgi__portal_emit *PE;
    pgi__emit_frame E; /* what pgi__light_emit reads: the scene, centre, radius, eps and PE */
} tracer;

typedef struct lane {
    pgi__rng rng;
    pgi__v3 o, d, flux;
    pgi__pdiff pd;
    pgi__hit h;
    int b;    /* bounce: the hit of this ray is the path's (b+1)-th */
    int path; /* path within the chunk; -1: idle */
    int bin;  /* the guide's bin of its emission */
    /* the texels of the hit's albedo (found before shading, where the path may go on; tex NULL:
       no texture, or one without texels) */
    const pgi__texture *tex;
    pgi__texel_quad tq;
    float u[4]; /* the hit's four numbers (BSDF, roulette) */
} lane;

/* The first numbers of path `index`: its stream seeded in `l`, the light it leaves (picked by
 * power), the pick's probability (0: a light of no power, emit_from ends the path), and a steered
 * path's bin and pair. */
typedef struct emission_pick {
    float ul, pl, a, b; /* the pick's number and probability; the steered pair */
} emission_pick;
static inline const pgi__light *pick_light(const tracer *T, uint64_t index, lane *l, emission_pick *e) {
    pgi__rng_seed_mixed(&l->rng, T->seed_mix, index);
    const pgi__guide *G = T->G;
    float ul;
    e->a = e->b = 0.f;
    if (G && G->on) {
        /* a bin of the guide, then the light pick and the steered pair inside it */
        float ub = pgi_rng_f(&l->rng), r0 = pgi_rng_f(&l->rng), r1 = pgi_rng_f(&l->rng), r2 = pgi_rng_f(&l->rng);
        l->bin = pgi__guide_sample(G, ub, r0, r1, r2, &ul, &e->a, &e->b);
    } else {
        ul = pgi_rng_f(&l->rng);
    }
    e->ul = ul;
    const size_t li = pgi__cdf_pick(T->cdf, T->nl, ul, &e->pl);
    return li < T->s->nlights ? &T->s->lights[li] : &T->s->env->light; /* the last: the sky */
}

/* start_path after pick_light (below), in two steps: emit_draw, the numbers (the four numbers
 * u[0..3] of the emission, the guide's bin and count; 0: the light carries nothing), then
 * emit_place, the ray and its flux (pgi__light_emit; emit_place_point takes `cs`, cos and sin of
 * 2 pi u[1] where known: pgi__trace_sincos_2pi, the same bits as cosf and sinf). */
static inline int emit_draw(const tracer *T, const pgi__light *L, const emission_pick *e, lane *l, uint32_t *cnt,
                            float u[4]) {
    const pgi__guide *G = T->G;
    const int steer = G && G->on;
    const float pl = e->pl;
    if (!(pl > 0.f)) return 0;
    /* The steered pair: the light's own (pgi__light_pair_late), the guide's a and b; its other
     * two numbers drawn. */
    const int late = pgi__light_pair_late(L);
    if (steer) {
        if (late) {
            u[2] = e->a;
            u[3] = e->b;
            u[0] = pgi_rng_f(&l->rng);
            u[1] = pgi_rng_f(&l->rng);
        } else {
            u[0] = e->a;
            u[1] = e->b;
            u[2] = u[3] = 0.f;
        }
    } else {
        pgi__light_draw(L, &l->rng, u);
        if (G) l->bin = late ? pgi__guide_bin(G, e->ul, u[2], u[3]) : pgi__guide_bin(G, e->ul, u[0], u[1]);
    }
    if (G) cnt[l->bin]++;
    return 1;
}

/* emit_place for a point or spot light (pgi__light_from_point). */
static inline void emit_place_point(const tracer *T, const pgi__light *L, float pl, const float u[4], const float *cs,
                                    lane *l) {
    pgi__light_emit_point(L, pl, u, cs, &l->o, &l->d, &l->flux);
    if (T->fp_track) pgi__fp_emit(&l->pd, &T->fp, T->s, L, pl, l->d, T->radius);
    l->b = 0;
}

static int emit_place(const tracer *T, const pgi__light *L, float pl, const float u[4], lane *l) {
    if (!pgi__light_emit(L, &T->E, pl, u, &l->rng, &l->o, &l->d, &l->flux)) return 0;
    if (T->fp_track) pgi__fp_emit(&l->pd, &T->fp, T->s, L, pl, l->d, T->radius);
    l->b = 0;
    return 1;
}

static int emit_from(const tracer *T, const pgi__light *L, const emission_pick *e, lane *l, uint32_t *cnt) {
    float u[4];
    return emit_draw(T, L, e, l, cnt, u) && emit_place(T, L, e->pl, u, l);
}

/* Starts path `index` in `l` (emission from a light picked by power). Flux is power / pick
 * probability (divided by the paths later; a steered path's photons then take its bin's weight
 * V/q too). Returns 0 when the path carries nothing. `cnt`: the thread's guide counters (paths of
 * each bin). */
static int start_path(const tracer *T, uint64_t index, lane *l, uint32_t *cnt) {
    emission_pick e;
    const pgi__light *L = pick_light(T, index, l, &e);
    return emit_from(T, L, &e, l, cnt);
}

/* Whether pgi__bsdf_sample scatters like a Lambertian surface at m: weight kd, whatever the
 * direction. */
static inline int lambert(const pgi__material *m) {
    return m->type != PGI__MAT_MIRROR && m->type != PGI__MAT_GLASS && m->type != PGI__MAT_PHONG &&
           m->type != PGI__MAT_PLASTIC;
}

/* Appends one photon of chunk path `path` to the thread's record. */
static int record(pgi__trace_tbuf *tb, int fp_on, int path, pgi__v3 p, pgi__v3 wi, pgi__v3 flux, pgi__v3 ng,
                  const pgi__footprint *fp) {
    if (tb->nrec == tb->rec_cap) {
        size_t cap = tb->rec_cap ? 2 * tb->rec_cap : 4096;
        stored_photon *r = realloc(tb->rec, cap * sizeof *r);
        if (r) tb->rec = r;
        uint16_t *rp = realloc(tb->rec_path, cap * sizeof *rp);
        if (rp) tb->rec_path = rp;
        pgi__footprint *rf = fp_on ? realloc(tb->rec_fp, cap * sizeof *rf) : tb->rec_fp;
        if (rf) tb->rec_fp = rf;
        if (!r || !rp || (fp_on && !rf)) return 0;
        tb->rec_cap = cap;
    }
    size_t j = tb->nrec++;
    stored_photon *sp = &tb->rec[j];
#if defined(__SSE2__)
    /* streamed past the caches (the gather reads them once, after the batch): the pass's
       rays, triangle records and texels keep the cache, and no line is read to be written */
    __m128i *q = (__m128i *)(void *)sp;
    _mm_stream_si128(q, _mm_castps_si128(_mm_setr_ps(p.x, p.y, p.z, wi.x)));
    _mm_stream_si128(q + 1, _mm_castps_si128(_mm_setr_ps(wi.y, wi.z, flux.x, flux.y)));
    _mm_stream_si128(q + 2, _mm_castps_si128(_mm_setr_ps(flux.z, ng.x, ng.y, ng.z)));
#else
    v3_store(sp->p, p);
    v3_store(sp->d, wi);
    v3_store(sp->f, flux);
    v3_store(sp->n, ng);
#endif
    if (fp_on) tb->rec_fp[j] = *fp;
    tb->rec_path[j] = (uint16_t)path;
    return 1;
}

/* A path between two hits, as the emission pre-pass (first_hits) leaves it for trace_chunk:
 * the lane's state that lasts from one bounce to the next (its differentials in a second
 * array, when a radius policy follows them; whether it goes on: trace_scratch.live). */
typedef struct path_state {
    _Alignas(64) pgi__rng rng; /* one cache line each: first_hits reads them in sorted order */
    pgi__v3 o, d, flux;
    uint16_t bin;
    uint8_t b;
} path_state;

static inline void state_save(const lane *l, path_state *ps, pgi__pdiff *pd) {
    ps->rng = l->rng;
    ps->o = l->o;
    ps->d = l->d;
    ps->flux = l->flux;
    ps->bin = (uint16_t)l->bin;
    ps->b = (uint8_t)l->b;
    if (pd) *pd = l->pd;
}

static inline void state_load(lane *l, const path_state *ps, const pgi__pdiff *pd) {
    l->rng = ps->rng;
    l->o = ps->o;
    l->d = ps->d;
    l->flux = ps->flux;
    l->bin = ps->bin;
    l->b = ps->b;
    if (pd) l->pd = *pd;
}

/* A wave's packet has returned: each lane's hit, its triangle records requested (the misses of
 * the 16 hits overlap), and the numbers shading draws where the path may scatter, drawn while
 * the records load: a path that goes on uses all four (a failed BSDF sample ends it), so its
 * stream stays as it was. */
static inline void wave_hits(const tracer *T, lane *L, const int *valid, const float *t, const float *u, const float *v,
                             const uint32_t *prim) {
    for (int k = 0; k < WAVE; k++) {
        if (!valid[k]) continue;
        L[k].h.t = t[k];
        L[k].h.u = u[k];
        L[k].h.v = v[k];
        L[k].h.prim = prim[k];
        if (prim[k] != UINT32_MAX) {
            __builtin_prefetch(T->tris + prim[k]);
            if (T->tri_uv) __builtin_prefetch(T->tri_uv + PGI__TRI_UV * (size_t)prim[k]);
            if (L[k].b < T->bounces) {
                for (int j = 0; j < 4; j++) L[k].u[j] = pgi_rng_f(&L[k].rng);
                /* no roulette at the first hit (keep_first): its number -1, which the scattering
                 * reads as a probability of 1 (the flux times the albedo, not divided by it) */
                if (T->keep_first && L[k].b == 0) L[k].u[3] = -1.f;
            }
        }
    }
}

/* Casts the rays of a wave's lanes that carry a path (path >= 0) as one 16-wide packet, counted
 * in *rays, and takes their hits (wave_hits). Coherent: only where every ray leaves one point (a
 * point or spot light's paths, sorted by direction: first_hits); otherwise single rays. */
static inline void cast_wave(const tracer *T, lane *L, int coherent, uint64_t *rays) {
    int valid[WAVE];
    _Alignas(64) float o[3][WAVE], d[3][WAVE], t[WAVE], u[WAVE], v[WAVE];
    _Alignas(64) uint32_t prim[WAVE];
    for (int k = 0; k < WAVE; k++) {
        valid[k] = L[k].path >= 0;
        o[0][k] = L[k].o.x;
        o[1][k] = L[k].o.y;
        o[2][k] = L[k].o.z;
        d[0][k] = L[k].d.x;
        d[1][k] = L[k].d.y;
        d[2][k] = L[k].d.z;
        *rays += (uint64_t)valid[k];
    }
    if (coherent) { /* without a branch a lane: several lanes an instruction */
        int differ = 0;
        for (int k = 1; k < WAVE; k++)
            differ |= valid[k] & ((o[0][k] != o[0][0]) | (o[1][k] != o[1][0]) | (o[2][k] != o[2][0]));
        coherent = !differ;
    }
    pgi__rt_intersect16(T->rt, valid, (const float(*)[WAVE])o, (const float(*)[WAVE])d, coherent, t, u, v, prim);
    wave_hits(T, L, valid, t, u, v, prim);
}

/* The sines and cosines of the wave's BSDF azimuths 2 pi u[1] into sc (sin, cos), all 16 at once
 * while the hits' records load; NULL where that is not the faster way (wave_shade then calls
 * cosf and sinf where it needs them). */
static inline float (*wave_azimuths(const tracer *T, const lane *L, float (*sc)[WAVE]))[WAVE] {
    if (!T->fast_sincos || T->lambert_simd) return NULL; /* the batch finds its own */
    float az[WAVE];
    for (int k = 0; k < WAVE; k++)
        az[k] = L[k].path >= 0 && L[k].h.prim != UINT32_MAX && L[k].b < T->bounces ? L[k].u[1] : 0.f;
    pgi__trace_sincos_2pi(az, sc[0], sc[1], WAVE);
    return sc;
}

/* Then which hits may scatter, into W->go in lane order (a lane that ends here ends without a
 * branch on it: whether a path goes on is a coin toss, and a branch on it missed half the
 * time), and the texels of those with a texture (the albedo weighs the scattered flux): each
 * stage's loads are in cache when the next stage needs them. */
typedef struct wave_go {
    int n;
    uint8_t k[WAVE];                /* the lanes that may scatter */
    const pgi__material *mat[WAVE]; /* and their materials */
    uint8_t lam[WAVE];              /* lambert(mat) */
    /* wave_shade's hit point, facing normal and side of each lane */
    pgi__v3 p[WAVE], ng[WAVE];
    uint8_t front[WAVE];
} wave_go;

static inline void wave_texels(const tracer *T, lane *L, wave_go *W) {
    const pgi_scene *s = T->s;
    int n = 0;
    for (int k = 0; k < WAVE; k++) {
        lane *l = &L[k];
        l->tex = NULL;
        if (l->path < 0 || l->h.prim == UINT32_MAX || l->b >= T->bounces) continue;
        const pgi__material *m = &s->mats[T->tris[l->h.prim].mat];
        const int lam = lambert(m);
        int ends = 0;
        if (lam) {
            /* The scattered flux is flux kd col tex, with the vertex colour col <= 1 and tex <= 1
             * (+ a rounding): the roulette's probability with col = tex = 1 bounds it from above.
             * A path whose roulette number is past the bound (times 1.0001) ends whatever its
             * colour, texel and direction, so it needs none of them (a quarter of Sibenik's stone
             * hits). Where kd and the flux are not all >= 0 (the bound holds for those only),
             * found but not taken. */
            const pgi__v3 kd = v3_load(m->kd), f = l->flux;
            const int signs =
                (kd.x >= 0.f) & (kd.y >= 0.f) & (kd.z >= 0.f) & (f.x >= 0.f) & (f.y >= 0.f) & (f.z >= 0.f);
            const float mf = v3_maxc(f);
            const float Rb = mf > 0.f ? pgi_minf(v3_maxc(v3_mul(f, kd)) / mf, 1.f) : 0.f;
            ends = signs & (Rb < 1.f) & (l->u[3] >= Rb * 1.0001f);
        }
        W->k[n] = (uint8_t)k;
        W->mat[k] = m;
        W->lam[k] = (uint8_t)lam;
        n += !ends;
    }
    W->n = n;
    for (int i = 0; i < n; i++) {
        lane *l = &L[W->k[i]];
        const pgi__material *m = W->mat[W->k[i]];
        if (m->tex_kd < 0) continue;
        l->tex = &s->texs[m->tex_kd];
        float u = 0.f, v = 0.f; /* without texture coordinates the lookup reads (0, 0) */
        if (T->tri_uv) pgi__tri_rec_uv(T->tri_uv + PGI__TRI_UV * (size_t)l->h.prim, l->h.u, l->h.v, &u, &v);
        if (!pgi__texture_quad(l->tex, u, v, &l->tq)) l->tex = NULL; /* no texels: white */
    }
}

/* Shade: store, scatter, roulette. A lane whose path ends gets path -1; returns how many did.
 * Photons are stored from the second hit on (b >= 1), into tb with cnt counting each chunk
 * path's: a wave of first hits (b = 0 everywhere) stores none and may pass NULL for both. *ok
 * becomes 0 when out of memory (the wave is then left as it is). First every hit (its photon),
 * then the lanes that may scatter (W, from wave_texels); the others end. */
static inline int wave_shade(const tracer *T, lane *L, float (*sc)[WAVE], pgi__lambert_batch *lbs, wave_go *W,
                             pgi__trace_tbuf *tb, uint8_t *cnt, uint32_t *gcnt, int *ok) {
    const pgi_scene *s = T->s;
    int ended = 0;
    uint32_t go = 0; /* the lanes in W */
    for (int i = 0; i < W->n; i++) go |= 1u << W->k[i];
    for (int k = 0; k < WAVE; k++) {
        lane *l = &L[k];
        if (l->path < 0) continue;
        if (l->h.prim != UINT32_MAX) {
            /* pgi__tri_rec_surface's values (the shading normal and albedo only where the path
             * scatters) in registers rather than a pgi__surface (whose copies through memory
             * stalled the loads after them), the same operations */
            const pgi__tri_rec *r = &T->tris[l->h.prim];
            const pgi__material *mat = &s->mats[r->mat];
            const pgi__v3 p = v3_madd(l->o, l->d, l->h.t);
            const pgi__v3 g = v3_load(r->ng);
            const pgi__v3 wi = v3_neg(l->d);
            const int front = v3_dot(wi, g) >= 0.f;
            const pgi__v3 ng = front ? g : v3_neg(g);
            W->p[k] = p;
            W->ng[k] = ng;
            W->front[k] = (uint8_t)front;
            if (T->fp_track) pgi__fp_hit(&l->pd, &T->fp, l->d, l->h.t, ng);
            if (l->b >= 1 && !pgi__mat_specular(mat)) {
                pgi__footprint fp;
                if (T->fp_on) pgi__fp_store(&l->pd, &T->fp, ng, &fp);
                if (T->G) { /* the guide's evidence: every photon the path would store */
                    gcnt[T->G->nbins + l->bin]++;
                    if (pgi__view_grid_has(T->vg, p, ng)) gcnt[2 * T->G->nbins + l->bin]++;
                }
                if (T->near && !pgi__view_grid_near(T->near, p)) {
                    tb->culled++;
                } else {
                    if (!record(tb, T->fp_on, l->path, p, wi, l->flux, ng, &fp)) *ok = 0;
                    cnt[l->path]++;
                }
            }
        }
        const int e = !(go >> k & 1); /* a miss, the last bounce, or the roulette's bound */
        l->path |= -e;
        ended += e;
    }
    if (!*ok) return ended;
    /* Lambertian scattering, 8 lanes an instruction (AVX2, no radius policy): the lanes that
     * scatter so go into a batch, shaded together after the others */
    pgi__lambert_batch *lb = NULL;
    int lmap[WAVE];
    if (T->lambert_simd) {
        lb = lbs;
        lb->n = 0;
        lb->nrm = s->nrm != NULL;
        lb->eps = T->eps;
    }
    for (int i = 0; i < W->n; i++) {
        const int k = W->k[i];
        lane *l = &L[k];
        const pgi__tri_rec *r = &T->tris[l->h.prim];
        const pgi__material *mat = W->mat[k];
        const pgi__v3 p = W->p[k], g = v3_load(r->ng), wi = v3_neg(l->d), ng = W->ng[k];
        const int front = W->front[k];
        int alive = 0;
        /* the shading normal (the batch finds its own) */
        const int lam = W->lam[k], batched = lb && lam;
        const pgi__v3 ns = batched ? g : pgi__tri_rec_ns(s, r, l->h.u, l->h.v, g);
        pgi__v3 kd = pgi__scene_kd(s, mat, l->h.prim, l->h.u, l->h.v);
        if (l->tex) kd = v3_mul(kd, pgi__texture_quad_lookup(&l->tq));
        pgi__v3 wo, w;
        int scatters;
        if (batched) {
            /* into the wave's batch (pgi__trace_lambert_avx2: the operations below) */
            const int j = lb->n++;
            lmap[j] = k;
            lb->bu[j] = l->h.u;
            lb->bv[j] = l->h.v;
            if (s->nrm)
                for (int q = 0; q < 9; q++) lb->nv[q][j] = r->n[q];
            lb->g[0][j] = g.x;
            lb->g[1][j] = g.y;
            lb->g[2][j] = g.z;
            lb->side[j] = front ? 1.f : -1.f;
            lb->kd[0][j] = kd.x;
            lb->kd[1][j] = kd.y;
            lb->kd[2][j] = kd.z;
            lb->u0[j] = l->u[0];
            lb->u3[j] = l->u[3];
            lb->u1[j] = l->u[1];
            lb->flux[0][j] = l->flux.x;
            lb->flux[1][j] = l->flux.y;
            lb->flux[2][j] = l->flux.z;
            lb->p[0][j] = p.x;
            lb->p[1][j] = p.y;
            lb->p[2][j] = p.z;
            lb->ng[0][j] = ng.x;
            lb->ng[1][j] = ng.y;
            lb->ng[2][j] = ng.z;
            continue; /* its fate after the loop */
        }
        if (lam) {
            /* pgi__bsdf_sample's Lambertian case, its azimuth's cosine and sine found for
             * the wave at once where that is faster (the same bits) */
            const float side = front ? 1.f : -1.f;
            const pgi__v3 gn = v3_scale(g, side), sn = v3_scale(ns, side);
            const pgi__v3 c =
                sc ? pgi_sample_cosine_cs(l->u[0], sc[1][k], sc[0][k]) : pgi_sample_cosine(l->u[0], l->u[1]);
            wo = pgi_to_world(c, sn);
            w = kd;
            scatters = v3_dot(wo, gn) > 0.f;
        } else {
            const pgi__surface sf = {.p = p, .ng = g, .ns = ns, .mat = mat, .kd = kd};
            scatters = pgi__bsdf_sample(&sf, wi, l->u[0], l->u[1], l->u[2], &wo, &w);
        }
        if (scatters) {
            if (T->fp_track) {
                const pgi__surface sf = {.p = p, .ng = g, .ns = ns, .mat = mat, .kd = kd};
                pgi__fp_scatter(&l->pd, &T->fp, s, l->h.prim, l->h.u, l->h.v, &sf, wi, wo, w);
            }
            pgi__v3 nf = v3_mul(l->flux, w);
            float mf = v3_maxc(l->flux);
            float R = mf > 0.f ? pgi_minf(v3_maxc(nf) / mf, 1.f) : 0.f;
            if (l->u[3] < 0.f && mf > 0.f) R = 1.f; /* keep_first */
            if (l->u[3] < R) {
                l->flux = v3_scale(nf, 1.f / R);
                if (v3_finite(l->flux)) {
                    if (T->fp_track) pgi__fp_roulette(&l->pd, &T->fp, R);
                    l->o = v3_madd(p, v3_dot(wo, ng) >= 0.f ? ng : v3_neg(ng), T->eps);
                    l->d = wo;
                    l->b++;
                    alive = 1;
                }
            }
        }
        if (!alive) {
            l->path = -1;
            ended++;
        }
    }
    if (lb && lb->n) {
        pgi__trace_lambert_avx2(lb); /* the lanes past n: earlier waves' (or zeros), not read */
        /* without a branch on the roulette (a coin toss: a branch missed as often as it hit);
           an ended path's flux and ray are not read again */
        for (int j = 0; j < lb->n; j++) {
            lane *l = &L[lmap[j]];
            const int a = lb->alive[j] != 0;
            l->flux = v3(lb->f[0][j], lb->f[1][j], lb->f[2][j]);
            l->o = v3(lb->o[0][j], lb->o[1][j], lb->o[2][j]);
            l->d = v3(lb->d[0][j], lb->d[1][j], lb->d[2][j]);
            l->b += a;
            l->path |= -(int)!a; /* -1: ended */
            ended += !a;
        }
    }
    return ended;
}

/* A wave in flight (trace_chunk carries two, first_hits one): its lanes, which of them carry no
 * path and how many do, and, once it is cast, what wave_ready finds for its shading. */
typedef struct wave {
    lane L[WAVE];
    uint32_t idle; /* lanes without a path */
    int active;    /* lanes with one */
    wave_go go;
    float scb[2][WAVE], (*sc)[WAVE]; /* wave_azimuths' */
} wave;

/* A cast wave's azimuths and texels requested (wave_azimuths, wave_texels), for wave_finish. */
static inline void wave_ready(const tracer *T, wave *w) {
    w->sc = wave_azimuths(T, w->L, w->scb);
    wave_texels(T, w->L, &w->go);
}

/* A ready wave shaded (wave_shade), the lanes whose paths ended marked idle. */
static inline void wave_finish(const tracer *T, wave *w, pgi__lambert_batch *lbs, pgi__trace_tbuf *tb, uint8_t *cnt,
                               uint32_t *gcnt, int *ok) {
    w->active -= wave_shade(T, w->L, w->sc, lbs, &w->go, tb, cnt, gcnt, ok);
    for (int k = 0; k < WAVE; k++) w->idle |= (uint32_t)(w->L[k].path < 0) << k;
}

/* How a path of the batch starts (start_paths): */
enum {
    START_NONE = 0,  /* it carries nothing */
    START_STATE = 1, /* from its state in ps (its first hit already found by first_hits) */
    START_CHUNK = 2  /* in its chunk (trace_chunk calls start_path) */
};

/* Paths [p0, p1) of the batch (its first path `base`) decide how they start. The first `room`
 * paths from point or spot lights start here: each one's state into ps[m] and its sort key and
 * slot into key[m], idx[m] = m, m counting from `slot`, in path order; returns how many. The
 * others start in their chunk (trace_chunk): their origins differ, so their packets would not be
 * coherent. pbin: the guide bins (guided emission), gcnt: the thread's guide counters. */
static size_t start_paths(const tracer *T, uint64_t base, size_t p0, size_t p1, size_t slot, size_t room,
                          path_state *ps, pgi__pdiff *pd, uint8_t *mode, uint32_t *key, uint32_t *idx, uint32_t *gcnt,
                          uint16_t *pbin, uint32_t *hist) {
    size_t m = slot;
    /* 16 paths at a time: their numbers, then the sines and cosines of their azimuths together
     * (pgi__trace_sincos_2pi), then their rays, states and sort keys */
    for (size_t i0 = p0; i0 < p1; i0 += WAVE) {
        lane lb[WAVE];
        const pgi__light *lights[WAVE];
        float pl[WAVE], u[WAVE][4], az[WAVE], sn[WAVE], cs[WAVE];
        int nb = 0;
        for (size_t i = i0; i < p1 && i < i0 + WAVE; i++) {
            lane *l = &lb[nb];
            l->bin = 0;
            l->path = 0;
            emission_pick e;
            const pgi__light *L = m < slot + room ? pick_light(T, base + i, l, &e) : NULL;
            if (!L || !pgi__light_from_point(L)) {
                mode[i] = START_CHUNK;
                continue;
            }
            if (!emit_draw(T, L, &e, l, gcnt, u[nb])) {
                mode[i] = START_NONE;
                continue;
            }
            mode[i] = START_STATE;
            if (pbin) pbin[i] = (uint16_t)l->bin;
            lights[nb] = L;
            pl[nb] = e.pl;
            az[nb] = u[nb][1];
            nb++;
            m++;
        }
        if (!nb) continue;
        const int n8 = (nb + 7) & ~7;
        for (int k = nb; k < n8; k++) az[k] = 0.f;
        pgi__trace_sincos_2pi(az, sn, cs, n8);
        const size_t m0 = m - (size_t)nb;
        float o[3][WAVE], d[3][WAVE];
        for (int k = 0; k < nb; k++) {
            const float c2[2] = {cs[k], sn[k]};
            lane *l = &lb[k];
            emit_place_point(T, lights[k], pl[k], u[k], c2, l);
            state_save(l, &ps[m0 + (size_t)k], pd ? &pd[m0 + (size_t)k] : NULL);
            o[0][k] = l->o.x;
            o[1][k] = l->o.y;
            o[2][k] = l->o.z;
            d[0][k] = l->d.x;
            d[1][k] = l->d.y;
            d[2][k] = l->d.z;
            idx[m0 + (size_t)k] = (uint32_t)(m0 + (size_t)k);
        }
        pgi__trace_emit_keys(T->centre, T->radius, o[0], o[1], o[2], d[0], d[1], d[2], nb, key + m0);
        for (int k = 0; k < nb; k++) { /* the sort's counts of each byte of the keys (sort_paths) */
            const uint32_t kk = key[m0 + (size_t)k];
            hist[kk & 255]++;
            hist[256 + (kk >> 8 & 255)]++;
            hist[512 + (kk >> 16 & 255)]++;
            hist[768 + (kk >> 24)]++;
        }
    }
    return m - slot;
}

/* The first chunk of part q of nch chunks cut into nt parts (start_paths, sort_paths). */
static inline long long part_first(long long nch, int nt, int q) { return nch * q / nt; }

/* Sorts the batch's n keyed paths by key, stably (a key's paths stay in path order): chunk c's
 * sort keys and slots are key, idx + c room (chunks[c].keyed of them, at chunks[c].kofs among the
 * batch's). A byte of the key at a time, each byte's counts taken by start_paths as it made the
 * keys (hist + 1024 (q + 1) for part q of the chunks: part_first); a byte that every key shares
 * (a point light's origin cell) is skipped. The first pass gathers the chunks' keys as it places
 * them by the most significant byte, the parts in parallel (each part's place in each run known
 * from the counts of the parts before it); the runs it makes are then sorted on their own, in
 * parallel; the order ends in idx (tkey, tidx: room for n more). A sort of the whole batch in
 * parallel, a pass at a time, was no faster: its passes are bound by the cache misses of their
 * scattered writes. */
static void sort_paths(pgi__trace_scratch *sc, long long nch, size_t room, size_t n, int nt) {
    uint32_t *const key = sc->key, *const idx = sc->idx;
    const chunk_info *ch = sc->chunks;
    uint32_t *const h = sc->hist; /* 4 x 256 counts: the sums of the parts' (start_paths), which follow */
    for (int b = 0; b < 1024; b++) {
        uint32_t c = 0;
        for (int t = 1; t <= nt; t++) c += h[(size_t)t * 1024 + (size_t)b];
        h[b] = c;
    }
    int pass[4], np = 0;
    for (int d = 0; d < 4; d++) {
        int one = 0;
        uint32_t acc = 0, *hd = h + 256 * d;
        for (int b = 0; b < 256; b++) {
            const uint32_t c = hd[b];
            one |= c == n;
            hd[b] = acc;
            acc += c;
        }
        if (!one) pass[np++] = d;
    }
    if (!np) { /* one key: the chunks' slots in path order */
        for (long long c = 0; c < nch; c++)
            if (ch[c].keyed && ch[c].kofs != (size_t)c * room)
                memmove(idx + ch[c].kofs, idx + (size_t)c * room, ch[c].keyed * sizeof *idx);
        return;
    }
    /* The first pass, from the chunks' slices into tkey, tidx, by the most significant byte the
       keys do not all share: 256 runs, each a part of the order. Then each run on its own by the
       other bytes, least significant first (a run fits the cache; runs in parallel, each the same
       whatever thread takes it), back and forth with key, idx (whose slices the first pass has
       read), the last into idx. The order is the one stable sort by key. */
    {
        const int top = pass[np - 1], d = 8 * top;
        uint32_t *const hd = h + 256 * top, run[257];
        for (int b = 0; b < 256; b++) run[b] = hd[b];
        run[256] = (uint32_t)n;
        /* each part's first place in each run, in its counts' place */
        for (int b = 0; b < 256; b++) {
            uint32_t acc = hd[b];
            for (int q = 1; q <= nt; q++) {
                uint32_t *const hq = h + (size_t)q * 1024 + 256 * top + b, c = *hq;
                *hq = acc;
                acc += c;
            }
        }
#pragma omp parallel for schedule(static, 1) num_threads(nt)
        for (int q = 0; q < nt; q++) {
            uint32_t *const o = h + (size_t)(q + 1) * 1024 + 256 * top;
            for (long long c = part_first(nch, nt, q); c < part_first(nch, nt, q + 1); c++)
                for (size_t i = (size_t)c * room, e = i + ch[c].keyed; i < e; i++) {
                    const uint32_t k = key[i], j = o[k >> d & 255]++;
                    sc->tkey[j] = k;
                    sc->tidx[j] = idx[i];
                }
        }
        if (np == 1) {
            memcpy(idx, sc->tidx, n * sizeof *idx);
            return;
        }
#pragma omp parallel for schedule(dynamic, 16) num_threads(nt)
        for (int b = 0; b < 256; b++) {
            const size_t r0 = run[b], rn = run[b + 1] - run[b];
            if (rn < 2) {
                if (rn) idx[r0] = sc->tidx[r0];
                continue;
            }
            uint32_t *sk = sc->tkey + r0, *si = sc->tidx + r0;
            for (int p = 0; p < np - 1; p++) {
                const int dp = 8 * pass[p];
                uint32_t o[256] = {0};
                for (size_t i = 0; i < rn; i++) o[sk[i] >> dp & 255]++;
                for (uint32_t q = 0, acc = 0; q < 256; q++) {
                    const uint32_t cq = o[q];
                    o[q] = acc;
                    acc += cq;
                }
                uint32_t *const dk = sk == sc->tkey + r0 ? key + r0 : sc->tkey + r0;
                uint32_t *const di = si == sc->tidx + r0 ? idx + r0 : sc->tidx + r0;
                for (size_t i = 0; i < rn; i++) {
                    const uint32_t k = sk[i], j = o[k >> dp & 255]++;
                    dk[j] = k;
                    di[j] = si[i];
                }
                sk = dk;
                si = di;
            }
            if (si != idx + r0) memcpy(idx + r0, si, rn * sizeof *si);
        }
    }
}

/* The first hits of sorted paths order[g0*16 .. g1*16) (of n), 16 at a time, shaded in that
 * order (neighbouring hits share triangle records and texels) and saved back as each path's next
 * ray. With `coherent`, a group whose rays leave one point is cast as a coherent packet: sorted by
 * direction, Embree's packet traversal runs 2-3x faster than single rays. A packet's answers may
 * depend on its other rays (ties, and the kernel that finishes a thinned packet), so the groups are
 * a function of the batch alone (its sorted paths, 16 at a time), whatever the thread count. */
static void first_hits(const tracer *T, path_state *ps, pgi__pdiff *pd, uint8_t *live, const uint32_t *order, size_t n,
                       size_t g0, size_t g1, int coherent, uint64_t *rays) {
    enum { AHEAD = 2 };     /* groups whose states are requested ahead (they lie anywhere in ps) */
    pgi__lambert_batch lbs; /* wave_shade's (zeroed once: its lanes are all defined) */
    memset(&lbs, 0, sizeof lbs);
    wave w;
    lane *const L = w.L;
    for (size_t g = g0; g < g1; g++) {
        /* the states of group g + AHEAD (and, at the start, of the groups before it) */
        for (size_t j = (g == g0 ? g : g + AHEAD) * WAVE; j < (g + AHEAD + 1) * WAVE && j < n; j++) {
            __builtin_prefetch(&ps[order[j]]);
            if (pd) __builtin_prefetch(&pd[order[j]]);
        }
        for (int k = 0; k < WAVE; k++) {
            const size_t j = g * WAVE + (size_t)k;
            L[k].path = j < n ? 0 : -1;
            if (j < n) state_load(&L[k], &ps[order[j]], pd ? &pd[order[j]] : NULL);
            else L[k].o = L[k].d = v3(0.f, 0.f, 1.f);
        }
        cast_wave(T, L, coherent, rays);
        wave_ready(T, &w);
        int ok = 1;
        wave_shade(T, L, w.sc, &lbs, &w.go, NULL, NULL, NULL, &ok);
        for (int k = 0; k < WAVE; k++) {
            const size_t j = g * WAVE + (size_t)k;
            if (j < n) {
                state_save(&L[k], &ps[order[j]], pd ? &pd[order[j]] : NULL);
                live[order[j]] = L[k].path >= 0;
            }
        }
    }
}

/* Traces paths [p0, p1) of the batch (one chunk; its first path `base`; mode: how each starts,
 * NULL: all here; ps, pd: the chunk's room_n states from start_paths and first_hits, live + t
 * live_stride for t < live_n: the threads' bytes of whether each goes on) two waves in turn, then
 * one (the tail);
 * their photons are appended to tb->rec, cnt[i - p0] gets path i's count. Returns 0 when out of
 * memory. */
static int trace_chunk(const tracer *T, uint64_t base, const uint8_t *mode, const path_state *ps, const pgi__pdiff *pd,
                       const uint8_t *live, size_t live_stride, int live_n, size_t p0, size_t p1, pgi__trace_tbuf *tb,
                       uint8_t *cnt, uint64_t *rays, uint32_t *gcnt, uint16_t *pbin) {
    const int n = (int)(p1 - p0);
    memset(cnt, 0, (size_t)n);
    pgi__lambert_batch lbs; /* wave_shade's (zeroed once: its lanes are all defined) */
    memset(&lbs, 0, sizeof lbs);
    /* The chunk's paths that go on, in path order, and their states in ps (START_STATE): the
     * refill below takes them without a test a path (whether a path ended at its first hit is
     * as random as a coin: a branch on it missed half the time). */
    uint16_t go_pi[CHUNK], go_j[CHUNK];
    int ngo = 0;
    for (int pi = 0, j = 0; pi < n; pi++) {
        const int m = !mode ? START_CHUNK : mode[p0 + (size_t)pi];
        const int st = m == START_STATE;
        go_pi[ngo] = (uint16_t)pi;
        go_j[ngo] = (uint16_t)j;
        int on = 0; /* the path goes on: in the byte of the thread that shaded its first hit */
        for (int t = 0; st && t < live_n; t++) on |= live[(size_t)t * live_stride + (size_t)j];
        ngo += st ? on != 0 : m == START_CHUNK;
        j += st;
    }
    /* Two waves in turn: a wave waits, its triangle records (requested as its hits came back)
     * and then its texels (requested just before the other wave's cast) on their way, while the
     * other wave's rays are in Embree; then it is shaded, its misses served during that cast
     * rather than stalling the shading. Once every path has started, the two merge into one
     * (the tail, below). */
    wave W[2];
    memset(W, 0, sizeof W); /* lanes without a path still go to Embree (masked): no garbage */
    int gi = 0, ok = 1, cast[2] = {0, 0}, cur = 0;
    for (int w = 0; w < 2; w++) {
        W[w].idle = (1u << WAVE) - 1;
        for (int k = 0; k < WAVE; k++) W[w].L[k].path = -1;
    }
    int ahead = 0; /* the go list's states requested so far */
    for (;; cur ^= 1) {
        wave *const C = &W[cur], *const O = &W[cur ^ 1];
        /* the texels of the wave cast last (its records arrived during the other's shading) */
        if (cast[cur]) wave_ready(T, C);
        /* The states the next waves start from: they lie in ps in path order, written by
         * first_hits in sorted order (a miss each, which the hardware prefetcher does not see
         * coming across the chunk's scattered writes). */
        if (ps)
            for (; ahead < gi + 2 * WAVE && ahead < ngo; ahead++) {
                __builtin_prefetch(&ps[go_j[ahead]]);
                if (pd) __builtin_prefetch(&pd[go_j[ahead]]);
            }
        /* Fill the other wave's idle lanes with the chunk's next paths, lowest lane first. */
        lane *const L = O->L;
        while (O->idle && gi < ngo) {
            const int k = __builtin_ctz(O->idle), pi = go_pi[gi];
            const size_t i = p0 + (size_t)pi, j = go_j[gi];
            gi++;
            if (mode && mode[i] == START_STATE) {
                state_load(&L[k], &ps[j], pd ? &pd[j] : NULL);
            } else {
                if (!start_path(T, base + i, &L[k], gcnt)) continue; /* it carries nothing */
                if (pbin) pbin[i] = (uint16_t)L[k].bin;
            }
            L[k].path = pi;
            O->idle &= O->idle - 1;
            O->active++;
        }
        if (gi >= ngo) break; /* every path started (the other wave may not be full): the tail */
        /* Cast the other (full) wave's rays as one 16-wide incoherent packet (single rays, 8-
         * and 16-wide packets and streams are within noise of each other for these rays:
         * photongi-bench --limits); the triangle records of all the hits are requested
         * together. */
        cast_wave(T, L, 0, rays);
        cast[cur ^ 1] = 1;
        if (cast[cur]) {
            wave_finish(T, C, &lbs, tb, cnt, gcnt, &ok);
            cast[cur] = 0;
            if (!ok) break;
        }
    }
    /* The tail: the wave cast last shaded, then one wave at a time (waves half empty cost Embree
     * more a ray), its idle lanes filled from the other's paths. */
    if (ok && cast[cur]) wave_finish(T, &W[cur], &lbs, tb, cnt, gcnt, &ok);
    uint32_t more = ~W[1].idle & ((1u << WAVE) - 1); /* the paths waiting in wave 1 */
    W[0].active += W[1].active;
    while (ok && W[0].active > 0) {
        for (; W[0].idle && more; W[0].idle &= W[0].idle - 1, more &= more - 1)
            W[0].L[__builtin_ctz(W[0].idle)] = W[1].L[__builtin_ctz(more)];
        cast_wave(T, W[0].L, 0, rays);
        wave_ready(T, &W[0]);
        wave_finish(T, &W[0], &lbs, tb, cnt, gcnt, &ok);
    }
#if defined(__SSE2__)
    _mm_sfence(); /* record's streaming stores, ordered before the gather reads them */
#endif
    return ok;
}

#ifndef PGI__TRACE_V3 /* defined once (the baseline's) */
void pgi__trace_scratch_free(pgi__trace_scratch *sc) {
    pgi__trace_tbuf *tb = sc->tbuf;
    for (int t = 0; t < sc->nthreads; t++) {
        free(tb[t].rec);
        free(tb[t].rec_fp);
        free(tb[t].rec_path);
    }
    void *const bufs[] = {sc->tbuf,  sc->counts, sc->chunks, sc->path_bin, sc->ph_bin, sc->ps,   sc->live,
                          sc->ps_pd, sc->mode,   sc->key,    sc->idx,      sc->tkey,   sc->tidx, sc->hist};
    for (size_t i = 0; i < sizeof bufs / sizeof *bufs; i++) free(bufs[i]);
    pgi__tri_cache_free(&sc->tc);
    memset(sc, 0, sizeof *sc);
}

size_t pgi__trace_scratch_bytes(const pgi__trace_scratch *sc) {
    size_t b = sc->cap * sizeof(uint8_t) + sc->cap / CHUNK * sizeof(chunk_info) +
               (size_t)sc->nthreads * sizeof *sc->tbuf + (sc->path_bin_cap + sc->ph_bin_cap) * sizeof(uint16_t) +
               sc->tc.bytes + sc->mode_cap + sc->ps_cap * (sizeof(path_state) + 4 * sizeof(uint32_t)) + sc->live_n +
               sc->pd_cap * sizeof(pgi__pdiff) + sc->hist_n * sizeof(uint32_t);
    for (int t = 0; t < sc->nthreads; t++) {
        const pgi__trace_tbuf *tb = &sc->tbuf[t];
        b += tb->rec_cap * (sizeof(stored_photon) + sizeof(uint16_t) + (tb->rec_fp ? sizeof(pgi__footprint) : 0));
    }
    return b;
}

#endif

/* Guided emission: a guide bin for each photon stored (a bin a path: scratch_reserve). */
static pgi_status guide_reserve(pgi__trace_scratch *sc, size_t photons) {
    if (photons > sc->ph_bin_cap) {
        uint16_t *b = realloc(sc->ph_bin, photons * sizeof *b);
        if (!b) return pgi__fail(PGI_ERR_OOM, "out of memory for %zu photons' emission bins", photons);
        sc->ph_bin = b;
        sc->ph_bin_cap = photons;
    }
    return PGI_OK;
}

/* Scratch for a batch of `paths` paths on `nt` threads (and their guide bins when `guided`, their
 * differentials when `diffs`). */
static pgi_status scratch_reserve(pgi__trace_scratch *sc, size_t paths, int nt, int guided, int diffs, size_t room) {
    if (sc->nthreads < nt) {
        pgi__trace_tbuf *tb = aligned_alloc(_Alignof(pgi__trace_tbuf), (size_t)nt * sizeof *tb);
        if (!tb) return pgi__fail(PGI_ERR_OOM, "out of memory for %d photon-tracing threads", nt);
        if (sc->nthreads) memcpy(tb, sc->tbuf, (size_t)sc->nthreads * sizeof *tb);
        free(sc->tbuf);
        memset(tb + sc->nthreads, 0, (size_t)(nt - sc->nthreads) * sizeof *tb);
        sc->tbuf = tb;
        sc->nthreads = nt;
    }
    if (paths > sc->cap) {
        size_t nch = (paths + CHUNK - 1) / CHUNK;
        uint8_t *c = realloc(sc->counts, nch * CHUNK);
        if (c) sc->counts = c;
        chunk_info *ci = realloc(sc->chunks, nch * sizeof *ci);
        if (ci) sc->chunks = ci;
        if (!c || !ci) return pgi__fail(PGI_ERR_OOM, "out of memory tracing photons (%zu paths a batch)", paths);
        sc->cap = nch * CHUNK;
    }
    if (guided && sc->path_bin_cap < sc->cap) {
        uint16_t *pb = realloc(sc->path_bin, sc->cap * sizeof *pb);
        if (!pb) return pgi__fail(PGI_ERR_OOM, "out of memory tracing photons (%zu paths a batch)", paths);
        sc->path_bin = pb;
        sc->path_bin_cap = sc->cap;
    }
    if (!room) return PGI_OK;
    /* the emission pre-pass: a start mode a path, `room` states a chunk */
    const size_t states = (paths + CHUNK - 1) / CHUNK * room;
    const size_t hist_n = (size_t)(nt + 1) * 1024; /* the sort's counts, each thread's and theirs (sort_paths) */
    if (sc->hist_n < hist_n) {
        free(sc->hist);
        sc->hist = malloc(hist_n * sizeof *sc->hist);
        sc->hist_n = sc->hist ? hist_n : 0;
        if (!sc->hist) return pgi__fail(PGI_ERR_OOM, "%s", "out of memory for the emission sort");
    }
    if (paths > sc->mode_cap) {
        free(sc->mode);
        sc->mode = malloc(paths);
        sc->mode_cap = sc->mode ? paths : 0;
        if (!sc->mode) return pgi__fail(PGI_ERR_OOM, "out of memory tracing photons (%zu paths a batch)", paths);
    }
    if (states > sc->ps_cap) {
        free(sc->ps);
        free(sc->key);
        free(sc->idx);
        free(sc->tkey);
        free(sc->tidx);
        sc->ps = aligned_alloc(64, states * sizeof *sc->ps);
        sc->key = malloc(states * sizeof *sc->key);
        sc->idx = malloc(states * sizeof *sc->idx);
        sc->tkey = malloc(states * sizeof *sc->tkey);
        sc->tidx = malloc(states * sizeof *sc->tidx);
        sc->ps_cap = sc->ps && sc->key && sc->idx && sc->tkey && sc->tidx ? states : 0;
        if (!sc->ps_cap) return pgi__fail(PGI_ERR_OOM, "out of memory tracing photons (%zu paths a batch)", paths);
    }
    if (states * (size_t)nt > sc->live_n) {
        free(sc->live);
        sc->live = malloc(states * (size_t)nt);
        sc->live_n = sc->live ? states * (size_t)nt : 0;
        if (!sc->live) return pgi__fail(PGI_ERR_OOM, "out of memory tracing photons (%zu paths a batch)", paths);
    }
    if (diffs && states > sc->pd_cap) {
        free(sc->ps_pd);
        sc->ps_pd = malloc(states * sizeof *sc->ps_pd);
        sc->pd_cap = sc->ps_pd ? states : 0;
        if (!sc->ps_pd) return pgi__fail(PGI_ERR_OOM, "out of memory tracing photons (%zu paths a batch)", paths);
    }
    return PGI_OK;
}

/* The lights, then the sky (if any) as entry nl - 1: `cdf` (nl floats) by luminance of power
 * (through the portals for the sun and the sky with portal emission), and the room a chunk for
 * the states of paths from point and spot lights (start_paths). 0 in *total: no light. */
static void light_table(const pgi_scene *s, const pgi__trace_desc *d, const pgi__portal_emit *pe, float *cdf, size_t nl,
                        double *total_out, size_t *room_out) {
    double total = 0.0;
    for (size_t i = 0; i < nl; i++) {
        const pgi__light *L = i < s->nlights ? &s->lights[i] : &s->env->light;
        total += pgi__light_pick_power(s, L, d->portals ? pe : NULL);
        cdf[i] = (float)total;
    }
    *total_out = total;
    *room_out = 0;
    if (!(total > 0.0)) return;
    /* The share of the power that leaves point and spot lights sizes the room for their paths'
     * states a chunk (start_paths): the expected count and 4 sigma; the chunk's paths past it
     * start in the chunk. */
    double point_power = 0.0;
    for (size_t i = 0; i < s->nlights; i++)
        if (pgi__light_from_point(&s->lights[i])) point_power += fmax(0.0, (double)v3_lum(v3_load(s->lights[i].power)));
    const double share = point_power / total;
    size_t room = share <= 0.0 ? 0 : (size_t)ceil(share * CHUNK + 4.0 * sqrt(share * (1.0 - share) * CHUNK) + 16.0);
    if (room > CHUNK) room = CHUNK;
    if (pgi__trace_room_cap > 0 && room > (size_t)pgi__trace_room_cap) room = (size_t)pgi__trace_room_cap;
    for (size_t i = 0; i < nl; i++) cdf[i] = (float)(cdf[i] / total);
    cdf[nl - 1] = 1.f;
    *room_out = room;
}

/* The paths of the next batch, from the yield seen so far (seen_paths, seen_photons) and the
 * photons still missing in this phase (`remaining`); at most `left` paths. */
static size_t batch_paths(double seen_paths, double seen_photons, size_t remaining, size_t room, uint64_t left) {
    size_t batch;
    if (seen_photons < 64.0) {
        batch = remaining / 4 + 64; /* no estimate yet: a pilot batch */
        if (batch > 4 * CHUNK) batch = 4 * CHUNK;
        /* ... as many paths as all the pilots before it: a scene that stores (almost) nothing
         * reaches max_paths in a few dozen batches, not in a million-path crawl of 64 at a time */
        if ((double)batch < seen_paths) batch = (size_t)seen_paths;
    } else {
        /* The bulk of a phase: an upper bound of the yield (1 sigma of the photon count seen)
         * sizes the batch from below, as a rule (paths traced for nothing cost more than
         * the smaller batch that then ends the phase). A batch that ends the phase after
         * its bulk (fewer photons missing than seen so far) takes a lower bound, 3 sigma of
         * the count seen and 4 of the batch's own (a path stores 0 to `bounces` photons:
         * a Poisson count's, with room), and so ends it, where its paths too many would be
         * at most 1 % of those seen: they cost less than a further batch (Sibenik's frames
         * took five batches, with 3 sigma from above throughout: the last two of 131 and 64
         * paths). */
        const double y = seen_photons / seen_paths, rem = (double)remaining;
        batch = (size_t)(rem / (y * (1.0 + 1.0 / sqrt(seen_photons)))) + 1;
        if (rem < seen_photons) {
            const double lo = fmax(1.0 - 3.0 / sqrt(seen_photons) - 4.0 / sqrt(rem), 0.5);
            if (rem / (y * lo) - rem / y <= 0.01 * seen_paths) batch = (size_t)(rem / (y * lo)) + 1;
        }
    }
    if (batch < 64) batch = 64;
    if (batch > (1u << 20)) batch = 1u << 20;
    if (room && batch > PREPASS_BATCH) batch = PREPASS_BATCH;
    if (batch > left) batch = (size_t)left;
    return batch;
}

/* Traces a batch of `batch` paths from path index `path` into the threads' buffers (sc->tbuf,
 * sc->chunks, sc->counts): the paths from point and spot lights start first (up to `room` a
 * chunk), sorted by where they go, and meet their first hits in that order (first_hits); then
 * each chunk traces its paths on from there, and starts the others. 0 when a thread ran out of
 * memory for its photons. */
static int trace_batch(const tracer *T, pgi__trace_scratch *sc, uint64_t path, size_t batch, int nt, size_t room,
                       uint64_t *rays_out) {
    const long long nch = (long long)((batch + CHUNK - 1) / CHUNK);
    for (int t = 0; t < nt; t++) sc->tbuf[t].nrec = 0;
    uint64_t batch_rays = 0;
    int failed = 0;
    path_state *ps = sc->ps;
    pgi__pdiff *pd = T->fp_track ? sc->ps_pd : NULL;
    if (room) {
        /* nt parts of consecutive chunks, each with its own counts of the keys' bytes: the
           sort's first pass places each part's keys in parallel (sort_paths) */
        memset(sc->hist, 0, (size_t)(nt + 1) * 1024 * sizeof *sc->hist);
#pragma omp parallel for schedule(static, 1) num_threads(nt)
        for (int q = 0; q < nt; q++) {
            uint32_t *gc = T->G ? T->G->tcount + (size_t)omp_get_thread_num() * 3 * (size_t)T->G->nbins : NULL;
            for (long long c = part_first(nch, nt, q); c < part_first(nch, nt, q + 1); c++) {
                const size_t p0 = (size_t)c * CHUNK, p1 = p0 + CHUNK < batch ? p0 + CHUNK : batch;
                sc->chunks[c].keyed =
                    start_paths(T, path, p0, p1, (size_t)c * room, room, ps, pd, sc->mode, sc->key, sc->idx, gc,
                                T->G ? sc->path_bin : NULL, sc->hist + (size_t)(q + 1) * 1024);
            }
        }
    }
    size_t keyed = 0; /* each chunk's keyed paths, together */
    for (long long c = 0; room && c < nch; c++) {
        sc->chunks[c].kofs = keyed;
        keyed += sc->chunks[c].keyed;
    }
    if (keyed) sort_paths(sc, nch, room, keyed, nt);
    const long long ngroups = (long long)((keyed + WAVE - 1) / WAVE), nblocks = (ngroups + 15) / 16;
    /* each thread's byte a state slot (first_hits: whether the path goes on), zero where
       another thread shades the path: one array written by all, at random places, had the
       threads take its lines from each other's caches (first_hits took 13 % longer a thread
       at two threads than at one) */
    const size_t slots = (size_t)nch * room;
    if (keyed) memset(sc->live, 0, slots * (size_t)nt);
#pragma omp parallel for schedule(dynamic, 1) reduction(+ : batch_rays) num_threads(nt)
    for (long long bk = 0; bk < nblocks; bk++) {
        uint64_t r = 0;
        const size_t g0 = (size_t)bk * 16, g1 = g0 + 16 < (size_t)ngroups ? g0 + 16 : (size_t)ngroups;
        first_hits(T, ps, pd, sc->live + (size_t)omp_get_thread_num() * slots, sc->idx, keyed, g0, g1,
                   keyed >= COHERENT_MIN, &r);
        batch_rays += r;
    }
#pragma omp parallel for schedule(dynamic, 1) reduction(+ : batch_rays) num_threads(nt)
    for (long long c = 0; c < nch; c++) {
        int tid = omp_get_thread_num();
        pgi__trace_tbuf *tb = &sc->tbuf[tid];
        const size_t p0 = (size_t)c * CHUNK, p1 = p0 + CHUNK < batch ? p0 + CHUNK : batch;
        chunk_info *ci = &sc->chunks[c];
        ci->tid = tid;
        ci->off = tb->nrec;
        uint64_t r = 0;
        int ok = 0;
        int f;
#pragma omp atomic read
        f = failed;
        uint32_t *gc = T->G ? T->G->tcount + (size_t)tid * 3 * (size_t)T->G->nbins : NULL;
        if (!f)
            ok = trace_chunk(T, path, room ? sc->mode : NULL, room ? ps + (size_t)c * room : NULL,
                             pd && room ? pd + (size_t)c * room : NULL, room ? sc->live + (size_t)c * room : NULL,
                             slots, nt, p0, p1, tb, sc->counts + (size_t)c * CHUNK, &r, gc, T->G ? sc->path_bin : NULL);
        if (!ok) {
#pragma omp atomic write
            failed = 1;
        }
        ci->total = ci->count = ok ? tb->nrec - ci->off : 0;
        batch_rays += r;
    }
    *rays_out = batch_rays;
    return !failed;
}

/* The chunks whose photons the buffer takes: whole chunks while they fit, the last one cut after
 * the path that fills it (its count lowered; with `whole`, the filling path kept whole when the
 * buffer's `cap` photons allow). Adds their photons to *produced and their paths to *used_paths; returns
 * how many chunks. */
static long long take_chunks(pgi__trace_scratch *sc, long long nch, size_t batch, size_t count, size_t goal, int whole,
                             size_t cap, size_t *produced_out, size_t *used_out) {
    size_t produced = 0, used_paths = 0;
    long long c = 0;
    for (; c < nch && count + produced < goal; c++) {
        chunk_info *ci = &sc->chunks[c];
        size_t np = (size_t)((c + 1) * CHUNK <= (long long)batch ? CHUNK : batch - (size_t)c * CHUNK);
        if (count + produced + ci->count < goal) { /* an exact fill is cut after its filling path */
            produced += ci->count;
            used_paths += np;
            continue;
        }
        size_t take = 0, i = 0;
        const uint8_t *cn = sc->counts + (size_t)c * CHUNK;
        while (count + produced + take < goal) take += cn[i++];
        /* The pilot keeps its filling path whole (room allowing): where it then keeps uniform
           emission, its photons are the first paths' all, as uniform emission's frame has them */
        ci->count = whole && count + produced + take <= cap ? take : goal - count - produced;
        produced += ci->count;
        used_paths += i;
        c++;
        break;
    }
    *produced_out = produced;
    *used_out = used_paths;
    return c;
}

/* Copies the photons of the first `used_chunks` chunks into ph after its `ph->count`, in path
 * order, with their guide bins and footprints (and the footprint histogram). */
static pgi_status gather_photons(const tracer *T, pgi__trace_scratch *sc, const pgi__trace_desc *d, pgi_photons *ph,
                                 long long used_chunks, size_t batch, int nt) {
    const float bin_w = d->r_max / 14.f;
    size_t *dst = malloc((size_t)(used_chunks ? used_chunks : 1) * sizeof *dst);
    if (!dst) { return pgi__fail(PGI_ERR_OOM, "out of memory gathering photons"); }
    size_t acc = ph->count;
    for (long long k = 0; k < used_chunks; k++) {
        dst[k] = acc;
        acc += sc->chunks[k].count;
    }
#pragma omp parallel for schedule(dynamic, 4) num_threads(nt)
    for (long long k = 0; k < used_chunks; k++) {
        const chunk_info *ci = &sc->chunks[k];
        const pgi__trace_tbuf *tb = &sc->tbuf[ci->tid];
        const uint8_t *cn = sc->counts + (size_t)k * CHUNK;
        if (T->G) { /* each photon's bin, from its path's */
            size_t q = 0;
            for (int i = 0; q < ci->count; i++)
                for (int m = 0; m < cn[i] && q < ci->count; m++) sc->ph_bin[dst[k] + q++] = sc->path_bin[k * CHUNK + i];
        }
        /* The chunk's photons into path order as they are copied: a path's photons were
         * recorded in its bounce order, so each goes to its path's start plus the ones
         * before it; those past the count taken (the cut chunk) stay out. */
        const size_t np = (size_t)((k + 1) * CHUNK <= (long long)batch ? CHUNK : batch - (size_t)k * CHUNK);
        uint32_t start[CHUNK];
        uint32_t first = 0;
        for (size_t i = 0; i < np; i++) {
            start[i] = first;
            first += cn[i];
        }
        uint64_t hist[PGI_FOOTPRINT_BINS] = {0};
        for (size_t q = 0; q < ci->total; q++) {
            const size_t r = ci->off + q;
            const uint32_t pos = start[tb->rec_path[r]]++;
            if (pos >= ci->count) continue;
            const stored_photon *sp = &tb->rec[r];
            const size_t j = dst[k] + pos;
            ph->px[j] = sp->p[0];
            ph->py[j] = sp->p[1];
            ph->pz[j] = sp->p[2];
            ph->dx[j] = sp->d[0];
            ph->dy[j] = sp->d[1];
            ph->dz[j] = sp->d[2];
            ph->fr[j] = sp->f[0];
            ph->fg[j] = sp->f[1];
            ph->fb[j] = sp->f[2];
            ph->nx[j] = sp->n[0];
            ph->ny[j] = sp->n[1];
            ph->nz[j] = sp->n[2];
            if (T->fp_on) {
                const pgi__footprint *fp = &tb->rec_fp[r];
                ph->radius[j] = fp->r;
                if (ph->sax) {
                    ph->sax[j] = fp->a[0];
                    ph->say[j] = fp->a[1];
                    ph->saz[j] = fp->a[2];
                    ph->sbx[j] = fp->b[0];
                    ph->sby[j] = fp->b[1];
                    ph->sbz[j] = fp->b[2];
                }
                if (d->footprint_hist) {
                    float qb = fp->r_raw / bin_w;
                    int bin = qb < (float)(PGI_FOOTPRINT_BINS - 1) ? (int)qb : PGI_FOOTPRINT_BINS - 1;
                    hist[bin < 0 ? 0 : bin]++;
                }
            }
        }
        if (T->fp_on && d->footprint_hist)
            for (int i = 0; i < PGI_FOOTPRINT_BINS; i++)
                if (hist[i]) {
#pragma omp atomic
                    d->footprint_hist[i] += hist[i];
                }
    }
    free(dst);
    return PGI_OK;
}

/* The photons' flux over the paths traced (ph->emitted): with steered paths (after a guide's
 * pilot), weighted by V_b / q_b of their bins (guide.h). */
static void scale_flux(pgi_photons *ph, const pgi__trace_scratch *sc, const pgi__guide *g, uint64_t path, int steered,
                       int nt) {
    if (steered && path > 0) {
        /* steered paths: weight V_b / q_b (guide.h), over the paths */
        float w[PGI__GUIDE_GROUPS * PGI__GUIDE_RES * PGI__GUIDE_RES];
        for (int b = 0; b < g->nbins; b++)
            w[b] = g->q[b] > 0 ? (float)(pgi__guide_volume(g, b) / g->q[b] / (double)path) : 0.f;
#pragma omp parallel for schedule(static) num_threads(nt) if (ph->count >= 65536)
        for (size_t j = 0; j < ph->count; j++) {
            const float f = w[sc->ph_bin[j]];
            ph->fr[j] *= f;
            ph->fg[j] *= f;
            ph->fb[j] *= f;
        }
        return;
    }
    if (path > 0) {
        const float inv = (float)(1.0 / (double)path);
#pragma omp parallel for schedule(static) num_threads(nt) if (ph->count >= 65536)
        for (size_t j = 0; j < ph->count; j++) {
            ph->fr[j] *= inv;
            ph->fg[j] *= inv;
            ph->fb[j] *= inv;
        }
    }
}

/* The tracer of a frame: its scene, rays, light table (cdf, nl entries), triangle records, guide,
 * radius policy and portal emission (pe: NULL, or the sky's table). */
static pgi_status tracer_init(tracer *T, const pgi_scene *s, const pgi__rt *rt, const pgi__trace_desc *d,
                              const pgi_photons *ph, pgi__trace_scratch *sc, const float *cdf, size_t nl,
                              const pgi__portal_emit *pe, int nt) {
    *T = (tracer){.s = s,
                  .rt = rt,
                  .cdf = cdf,
                  .nl = nl,
                  .bounces = d->bounces,
                  .seed_mix = pgi__rng_seed_mix(d->seed),
                  .eps = pgi__scene_epsilon(s),
                  .centre = v3_scale(v3_add(v3_load(s->bmin), v3_load(s->bmax)), 0.5f),
                  .radius = 0.5f * pgi__scene_diagonal(s),
                  .near = d->near,
                  .PE = pe};
    T->E = (pgi__emit_frame){s, T->centre, T->radius, T->eps, pe};
    pgi_status ts = pgi__tri_cache_update(&sc->tc, s, nt);
    if (ts) return ts;
    T->tris = sc->tc.tris;
    T->tri_uv = sc->tc.tri_uv;
    T->fast_sincos = pgi__trace_sincos_fast();
    if (d->guide) {
        if (!d->vgrid) return pgi__fail(PGI_ERR_INVALID_ARG, "%s", "guided emission needs the view grid");
        if ((ts = pgi__guide_init(d->guide, cdf, nl, nt, d->guide_keep))) return ts;
        T->G = d->guide;
        T->vg = d->vgrid;
    }
    pgi__fp_params_init(&T->fp, d->radius_policy, d->r_min, d->r_max, d->smoothing, d->photons, 2.f * T->radius);
    T->fp_track = d->radius_policy != PGI_RADIUS_FIXED;
    T->lambert_simd = T->fast_sincos && !T->fp_track; /* AVX2 (and FMA), not narrow; no radius policy */
    /* A path through a portal nearly always hits the inside, and its first hit stores nothing (the
     * direct pass lights it): a roulette there ended four in five of Sponza's paths for nothing. */
    T->keep_first = pe != NULL && !T->fp_track;
    T->fp_on = T->fp_track && ph->radius;
    return PGI_OK;
}

static pgi_status trace_photons(const pgi_scene *s, const pgi__rt *rt, const pgi__trace_desc *d, pgi_photons *ph,
                                pgi__trace_scratch *sc, uint64_t *rays_out) {
    ph->count = 0;
    ph->emitted = 0;
    *rays_out = 0;
    sc->paths_traced = 0;
    if (d->photons > ph->capacity)
        return pgi__fail(PGI_ERR_INVALID_ARG, "photon buffer holds %zu photons, %u requested", ph->capacity,
                         d->photons);
    if (d->bounces < 1) return PGI_OK;
    if (d->bounces > 255) return pgi__fail(PGI_ERR_INVALID_ARG, "photon bounces %d exceed 255", d->bounces);
    /* The lights, then the sky (if any) as entry nlights. */
    const size_t nl = s->nlights + (s->env ? 1 : 0);
    float *cdf = malloc((nl ? nl : 1) * sizeof *cdf);
    if (!cdf) return pgi__fail(PGI_ERR_OOM, "out of memory for the light table");
    pgi__portal_emit pe = {0};
    if (d->portals) {
        if (d->guide) {
            free(cdf);
            return pgi__fail(PGI_ERR_INVALID_ARG, "%s", "portal emission is not combined with guided emission");
        }
        pgi_status ps = pgi__portal_emit_init(&pe, s);
        if (ps) {
            free(cdf);
            return ps;
        }
    }
    double total;
    size_t room;
    light_table(s, d, &pe, cdf, nl, &total, &room);
    if (!(total > 0.0)) {
        free(cdf);
        pgi__portal_emit_free(&pe);
        return PGI_OK; /* no light: no photons; the image is black but valid */
    }

    tracer T;
    const int nt = pgi__threads(d->threads);
    pgi_status ts = tracer_init(&T, s, rt, d, ph, sc, cdf, nl, d->portals ? &pe : NULL, nt);
    if (ts) {
        free(cdf);
        pgi__portal_emit_free(&pe);
        return ts;
    }
    uint64_t path = 0, traced = 0, rays = 0;
    const uint64_t max_paths = 64ull * d->photons + (1u << 20);
    const size_t want = d->photons;
    /* Photons per path, observed: the last frame's counts seed this frame's, so that each
     * batch traces about the paths still needed and few are thrown away. Not with guided
     * emission: its pilot ends with a whole batch, so the batches' sizes decide the guide, and a
     * frame must not depend on the frames rendered before it (progressive frames dealt to MPI
     * ranks, test_mpi). Nor with point or spot lights: their paths' first hits come from packets
     * formed within a batch (first_hits), so there too the batches must follow from the request
     * alone (a pilot batch a frame instead). */
    const int fresh = d->guide || room > 0;
    double seen_paths = fresh ? 0.0 : sc->prior_paths, seen_photons = fresh ? 0.0 : sc->prior_photons;
    double frame_paths = 0, frame_photons = 0;
    uint64_t pilot_paths = 0; /* guided emission: paths of the uniform pilot, dropped */
    int guide_done = 0;       /* the pilot has decided */
    int steered = 0;          /* the photons kept come from paths steered by the guide */
    /* the evidence's photons (stored, in view) that are not this frame's kept ones */
    double pilot_stored = 0, pilot_useful = 0, carried_stored = 0, carried_useful = 0;
    if (d->guide && d->guide->carried) {
        /* earlier frames' evidence (guide_keep): no pilot; q from that evidence alone, which this
           frame's random numbers did not build, so its weights V/q keep the estimate unbiased */
        pgi__guide_totals(d->guide, &carried_stored, &carried_useful);
        pilot_stored = carried_stored;
        pilot_useful = carried_useful;
        pgi__guide_update(d->guide, d->min_gain);
        guide_done = 1;
        steered = d->guide->on; /* else uniform, the paths still counted as evidence */
    }
    pgi_status st = PGI_OK;
    if (d->guide && (st = guide_reserve(sc, want))) {
        free(cdf);
        return st;
    }
    /* guided emission: the uniform pilot stores about an eighth of the photons */
    const size_t pilot_want = want / 8 + 1 < want ? want / 8 + 1 : want;
    while (ph->count < want && path < max_paths) {
        if (d->progress) d->progress(d->progress_ctx, ph->count, want);
        if (pgi__cancelled(d->cancel)) {
            st = pgi__fail_cancelled("trace");
            break;
        }
        const size_t goal = d->guide && !guide_done ? pilot_want : want; /* this phase's photons */
        const size_t remaining = goal - ph->count;
        const size_t batch = batch_paths(seen_paths, seen_photons, remaining, room, max_paths - path);
        if ((st = scratch_reserve(sc, batch, nt, T.G != NULL, T.fp_track, room))) break;
        const long long nch = (long long)((batch + CHUNK - 1) / CHUNK);
        uint64_t batch_rays = 0;
        const int ok = trace_batch(&T, sc, path, batch, nt, room, &batch_rays);
        rays += batch_rays;
        traced += batch;
        if (!ok) {
            st = pgi__fail(PGI_ERR_OOM, "out of memory storing traced photons");
            break;
        }
        /* Take whole chunks while they fit; cut the last one after the path that fills the buffer. */
        size_t produced = 0, used_paths = 0;
        const long long used_chunks =
            take_chunks(sc, nch, batch, ph->count, goal, d->guide && !guide_done, want, &produced, &used_paths);
        if ((st = gather_photons(&T, sc, d, ph, used_chunks, batch, nt))) break;
        /* The batch's full yield (all its paths and photons) informs the next batch. */
        size_t batch_photons = 0;
        for (size_t i = 0; i < batch; i++) batch_photons += sc->counts[i];
        seen_paths += (double)batch;
        seen_photons += (double)batch_photons;
        frame_paths += (double)batch;
        frame_photons += (double)batch_photons;
        ph->count += produced;
        const uint64_t batch_end = path + batch; /* every path index this batch traced */
        path += used_paths;
        if (d->guide) {
            pgi__guide_collect(d->guide);
            if (!guide_done && (ph->count >= goal || path >= max_paths)) { /* the pilot decides, once */
                guide_done = 1;
                pgi__guide_totals(d->guide, &pilot_stored, &pilot_useful);
                pgi__guide_update(d->guide, d->min_gain);
                if (d->guide->on) {
                    steered = 1;
                    /* The pilot's photons go: weighted by a q built from themselves they would
                       be biased (a lucky bin lowers its own weight), and with their uniform
                       weight they would stand out as bright disks among the steered ones. The
                       steered paths start after every index the pilot traced (none reuses a
                       pilot path's random numbers, which built q). */
                    ph->count = 0;
                    path = pilot_paths = batch_end;
                    if (d->footprint_hist) memset(d->footprint_hist, 0, PGI_FOOTPRINT_BINS * sizeof *d->footprint_hist);
                    /* steering changes the yield: size the next batch by the guide's prediction */
                    seen_paths = 1024.0;
                    seen_photons = 1024.0 * d->guide->yield;
                } else {
                    /* uniform after all: the pilot's photons stay */
                    pilot_stored = carried_stored;
                    pilot_useful = carried_useful;
                    if (!d->guide_keep) T.G = NULL; /* and the paths after it count nothing (in_view: the pilot's) */
                }
            }
        }
    }
    free(cdf);
    pgi__portal_emit_free(&pe);
    *rays_out = rays;
    sc->paths_traced = traced;
    if (st) return st;
    if (d->progress) d->progress(d->progress_ctx, ph->count, want);
    /* This frame's counts seed the next frame's batches (a moved light changes the yield: a
     * frame's worth of evidence is enough to forget the older ones). */
    sc->prior_paths = frame_paths;
    sc->prior_photons = frame_photons;
    sc->paths_pilot = pilot_paths;
    sc->culled = 0;
    for (int t = 0; t < sc->nthreads; t++) {
        sc->culled += sc->tbuf[t].culled;
        sc->tbuf[t].culled = 0;
    }
    if (d->guide) {
        double S, U;
        pgi__guide_totals(d->guide, &S, &U);
        d->guide->in_view = S > pilot_stored ? (U - pilot_useful) / (S - pilot_stored) : 0.0;
    }
    path -= pilot_paths;
    ph->emitted = path;
    scale_flux(ph, sc, d->guide, path, steered, nt);
    return PGI_OK;
}

#if defined(PGI__TRACE_V3) /* the wider builds' entries (trace_v3.c, trace_v4.c) */
#ifdef PGI__TRACE_V4
#define PGI__TRACE_ENTRY pgi__photons_trace_v4
#else
#define PGI__TRACE_ENTRY pgi__photons_trace_v3
#endif
pgi_status PGI__TRACE_ENTRY(const pgi_scene *s, const pgi__rt *rt, const pgi__trace_desc *d, pgi_photons *ph,
                            pgi__trace_scratch *sc, uint64_t *rays_out) {
    return trace_photons(s, rt, d, ph, sc, rays_out);
}
#else
pgi_status pgi__photons_trace(const pgi_scene *s, const pgi__rt *rt, const pgi__trace_desc *d, pgi_photons *ph,
                              pgi__trace_scratch *sc, uint64_t *rays_out) {
#if PGI__AVX2_TARGET
    if (pgi__trace_v4_ok()) return pgi__photons_trace_v4(s, rt, d, ph, sc, rays_out);
    if (pgi__trace_v3_ok()) return pgi__photons_trace_v3(s, rt, d, ph, sc, rays_out);
#endif
    return trace_photons(s, rt, d, ph, sc, rays_out);
}
#endif
