/* Embree 3 back end. Pitfalls: ray.mask must be -1 (all bits) or every
 * geometry is skipped; 8-wide packets are native on AVX2 CPUs. */
#include "rt.h"

#include <embree3/rtcore.h>
#include <stdatomic.h>
#include <stdio.h>
#include <string.h>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif

/* One Embree geometry: a class of the scene's triangles (static or animated, with or without
 * a cut-out mask). */
typedef struct rt_geom {
    RTCGeometry g;
    uint32_t *map;   /* scene triangle of each of its triangles; NULL: identity (all of them) */
    uint32_t *verts; /* scene vertex of each of its vertices; NULL: all scene vertices */
    size_t nverts;
    size_t ntri;
    int dynamic;        /* its triangles move with the animation (refitted) */
    const pgi_scene *s; /* masked geometries: the scene their filter reads */
} rt_geom;

/* Triangle classes, each its own geometry when present: bit 0 a cut-out mask, bit 1 animated. */
#define CLASS_MASKED 1
#define CLASS_DYNAMIC 2
#define NCLASS 4
_Static_assert(NCLASS == 4, "packet16_prims tests the four classes' maps");

struct pgi__rt {
    RTCDevice device;
    RTCScene scene;
    /* Scenes with animated objects keep the static triangles (built once, high quality) and
     * the animated ones (refitted each time they move) in geometries of their own; Embree then
     * builds a two-level BVH and only the moved geometry is redone. Triangles with a cut-out
     * mask get geometries of their own too, and only those carry the filter functions
     * (alpha_filter), so that scenes without masks trace exactly as before. A scene of static,
     * unmasked triangles has one geometry over all of them (map and verts NULL). */
    rt_geom geom[NCLASS];
    int ngeom;
    int any_dynamic;
    uint64_t static_version, dynamic_version;
    pgi__rt_capture capture; /* reserve NULL: off (pgi__rt_capture_hook) */
    /* Embree's bytes as its memory monitor reports them (BVH, geometry buffers, build scratch);
     * the monitor runs on Embree's build threads, hence atomics. */
    _Atomic long long embree_bytes, embree_peak;
};

/* Ray capture (the hook of rt.h): each query ends with `if (CAPTURING(rt)) capture...(...)`. The
 * capture functions are out of line and read the ray back from Embree's structure (Embree
 * leaves origin, direction and tnear as they were; tfar is passed, Embree overwrites it), so
 * that while capture is off a query pays one load and a not-taken branch, and keeps nothing
 * else alive across the Embree call. */
#define CAPTURING(rt) __builtin_expect((rt)->capture.reserve != NULL, 0)
#if defined(__GNUC__)
#define PGI__COLD __attribute__((noinline, cold))
#else
#define PGI__COLD
#endif

static PGI__COLD void capture1(const pgi__rt_capture *log, pgi__ray_kind kind, const struct RTCRay *r, float tfar,
                               unsigned geom, unsigned prim) {
    pgi__ray_rec *c = log->reserve(log->user, kind, 1, 0);
    if (c)
        pgi__ray_rec_set(c, v3(r->org_x, r->org_y, r->org_z), v3(r->dir_x, r->dir_y, r->dir_z), r->tnear, tfar, 1, geom,
                         prim);
}

/* The lanes of an Embree packet, whatever its width (RTCRay8 and RTCRay16 differ only in the
 * length of their arrays): the 8- and 16-wide queries below fill, read and capture packets
 * through this one view. The hit arrays are NULL for occlusion rays. */
typedef struct packet_view {
    int n;
    float *ox, *oy, *oz, *dx, *dy, *dz, *tnear, *tfar, *time;
    unsigned *mask, *id, *flags;
    unsigned *geom, *prim, *inst;
    float *u, *v;
} packet_view;
#define PACKET_RAYS(N, r)                                                                                              \
    .n = N, .ox = (r).org_x, .oy = (r).org_y, .oz = (r).org_z, .dx = (r).dir_x, .dy = (r).dir_y, .dz = (r).dir_z,      \
    .tnear = (r).tnear, .tfar = (r).tfar, .time = (r).time, .mask = (r).mask, .id = (r).id, .flags = (r).flags
#define PACKET_HITS(h) .geom = (h).geomID, .prim = (h).primID, .inst = (h).instID[0], .u = (h).u, .v = (h).v

