/* Ray capture and replay (ray_log.h). The capture buffers are per thread:
 * a thread claims a slot of the log the first time it captures into it (one
 * atomic increment) and remembers it in a thread-local cache keyed by the
 * log's unique id, so appending is a bounds check and a store. */
#include "ray_log.h"

#include <embree3/rtcore.h>
#include <stdatomic.h>
#include <string.h>

#define SLOTS 256
#define GROUPS ((int)PGI__PASS_COUNT * (int)PGI__RAY_KIND_COUNT)

typedef struct {
    _Alignas(64) pgi__ray_rec *rec;
    size_t n, cap;
    uint32_t calls; /* packet ids handed out */
} slot;

struct pgi__ray_log {
    uint64_t id;
    atomic_int nslots;
    atomic_uint_fast64_t dropped;
    int pass;
    slot slots[SLOTS];
    /* merged */
    pgi__ray_rec *rec;
    size_t n;
    size_t begin[GROUPS + 1];
    uint64_t rays[GROUPS];
    size_t *pk[GROUPS]; /* packet / stream starts of each group (packet kinds), npk[g] + 1 entries */
    size_t npk[GROUPS];
};

static atomic_uint_fast64_t g_next_log_id = 1;
static _Thread_local struct {
    uint64_t log_id;
    slot *s; /* NULL: no slot left, drop */
} t_slot;

static int group_of(int pass, int kind) { return pass * (int)PGI__RAY_KIND_COUNT + kind; }

static int kind_width(int kind) {
    switch (kind) {
    case PGI__RAY_INTERSECT8:
    case PGI__RAY_OCCLUDED8: return 8;
    case PGI__RAY_INTERSECT16:
    case PGI__RAY_OCCLUDED16: return 16;
    case PGI__RAY_INTERSECT1M:
    case PGI__RAY_OCCLUDED1M: return 0; /* streams: any length */
    default: return 1;
    }
}

int pgi__ray_kind_occluded(pgi__ray_kind k) { return (int)k & 1; }

const char *pgi__ray_kind_name(pgi__ray_kind k) {
    static const char *names[PGI__RAY_KIND_COUNT] = {"intersect1",  "occluded1",  "intersect8",  "occluded8",
                                                     "intersect16", "occluded16", "intersect1M", "occluded1M"};
    return (unsigned)k < PGI__RAY_KIND_COUNT ? names[k] : "?";
}

pgi_status pgi__ray_log_create(pgi__ray_log **out) {
    *out = calloc(1, sizeof **out);
    if (!*out) return pgi__fail(PGI_ERR_OOM, "out of memory for a ray log");
    (*out)->id = atomic_fetch_add(&g_next_log_id, 1);
    return PGI_OK;
}

void pgi__ray_log_clear(pgi__ray_log *log) {
    if (!log) return;
    int ns = atomic_load(&log->nslots);
    for (int i = 0; i < ns && i < SLOTS; i++) log->slots[i].n = 0;
    free(log->rec);
    log->rec = NULL;
    log->n = 0;
    for (int g = 0; g < GROUPS; g++) {
        free(log->pk[g]);
        log->pk[g] = NULL;
        log->npk[g] = 0;
        log->rays[g] = 0;
    }
    memset(log->begin, 0, sizeof log->begin);
    atomic_store(&log->dropped, 0);
}

void pgi__ray_log_destroy(pgi__ray_log *log) {
    if (!log) return;
    pgi__ray_log_clear(log);
    for (int i = 0; i < SLOTS; i++) free(log->slots[i].rec);
    free(log);
}

void pgi__ray_log_set_pass(pgi__ray_log *log, pgi__pass pass) { log->pass = (int)pass; }

static pgi__ray_rec *hook_reserve(void *log, pgi__ray_kind kind, unsigned n, unsigned flags) {
    return pgi__ray_log_reserve(log, kind, n, flags);
}
static void hook_set_pass(void *log, pgi__pass pass) { pgi__ray_log_set_pass(log, pass); }

