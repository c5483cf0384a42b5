/* tiled: screen-space tiles gather from their own copy of the photons that
 * can reach them (tiled paper §2.3.1, Listings 5-6).
 *
 * Per frame: (1) tile bounds: the view-space box of each tile's view samples
 * (its min/max depth, and x/y for samples seen through mirrors); (2) count:
 * every photon's sphere is projected to a screen rectangle, and each tile in
 * it is tested against the sphere (tile frustum planes + depth/box bounds);
 * (3) prefix sum; (4) copy the photon into every tile it overlaps; (5)
 * gather: each view sample reads only its tile's photons.
 *
 * Determinism: photons are processed in fixed chunks (independent of the
 * thread count) and each tile lists them in photon order, so summation order
 * and therefore the image are the same for any number of threads.
 *
 * View samples reached through mirrors/glass lie outside their tile's
 * frustum, anywhere in the reflected scene. They are left out of the tiles
 * and grouped by position instead (spec_cells.h): cells of edge >= 2r in view
 * space, each with the tight box of its samples, one more photon list per
 * cell after the tiles' lists. A photon reaches only the cells near it. */
#include "estimator_internal.h"
#include "spec_cells.h"

typedef struct {
    float lo[3], hi[3]; /* view-space box of the tile's primary samples */
    int valid;          /* has at least one valid primary sample */
} tile_bounds;

typedef struct {
    pgi__est_common c;
    int T, ntx, nty, ntiles;
    tile_bounds *bounds;
    size_t bounds_cap;
    pgi__spec_cells cells;          /* samples seen through mirrors/glass: lists ntiles .. nlists - 1 */
    int nlists;                     /* ntiles + cells.n */
    float frame_lo[3], frame_hi[3]; /* box of all tiles' boxes (primary samples) */
    uint32_t *counts;               /* [chunk][list] */
    size_t counts_cap;
    uint32_t *tile_start; /* nlists + 1 */
    size_t tile_start_cap;
    pgi__packed_photon *tile_photons; /* the tiles' lists: packed copies */
    size_t tile_photons_cap;
    uint32_t *cell_ids; /* the cells' lists: photon indices (packed per cell when gathered) */
    size_t cell_ids_cap;
    size_t copies;
} tiled_state;
_Static_assert(offsetof(tiled_state, c) == 0, "pgi__est_default_stats reads the state as its pgi__est_common");

const pgi_option pgi__opt_tile = {.name = "tile",
                                  .type = PGI_OPTION_INT,
                                  .offset = offsetof(pgi_estimator_desc, tiled.tile_size),
                                  .min = 1,
                                  .max = 4096,
                                  .def = 32,
                                  .help = "screen tile edge in pixels (1..4096; default 16 for tiled, 32 for "
                                          "bounds3d and bounds25d)"};
static const pgi_option *const k_options[] = {&pgi__opt_tile, NULL};
/* Measured when the default was chosen: 16-pixel tiles build + estimate 1.2-1.7x faster
 * than 32 on cornell, sibenik and conference, 5 % slower on fireplace-room; smaller tiles lose
 * badly where mirrors leave tiles unbounded. The bounds methods stay at the row's 32. */
static const pgi_option_default k_defaults[] = {{&pgi__opt_tile, 16}, {NULL, 0}};

static pgi_status tiled_create(const pgi_estimator_desc *d, void **state) {
    tiled_state *s = calloc(1, sizeof *s);
    if (!s) return pgi__fail(PGI_ERR_OOM, "out of memory");
    s->c.desc = *d;
    s->T = d->tiled.tile_size;
    *state = s;
    return PGI_OK;
}

/* Tangent slopes u = x/z of the lines through the eye that touch the circle
 * (a, z, r), z > r: roots of u^2 (z^2 - r^2) - 2 a z u + a^2 - r^2 = 0. */
static inline void silhouette(float a, float z, float r, float *u0, float *u1) {
    float den = z * z - r * r;
    float disc = sqrtf(fmaxf(0.f, a * a + den));
    *u0 = (a * z - r * disc) / den;
    *u1 = (a * z + r * disc) / den;
}

/* Sphere vs tile (view-space centre c, padded radius rr): box distance, then
 * the four side planes of the tile's frustum (through the eye and the tile's
 * pixel edges). */