/* Lane i: the ray o + t d over (0, tfar), enabled or not in vmask. */
static inline void packet_set(const packet_view *p, int *vmask, int i, int valid, pgi__v3 o, pgi__v3 d, float tfar) {
    vmask[i] = valid ? -1 : 0;
    p->ox[i] = o.x;
    p->oy[i] = o.y;
    p->oz[i] = o.z;
    p->dx[i] = d.x;
    p->dy[i] = d.y;
    p->dz[i] = d.z;
    p->tnear[i] = 0.f;
    p->tfar[i] = tfar;
    p->time[i] = 0.f;
    p->mask[i] = (unsigned)-1;
    p->id[i] = (unsigned)i;
    p->flags[i] = 0;
    if (p->geom) p->geom[i] = p->inst[i] = RTC_INVALID_GEOMETRY_ID;
}

/* A packet's lanes as cast: `tfars` the lanes' tfar before the query (NULL: `tfar` for all);
 * `occluded` the answers of an occlusion query (NULL: the packet's hits). */
static PGI__COLD void capture_packet(const pgi__rt_capture *log, pgi__ray_kind kind, unsigned flags,
                                     const packet_view *p, const int *vmask, float tfar, const float *tfars,
                                     const int *occluded) {
    pgi__ray_rec *c = log->reserve(log->user, kind, (unsigned)p->n, flags);
    for (int i = 0; c && i < p->n; i++)
        pgi__ray_rec_set(c + i, v3(p->ox[i], p->oy[i], p->oz[i]), v3(p->dx[i], p->dy[i], p->dz[i]), p->tnear[i],
                         tfars ? tfars[i] : tfar, vmask[i] != 0,
                         occluded ? (occluded[i] ? 0u : RTC_INVALID_GEOMETRY_ID) : p->geom[i],
                         occluded ? 0u : p->prim[i]);
}

static _Thread_local char g_rt_error[256];

/* Embree's memory monitor: bytes > 0 before an allocation, < 0 after a free. Never refuses (the
 * budget is checked per frame, where the BVH's size is known). */
static bool on_memory(void *user, ssize_t bytes, bool post) {
    (void)post;
    pgi__rt *rt = user;
    long long now = atomic_fetch_add_explicit(&rt->embree_bytes, (long long)bytes, memory_order_relaxed) + bytes;
    long long peak = atomic_load_explicit(&rt->embree_peak, memory_order_relaxed);
    while (now > peak && !atomic_compare_exchange_weak_explicit(&rt->embree_peak, &peak, now, memory_order_relaxed,
                                                                memory_order_relaxed)) {}
    return true;
}

size_t pgi__rt_memory(const pgi__rt *rt, size_t *peak) {
    long long cur = atomic_load_explicit(&rt->embree_bytes, memory_order_relaxed);
    long long pk = atomic_load_explicit(&rt->embree_peak, memory_order_relaxed);
    size_t own = sizeof *rt; /* and the triangle and vertex maps of split geometries */
    for (int g = 0; g < rt->ngeom; g++)
        own += ((rt->geom[g].map ? rt->geom[g].ntri : 0) + (rt->geom[g].verts ? rt->geom[g].nverts : 0)) *
               sizeof(uint32_t);
    if (peak) *peak = (pk > 0 ? (size_t)pk : 0) + own;
    return (cur > 0 ? (size_t)cur : 0) + own;
}

static void on_error(void *user, enum RTCError code, const char *str) {
    (void)user;
    snprintf(g_rt_error, sizeof g_rt_error, "Embree error %d: %s", (int)code, str ? str : "");
}

/* Embree filter of the masked geometries (intersection and occlusion alike, any packet width):
 * a hit where the mask is cut out is refused, and traversal goes on behind it. */
static void alpha_filter(const struct RTCFilterFunctionNArguments *args) {
    const rt_geom *g = args->geometryUserPtr;
    const unsigned n = args->N;
    /* RTCHitN is N-wide SOA: Ng_x, Ng_y, Ng_z, u, v, primID, ... (rtcore_ray.h's accessors are C++). */
    const float *hf = (const float *)args->hit;
    const unsigned *hu = (const unsigned *)args->hit;
    for (unsigned i = 0; i < n; i++) {
        if (args->valid[i] != -1) continue;
        unsigned prim = hu[5 * n + i];
        uint32_t tri = g->map ? g->map[prim] : prim;
        if (pgi__scene_cut_out(g->s, tri, hf[3 * n + i], hf[4 * n + i])) args->valid[i] = 0;
    }
}