void pgi__rt_capture_set(pgi__rt *rt, pgi__ray_log *log) {
    pgi__rt_capture_hook(rt, log ? &(pgi__rt_capture){hook_reserve, hook_set_pass, log} : NULL);
}

static slot *claim_slot(pgi__ray_log *log) {
    int i = atomic_fetch_add(&log->nslots, 1);
    t_slot.log_id = log->id;
    t_slot.s = i < SLOTS ? &log->slots[i] : NULL;
    return t_slot.s;
}

pgi__ray_rec *pgi__ray_log_reserve(pgi__ray_log *log, pgi__ray_kind kind, unsigned n, unsigned flags) {
    slot *s = t_slot.log_id == log->id ? t_slot.s : claim_slot(log);
    if (!s || n == 0 || n > 65536) {
        atomic_fetch_add(&log->dropped, n);
        return NULL;
    }
    if (s->n + n > s->cap) {
        size_t cap = s->cap ? 2 * s->cap : 4096;
        while (cap < s->n + n) cap *= 2;
        pgi__ray_rec *r = realloc(s->rec, cap * sizeof *r);
        if (!r) {
            atomic_fetch_add(&log->dropped, n);
            return NULL;
        }
        s->rec = r;
        s->cap = cap;
    }
    pgi__ray_rec *r = s->rec + s->n;
    s->n += n;
    uint32_t call = s->calls++;
    for (unsigned i = 0; i < n; i++) {
        memset(&r[i], 0, sizeof r[i]);
        r[i].packet = call;
        r[i].lane = (uint16_t)i;
        r[i].kind = (uint8_t)kind;
        r[i].pass = (uint8_t)log->pass;
        r[i].flags = (uint8_t)(PGI__RAY_VALID | (flags & PGI__RAY_COHERENT));
    }
    return r;
}

pgi_status pgi__ray_log_merge(pgi__ray_log *log) {
    int ns = atomic_load(&log->nslots);
    if (ns > SLOTS) ns = SLOTS;
    /* Sources in order: what was merged before, then the slots. */
    size_t count[GROUPS] = {0}, total = 0;
    for (int src = -1; src < ns; src++) {
        const pgi__ray_rec *R = src < 0 ? log->rec : log->slots[src].rec;
        size_t n = src < 0 ? log->n : log->slots[src].n;
        for (size_t i = 0; i < n; i++) count[group_of(R[i].pass, R[i].kind)]++;
        total += n;
    }
    pgi__ray_rec *out = malloc((total ? total : 1) * sizeof *out);
    size_t *pk[GROUPS] = {0};
    size_t npk[GROUPS] = {0};
    if (!out) return pgi__fail(PGI_ERR_OOM, "out of memory merging %zu captured rays", total);
    for (int g = 0; g < GROUPS; g++) {
        if (kind_width(g % PGI__RAY_KIND_COUNT) == 1 || !count[g]) continue;
        pk[g] = malloc((count[g] + 1) * sizeof(size_t)); /* at most one packet per record */
        if (!pk[g]) {
            for (int k = 0; k < g; k++) free(pk[k]);
            free(out);
            return pgi__fail(PGI_ERR_OOM, "out of memory merging %zu captured rays", total);
        }
    }
    size_t begin[GROUPS + 1], at[GROUPS];
    begin[0] = 0;
    for (int g = 0; g < GROUPS; g++) begin[g + 1] = begin[g] + count[g], at[g] = begin[g];
    uint64_t rays[GROUPS] = {0};
    int last_src[GROUPS];
    uint32_t last_call[GROUPS];
    for (int g = 0; g < GROUPS; g++) last_src[g] = -2, last_call[g] = 0;
    for (int src = -1; src < ns; src++) {
        const pgi__ray_rec *R = src < 0 ? log->rec : log->slots[src].rec;
        size_t n = src < 0 ? log->n : log->slots[src].n;
        for (size_t i = 0; i < n; i++) {
            int g = group_of(R[i].pass, R[i].kind);
            pgi__ray_rec r = R[i];
            if (src != last_src[g] || r.packet != last_call[g]) {
                last_src[g] = src;
                last_call[g] = r.packet;
                if (pk[g]) pk[g][npk[g]] = at[g] - begin[g];
                npk[g]++;
            }
            r.packet = (uint32_t)(npk[g] - 1);
            rays[g] += (r.flags & PGI__RAY_VALID) != 0;
            out[at[g]++] = r;
        }
    }
    for (int g = 0; g < GROUPS; g++) {
        if (pk[g]) pk[g][npk[g]] = count[g];
        free(log->pk[g]);
        log->pk[g] = pk[g];
        log->npk[g] = npk[g];
        log->rays[g] = rays[g];
    }
    free(log->rec);
    log->rec = out;
    log->n = total;
    memcpy(log->begin, begin, sizeof begin);
    for (int i = 0; i < ns; i++) log->slots[i].n = 0;
    return PGI_OK;
}

