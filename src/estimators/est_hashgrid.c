/* hashgrid: photons in sparse grid cells kept in a hash table (tiled paper
 * §2.3.1, Listings 3-4; Ma & McCool 2002). Wang's hash6432shift, open
 * addressing with quadratic probing, a power-of-two number of slots, and the
 * photons sorted by cell so that every cell is one contiguous range.
 *
 * Build is deterministic (cells filled in photon order), so the image does
 * not depend on the thread count. */
#include "estimator_internal.h"

#define EMPTY_KEY UINT64_MAX
#define FIELD_BITS 21
#define FIELD_BIAS (1 << (FIELD_BITS - 1))

typedef struct {
    uint64_t key;
    uint32_t start, count;
} slot;

typedef struct {
    pgi__est_common c;
    float cell, inv_cell;
    slot *slots;
    size_t slot_cap, nslots;
    uint32_t mask;
    pgi__packed_photon *sorted;
    size_t sorted_cap;
    uint64_t *keys;
    size_t keys_cap;
    uint32_t *slot_of;
    size_t slot_of_cap;
    size_t cells_used;
    uint32_t max_probe;
} hashgrid_state;
_Static_assert(offsetof(hashgrid_state, c) == 0, "pgi__est_default_stats reads the state as its pgi__est_common");

/* Listing 4 of the tiled paper. */
static inline uint32_t hash6432shift(uint64_t key) {
    key = (~key) + (key << 18);
    key = key ^ (key >> 31);
    key = key * 21;
    key = key ^ (key >> 11);
    key = key + (key << 6);
    key = key ^ (key >> 22);
    return (uint32_t)key;
}

/* Cell coordinate, clamped so that the float->int conversion is defined and
 * fits the 21-bit key field. Clamping merges far-away cells, which only costs
 * time: every photon is still tested against the sphere. */
static inline int32_t cell_coord(float x, float inv) {
    float c = floorf(x * inv);
    if (!(c > (float)-FIELD_BIAS)) c = (float)-FIELD_BIAS; /* also catches NaN */
    if (c > (float)(FIELD_BIAS - 1)) c = (float)(FIELD_BIAS - 1);
    return (int32_t)c;
}

static inline uint64_t cell_key(int32_t x, int32_t y, int32_t z) {
    const uint64_t m = (1u << FIELD_BITS) - 1;
    return ((uint64_t)((x + FIELD_BIAS) & m) << (2 * FIELD_BITS)) | ((uint64_t)((y + FIELD_BIAS) & m) << FIELD_BITS) |
           (uint64_t)((z + FIELD_BIAS) & m);
}

/* Quadratic probing: slot b0 + (d + d^2)/2 at probe d (triangular numbers,
 * which visit every slot of a power-of-two table). */
static inline uint32_t probe(const hashgrid_state *s, uint64_t key, uint32_t *probes) {
    uint32_t b0 = hash6432shift(key) & s->mask, b = b0, d = 0;
    while (s->slots[b].key != key && s->slots[b].key != EMPTY_KEY) {
        d++;
        b = (b0 + ((d + d * d) >> 1)) & s->mask;
    }
    *probes += d + 1;
    return b;
}

static const pgi_option k_opt_cell_size =
    {.name = "cell-size",
     .type = PGI_OPTION_FLOAT,
     .offset = offsetof(pgi_estimator_desc, hashgrid.cell_size),
     .help = "hashgrid cell edge in scene units (at least radius/64; default 2 x radius)"};
static const pgi_option *const k_options[] = {&k_opt_cell_size, NULL};

static pgi_status hg_create(const pgi_estimator_desc *d, void **state) {
    hashgrid_state *s = calloc(1, sizeof *s);
    if (!s) return pgi__fail(PGI_ERR_OOM, "out of memory");
    s->c.desc = *d;
    *state = s;
    return PGI_OK;
}