/* A triangle geometry over `ntri` triangles of the scene (tris[i], or i when
 * tris is NULL); vertices are all scene vertices, or the `nv` listed in
 * `verts`, with `remap` giving each scene vertex its local index. `masked`:
 * the geometry's record, for the cut-out filters (NULL: no filter). */
static RTCGeometry make_geometry(pgi__rt *rt, const pgi_scene *s, const uint32_t *tris, size_t ntri,
                                 const uint32_t *verts, size_t nv, const uint32_t *remap, enum RTCBuildQuality q,
                                 rt_geom *masked) {
    RTCGeometry g = rtcNewGeometry(rt->device, RTC_GEOMETRY_TYPE_TRIANGLE);
    if (!g) return NULL;
    size_t nvb = verts ? nv : s->nverts;
    float *vb = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), nvb);
    unsigned *ib = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned), ntri);
    if (!vb || !ib) {
        rtcReleaseGeometry(g);
        return NULL;
    }
    if (verts)
        for (size_t i = 0; i < nv; i++) memcpy(vb + 3 * i, s->pos + 3 * (size_t)verts[i], 3 * sizeof(float));
    else memcpy(vb, s->pos, s->nverts * 3 * sizeof(float));
    for (size_t i = 0; i < ntri; i++) {
        size_t t = tris ? tris[i] : i;
        for (int k = 0; k < 3; k++) {
            uint32_t v = s->tri[3 * t + k];
            ib[3 * i + k] = remap ? remap[v] : v;
        }
    }
    rtcSetGeometryBuildQuality(g, q);
    if (masked) {
        rtcSetGeometryUserData(g, masked);
        rtcSetGeometryIntersectFilterFunction(g, alpha_filter);
        rtcSetGeometryOccludedFilterFunction(g, alpha_filter);
    }
    rtcCommitGeometry(g);
    return g;
}

static int tri_class(const pgi_scene *s, size_t t) {
    return (pgi__mat_masked(&s->mats[s->tri_mat[t]]) ? CLASS_MASKED : 0) |
           (s->tri_dynamic && s->tri_dynamic[t] ? CLASS_DYNAMIC : 0);
}

/* Geometry of the `ntri` triangles `tris` of class c; every class but the static, unmasked one
 * gets a vertex buffer of its own vertices only (remap: scratch of nverts entries). */
static pgi_status add_class(pgi__rt *rt, const pgi_scene *s, int c, uint32_t *tris, size_t ntri, uint32_t *remap) {
    rt_geom *g = &rt->geom[rt->ngeom];
    g->map = ntri == s->ntris && c == 0 ? NULL : tris;
    g->ntri = ntri;
    if (g->map != tris) free(tris);
    g->dynamic = (c & CLASS_DYNAMIC) != 0;
    g->s = s;
    if (c != 0) {
        g->verts = malloc((s->nverts ? s->nverts : 1) * sizeof(uint32_t));
        if (!g->verts) return pgi__fail(PGI_ERR_OOM, "out of memory splitting %zu triangles", ntri);
        for (size_t v = 0; v < s->nverts; v++) remap[v] = UINT32_MAX;
        for (size_t i = 0; i < ntri; i++)
            for (int k = 0; k < 3; k++) {
                uint32_t v = s->tri[3 * (size_t)tris[i] + k];
                if (remap[v] == UINT32_MAX) {
                    remap[v] = (uint32_t)g->nverts;
                    g->verts[g->nverts++] = v;
                }
            }
    }
    g->g = make_geometry(rt, s, g->map, ntri, g->verts, g->nverts, g->verts ? remap : NULL,
                         g->dynamic ? RTC_BUILD_QUALITY_REFIT : RTC_BUILD_QUALITY_HIGH, c & CLASS_MASKED ? g : NULL);
    rt->ngeom++;
    if (!g->g) return pgi__fail(PGI_ERR_OOM, "Embree could not allocate geometry buffers for %zu triangles", ntri);
    return PGI_OK;
}

