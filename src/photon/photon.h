/* Photon tracing (docs/design.md, "One frame"). */
#ifndef PGI__PHOTON_H
#define PGI__PHOTON_H

#include "rt/rt.h"
#include "scene/bsdf.h"

/* A triangle as the tracers shade it, one cache line: its unit geometric normal, material and
 * vertex normals (what pgi__scene_surface_untextured reads, less the positions); the texture
 * coordinates are in a second array, 8 floats a triangle (u0 v0 u1 v1 u2 v2, 2 unused). A hit
 * then needs one line (two when textured) instead of the triangle's indices and material
 * and its vertices' positions, normals and coordinates: 9 scattered lines after a dependent
 * one. */
typedef struct pgi__trace_tri {
    float ng[3];
    uint32_t mat;
    float n[9];
    float pad[3];
} pgi__trace_tri;
_Static_assert(sizeof(pgi__trace_tri) == 64, "a triangle record is one cache line");
#define PGI__TRI_UV 8

/* pgi__scene_surface_untextured from a triangle record, less the texture coordinates (the texels
 * are found before shading): the same operations on the same values, so the same bits. In two
 * halves for a path tracer: the geometry (p, ng, mat: all that a path's last vertex needs),
 * then the shading (ns, kd). */
static inline void pgi__trace_tri_geometry(const pgi_scene *s, const pgi__trace_tri *r, pgi__v3 p, pgi__surface *o) {
    o->p = p;
    o->ng = v3_load(r->ng);
    o->mat = &s->mats[r->mat];
}

/* The shading normal of r at barycentrics (bu, bv): its vertex normals interpolated, turned to
 * the side of the geometric normal g (g itself without vertex normals or where they cancel). */
static inline pgi__v3 pgi__trace_tri_ns(const pgi_scene *s, const pgi__trace_tri *r, float bu, float bv, pgi__v3 g) {
    if (!s->nrm) return g;
    float bw = 1.f - bu - bv;
    pgi__v3 n =
        v3_add(v3_add(v3_scale(v3_load(r->n), bw), v3_scale(v3_load(r->n + 3), bu)), v3_scale(v3_load(r->n + 6), bv));
    float l = v3_len(n);
    if (!(l > 0.f && isfinite(l))) return g;
    n = v3_scale(n, 1.f / l);
    return v3_dot(n, g) < 0.f ? v3_neg(n) : n;
}
/* (r is triangle prim's record: the vertex colours, where the scene has them, are read from the
 * scene's arrays.) */
static inline void pgi__trace_tri_shading(const pgi_scene *s, const pgi__trace_tri *r, uint32_t prim, float bu,
                                          float bv, pgi__surface *o) {
    o->ns = pgi__trace_tri_ns(s, r, bu, bv, o->ng);
    o->u = o->v = 0.f;
    o->kd = pgi__scene_kd(s, o->mat, prim, bu, bv);
}

static inline void pgi__trace_tri_surface(const pgi_scene *s, const pgi__trace_tri *r, uint32_t prim, float bu,
                                          float bv, pgi__v3 p, pgi__surface *o) {
    pgi__trace_tri_geometry(s, r, p, o);
    pgi__trace_tri_shading(s, r, prim, bu, bv, o);
}

/* The texture level of detail of a triangle with corners a, b, c and texture coordinates
 * q[0..5] (Ray Tracing Gems ch. 20, eq. 34's Delta): 0.5 log2(texture-space area / world-space
 * area), in uv units (a texture's 0.5 log2(w h) is added at the lookup: pgi__texture_cone_lod).
 * In double, once a triangle; -inf for a degenerate mapping (level 0), +inf for a degenerate
 * triangle (the coarsest level). Kept in the triangle's PGI__TRI_UV record, q[6]. */