size_t pgi__ray_log_group(const pgi__ray_log *log, pgi__pass pass, pgi__ray_kind kind, const pgi__ray_rec **rec) {
    int g = group_of((int)pass, (int)kind);
    if (rec) *rec = log->rec + log->begin[g];
    return log->begin[g + 1] - log->begin[g];
}

uint64_t pgi__ray_log_rays(const pgi__ray_log *log, pgi__pass pass, pgi__ray_kind kind) {
    return log->rays[group_of((int)pass, (int)kind)];
}

uint64_t pgi__ray_log_dropped(const pgi__ray_log *log) { return atomic_load(&log->dropped); }

/* ------------------------------------------------------------------ replay */

const char *pgi__replay_method_name(pgi__replay_method m) {
    static const char *names[PGI__REPLAY_METHOD_COUNT] = {"cast", "1", "8", "8i", "16", "16i", "1M", "1Mc"};
    return (unsigned)m < PGI__REPLAY_METHOD_COUNT ? names[m] : "?";
}

const char *pgi__replay_method_call(pgi__replay_method m, int occluded) {
    static const char *calls[2][PGI__REPLAY_METHOD_COUNT] = {{"as captured", "rtcIntersect1", "rtcIntersect8 coherent",
                                                              "rtcIntersect8 incoherent", "rtcIntersect16 coherent",
                                                              "rtcIntersect16 incoherent", "rtcIntersect1M incoherent",
                                                              "rtcIntersect1M coherent"},
                                                             {"as captured", "rtcOccluded1", "rtcOccluded8 coherent",
                                                              "rtcOccluded8 incoherent", "rtcOccluded16 coherent",
                                                              "rtcOccluded16 incoherent", "rtcOccluded1M incoherent",
                                                              "rtcOccluded1M coherent"}};
    return (unsigned)m < PGI__REPLAY_METHOD_COUNT ? calls[occluded != 0][m] : "?";
}

int pgi__rt_replay_supported(const pgi__rt *rt, pgi__replay_method m) {
    if (m != PGI__REPLAY_16 && m != PGI__REPLAY_16I) return (unsigned)m < PGI__REPLAY_METHOD_COUNT;
    RTCDevice dev = rtcGetSceneDevice(pgi__rt_embree_scene(rt));
    int native = rtcGetDeviceProperty(dev, RTC_DEVICE_PROPERTY_NATIVE_RAY16_SUPPORTED) != 0;
    rtcReleaseDevice(dev);
    return native;
}

/* Replay counters of one unit of work. */
typedef struct {
    uint64_t rays, hits, mism;
} tally;

/* Compares Embree's answer for record r with the captured one. */
static inline void check(const pgi__ray_rec *r, int occluded, unsigned geom, unsigned prim, tally *t) {
    t->rays++;
    if (occluded) {
        int occ = geom != RTC_INVALID_GEOMETRY_ID;
        t->hits += occ;
        t->mism += occ != (r->geom != PGI__RAY_NO_GEOM);
        return;
    }
    int hit = geom != RTC_INVALID_GEOMETRY_ID;
    t->hits += hit;
    if (hit) t->mism += r->geom != geom || r->prim != prim;
    else t->mism += r->geom != PGI__RAY_NO_GEOM;
}