pgi_status pgi__rt_create(const pgi_scene *s, pgi__rt **out) {
    *out = NULL;
    g_rt_error[0] = 0;
    pgi__rt *rt = calloc(1, sizeof *rt);
    if (!rt) return pgi__fail(PGI_ERR_OOM, "out of memory creating the ray tracer");
    rt->device = rtcNewDevice(NULL);
    if (!rt->device) {
        free(rt);
        return pgi__fail(PGI_ERR_INTERNAL, "cannot create an Embree device (error %d)", (int)rtcGetDeviceError(NULL));
    }
    rtcSetDeviceErrorFunction(rt->device, on_error, NULL);
    rtcSetDeviceMemoryMonitorFunction(rt->device, on_memory, rt);
    rt->scene = rtcNewScene(rt->device);
    rt->static_version = s->static_version;
    rt->dynamic_version = s->dynamic_version;
    size_t count[NCLASS] = {0};
    for (size_t t = 0; t < s->ntris; t++) count[tri_class(s, t)]++;
    rt->any_dynamic = count[CLASS_DYNAMIC] + count[CLASS_DYNAMIC | CLASS_MASKED] > 0;
    if (count[CLASS_MASKED] + count[CLASS_MASKED | CLASS_DYNAMIC] > 0 &&
        !rtcGetDeviceProperty(rt->device, RTC_DEVICE_PROPERTY_FILTER_FUNCTION_SUPPORTED)) {
        pgi__rt_destroy(rt);
        return pgi__fail(PGI_ERR_UNSUPPORTED,
                         "the scene has cut-out (alpha-masked) materials, and this Embree was built without filter "
                         "functions (EMBREE_FILTER_FUNCTION)");
    }
    if (!rt->any_dynamic) {
        rtcSetSceneBuildQuality(rt->scene, RTC_BUILD_QUALITY_HIGH);
    } else {
        /* LOW scene quality + DYNAMIC selects Embree's two-level builder, which
         * honours each geometry's own quality: HIGH for the static part, REFIT
         * for the animated part (rigid motions keep the topology, so a refit
         * keeps the tree's quality). */
        rtcSetSceneFlags(rt->scene, RTC_SCENE_FLAG_DYNAMIC);
        rtcSetSceneBuildQuality(rt->scene, RTC_BUILD_QUALITY_LOW);
    }
    uint32_t *remap = count[0] < s->ntris ? malloc((s->nverts ? s->nverts : 1) * sizeof(uint32_t)) : NULL;
    pgi_status st =
        count[0] < s->ntris && !remap ? pgi__fail(PGI_ERR_OOM, "out of memory creating the ray tracer") : PGI_OK;
    for (int c = 0; c < NCLASS && !st; c++) {
        if (!count[c]) continue;
        uint32_t *tris = malloc(count[c] * sizeof(uint32_t));
        if (!tris) {
            st = pgi__fail(PGI_ERR_OOM, "out of memory splitting %zu triangles", count[c]);
            break;
        }
        size_t n = 0;
        for (size_t t = 0; t < s->ntris; t++)
            if (tri_class(s, t) == c) tris[n++] = (uint32_t)t;
        st = add_class(rt, s, c, tris, n, remap);
    }
    free(remap);
    if (st) {
        pgi__rt_destroy(rt);
        return st;
    }
    for (int g = 0; g < rt->ngeom; g++) rtcAttachGeometryByID(rt->scene, rt->geom[g].g, (unsigned)g);
    rtcCommitScene(rt->scene);
    if (rtcGetDeviceError(rt->device) != RTC_ERROR_NONE || g_rt_error[0]) {
        st = pgi__fail(PGI_ERR_INTERNAL, "building the ray-tracing BVH failed: %s", g_rt_error);
        pgi__rt_destroy(rt);
        return st;
    }
    *out = rt;
    return PGI_OK;
}

int pgi__rt_needs_update(const pgi__rt *rt, const pgi_scene *s) {
    return rt->static_version != s->static_version || rt->dynamic_version != s->dynamic_version;
}

pgi_status pgi__rt_update(pgi__rt *rt, const pgi_scene *s) {
    if (!pgi__rt_needs_update(rt, s)) return PGI_OK;
    g_rt_error[0] = 0;
    const int stat_moved = rt->static_version != s->static_version;
    const int dyn_moved = rt->dynamic_version != s->dynamic_version;
    for (int i = 0; i < rt->ngeom; i++) {
        rt_geom *g = &rt->geom[i];
        if (!(g->dynamic ? dyn_moved : (stat_moved || (!rt->any_dynamic && dyn_moved)))) continue;
        float *vb = rtcGetGeometryBufferData(g->g, RTC_BUFFER_TYPE_VERTEX, 0);
        if (!vb) return pgi__fail(PGI_ERR_INTERNAL, "Embree vertex buffer is missing");
        if (g->verts)
            for (size_t v = 0; v < g->nverts; v++)
                memcpy(vb + 3 * v, s->pos + 3 * (size_t)g->verts[v], 3 * sizeof(float));
        else memcpy(vb, s->pos, s->nverts * 3 * sizeof(float));
        rtcUpdateGeometryBuffer(g->g, RTC_BUFFER_TYPE_VERTEX, 0);
        rtcCommitGeometry(g->g);
    }
    rtcCommitScene(rt->scene);
    rt->static_version = s->static_version;
    rt->dynamic_version = s->dynamic_version;
    if (rtcGetDeviceError(rt->device) != RTC_ERROR_NONE || g_rt_error[0])
        return pgi__fail(PGI_ERR_INTERNAL, "updating the ray-tracing BVH failed: %s", g_rt_error);
    return PGI_OK;
}