static inline float pgi__tri_uv_lod(pgi__v3 a, pgi__v3 b, pgi__v3 c, const float *q) {
    const double e1[3] = {(double)b.x - a.x, (double)b.y - a.y, (double)b.z - a.z};
    const double e2[3] = {(double)c.x - a.x, (double)c.y - a.y, (double)c.z - a.z};
    const double cx = e1[1] * e2[2] - e1[2] * e2[1], cy = e1[2] * e2[0] - e1[0] * e2[2],
                 cz = e1[0] * e2[1] - e1[1] * e2[0];
    const double pa = sqrt(cx * cx + cy * cy + cz * cz);
    const double ta =
        fabs(((double)q[2] - q[0]) * ((double)q[5] - q[1]) - ((double)q[4] - q[0]) * ((double)q[3] - q[1]));
    if (!(ta > 0.0)) return -INFINITY;
    if (!(pa > 0.0)) return INFINITY;
    return (float)(0.5 * log2(ta / pa));
}

/* pgi__scene_uv from a triangle's PGI__TRI_UV coordinates `q`: the same operations. */
static inline void pgi__trace_tri_uv(const float *q, float bu, float bv, float *u, float *v) {
    float bw = 1.f - bu - bv;
    *u = bw * q[0] + bu * q[2] + bv * q[4];
    *v = bw * q[1] + bu * q[3] + bv * q[5];
}

typedef struct pgi__trace_desc {
    uint32_t photons; /* photons to store */
    int bounces;      /* maximum scattering events of a path */
    uint64_t seed;
    int threads; /* 0 = OpenMP's default */
    /* radius policies (radius.h): per-photon footprints go to ph->radius (and the ellipsoid
       axes ph->sax.. for differentials) when those arrays are set */
    int radius_policy;
    float r_min, r_max, smoothing;
    uint64_t *footprint_hist; /* optional out: PGI_FOOTPRINT_BINS counts of the radius before the clamp */
    /* optional: called with the photons stored so far and the photons wanted, before the first
       batch and after each one, on the calling thread (outside the parallel regions) */
    void (*progress)(void *ctx, uint64_t stored, uint64_t wanted);
    void *progress_ctx;
    const pgi_cancel *cancel; /* may be NULL: once requested, the tracer stops after the batch in flight
                                 (PGI_ERR_CANCELLED) */
    /* view-importance emission (guide.h): NULL = uniform. A uniform pilot batch, then batches
       steered by the guide whenever it predicts at least `min_gain` times the photons in view */
    struct pgi__guide *guide;
    const struct pgi__view_grid *vgrid;
    const struct pgi__view_grid *near; /* non-NULL: store only photons in its cells (PGI_STORE_VIEW) */
    double min_gain;
    /* 1: the guide's evidence of the frames before this one is kept (the same light layout), and
       when it holds any the frame runs no pilot: it steers from its first path where that
       evidence predicts min_gain, else traces uniformly, and adds its paths' counts to the
       evidence (progressive frames of one picture, pgi_progressive_keep_guide). 0: a fresh guide */
    int guide_keep;
    /* portal emission (scene/portal.h): the sun's and the sky's photons start on the scene's
       portals (needs portals; no guide, a fixed radius) */
    int portals;
} pgi__trace_desc;

/* Fills `ph` (capacity >= photons) with exactly `photons` photons, unless the
 * scene loses nearly all light (then fewer: after 64 paths per requested
 * photon the tracer stops). ph->emitted is the number of light paths, and the
 * flux of every photon is already divided by it. `rays` counts rays cast.
 * The result is identical for any thread count: path i uses RNG stream i and
 * paths are appended in index order. */
/* Tracing buffers kept between frames, so that steady-state frames allocate nothing: each
 * thread's photons (about the photons stored, whatever --bounces), a byte a path of the
 * current batch, and the yield seen in the last frame. Zero-initialise; free with
 * pgi__trace_scratch_free. */
