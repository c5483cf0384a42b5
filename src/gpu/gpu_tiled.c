/* tiled on the GPU (docs/gpu.md): the CPU estimator's method (src/estimators/est_tiled.c; Mara et
 * al. 2013 §2.3.1, Listings 5-6) on the device, exact like it.
 *
 * Screen tiles of T x T pixels (--tile, any size: the passes are not a workgroup a tile), each
 * bounded by the view-space box of its valid primary samples; samples seen through mirrors or
 * glass are grouped by the CPU's own view-space cells (spec_cells.h, built on the host from the
 * view samples: one more list per cell after the tiles'). One command sequence builds the lists:
 *   tl_bounds   a tile's box (one invocation a tile; min/max)
 *   tl_frame    the box of every tile's box (one invocation, tiles in order)
 *   tl_count    per chunk of photons (one invocation a chunk, photons in order, as the CPU's
 *               chunks): the tiles of the photon's screen rectangle whose box and frustum planes its
 *               padded sphere reaches, then the cells near it (est_tiled.c FOR_EACH_TILE, in GLSL:
 *               shaders/tl_lists.glsl); counts[list][chunk], no atomics
 *   hg_scan     exclusive prefix sum over (list, chunk): each chunk's offset in each list
 * then, after reading back the number of copies (the list buffer sized to it), a second one:
 *   tl_copy     the same walk, each photon's index at its chunk's next offset: every list in
 *               photon order, without atomics (nothing to rank)
 *   tl_gather   per view sample: its tile's (a mirror-seen sample: its cell's) list through
 *               gather.glsl's contribution test and sums (tiles a multiple of 8 pixels: the tile's
 *               photons through shared memory, 64 at a time, for the workgroup's primary samples)
 * Every float sum is in photon order: the same image bit for bit every run. Exactness: the lists
 * are conservative (the CPU's tests with a padded radius, pad_radius in shaders/tiled.glsl) and
 * the gather applies gather.glsl's test to every listed photon.
 * Limits: one invocation a chunk of photons (at most 4096 chunks) walks its photons in turn (the
 * order that makes the lists deterministic without a rank pass); --subsample and per-photon
 * footprints are refused, as are more than 2^30 photon copies or (list, chunk) counts. */
#include "gpu/gpu_estimator.h"
#include "gpu/gpu_scan.h"

#include <stdio.h>
#include <string.h>

#include "core/core.h"
#include "estimators/estimator_internal.h"
#include "estimators/spec_cells.h"

#ifndef PGI__HAVE_VULKAN

static pgi_status tl_create(pgi__gpu *g, const pgi_estimator_desc *d, void **state) {
    (void)g, (void)d;
    *state = NULL;
    return pgi__fail(PGI_ERR_UNSUPPORTED, "this build of photongi has no Vulkan backend (built without Vulkan/glslc)");
}
static pgi_status tl_run(void *state, const pgi_estimate_args *a, pgi_estimator_stats *st) {
    (void)state, (void)a, (void)st;
    return pgi__fail(PGI_ERR_UNSUPPORTED, "this build of photongi has no Vulkan backend (built without Vulkan/glslc)");
}
static void tl_destroy(void *state) { (void)state; }

#else

#include "gpu/spirv.h"

#define GGX_NMU PGI__GGX_NMU
#define MAX_CHUNKS 4096u /* count/copy invocations */

typedef pgi__gpu_vs gpu_vs;
typedef pgi__gpu_lobe gpu_lobe;

/* shaders/tiled.glsl Push */
typedef struct {
    float e[3], rt[3], up[3], fw[3];
    float sx, sy, r, r2;
    uint32_t width, height, T, ntx, nty, ntiles, nlists, n, chunk, nchunks, kernel;
    float scale;
    uint32_t hmask;
} tl_push;
_Static_assert(offsetof(tl_push, sx) == 48 && offsetof(tl_push, width) == 64 && offsetof(tl_push, kernel) == 104 &&
                   offsetof(tl_push, hmask) == 112,
               "tiled.glsl Push");

/* shaders/tiled.glsl CellGrid */
typedef struct {
    float lo[3], hi[3], o[3], inv_h;
    int32_t dim[3];
    uint32_t n;
} tl_grid;

enum { K_BOUNDS, K_FRAME, K_COUNT, K_COPY, K_GATHER, K_N };