static inline int overlaps(const tiled_state *s, const pgi__view_xf *x, int t, pgi__v3 c, float rr) {
    const tile_bounds *b = &s->bounds[t];
    if (!b->valid || pgi__box_d2(b->lo, b->hi, c) > rr * rr) return 0;
    int tx = t % s->ntx, ty = t / s->ntx;
    float u0 = (2.f * (float)(tx * s->T) / (float)x->W - 1.f) * x->sx;
    float u1 = (2.f * (float)((tx + 1) * s->T) / (float)x->W - 1.f) * x->sx;
    float v0 = (1.f - 2.f * (float)(ty * s->T) / (float)x->H) * x->sy;       /* top edge */
    float v1 = (1.f - 2.f * (float)((ty + 1) * s->T) / (float)x->H) * x->sy; /* bottom edge */
    /* inside: u0 <= x/z <= u1, v1 <= y/z <= v0 */
    if ((c.x - u0 * c.z) / sqrtf(1.f + u0 * u0) < -rr) return 0;
    if ((u1 * c.z - c.x) / sqrtf(1.f + u1 * u1) < -rr) return 0;
    if ((c.y - v1 * c.z) / sqrtf(1.f + v1 * v1) < -rr) return 0;
    if ((v0 * c.z - c.y) / sqrtf(1.f + v0 * v0) < -rr) return 0;
    return 1;
}

/* Early reject against the view-space box of all primary samples: photons
 * behind the camera or beyond the farthest sample touch no tile. (The
 * mirror-seen samples, behind the camera too, have their own box in cells:
 * with them in this box, every photon behind the camera would go through the
 * whole-screen branch below and test every tile: 2 s of a 1M-photon build on
 * fireplace-room.) */
static inline int frame_overlaps(const tiled_state *s, pgi__v3 c, float rr) {
    return pgi__box_d2(s->frame_lo, s->frame_hi, c) <= rr * rr;
}

/* Runs BODY with `t` every photon list the sphere (view-space centre c) may
 * reach: the tiles of its screen rectangle, then the cells of the samples seen
 * through mirrors/glass near it. */
#define FOR_EACH_TILE(S_, XF_, C_, R_, BODY)                                                                           \
    do {                                                                                                               \
        const float rr_ = pgi__pad_radius((C_), (R_));                                                                 \
        if (frame_overlaps((S_), (C_), rr_)) {                                                                         \
            int tx0 = 0, tx1 = (S_)->ntx - 1, ty0 = 0, ty1 = (S_)->nty - 1;                                            \
            if ((C_).z - (R_) > 1e-6f * fabsf((C_).z)) {                                                               \
                float u0, u1, w0, w1;                                                                                  \
                silhouette((C_).x, (C_).z, (R_), &u0, &u1);                                                            \
                silhouette((C_).y, (C_).z, (R_), &w0, &w1);                                                            \
                float px0 = (u0 / (XF_)->sx + 1.f) * 0.5f * (float)(XF_)->W - 1.f;                                     \
                float px1 = (u1 / (XF_)->sx + 1.f) * 0.5f * (float)(XF_)->W + 1.f;                                     \
                float py0 = (1.f - w1 / (XF_)->sy) * 0.5f * (float)(XF_)->H - 1.f;                                     \
                float py1 = (1.f - w0 / (XF_)->sy) * 0.5f * (float)(XF_)->H + 1.f;                                     \
                float fT = (float)(S_)->T;                                                                             \
                tx0 = px0 <= 0.f ? 0 : (px0 >= (float)(XF_)->W ? (S_)->ntx : (int)(px0 / fT));                         \
                tx1 = px1 < 0.f ? -1 : (px1 >= (float)(XF_)->W ? (S_)->ntx - 1 : (int)(px1 / fT));                     \
                ty0 = py0 <= 0.f ? 0 : (py0 >= (float)(XF_)->H ? (S_)->nty : (int)(py0 / fT));                         \
                ty1 = py1 < 0.f ? -1 : (py1 >= (float)(XF_)->H ? (S_)->nty - 1 : (int)(py1 / fT));                     \
            }                                                                                                          \
            for (int ty_ = ty0; ty_ <= ty1; ty_++)                                                                     \
                for (int tx_ = tx0; tx_ <= tx1; tx_++) {                                                               \
                    int t = ty_ * (S_)->ntx + tx_;                                                                     \
                    if (overlaps((S_), (XF_), t, (C_), rr_)) { BODY; }                                                 \
                }                                                                                                      \
        }                                                                                                              \
        PGI__FOR_EACH_SPEC_CELL(&(S_)->cells, (C_), rr_, int t = (S_)->ntiles + (int)k_; BODY);                        \
    } while (0)