static void cast1(RTCScene sc, const pgi__ray_rec *R, size_t n, int occluded, int coherent, tally *t) {
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    if (coherent) ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
    for (size_t i = 0; i < n; i++) {
        const pgi__ray_rec *r = &R[i];
        if (!(r->flags & PGI__RAY_VALID)) continue;
        struct RTCRayHit rh;
        rh.ray.org_x = r->org[0];
        rh.ray.org_y = r->org[1];
        rh.ray.org_z = r->org[2];
        rh.ray.tnear = r->tnear;
        rh.ray.dir_x = r->dir[0];
        rh.ray.dir_y = r->dir[1];
        rh.ray.dir_z = r->dir[2];
        rh.ray.time = 0.f;
        rh.ray.tfar = r->tfar;
        rh.ray.mask = (unsigned)-1;
        rh.ray.id = 0;
        rh.ray.flags = 0;
        if (occluded) {
            rtcOccluded1(sc, &ctx, &rh.ray);
            check(r, 1, rh.ray.tfar < 0.f ? 0u : RTC_INVALID_GEOMETRY_ID, 0u, t);
        } else {
            rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
            rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
            rtcIntersect1(sc, &ctx, &rh);
            check(r, 0, rh.hit.geomID, rh.hit.primID, t);
        }
    }
}

/* Packets of W lanes (8 or 16). `exact`: R is one captured packet, each
 * record goes to its own lane, invalid lanes stay off; otherwise the valid
 * records of R fill packets in order. */
#define DEFINE_CAST_PACKETS(W)                                                                                         \
    static void cast##W(RTCScene sc, const pgi__ray_rec *R, size_t n, int occluded, int coherent, int exact,           \
                        tally *t) {                                                                                    \
        struct RTCIntersectContext ctx;                                                                                \
        rtcInitIntersectContext(&ctx);                                                                                 \
        if (coherent) ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;                                                 \
        RTC_ALIGN(64) struct RTCRayHit##W rh;                                                                          \
        RTC_ALIGN(64) int vmask[W];                                                                                    \
        const pgi__ray_rec *lane_rec[W];                                                                               \
        size_t i = 0;                                                                                                  \
        while (i < n) {                                                                                                \
            int k = 0;                                                                                                 \
            for (int l = 0; l < W; l++) vmask[l] = 0, lane_rec[l] = NULL;                                              \
            if (exact) {                                                                                               \
                for (; i < n; i++)                                                                                     \
                    if (R[i].lane < W && (R[i].flags & PGI__RAY_VALID)) lane_rec[R[i].lane] = &R[i];                   \
            } else {                                                                                                   \
                for (; i < n && k < W; i++)                                                                            \
                    if (R[i].flags & PGI__RAY_VALID) lane_rec[k++] = &R[i];                                            \
            }                                                                                                          \
            for (int l = 0; l < W; l++) {                                                                              \
                const pgi__ray_rec *r = lane_rec[l] ? lane_rec[l] : &R[0];                                             \
                vmask[l] = lane_rec[l] ? -1 : 0;                                                                       \
                rh.ray.org_x[l] = r->org[0];                                                                           \
                rh.ray.org_y[l] = r->org[1];                                                                           \
                rh.ray.org_z[l] = r->org[2];                                                                           \
                rh.ray.tnear[l] = r->tnear;                                                                            \
                rh.ray.dir_x[l] = r->dir[0];                                                                           \
                rh.ray.dir_y[l] = r->dir[1];                                                                           \
                rh.ray.dir_z[l] = r->dir[2];                                                                           \
                rh.ray.time[l] = 0.f;                                                                                  \
                rh.ray.tfar[l] = r->tfar;                                                                              \
                rh.ray.mask[l] = (unsigned)-1;                                                                         \
                rh.ray.id[l] = (unsigned)l;                                                                            \
                rh.ray.flags[l] = 0;                                                                                   \
                rh.hit.geomID[l] = RTC_INVALID_GEOMETRY_ID;                                                            \
                rh.hit.instID[0][l] = RTC_INVALID_GEOMETRY_ID;                                                         \
            }                                                                                                          \
            if (occluded) {                                                                                            \
                rtcOccluded##W(vmask, sc, &ctx, &rh.ray);                                                              \
                for (int l = 0; l < W; l++)                                                                            \
                    if (lane_rec[l])                                                                                   \
                        check(lane_rec[l], 1, rh.ray.tfar[l] < 0.f ? 0u : RTC_INVALID_GEOMETRY_ID, 0u, t);             \
            } else {                                                                                                   \
                rtcIntersect##W(vmask, sc, &ctx, &rh);                                                                 \
                for (int l = 0; l < W; l++)                                                                            \
                    if (lane_rec[l]) check(lane_rec[l], 0, rh.hit.geomID[l], rh.hit.primID[l], t);                     \
            }                                                                                                          \
        }                                                                                                              \
    }