void pgi__rt_destroy(pgi__rt *rt) {
    if (!rt) return;
    for (int g = 0; g < NCLASS; g++) {
        if (rt->geom[g].g) rtcReleaseGeometry(rt->geom[g].g);
        free(rt->geom[g].map);
        free(rt->geom[g].verts);
    }
    if (rt->scene) rtcReleaseScene(rt->scene);
    if (rt->device) rtcReleaseDevice(rt->device);
    free(rt);
}

static inline uint32_t global_prim(const pgi__rt *rt, unsigned geom, unsigned prim) {
    const uint32_t *m = rt->geom[geom & (NCLASS - 1)].map;
    return m ? m[prim] : prim;
}

int pgi__rt_intersect(const pgi__rt *rt, pgi__v3 o, pgi__v3 d, float tnear, float tfar, pgi__hit *h) {
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    struct RTCRayHit rh;
    rh.ray.org_x = o.x;
    rh.ray.org_y = o.y;
    rh.ray.org_z = o.z;
    rh.ray.dir_x = d.x;
    rh.ray.dir_y = d.y;
    rh.ray.dir_z = d.z;
    rh.ray.tnear = tnear;
    rh.ray.tfar = tfar;
    rh.ray.time = 0.f;
    rh.ray.mask = (unsigned)-1;
    rh.ray.id = 0;
    rh.ray.flags = 0;
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(rt->scene, &ctx, &rh);
    if (CAPTURING(rt)) capture1(&rt->capture, PGI__RAY_INTERSECT1, &rh.ray, tfar, rh.hit.geomID, rh.hit.primID);
    if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) {
        h->prim = UINT32_MAX;
        return 0;
    }
    h->t = rh.ray.tfar;
    h->u = rh.hit.u;
    h->v = rh.hit.v;
    h->prim = global_prim(rt, rh.hit.geomID, rh.hit.primID);
    return 1;
}

int pgi__rt_occluded(const pgi__rt *rt, pgi__v3 o, pgi__v3 d, float tnear, float tfar) {
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    struct RTCRay r;
    r.org_x = o.x;
    r.org_y = o.y;
    r.org_z = o.z;
    r.dir_x = d.x;
    r.dir_y = d.y;
    r.dir_z = d.z;
    r.tnear = tnear;
    r.tfar = tfar;
    r.time = 0.f;
    r.mask = (unsigned)-1;
    r.id = 0;
    r.flags = 0;
    rtcOccluded1(rt->scene, &ctx, &r);
    if (CAPTURING(rt))
        capture1(&rt->capture, PGI__RAY_OCCLUDED1, &r, tfar, r.tfar < 0.f ? 0u : RTC_INVALID_GEOMETRY_ID, 0u);
    return r.tfar < 0.f; /* Embree sets tfar to -inf when occluded */
}

/* The hits of an intersected packet (disabled lanes and misses: prim UINT32_MAX). */
static inline void packet_hits(const pgi__rt *rt, const packet_view *p, const int *valid, pgi__hit *hits) {
    for (int i = 0; i < p->n; i++) {
        if (!valid[i] || p->geom[i] == RTC_INVALID_GEOMETRY_ID) {
            hits[i].prim = UINT32_MAX;
            continue;
        }
        hits[i].t = p->tfar[i];
        hits[i].u = p->u[i];
        hits[i].v = p->v[i];
        hits[i].prim = global_prim(rt, p->geom[i], p->prim[i]);
    }
}