static pgi_status tiled_build(void *state, const pgi_estimate_args *a) {
    tiled_state *s = state;
    pgi__est_frame(&s->c, a);
    memset(&s->c.st, 0, sizeof s->c.st);
    const pgi_view_samples *vs = a->samples;
    const pgi_photons *ph = a->photons;
    const pgi_camera *cam = a->camera;
    const float r = s->c.radius;
    const int W = vs->width, H = vs->height, T = s->T;
    s->ntx = (W + T - 1) / T;
    s->nty = (H + T - 1) / T;
    s->ntiles = s->ntx * s->nty;
    const size_t n = ph->count;
    /* Fixed chunking, independent of the thread count: at most 64 chunks. */
    size_t chunk = n / 64 + 1;
    if (chunk < 8192) chunk = 8192;
    const size_t nchunks = (n + chunk - 1) / chunk;
    pgi_status st;
    if ((st = pgi__ensure((void **)&s->bounds, &s->bounds_cap, (size_t)s->ntiles, sizeof(tile_bounds)))) return st;
    pgi__view_xf x = pgi__view_xf_make(cam, W, H);

    double t0 = pgi__now_ms();
    if ((st = pgi__spec_cells_build(&s->cells, vs, &x, r, pgi__spec_cells_cap(s->ntiles), s->c.threads))) return st;
    s->nlists = s->ntiles + (int)s->cells.n;
    if ((st = pgi__ensure((void **)&s->tile_start, &s->tile_start_cap, (size_t)s->nlists + 1, sizeof(uint32_t))) ||
        (st = pgi__ensure((void **)&s->counts, &s->counts_cap, (nchunks + 1) * (size_t)s->nlists, sizeof(uint32_t))))
        return st;
#pragma omp parallel for schedule(dynamic, 4) num_threads(s->c.threads)
    for (int t = 0; t < s->ntiles; t++) {
        tile_bounds *b = &s->bounds[t];
        b->valid = 0;
        for (int k = 0; k < 3; k++) {
            b->lo[k] = INFINITY;
            b->hi[k] = -INFINITY;
        }
        int tx = t % s->ntx, ty = t / s->ntx;
        for (int py = ty * T; py < (ty + 1) * T && py < H; py++)
            for (int px = tx * T; px < (tx + 1) * T && px < W; px++) {
                size_t i = (size_t)py * W + (size_t)px;
                if ((vs->flags[i] & (PGI_VS_VALID | PGI_VS_PRIMARY)) != (PGI_VS_VALID | PGI_VS_PRIMARY)) continue;
                const float *p = vs->pos + 3 * i;
                pgi__v3 q = pgi__to_view(&x, p[0], p[1], p[2]);
                float qq[3] = {q.x, q.y, q.z};
                for (int k = 0; k < 3; k++) {
                    b->lo[k] = fminf(b->lo[k], qq[k]);
                    b->hi[k] = fmaxf(b->hi[k], qq[k]);
                }
                b->valid = 1;
            }
    }
    for (int k = 0; k < 3; k++) {
        s->frame_lo[k] = INFINITY;
        s->frame_hi[k] = -INFINITY;
    }
    for (int t = 0; t < s->ntiles; t++)
        if (s->bounds[t].valid)
            for (int k = 0; k < 3; k++) {
                s->frame_lo[k] = fminf(s->frame_lo[k], s->bounds[t].lo[k]);
                s->frame_hi[k] = fmaxf(s->frame_hi[k], s->bounds[t].hi[k]);
            }
    double t1 = pgi__now_ms();

    const int nlists = s->nlists; /* tiles, then cells */
    uint64_t tested = 0;
#pragma omp parallel for schedule(dynamic, 1) reduction(+ : tested) num_threads(s->c.threads)
    for (long long cidx = 0; cidx < (long long)nchunks; cidx++) {
        uint32_t *cnt = s->counts + (size_t)cidx * nlists;
        memset(cnt, 0, (size_t)nlists * sizeof *cnt);
        size_t j1 = ((size_t)cidx + 1) * chunk < n ? ((size_t)cidx + 1) * chunk : n;
        for (size_t j = (size_t)cidx * chunk; j < j1; j++) {
            pgi__v3 c = pgi__to_view(&x, ph->px[j], ph->py[j], ph->pz[j]);
            FOR_EACH_TILE(s, &x, c, r, cnt[t]++; tested++);
        }
    }
    double t2 = pgi__now_ms();
    /* Prefix sum, tile-major then chunk: counts become write offsets. */
    uint64_t sum = 0;
    for (int t = 0; t < nlists; t++) {
        s->tile_start[t] = (uint32_t)sum;
        for (size_t cidx = 0; cidx < nchunks; cidx++) {
            uint32_t *cnt = s->counts + cidx * nlists + t;
            uint32_t c = *cnt;
            *cnt = (uint32_t)sum;
            sum += c;
        }
    }
    s->tile_start[nlists] = (uint32_t)sum;
    if (sum > UINT32_MAX)
        return pgi__fail(PGI_ERR_UNSUPPORTED, "tiled: %llu photon copies exceed the 32-bit index; use a smaller radius",
                         (unsigned long long)sum);
    /* The tiles' lists are read by every sample of the tile: packed copies. A cell's list is
     * packed into a scratch buffer when the cell is gathered, so it is kept as indices (4 bytes,
     * not 36: on cornell-mirrors at 1M photons 64.8 MB of cell copies become 7.2 MB). */
    const size_t in_tiles = s->tile_start[s->ntiles];
    if ((st = pgi__ensure((void **)&s->tile_photons, &s->tile_photons_cap, in_tiles + 1, sizeof(pgi__packed_photon))) ||
        (st = pgi__ensure((void **)&s->cell_ids, &s->cell_ids_cap, (size_t)sum - in_tiles + 1, sizeof(uint32_t))))
        return st;
    s->copies = (size_t)sum;
    const int ntl = s->ntiles;
    double t3 = pgi__now_ms();
#pragma omp parallel for schedule(dynamic, 1) num_threads(s->c.threads)
    for (long long cidx = 0; cidx < (long long)nchunks; cidx++) {
        uint32_t *off = s->counts + (size_t)cidx * nlists;
        size_t j1 = ((size_t)cidx + 1) * chunk < n ? ((size_t)cidx + 1) * chunk : n;
        for (size_t j = (size_t)cidx * chunk; j < j1; j++) {
            pgi__v3 c = pgi__to_view(&x, ph->px[j], ph->py[j], ph->pz[j]);
            FOR_EACH_TILE(s, &x, c, r, {
                uint32_t o_ = off[t]++;
                if (t < ntl) pgi__pack_photon(ph, j, &s->tile_photons[o_]);
                else s->cell_ids[o_ - in_tiles] = (uint32_t)j;
            });
        }
    }
    double t4 = pgi__now_ms();
    pgi__stats_pass(&s->c.st, "bounds", t1 - t0);
    pgi__stats_pass(&s->c.st, "count", t2 - t1);
    pgi__stats_pass(&s->c.st, "scan", t3 - t2);
    pgi__stats_pass(&s->c.st, "copy", t4 - t3);
    s->c.st.build_ms = t4 - t0;
    s->c.st.nodes_visited = tested;
    return PGI_OK;
}