typedef struct {
    pgi__gpu *g;
    pgi_estimator_desc desc;
    pgi__gpu_kernel *k[K_N];
    pgi__gpu_buffer *photons, *vs, *lobes, *out, *bounds, *frame, *grid, *cbox, *ctable, *cell_of, *counts, *ids,
        *counters;
    pgi__gpu_scan scan; /* each chunk's offset in each list */
    pgi__spec_cells cells;
    /* host-side upload arrays */
    pgi__packed_photon *packed;
    size_t packed_cap;
    pgi__gpu_vs_pack pk; /* the view samples in the shaders' form */
    uint32_t *hcell_of;
    size_t hcell_of_cap;
    uint32_t *htable;
    size_t htable_cap;
} tl_state;

static void tl_destroy(void *state) {
    tl_state *s = state;
    if (!s) return;
    for (int i = 0; i < K_N; i++) pgi__gpu_kernel_destroy(s->g, s->k[i]);
    pgi__gpu_buffer *b[] = {s->photons, s->vs,     s->lobes,   s->out,    s->bounds, s->frame,   s->grid,
                            s->cbox,    s->ctable, s->cell_of, s->counts, s->ids,    s->counters};
    for (size_t i = 0; i < sizeof b / sizeof b[0]; i++) pgi__gpu_buffer_destroy(s->g, b[i]);
    pgi__gpu_scan_destroy(&s->scan);
    pgi__spec_cells_free(&s->cells);
    pgi__afree(s->packed);
    pgi__gpu_vs_pack_free(&s->pk);
    pgi__afree(s->hcell_of);
    pgi__afree(s->htable);
    free(s);
}

static pgi_status tl_create(pgi__gpu *g, const pgi_estimator_desc *d, void **state) {
    *state = NULL;
    if (d->subsample > 1)
        return pgi__fail(PGI_ERR_UNSUPPORTED, "tiled on the GPU: --subsample is not supported (CPU only)");
    if (d->tiled.tile_size < 1)
        return pgi__fail(PGI_ERR_INVALID_ARG, "tiled on the GPU: --tile must be at least 1, got %d",
                         d->tiled.tile_size);
    tl_state *s = calloc(1, sizeof *s);
    if (!s) return pgi__fail(PGI_ERR_OOM, "out of memory");
    s->g = g;
    s->desc = *d;
    static const pgi__gpu_kernel_spec k[K_N] = {
        [K_BOUNDS] = PGI__GPU_KERNEL(tl_bounds, 2, sizeof(tl_push)),
        [K_FRAME] = PGI__GPU_KERNEL(tl_frame, 2, sizeof(tl_push)),
        [K_COUNT] = PGI__GPU_KERNEL(tl_count, 8, sizeof(tl_push)),
        [K_COPY] = PGI__GPU_KERNEL(tl_copy, 8, sizeof(tl_push)),
        [K_GATHER] = PGI__GPU_KERNEL(tl_gather, 8, sizeof(tl_push)),
    };
    pgi_status st = pgi__gpu_kernels_create(g, k, K_N, 0, s->k);
    if (!st) st = pgi__gpu_scan_create(g, "gpu_tile_offsets", &s->scan);
    if (st) {
        tl_destroy(s);
        return st;
    }
    *state = s;
    return PGI_OK;
}

/* shaders/tiled.glsl cell_hash */
static uint32_t cell_hash(uint32_t ix, uint32_t iy, uint32_t iz) {
    uint32_t h = ix * 73856093u ^ iy * 19349663u ^ iz * 83492791u;
    h ^= h >> 16;
    h *= 0x7feb352du;
    h ^= h >> 15;
    return h;
}

/* The mirror-seen samples' cells for the device: each sample's cell (cell_of) and a table from
 * cell coordinates to cell (the coordinates decoded from the CPU table's keys). */