void pgi__rt_intersect8(const pgi__rt *rt, const int valid[8], pgi__v3 o, const pgi__v3 dirs[8], float tfar,
                        pgi__hit hits[8]) {
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
    RTC_ALIGN(32) struct RTCRayHit8 rh;
    RTC_ALIGN(32) int vmask[8];
    const packet_view p = {PACKET_RAYS(8, rh.ray), PACKET_HITS(rh.hit)};
    for (int i = 0; i < 8; i++) packet_set(&p, vmask, i, valid[i], o, dirs[i], tfar);
    rtcIntersect8(vmask, rt->scene, &ctx, &rh);
    if (CAPTURING(rt))
        capture_packet(&rt->capture, PGI__RAY_INTERSECT8, PGI__RAY_COHERENT, &p, vmask, tfar, NULL, NULL);
    packet_hits(rt, &p, valid, hits);
}

/* A 16-wide packet's rays over (0, infinity) from arrays in its layout (ray i from ox[i ostep],
 * oy[i ostep], oz[i ostep]: ostep 0 for one shared origin): packet_set's lanes, written through
 * the packet's own fields rather than a packet_view's pointers (which the compiler must assume
 * alias), so that the compiler writes several lanes an instruction (the photon tracer casts one
 * such packet a wave: through packet_set and packet_hits it took a fifth of the tracer's own
 * instructions). */
static inline void packet16_set(struct RTCRayHit16 *rh, int *vmask, const int valid[16], const float *ox,
                                const float *oy, const float *oz, size_t ostep, const float *dx, const float *dy,
                                const float *dz) {
    for (int i = 0; i < 16; i++) {
        vmask[i] = valid[i] ? -1 : 0;
        rh->ray.org_x[i] = ox[(size_t)i * ostep];
        rh->ray.org_y[i] = oy[(size_t)i * ostep];
        rh->ray.org_z[i] = oz[(size_t)i * ostep];
        rh->ray.dir_x[i] = dx[i];
        rh->ray.dir_y[i] = dy[i];
        rh->ray.dir_z[i] = dz[i];
        rh->ray.tnear[i] = 0.f;
        rh->ray.tfar[i] = INFINITY;
        rh->ray.time[i] = 0.f;
        rh->ray.mask[i] = (unsigned)-1;
        rh->ray.id[i] = (unsigned)i;
        rh->ray.flags[i] = 0;
        rh->hit.geomID[i] = RTC_INVALID_GEOMETRY_ID;
        rh->hit.instID[0][i] = RTC_INVALID_GEOMETRY_ID;
    }
}

/* The scene triangles a 16-wide packet hit (packet_hits' prim: UINT32_MAX for a miss or a lane
 * off), without a branch a lane where the scene is one geometry numbered as the scene (no class
 * has a map). */
static inline void packet16_prims(const pgi__rt *rt, const int valid[16], const struct RTCRayHit16 *rh,
                                  uint32_t prim[16]) {
    if (!rt->geom[0].map && !rt->geom[1].map && !rt->geom[2].map && !rt->geom[3].map) {
        for (int i = 0; i < 16; i++)
            prim[i] =
                ((valid[i] != 0) & (rh->hit.geomID[i] != RTC_INVALID_GEOMETRY_ID)) ? rh->hit.primID[i] : UINT32_MAX;
        return;
    }
    for (int i = 0; i < 16; i++)
        prim[i] = valid[i] && rh->hit.geomID[i] != RTC_INVALID_GEOMETRY_ID
                      ? global_prim(rt, rh->hit.geomID[i], rh->hit.primID[i])
                      : UINT32_MAX;
}

void pgi__rt_intersect16(const pgi__rt *rt, const int valid[16], const float o[3][16], const float d[3][16],
                         int coherent, float t[16], float u[16], float v[16], uint32_t prim[16]) {
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    ctx.flags = coherent ? RTC_INTERSECT_CONTEXT_FLAG_COHERENT : RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT;
    RTC_ALIGN(64) struct RTCRayHit16 rh;
    RTC_ALIGN(64) int vmask[16];
    packet16_set(&rh, vmask, valid, o[0], o[1], o[2], 1, d[0], d[1], d[2]);
    rtcIntersect16(vmask, rt->scene, &ctx, &rh);
    if (CAPTURING(rt)) {
        const packet_view p = {PACKET_RAYS(16, rh.ray), PACKET_HITS(rh.hit)};
        capture_packet(&rt->capture, PGI__RAY_INTERSECT16, coherent ? PGI__RAY_COHERENT : 0, &p, vmask, INFINITY, NULL,
                       NULL);
    }
    /* packet_hits' answers (t, u, v also where there is no hit) */
    for (int i = 0; i < 16; i++) {
        t[i] = rh.ray.tfar[i];
        u[i] = rh.hit.u[i];
        v[i] = rh.hit.v[i];
    }
    packet16_prims(rt, valid, &rh, prim);
}