DEFINE_CAST_PACKETS(8)
DEFINE_CAST_PACKETS(16)

/* One stream call over the valid records of R (at most PGI__REPLAY_STREAM). */
static void cast1M(RTCScene sc, const pgi__ray_rec *R, size_t n, int occluded, int coherent, tally *t) {
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    if (coherent) ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
    RTC_ALIGN(64) struct RTCRayHit rh[PGI__REPLAY_STREAM];
    const pgi__ray_rec *src[PGI__REPLAY_STREAM];
    unsigned m = 0;
    for (size_t i = 0; i < n && m < PGI__REPLAY_STREAM; i++) {
        const pgi__ray_rec *r = &R[i];
        if (!(r->flags & PGI__RAY_VALID)) continue;
        struct RTCRayHit *h = &rh[m];
        src[m++] = r;
        h->ray.org_x = r->org[0];
        h->ray.org_y = r->org[1];
        h->ray.org_z = r->org[2];
        h->ray.tnear = r->tnear;
        h->ray.dir_x = r->dir[0];
        h->ray.dir_y = r->dir[1];
        h->ray.dir_z = r->dir[2];
        h->ray.time = 0.f;
        h->ray.tfar = r->tfar;
        h->ray.mask = (unsigned)-1;
        h->ray.id = m - 1;
        h->ray.flags = 0;
        h->hit.geomID = RTC_INVALID_GEOMETRY_ID;
        h->hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
    }
    if (!m) return;
    if (occluded) {
        /* RTCRayHit starts with its RTCRay: a stride of sizeof(RTCRayHit) walks the rays. */
        rtcOccluded1M(sc, &ctx, &rh[0].ray, m, sizeof rh[0]);
        for (unsigned i = 0; i < m; i++) check(src[i], 1, rh[i].ray.tfar < 0.f ? 0u : RTC_INVALID_GEOMETRY_ID, 0u, t);
    } else {
        rtcIntersect1M(sc, &ctx, rh, m, sizeof rh[0]);
        for (unsigned i = 0; i < m; i++) check(src[i], 0, rh[i].hit.geomID, rh[i].hit.primID, t);
    }
}