static pgi_status pack_cells(tl_state *s, size_t ns, uint32_t *hmask) {
    const pgi__spec_cells *c = &s->cells;
    pgi_status st;
    if ((st = pgi__ensure((void **)&s->hcell_of, &s->hcell_of_cap, ns + 1, sizeof(uint32_t)))) return st;
    memset(s->hcell_of, 0, (ns + 1) * sizeof(uint32_t));
    for (uint32_t k = 0; k < c->n; k++)
        for (uint32_t m = c->start[k]; m < c->start[k + 1]; m++) s->hcell_of[c->sample[m]] = k;
    size_t tn = 16;
    while (tn < 2 * (size_t)c->n) tn <<= 1;
    if ((st = pgi__ensure((void **)&s->htable, &s->htable_cap, 4 * tn, sizeof(uint32_t)))) return st;
    memset(s->htable, 0xff, 4 * tn * sizeof(uint32_t));
    size_t found = 0;
    for (uint32_t e = 0; c->n && e <= c->hmask; e++) {
        uint64_t key = c->hkey[e];
        if (!key) continue;
        key -= 1;
        uint32_t ix = (uint32_t)(key >> 42), iy = (uint32_t)(key >> 21) & 0x1fffffu, iz = (uint32_t)key & 0x1fffffu;
        uint32_t h = cell_hash(ix, iy, iz) & (uint32_t)(tn - 1);
        while (s->htable[4 * h + 3] != UINT32_MAX) h = (h + 1) & (uint32_t)(tn - 1);
        s->htable[4 * h] = ix;
        s->htable[4 * h + 1] = iy;
        s->htable[4 * h + 2] = iz;
        s->htable[4 * h + 3] = c->hval[e];
        found++;
    }
    if (found != c->n)
        return pgi__fail(PGI_ERR_INTERNAL, "tiled on the GPU: %zu mirror cells in the table, not %u", found, c->n);
    *hmask = (uint32_t)(tn - 1);
    return PGI_OK;
}

/* the passes that are the gather (the rest is the build) */
static const char *const gather_passes[] = {"gpu_gather", NULL};