void pgi__rt_intersect16_soa(const pgi__rt *rt, const int valid[16], pgi__v3 o, const float *const d[3], float t[16],
                             float u[16], float v[16], uint32_t prim[16]) {
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
    RTC_ALIGN(64) struct RTCRayHit16 rh;
    RTC_ALIGN(64) int vmask[16];
    packet16_set(&rh, vmask, valid, &o.x, &o.y, &o.z, 0, d[0], d[1], d[2]);
    rtcIntersect16(vmask, rt->scene, &ctx, &rh);
    if (CAPTURING(rt)) {
        const packet_view p = {PACKET_RAYS(16, rh.ray), PACKET_HITS(rh.hit)};
        capture_packet(&rt->capture, PGI__RAY_INTERSECT16, PGI__RAY_COHERENT, &p, vmask, INFINITY, NULL, NULL);
    }
    packet16_prims(rt, valid, &rh, prim);
    for (int i = 0; i < 16; i++) {
        const int hit = prim[i] != UINT32_MAX;
        t[i] = hit ? rh.ray.tfar[i] : 0.f;
        u[i] = hit ? rh.hit.u[i] : 0.f;
        v[i] = hit ? rh.hit.v[i] : 0.f;
    }
}

void pgi__rt_occluded16(const pgi__rt *rt, const int valid[16], const pgi__v3 org[16], const pgi__v3 dirs[16],
                        const float tfar[16], int coherent, int occluded[16]) {
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    ctx.flags = coherent ? RTC_INTERSECT_CONTEXT_FLAG_COHERENT : RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT;
    RTC_ALIGN(64) struct RTCRay16 r;
    RTC_ALIGN(64) int vmask[16];
    const packet_view p = {PACKET_RAYS(16, r)};
    for (int i = 0; i < 16; i++) packet_set(&p, vmask, i, valid[i], org[i], dirs[i], valid[i] ? tfar[i] : 0.f);
    rtcOccluded16(vmask, rt->scene, &ctx, &r);
    for (int i = 0; i < 16; i++) occluded[i] = valid[i] && r.tfar[i] < 0.f;
    if (CAPTURING(rt)) {
        /* As cast: the query overwrote tfar, and capture_packet reads the lanes' own. */
        float tf[16];
        for (int i = 0; i < 16; i++) tf[i] = valid[i] ? tfar[i] : 0.f;
        capture_packet(&rt->capture, PGI__RAY_OCCLUDED16, coherent ? PGI__RAY_COHERENT : 0, &p, vmask, 0.f, tf,
                       occluded);
    }
}