/* Gathers view sample i from the photon list q[0 .. nq). */
static inline void gather_one(const pgi_estimate_args *a, size_t i, float r2, pgi_kernel kern, int sub, uint64_t seed,
                              const pgi__packed_photon *q, uint32_t nq, uint64_t *reads, uint64_t *contrib) {
    float *out = a->out_rgb + 3 * i;
    pgi__vs v;
    if (!pgi__vs_begin(a->samples, i, out, &v)) return;
    pgi__acc acc = {0};
    pgi__sub ss;
    pgi__sub_init(&ss, sub, seed, i);
    pgi__gather_list(&v, r2, kern, &ss, q, nq, &acc);
    pgi__acc_finish_k(&v, &acc, r2, kern, pgi__sub_scale(&ss), out);
    *reads += ss.visited;
    *contrib += acc.contributing;
}

static pgi_status tiled_estimate(void *state, const pgi_estimate_args *a) {
    tiled_state *s = state;
    pgi__est_frame(&s->c, a);
    double t0 = pgi__now_ms();
    const pgi_view_samples *vs = a->samples;
    const int W = vs->width, H = vs->height, T = s->T;
    if (W != a->camera->width || s->ntx != (W + T - 1) / T || s->nty != (H + T - 1) / T)
        return pgi__fail(PGI_ERR_INVALID_ARG, "tiled: estimate called with a frame size other than build's");
    const float r2 = s->c.radius * s->c.radius;
    const pgi_kernel kern = s->c.desc.kernel;
    const int sub = s->c.desc.subsample;
    const uint64_t seed = s->c.seed;
    uint64_t reads = 0, contrib = 0;
    int oom = 0;
    const size_t in_tiles = s->tile_start[s->ntiles];
#pragma omp parallel for schedule(dynamic, 1) reduction(+ : reads, contrib) reduction(| : oom) num_threads(s->c.threads)
    for (int t = 0; t < s->nlists; t++) {
        if (pgi__est_stop(&s->c)) continue;
        const uint32_t nq = s->tile_start[t + 1] - s->tile_start[t];
        if (t < s->ntiles) {
            const pgi__packed_photon *q = s->tile_photons + s->tile_start[t];
            int tx = t % s->ntx, ty = t / s->ntx;
            for (int py = ty * T; py < (ty + 1) * T && py < H; py++)
                for (int px = tx * T; px < (tx + 1) * T && px < W; px++) {
                    size_t i = (size_t)py * W + (size_t)px;
                    if ((vs->flags[i] & (PGI_VS_VALID | PGI_VS_PRIMARY)) == PGI_VS_VALID) continue;
                    gather_one(a, i, r2, kern, sub, seed, q, nq, &reads, &contrib);
                }
        } else {
            const pgi__spec_cells *c = &s->cells;
            const uint32_t k = (uint32_t)(t - s->ntiles);
            const uint32_t *ids = s->cell_ids + (s->tile_start[t] - in_tiles);
            pgi__packed_photon *q = malloc(((size_t)nq + 1) * sizeof *q);
            if (!q) {
                oom = 1;
                continue;
            }
            for (uint32_t e = 0; e < nq; e++) pgi__pack_photon(a->photons, ids[e], &q[e]);
            for (uint32_t m = c->start[k]; m < c->start[k + 1]; m++)
                gather_one(a, c->sample[m], r2, kern, sub, seed, q, nq, &reads, &contrib);
            free(q);
        }
    }
    if (oom) return pgi__fail(PGI_ERR_OOM, "tiled: out of memory packing a mirror cell's photons");
    pgi__stats_estimated(&s->c.st, t0, reads, contrib);
    s->c.st.memory_count = 0;
    pgi__stats_mem(&s->c.st, "tile_photons", in_tiles * sizeof(pgi__packed_photon));
    size_t longest = 0; /* a cell's list packed while it is gathered: one at a time a thread */
    for (int t = s->ntiles; t < s->nlists; t++)
        if (s->tile_start[t + 1] - s->tile_start[t] > longest) longest = s->tile_start[t + 1] - s->tile_start[t];
    pgi__stats_mem(&s->c.st, "cell_photons",
                   (s->copies - in_tiles) * sizeof(uint32_t) +
                       (size_t)s->c.threads * longest * sizeof(pgi__packed_photon));
    pgi__stats_mem(&s->c.st, "tile_bounds", (size_t)s->ntiles * sizeof(tile_bounds));
    pgi__stats_mem(&s->c.st, "tile_offsets", s->counts_cap * sizeof(uint32_t) + ((size_t)s->nlists + 1) * 4);
    pgi__stats_mem(&s->c.st, "specular_cells", pgi__spec_cells_bytes(&s->cells));
    return PGI_OK;
}

static void tiled_destroy(void *state) {
    tiled_state *s = state;
    if (!s) return;
    pgi__afree(s->bounds);
    pgi__spec_cells_free(&s->cells);
    pgi__afree(s->counts);
    pgi__afree(s->tile_start);
    pgi__afree(s->tile_photons);
    pgi__afree(s->cell_ids);
    free(s);
}

const pgi_estimator_vtbl pgi__est_tiled =
    PGI__EST_TABLE("tiled", "screen tiles with depth bounds; per-tile photon copies (Mara et al. 2013 §2.3.1)",
                   tiled_create, tiled_build, tiled_estimate, tiled_destroy, .exact = 1,
                   .caps = PGI_EST_CAP_KERNELS | PGI_EST_CAP_SUBSAMPLE, .options = k_options, .defaults = k_defaults,
                   .bytes_per_photon = 80, .bytes_per_sample = 48);