pgi_status pgi__rt_replay(const pgi__rt *rt, const pgi__ray_log *log, pgi__pass pass, pgi__ray_kind kind,
                          pgi__replay_method m, int threads, pgi__replay_result *out) {
    memset(out, 0, sizeof *out);
    if ((unsigned)pass >= PGI__PASS_COUNT || (unsigned)kind >= PGI__RAY_KIND_COUNT ||
        (unsigned)m >= PGI__REPLAY_METHOD_COUNT)
        return pgi__fail(PGI_ERR_INVALID_ARG, "replay: pass %d, kind %d or method %d out of range", (int)pass,
                         (int)kind, (int)m);
    if (!pgi__rt_replay_supported(rt, m))
        return pgi__fail(PGI_ERR_UNSUPPORTED, "replay: Embree has no native %s here", pgi__replay_method_call(m, 0));
    const int g = group_of((int)pass, (int)kind);
    const pgi__ray_rec *R = log->rec + log->begin[g];
    const size_t n = log->begin[g + 1] - log->begin[g];
    const int occl = pgi__ray_kind_occluded(kind), width = kind_width((int)kind);
    /* Units of work: runs of PGI__REPLAY_STREAM records, or for CAST of packet kinds as many whole
     * captured packets / streams (each cast as captured); a unit a packet would charge the
     * replay a scheduling step a packet, which the passes do not pay. */
    const int by_packet = m == PGI__REPLAY_CAST && width != 1;
    const size_t *pk = log->pk[g];
    const long long npk = (long long)log->npk[g];
    const long long per = by_packet && width > 1 ? PGI__REPLAY_STREAM / width : 1; /* packets a unit */
    const long long units =
        by_packet ? (npk + per - 1) / per : (long long)((n + PGI__REPLAY_STREAM - 1) / PGI__REPLAY_STREAM);
    RTCScene sc = pgi__rt_embree_scene(rt);
    uint64_t rays = 0, hits = 0, mism = 0;
    double t0 = pgi__now_ms();
#pragma omp parallel for schedule(dynamic, 1) reduction(+ : rays, hits, mism) num_threads(pgi__threads(threads))
    for (long long u = 0; u < units; u++) {
        const long long q1 = by_packet ? (u + 1) * per < npk ? (u + 1) * per : npk : 0;
        size_t b = by_packet ? pk[u * per] : (size_t)u * PGI__REPLAY_STREAM;
        size_t e = by_packet ? pk[q1] : (b + PGI__REPLAY_STREAM < n ? b + PGI__REPLAY_STREAM : n);
        const pgi__ray_rec *U = R + b;
        size_t len = e - b;
        int coh = (U[0].flags & PGI__RAY_COHERENT) != 0;
        tally t = {0, 0, 0};
        switch (m) {
        case PGI__REPLAY_CAST:
            if (by_packet)
                for (long long q = u * per; q < q1; q++) { /* each packet with its own context flags */
                    const pgi__ray_rec *P = R + pk[q];
                    const size_t pl = pk[q + 1] - pk[q];
                    const int pc = (P[0].flags & PGI__RAY_COHERENT) != 0;
                    if (width == 8) cast8(sc, P, pl, occl, pc, 1, &t);
                    else if (width == 16) cast16(sc, P, pl, occl, pc, 1, &t);
                    else
                        for (size_t s = 0; s < pl; s += PGI__REPLAY_STREAM)
                            cast1M(sc, P + s, pl - s < PGI__REPLAY_STREAM ? pl - s : PGI__REPLAY_STREAM, occl, pc, &t);
                }
            else cast1(sc, U, len, occl, coh, &t);
            break;
        case PGI__REPLAY_1: cast1(sc, U, len, occl, 0, &t); break;
        case PGI__REPLAY_8: cast8(sc, U, len, occl, 1, 0, &t); break;
        case PGI__REPLAY_8I: cast8(sc, U, len, occl, 0, 0, &t); break;
        case PGI__REPLAY_16: cast16(sc, U, len, occl, 1, 0, &t); break;
        case PGI__REPLAY_16I: cast16(sc, U, len, occl, 0, 0, &t); break;
        case PGI__REPLAY_1M: cast1M(sc, U, len, occl, 0, &t); break;
        case PGI__REPLAY_1MC: cast1M(sc, U, len, occl, 1, &t); break;
        default: break;
        }
        rays += t.rays;
        hits += t.hits;
        mism += t.mism;
    }
    out->ms = pgi__now_ms() - t0;
    out->rays = rays;
    out->hits = hits;
    out->mismatches = mism;
    return PGI_OK;
}