void pgi__rt_occluded16_soa(const pgi__rt *rt, const int valid[16], const float *const o[3], const float *const d[3],
                            const float tfar[16], int occluded[16]) {
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
    RTC_ALIGN(64) struct RTCRay16 r;
    RTC_ALIGN(64) int vmask[16];
    RTC_ALIGN(16) float tf[16];
#if defined(__SSE2__)
    /* Four lanes an instruction (gcc keeps the loop below scalar: a dozen stores a lane, as many
     * as the direct pass's own work on the lane). The same bits: a lane's values, or +0. */
    for (int i = 0; i < 16; i += 4) {
        const __m128i vi = _mm_loadu_si128((const __m128i *)(valid + i));
        const __m128i mi = _mm_xor_si128(_mm_cmpeq_epi32(vi, _mm_setzero_si128()), _mm_set1_epi32(-1));
        const __m128 m = _mm_castsi128_ps(mi);
        _mm_store_si128((__m128i *)(vmask + i), mi);
        _mm_store_ps(r.org_x + i, _mm_and_ps(m, _mm_loadu_ps(o[0] + i)));
        _mm_store_ps(r.org_y + i, _mm_and_ps(m, _mm_loadu_ps(o[1] + i)));
        _mm_store_ps(r.org_z + i, _mm_and_ps(m, _mm_loadu_ps(o[2] + i)));
        _mm_store_ps(r.dir_x + i, _mm_and_ps(m, _mm_loadu_ps(d[0] + i)));
        _mm_store_ps(r.dir_y + i, _mm_and_ps(m, _mm_loadu_ps(d[1] + i)));
        _mm_store_ps(r.dir_z + i, _mm_and_ps(m, _mm_loadu_ps(d[2] + i)));
        _mm_store_ps(r.tnear + i, _mm_setzero_ps());
        const __m128 t = _mm_and_ps(m, _mm_loadu_ps(tfar + i));
        _mm_store_ps(r.tfar + i, t);
        _mm_store_ps(tf + i, t);
        _mm_store_ps(r.time + i, _mm_setzero_ps());
        _mm_store_si128((__m128i *)(r.mask + i), _mm_set1_epi32(-1));
        _mm_store_si128((__m128i *)(r.id + i), _mm_setr_epi32(i, i + 1, i + 2, i + 3));
        _mm_store_si128((__m128i *)(r.flags + i), _mm_setzero_si128());
    }
#else
    for (int i = 0; i < 16; i++) {
        const int v = valid[i] != 0;
        vmask[i] = v ? -1 : 0;
        /* invalid lanes: zeros, not whatever the caller left there */
        r.org_x[i] = v ? o[0][i] : 0.f;
        r.org_y[i] = v ? o[1][i] : 0.f;
        r.org_z[i] = v ? o[2][i] : 0.f;
        r.dir_x[i] = v ? d[0][i] : 0.f;
        r.dir_y[i] = v ? d[1][i] : 0.f;
        r.dir_z[i] = v ? d[2][i] : 0.f;
        r.tnear[i] = 0.f;
        tf[i] = r.tfar[i] = v ? tfar[i] : 0.f;
        r.time[i] = 0.f;
        r.mask[i] = (unsigned)-1;
        r.id[i] = (unsigned)i;
        r.flags[i] = 0;
    }
#endif
    rtcOccluded16(vmask, rt->scene, &ctx, &r);
    for (int i = 0; i < 16; i++) occluded[i] = valid[i] && r.tfar[i] < 0.f;
    if (CAPTURING(rt)) {
        const packet_view p = {PACKET_RAYS(16, r)};
        capture_packet(&rt->capture, PGI__RAY_OCCLUDED16, PGI__RAY_COHERENT, &p, vmask, 0.f, tf, occluded);
    }
}

/* The rays of an occlusion stream as cast (Embree overwrote tfar). */
static PGI__COLD void capture_stream(const pgi__rt_capture *log, const struct RTCRay *r, size_t n, const float *tfar,
                                     const int *occluded) {
    pgi__ray_rec *c = log->reserve(log->user, PGI__RAY_OCCLUDED1M, (unsigned)n, 0);
    for (size_t i = 0; c && i < n; i++)
        pgi__ray_rec_set(c + i, v3(r[i].org_x, r[i].org_y, r[i].org_z), v3(r[i].dir_x, r[i].dir_y, r[i].dir_z),
                         r[i].tnear, tfar[i], 1, occluded[i] ? 0u : RTC_INVALID_GEOMETRY_ID, 0u);
}

void pgi__rt_occluded1M(const pgi__rt *rt, size_t n, const pgi__v3 *org, const pgi__v3 *dirs, const float *tfar,
                        int *occluded) {
    if (n == 0) return;
    if (n > PGI__RT_STREAM_MAX) n = PGI__RT_STREAM_MAX;
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT;
    RTC_ALIGN(64) struct RTCRay r[PGI__RT_STREAM_MAX];
    for (size_t i = 0; i < n; i++) {
        r[i].org_x = org[i].x;
        r[i].org_y = org[i].y;
        r[i].org_z = org[i].z;
        r[i].tnear = 0.f;
        r[i].dir_x = dirs[i].x;
        r[i].dir_y = dirs[i].y;
        r[i].dir_z = dirs[i].z;
        r[i].time = 0.f;
        r[i].tfar = tfar[i];
        r[i].mask = (unsigned)-1;
        r[i].id = (unsigned)i;
        r[i].flags = 0;
    }
    rtcOccluded1M(rt->scene, &ctx, r, (unsigned)n, sizeof r[0]);
    for (size_t i = 0; i < n; i++) occluded[i] = r[i].tfar < 0.f;
    if (CAPTURING(rt)) capture_stream(&rt->capture, r, n, tfar, occluded);
}

void pgi__rt_capture_hook(pgi__rt *rt, const pgi__rt_capture *hook) {
    rt->capture = hook ? *hook : (pgi__rt_capture){0};
}

void pgi__rt_capture_pass(const pgi__rt *rt, pgi__pass pass) {
    if (rt->capture.reserve && rt->capture.set_pass) rt->capture.set_pass(rt->capture.user, pass);
}

struct RTCSceneTy *pgi__rt_embree_scene(const pgi__rt *rt) {
    return rt->scene;
}