static pgi_status hg_build(void *state, const pgi_estimate_args *a) {
    hashgrid_state *s = state;
    pgi__est_frame(&s->c, a);
    memset(&s->c.st, 0, sizeof s->c.st);
    /* Cell edge 2r: a query sphere then overlaps at most 2x2x2 cells. Below r/64 a query would
     * visit over 2 million cells: reject rather than hang. */
    const float cell = s->c.desc.hashgrid.cell_size;
    if (cell > 0.f && cell < s->c.radius / 64.f)
        return pgi__fail(PGI_ERR_INVALID_ARG,
                         "hashgrid: --cell-size must be 0 (default: 2r) or at least r/64 = %g, got %g",
                         (double)(s->c.radius / 64.f), (double)cell);
    s->cell = cell > 0.f ? cell : 2.f * s->c.radius;
    s->inv_cell = 1.f / s->cell;
    double t0 = pgi__now_ms();
    const pgi_photons *ph = a->photons;
    const size_t n = ph->count;
    size_t nslots = 16;
    while (nslots < 2 * n) nslots <<= 1; /* load factor <= 1/2 */
    pgi_status st;
    if ((st = pgi__ensure((void **)&s->slots, &s->slot_cap, nslots, sizeof(slot))) ||
        (st = pgi__ensure((void **)&s->sorted, &s->sorted_cap, n + 1, sizeof(pgi__packed_photon))) ||
        (st = pgi__ensure((void **)&s->keys, &s->keys_cap, n + 1, sizeof(uint64_t))) ||
        (st = pgi__ensure((void **)&s->slot_of, &s->slot_of_cap, n + 1, sizeof(uint32_t))))
        return st;
    s->nslots = nslots;
    s->mask = (uint32_t)(nslots - 1);
    const float inv = s->inv_cell;
#pragma omp parallel num_threads(s->c.threads)
    {
#pragma omp for schedule(static)
        for (long long k = 0; k < (long long)nslots; k++) {
            s->slots[k].key = EMPTY_KEY;
            s->slots[k].start = s->slots[k].count = 0;
        }
#pragma omp for schedule(static)
        for (long long j = 0; j < (long long)n; j++)
            s->keys[j] = cell_key(cell_coord(ph->px[j], inv), cell_coord(ph->py[j], inv), cell_coord(ph->pz[j], inv));
    }
    double t1 = pgi__now_ms();
    /* Insert cells in photon order (sequential: a few ms for 1M photons,
     * and the order makes the layout independent of the thread count). */
    uint32_t probes = 0;
    size_t used = 0;
    for (size_t j = 0; j < n; j++) {
        uint32_t b = probe(s, s->keys[j], &probes);
        if (s->slots[b].key == EMPTY_KEY) {
            s->slots[b].key = s->keys[j];
            used++;
        }
        s->slots[b].count++;
        s->slot_of[j] = b;
    }
    uint32_t sum = 0;
    for (size_t b = 0; b < nslots; b++) {
        s->slots[b].start = sum;
        sum += s->slots[b].count;
        s->slots[b].count = 0; /* reused as the fill cursor */
    }
    for (size_t j = 0; j < n; j++) {
        slot *sl = &s->slots[s->slot_of[j]];
        pgi__pack_photon(ph, j, &s->sorted[sl->start + sl->count++]);
    }
    double t2 = pgi__now_ms();
    s->cells_used = used;
    pgi__stats_pass(&s->c.st, "keys", t1 - t0);
    pgi__stats_pass(&s->c.st, "insert+sort", t2 - t1);
    s->c.st.build_ms = t2 - t0;
    return PGI_OK;
}

static pgi_status hg_estimate(void *state, const pgi_estimate_args *a) {
    hashgrid_state *s = state;
    pgi__est_frame(&s->c, a);
    double t0 = pgi__now_ms();
    const pgi_view_samples *vs = a->samples;
    const float r = s->c.radius, r2 = r * r, inv = s->inv_cell;
    const pgi_kernel kern = s->c.desc.kernel;
    const int sub = s->c.desc.subsample;
    const uint64_t seed = s->c.seed;
    uint64_t reads = 0, contrib = 0, visited = 0;
#pragma omp parallel for schedule(dynamic, 64) reduction(+ : reads, contrib, visited) num_threads(s->c.threads)
    for (long long ii = 0; ii < (long long)vs->count; ii++) {
        pgi__vs v;
        float *out = pgi__est_sample(&s->c, a, ii, &v);
        if (!out) continue;
        pgi__acc acc = {0};
        pgi__sub ss;
        pgi__sub_init(&ss, sub, seed, (size_t)ii);
        int32_t x0 = cell_coord(v.px - r, inv), x1 = cell_coord(v.px + r, inv);
        int32_t y0 = cell_coord(v.py - r, inv), y1 = cell_coord(v.py + r, inv);
        int32_t z0 = cell_coord(v.pz - r, inv), z1 = cell_coord(v.pz + r, inv);
        uint32_t probes = 0;
        for (int32_t cx = x0; cx <= x1; cx++)
            for (int32_t cy = y0; cy <= y1; cy++)
                for (int32_t cz = z0; cz <= z1; cz++) {
                    uint32_t b = probe(s, cell_key(cx, cy, cz), &probes);
                    const slot *sl = &s->slots[b];
                    if (sl->key == EMPTY_KEY) continue;
                    const pgi__packed_photon *q = s->sorted + sl->start;
                    pgi__gather_list(&v, r2, kern, &ss, q, sl->count, &acc);
                }
        pgi__acc_finish_k(&v, &acc, r2, kern, pgi__sub_scale(&ss), out);
        reads += ss.visited;
        contrib += acc.contributing;
        visited += probes;
    }
    pgi__stats_estimated(&s->c.st, t0, reads, contrib);
    s->c.st.nodes_visited = visited;
    s->c.st.memory_count = 0;
    pgi__stats_mem(&s->c.st, "hash_table", s->nslots * sizeof(slot));
    pgi__stats_mem(&s->c.st, "sorted_photons", a->photons->count * sizeof(pgi__packed_photon));
    pgi__stats_mem(&s->c.st, "sort_keys", (a->photons->count + 1) * (sizeof(uint64_t) + sizeof(uint32_t)));
    return PGI_OK;
}

static void hg_destroy(void *state) {
    hashgrid_state *s = state;
    if (!s) return;
    pgi__afree(s->slots);
    pgi__afree(s->sorted);
    pgi__afree(s->keys);
    pgi__afree(s->slot_of);
    free(s);
}

const pgi_estimator_vtbl pgi__est_hashgrid =
    PGI__EST_TABLE("hashgrid", "3D hash grid of photon cells, pixel-major gather (Mara et al. 2013 §2.3.1)", hg_create,
                   hg_build, hg_estimate, hg_destroy, .exact = 1, .caps = PGI_EST_CAP_KERNELS | PGI_EST_CAP_SUBSAMPLE,
                   .options = k_options, .bytes_per_photon = 112);