static pgi_status tl_run(void *state, const pgi_estimate_args *a, pgi_estimator_stats *es) {
    tl_state *s = state;
    pgi__gpu *g = s->g;
    pgi_status st;
    memset(es, 0, sizeof *es);
    if (a->photons->radius)
        return pgi__fail(PGI_ERR_UNSUPPORTED, "tiled on the GPU: per-photon footprints are not supported");
    const pgi_photons *ph = a->photons;
    const pgi_view_samples *vs = a->samples;
    const pgi_camera *cam = a->camera;
    if (!cam || vs->width != cam->width || vs->height != cam->height)
        return pgi__fail(PGI_ERR_INVALID_ARG, "tiled on the GPU: view samples are %dx%d but the camera is %dx%d",
                         vs->width, vs->height, cam ? cam->width : 0, cam ? cam->height : 0);
    const float r = a->radius;
    const size_t n = ph->count, ns = vs->count;
    const uint32_t W = (uint32_t)vs->width, H = (uint32_t)vs->height, T = (uint32_t)s->desc.tiled.tile_size;
    const uint32_t ntx = (W + T - 1) / T, nty = (H + T - 1) / T, ntiles = ntx * nty;
    if (n > UINT32_MAX / 4 || ns > UINT32_MAX / 4)
        return pgi__fail(PGI_ERR_UNSUPPORTED, "tiled on the GPU: at most 2^30 photons and view samples");
    const pgi__view_xf x = pgi__view_xf_make(cam, (int)W, (int)H);

    /* upload: photons in photon order, the view samples and lobes, the mirror cells (host) */
    double t0 = pgi__now_ms();
    if ((st = pgi__spec_cells_build(&s->cells, vs, &x, r, pgi__spec_cells_cap((int)ntiles), pgi__threads(a->threads))))
        return st;
    const uint32_t nlists = ntiles + s->cells.n;
    size_t chunk = (n + MAX_CHUNKS - 1) / MAX_CHUNKS;
    if (chunk < 64) chunk = 64;
    size_t nchunks = (n + chunk - 1) / chunk;
    if (nchunks == 0) nchunks = 1;
    const size_t ncounts = (size_t)nlists * nchunks;
    if (ncounts > UINT32_MAX / 4)
        return pgi__fail(PGI_ERR_UNSUPPORTED,
                         "tiled on the GPU: %u lists x %zu photon chunks is too many; use larger tiles", nlists,
                         nchunks);
    if ((st = pgi__ensure((void **)&s->packed, &s->packed_cap, n + 1, sizeof(pgi__packed_photon)))) return st;
#pragma omp parallel for schedule(static) num_threads(pgi__threads(a->threads))
    for (long long j = 0; j < (long long)n; j++) pgi__pack_photon(ph, (size_t)j, &s->packed[j]);
    size_t nlobes = 0;
    uint32_t hmask = 0;
    if ((st = pgi__gpu_pack_samples(&s->pk, vs, a->threads, &nlobes)) || (st = pack_cells(s, ns, &hmask))) return st;
    const pgi__spec_cells *c = &s->cells;
    tl_grid grid = {.o = {c->o[0], c->o[1], c->o[2]},
                    .inv_h = c->inv_h,
                    .dim = {c->dim[0], c->dim[1], c->dim[2]},
                    .n = c->n};
    memcpy(grid.lo, c->lo, sizeof grid.lo);
    memcpy(grid.hi, c->hi, sizeof grid.hi);
    const size_t psz = sizeof(pgi__packed_photon);
    if ((st = pgi__gpu_buffer_reserve(g, &s->photons, (n + 1) * psz, "gpu_photons")) ||
        (st = pgi__gpu_buffer_reserve(g, &s->vs, (ns + 1) * sizeof(gpu_vs), "gpu_view_samples")) ||
        (st = pgi__gpu_buffer_reserve(g, &s->lobes, (nlobes + 1) * sizeof(gpu_lobe), "gpu_view_samples")) ||
        (st = pgi__gpu_buffer_reserve(g, &s->out, (3 * ns + 1) * sizeof(float), "gpu_radiance")) ||
        (st = pgi__gpu_buffer_reserve(g, &s->bounds, ((size_t)ntiles + 1) * 32, "gpu_tile_bounds")) ||
        (st = pgi__gpu_buffer_reserve(g, &s->frame, 32, "gpu_tile_bounds")) ||
        (st = pgi__gpu_buffer_reserve(g, &s->grid, sizeof grid, "gpu_mirror_cells")) ||
        (st = pgi__gpu_buffer_reserve(g, &s->cbox, ((size_t)c->n + 1) * 24, "gpu_mirror_cells")) ||
        (st = pgi__gpu_buffer_reserve(g, &s->ctable, (size_t)(hmask + 1) * 16, "gpu_mirror_cells")) ||
        (st = pgi__gpu_buffer_reserve(g, &s->cell_of, (ns + 1) * 4, "gpu_mirror_cells")) ||
        (st = pgi__gpu_buffer_reserve(g, &s->counts, (ncounts + 1) * 4, "gpu_tile_offsets")) ||
        (st = pgi__gpu_buffer_reserve(g, &s->counters, 8 * 4, "gpu_tile_offsets")) ||
        (st = pgi__gpu_scan_reserve(&s->scan, ncounts + 1)))
        return st;
    if ((st = pgi__gpu_upload(g, s->photons, 0, s->packed, n * psz)) ||
        (st = pgi__gpu_upload(g, s->vs, 0, s->pk.hvs, ns * sizeof(gpu_vs))) ||
        (st = pgi__gpu_upload(g, s->lobes, 0, s->pk.hlobes, nlobes * sizeof(gpu_lobe))) ||
        (st = pgi__gpu_upload(g, s->grid, 0, &grid, sizeof grid)) ||
        (c->n && (st = pgi__gpu_upload(g, s->cbox, 0, c->box, (size_t)c->n * 24))) ||
        (st = pgi__gpu_upload(g, s->ctable, 0, s->htable, (size_t)(hmask + 1) * 16)) ||
        (st = pgi__gpu_upload(g, s->cell_of, 0, s->hcell_of, ns * 4)))
        return st;
    tl_push p = {.e = {x.eye.x, x.eye.y, x.eye.z},
                 .rt = {x.right.x, x.right.y, x.right.z},
                 .up = {x.up.x, x.up.y, x.up.z},
                 .fw = {x.fwd.x, x.fwd.y, x.fwd.z},
                 .sx = x.sx,
                 .sy = x.sy,
                 .r = r,
                 .r2 = r * r,
                 .width = W,
                 .height = H,
                 .T = T,
                 .ntx = ntx,
                 .nty = nty,
                 .ntiles = ntiles,
                 .nlists = nlists,
                 .n = (uint32_t)n,
                 .chunk = (uint32_t)chunk,
                 .nchunks = (uint32_t)nchunks,
                 .kernel = (uint32_t)s->desc.kernel,
                 .scale = pgi__kernel_norm(s->desc.kernel),
                 .hmask = hmask};
    double t1 = pgi__now_ms();

    /* sequence 1: tile bounds, counts, offsets */
    double gpu_build = 0.0, gpu_gather = 0.0;
    pgi__gpu_buffer *lists_in[8] = {s->photons, s->bounds, s->frame,  s->grid,
                                    s->cbox,    s->ctable, s->counts, s->counters};
    if ((st = pgi__gpu_begin(g))) return st;
    pgi__gpu_timestamp(g, "start");
    if ((st = pgi__gpu_fill(g, s->counts, 0, (ncounts + 1) * 4, 0)) ||
        (st = pgi__gpu_fill(g, s->counters, 0, 8 * 4, 0)) ||
        (st = pgi__gpu_dispatch_1d(g, s->k[K_BOUNDS], (pgi__gpu_buffer *[]){s->vs, s->bounds}, &p, ntiles, 64)) ||
        (st = pgi__gpu_dispatch(g, s->k[K_FRAME], (pgi__gpu_buffer *[]){s->bounds, s->frame}, &p, 1, 1, 1)))
        goto fail;
    pgi__gpu_timestamp(g, "gpu_bounds");
    if ((st = pgi__gpu_dispatch_1d(g, s->k[K_COUNT], lists_in, &p, nchunks, 64))) goto fail;
    pgi__gpu_timestamp(g, "gpu_count");
    if ((st = pgi__gpu_scan_record(&s->scan, s->counts))) goto fail;
    pgi__gpu_timestamp(g, "gpu_scan");
    double t2 = pgi__now_ms();
    if ((st = pgi__gpu_submit_wait(g))) return st;
    double t3 = pgi__now_ms();
    pgi__gpu_est_add_timings(g, es, gather_passes, &gpu_build, &gpu_gather);
    uint32_t copies = 0, tested[2];
    if ((st = pgi__gpu_download(g, s->counts, ncounts * 4, &copies, 4)) ||
        (st = pgi__gpu_download(g, s->counters, 6 * 4, tested, sizeof tested)))
        return st;
    /* every list test is a copy: the 64-bit count catches a scan that wrapped */
    const uint64_t ncopies = pgi__gpu_u64(tested);
    if (ncopies > UINT32_MAX / 4)
        return pgi__fail(PGI_ERR_UNSUPPORTED,
                         "tiled on the GPU: %llu photon copies (at most 2^30); use a smaller radius or larger tiles",
                         (unsigned long long)ncopies);
    PGI__ASSERT(ncopies == copies);
    if ((st = pgi__gpu_buffer_reserve(g, &s->ids, ((size_t)copies + 1) * 4, "gpu_tile_photons"))) return st;

    /* sequence 2: the lists (photon order), the gather */
    double t4 = pgi__now_ms();
    if ((st = pgi__gpu_begin(g))) return st;
    pgi__gpu_timestamp(g, "start");
    lists_in[7] = s->ids;
    if ((st = pgi__gpu_dispatch_1d(g, s->k[K_COPY], lists_in, &p, nchunks, 64))) goto fail;
    pgi__gpu_timestamp(g, "gpu_copy");
    if ((st = pgi__gpu_dispatch(g, s->k[K_GATHER],
                                (pgi__gpu_buffer *[]){s->vs, s->lobes, s->photons, s->counts, s->ids, s->cell_of,
                                                      s->out, s->counters},
                                &p, (W + 7) / 8, (H + 7) / 8, 1)))
        goto fail;
    pgi__gpu_timestamp(g, "gpu_gather");
    double t5 = pgi__now_ms();
    if ((st = pgi__gpu_submit_wait(g))) return st;
    double t6 = pgi__now_ms();
    pgi__gpu_est_add_timings(g, es, gather_passes, &gpu_build, &gpu_gather);
    uint32_t cnt[8];
    if ((st = pgi__gpu_download(g, s->out, 0, a->out_rgb, 3 * ns * sizeof(float))) ||
        (st = pgi__gpu_download(g, s->counters, 0, cnt, sizeof cnt)))
        return st;
    double t7 = pgi__now_ms();

    /* stats: host passes (wall clock) and the device's (timestamps) */
    pgi__gpu_est_two_sequence_times(g, es, (double[8]){t0, t1, t2, t3, t4, t5, t6, t7}, gpu_build, gpu_gather);
    es->reads = pgi__gpu_u64(cnt);
    es->contributing = pgi__gpu_u64(cnt + 2);
    es->nodes_visited = pgi__gpu_u64(cnt + 6);
    pgi__stats_mem(es, "gpu_host_upload",
                   s->packed_cap * sizeof(pgi__packed_photon) + s->pk.hvs_cap * sizeof(gpu_vs) +
                       s->pk.hlobes_cap * sizeof(gpu_lobe) + (s->pk.lobe_of_cap + s->hcell_of_cap + s->htable_cap) * 4);
    pgi__stats_mem(es, "specular_cells", pgi__spec_cells_bytes(&s->cells));
    return PGI_OK;
fail:
    /* close the sequence so that the next frame can begin one */
    (void)pgi__gpu_submit_wait(g);
    return st;
}

#endif /* PGI__HAVE_VULKAN */

const pgi__gpu_est_vtbl pgi__gpu_est_tiled = {
    .name = "tiled",
    .create = tl_create,
    .run = tl_run,
    .destroy = tl_destroy,
};