struct pgi__trace_tbuf;
struct chunk_info;
typedef struct pgi__trace_scratch {
    struct pgi__trace_tbuf *tbuf;
    int nthreads;
    uint8_t *counts;    /* photons of each path of the batch */
    uint16_t *path_bin; /* guided emission: the guide's bin of each path of the batch */
    uint16_t *ph_bin;   /* ... and of each photon stored */
    size_t path_bin_cap, ph_bin_cap;
    struct chunk_info *chunks; /* where each chunk's photons are */
    size_t cap;                /* paths */
    /* How each path of the batch starts, the states of those from point and spot lights
       between their first and second hits (trace.c first_hits), their differentials (when a
       radius policy follows them: pd_cap), whether each goes on after its first hit (live: a
       byte a state for each thread, which writes those of the states it shades; live_n bytes),
       and their emission order (sort keys, indices) */
    uint8_t *mode;
    struct path_state *ps;
    uint8_t *live;
    struct pgi__pdiff *ps_pd;
    uint32_t *key, *idx, *tkey, *tidx, *hist;
    size_t mode_cap, ps_cap, pd_cap, hist_n, live_n;
    double prior_paths, prior_photons; /* the last frame's traced paths and their photons */
    uint64_t paths_traced;             /* out: paths traced by the last call (emitted + discarded + pilot) */
    uint64_t paths_pilot;              /* out: guided emission's uniform pilot, whose photons were dropped */
    uint64_t culled;                   /* out: photons not stored (trace desc `near`) */
    /* The scene's triangles as the tracer shades them (trace.c), rebuilt when the scene's
       geometry changes (its arrays, or static_version / dynamic_version) */
    struct pgi__trace_tri *tris;
    float *tri_uv;
    size_t tris_n, tris_bytes; /* triangles, bytes allocated for them */
    const void *tris_key[6];
    uint64_t tris_version[2];
} pgi__trace_scratch;
void pgi__trace_scratch_free(pgi__trace_scratch *sc);
/* (Re)builds sc's triangle records (tris, tri_uv) with `threads` threads (0: OpenMP's default) when the
 * scene's geometry is not the one they hold; the rest of sc is left alone. pgi__photons_trace calls
 * it; the view pass and the reference path tracer shade from the same records. */
pgi_status pgi__trace_tris_update(pgi__trace_scratch *sc, const pgi_scene *s, int threads);
/* Bytes the scratch holds. */
size_t pgi__trace_scratch_bytes(const pgi__trace_scratch *sc);

/* Whether every path of light L starts at one point (point and spot lights): the tracer sorts
 * those paths by direction and casts their first rays as coherent packets (trace.c first_hits). */
static inline int pgi__light_from_point(const pgi__light *L) {
    return L->type == PGI__LIGHT_POINT || L->type == PGI__LIGHT_SPOT;
}

/* Tests: at most this many paths of a chunk from point and spot lights start in the emission
 * pre-pass (0: no cap); the others start in their chunk (trace.c start_paths). */
extern int pgi__trace_room_cap;

pgi_status pgi__photons_trace(const pgi_scene *s, const pgi__rt *rt, const pgi__trace_desc *d, pgi_photons *ph,
                              pgi__trace_scratch *scratch, uint64_t *rays);

#if PGI__AVX2_TARGET
/* The same tracer built for AVX2, FMA, BMI1/2 and POPCNT (trace_v3.c): pgi__photons_trace calls it
 * where pgi__trace_v3_ok(); the same photons, bit for bit. */
pgi_status pgi__photons_trace_v3(const pgi_scene *s, const pgi__rt *rt, const pgi__trace_desc *d, pgi_photons *ph,
                                 pgi__trace_scratch *scratch, uint64_t *rays);
static inline int pgi__trace_v3_ok(void) {
    return pgi__cpu_avx2() && __builtin_cpu_supports("fma") && __builtin_cpu_supports("bmi") &&
           __builtin_cpu_supports("bmi2");
}
/* ... and for AVX-512 F, DQ, VL, BW and CD as well (trace_v4.c: x86-64-v4), where
 * pgi__trace_v4_ok() (not with pgi__cpu_no512); the same photons, bit for bit. */
pgi_status pgi__photons_trace_v4(const pgi_scene *s, const pgi__rt *rt, const pgi__trace_desc *d, pgi_photons *ph,
                                 pgi__trace_scratch *scratch, uint64_t *rays);
static inline int pgi__trace_v4_ok(void) {
    return pgi__trace_v3_ok() && pgi__cpu_avx512() && __builtin_cpu_supports("avx512dq") &&
           __builtin_cpu_supports("avx512vl") && __builtin_cpu_supports("avx512bw") &&
           __builtin_cpu_supports("avx512cd");
}
#endif

#endif
