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

#ifndef PGI__HAVE_VULKAN

const pgi__gpu_est_vtbl pgi__gpu_est_tiled = PGI__GPU_EST_NONE("tiled");

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
    uint32_t G, mode;
} tl_push;
_Static_assert(sizeof(tl_push) == 120 && offsetof(tl_push, sx) == 48 && offsetof(tl_push, width) == 64 &&
                   offsetof(tl_push, kernel) == 104 && offsetof(tl_push, G) == 112,
               "tiled.glsl Push");

#define GRID_BYTES 56 /* shaders/tiled.glsl CellGrid: lo, hi, o, inv_h, dim, n */

enum { K_CELLS, K_BOUNDS, K_FRAME, K_COUNT, K_COPY, K_GATHER, K_N };

/* A frame: the push constants, its sizes, the inputs it reads, the clocks. */
typedef struct tl_frame {
    tl_push p;
    size_t n, ns, ncells, ncounts;
    uint32_t copies;
    pgi__gpu_buffer *vs, *lobes;
    double t[8]; /* host: upload t0..t1, sequence 1 t2..t3, sequence 2 t4..t6, read back t7 */
    double gpu_build, gpu_gather;
} tl_frame;

typedef struct {
    pgi__gpu *g;
    pgi_estimator_desc desc;
    pgi__gpu_kernel *k[K_N];
    pgi__gpu_buffer *photons, *vs, *lobes, *out, *bounds, *frame, *grid, *cord, *cbox, *cell_of, *counts, *ids,
        *counters;
    pgi__gpu_scan scan; /* each chunk's offset in each list */
    /* host-side upload arrays (pgi_estimate_args inputs) */
    pgi__packed_photon *packed;
    size_t packed_cap;
    pgi__gpu_vs_pack pk; /* the view samples in the shaders' form */
    /* device inputs: the frame device_reserve built, its sequence's passes (for device_finish) */
    tl_frame dev;
    pgi_estimator_stats dev_es;
} tl_state;

static void tl_destroy(void *state) {
    tl_state *s = state;
    if (!s) return;
    for (int i = 0; i < K_N; i++) pgi__gpu_kernel_destroy(s->g, s->k[i]);
    pgi__gpu_buffer *b[] = {s->photons, s->vs,   s->lobes,   s->out,    s->bounds, s->frame,   s->grid,
                            s->cord,    s->cbox, s->cell_of, s->counts, s->ids,    s->counters};
    for (size_t i = 0; i < sizeof b / sizeof b[0]; i++) pgi__gpu_buffer_destroy(s->g, b[i]);
    pgi__gpu_scan_destroy(&s->scan);
    pgi__afree(s->packed);
    pgi__gpu_vs_pack_free(&s->pk);
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
        [K_CELLS] = PGI__GPU_KERNEL(tl_cells, 5, sizeof(tl_push)),
        [K_BOUNDS] = PGI__GPU_KERNEL(tl_bounds, 2, sizeof(tl_push)),
        [K_FRAME] = PGI__GPU_KERNEL(tl_frame, 2, sizeof(tl_push)),
        [K_COUNT] = PGI__GPU_KERNEL(tl_count, 7, sizeof(tl_push)),
        [K_COPY] = PGI__GPU_KERNEL(tl_copy, 7, sizeof(tl_push)),
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

/* the passes that are the gather (the rest is the build) */
static const char *const gather_passes[] = {"gpu_gather", NULL};
/* every pass this estimator times (device_finish keeps these from the caller's sequence) */
static const char *const own_passes[] = {"gpu_cells", "gpu_bounds", "gpu_count", "gpu_scan",
                                         "gpu_copy",  "gpu_gather", NULL};


/* The frame's sizes and push constants; every buffer but the inputs' and the lists' reserved. */
static pgi_status tl_plan(tl_state *s, const pgi__gpu_est_in *in, tl_frame *f) {
    pgi__gpu *g = s->g;
    const pgi_camera *cam = in->cam;
    if (!cam || in->width != cam->width || in->height != cam->height)
        return pgi__fail(PGI_ERR_INVALID_ARG, "tiled on the GPU: view samples are %dx%d but the camera is %dx%d",
                         in->width, in->height, cam ? cam->width : 0, cam ? cam->height : 0);
    const float r = in->radius;
    const size_t n = in->n, ns = (size_t)in->width * (size_t)in->height;
    const uint32_t W = (uint32_t)in->width, H = (uint32_t)in->height, T = (uint32_t)s->desc.tiled.tile_size;
    const uint32_t ntx = (W + T - 1) / T, nty = (H + T - 1) / T, ntiles = ntx * nty;
    if (n > UINT32_MAX / 4 || ns > UINT32_MAX / 4)
        return pgi__fail(PGI_ERR_UNSUPPORTED, "tiled on the GPU: at most 2^30 photons and view samples");
    const pgi__view_xf x = pgi__view_xf_make(cam, (int)W, (int)H);
    /* mirror cells: a dense grid of G^3 cells, G^3 <= max(tiles, 512), 8..20 a side (every cell is a
     * list, scanned with the tiles': cells finer than the grid's would cost the scan more than they
     * save the gather) */
    uint32_t G = 8;
    while (G < 20 && (size_t)(G + 1) * (G + 1) * (G + 1) <= ntiles) G++;
    const size_t ncells = (size_t)G * G * G;
    const size_t nlists = ntiles + ncells;
    size_t chunk = (n + MAX_CHUNKS - 1) / MAX_CHUNKS;
    if (chunk < 64) chunk = 64;
    size_t nchunks = (n + chunk - 1) / chunk;
    if (nchunks == 0) nchunks = 1;
    const size_t ncounts = nlists * nchunks;
    if (ncounts > UINT32_MAX / 4)
        return pgi__fail(PGI_ERR_UNSUPPORTED,
                         "tiled on the GPU: %zu lists x %zu photon chunks is too many; use larger tiles", nlists,
                         nchunks);
    *f = (tl_frame){.n = n, .ns = ns, .ncells = ncells, .ncounts = ncounts, .vs = s->vs, .lobes = s->lobes};
    f->p = (tl_push){.e = {x.eye.x, x.eye.y, x.eye.z},
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
                     .nlists = (uint32_t)nlists,
                     .n = (uint32_t)n,
                     .chunk = (uint32_t)chunk,
                     .nchunks = (uint32_t)nchunks,
                     .kernel = (uint32_t)s->desc.kernel,
                     .scale = pgi__kernel_norm(s->desc.kernel),
                     .G = G};
    pgi_status st;
    if ((st = pgi__gpu_buffer_reserve(g, &s->out, (3 * ns + 1) * sizeof(float), "gpu_radiance")) ||
        (st = pgi__gpu_buffer_reserve(g, &s->bounds, ((size_t)ntiles + 1) * 32, "gpu_tile_bounds")) ||
        (st = pgi__gpu_buffer_reserve(g, &s->frame, 32, "gpu_tile_bounds")) ||
        (st = pgi__gpu_buffer_reserve(g, &s->grid, GRID_BYTES, "gpu_mirror_cells")) ||
        (st = pgi__gpu_buffer_reserve(g, &s->cord, (6 + 6 * ncells) * 4, "gpu_mirror_cells")) ||
        (st = pgi__gpu_buffer_reserve(g, &s->cbox, 6 * ncells * 4, "gpu_mirror_cells")) ||
        (st = pgi__gpu_buffer_reserve(g, &s->cell_of, (ns + 1) * 4, "gpu_mirror_cells")) ||
        (st = pgi__gpu_buffer_reserve(g, &s->counts, (ncounts + 1) * 4, "gpu_tile_offsets")) ||
        (st = pgi__gpu_buffer_reserve(g, &s->counters, 8 * 4, "gpu_tile_offsets")) ||
        (st = pgi__gpu_scan_reserve(&s->scan, ncounts + 1)))
        return st;
    return PGI_OK;
}

/* pgi_estimate_args inputs: photons in photon order, the view samples and lobes uploaded */
static pgi_status tl_upload(tl_state *s, const pgi_estimate_args *a, tl_frame *f) {
    f->t[0] = pgi__now_ms();
    pgi_status st = pgi__gpu_est_upload(s->g, a, &s->packed, &s->packed_cap, &s->pk, &s->photons, &s->vs, &s->lobes);
    if (st) return st;
    f->vs = s->vs;
    f->lobes = s->lobes;
    f->t[1] = pgi__now_ms();
    return PGI_OK;
}

/* Records sequence 1: the mirror cells, tile bounds, counts, offsets. */
static pgi_status record_counts(void *state, const void *frame, pgi__gpu_buffer *photons) {
    tl_state *s = state;
    const tl_frame *f = frame;
    pgi__gpu *g = s->g;
    pgi_status st;
    tl_push q = f->p;
    pgi__gpu_buffer *cells[5] = {f->vs, s->cord, s->grid, s->cbox, s->cell_of};
    if ((st = pgi__gpu_fill(g, s->counts, 0, (f->ncounts + 1) * 4, 0)) ||
        (st = pgi__gpu_fill(g, s->counters, 0, 8 * 4, 0)) ||
        (st = pgi__gpu_fill(g, s->cord, 0, (6 + 6 * f->ncells) * 4, 0xffffffffu))) /* empty boxes */
        return st;
    const size_t items[4] = {f->ns, 1, f->ns, f->ncells};
    for (uint32_t m = 0; m < 4; m++) {
        q.mode = m;
        if ((st = pgi__gpu_dispatch_1d(g, s->k[K_CELLS], cells, &q, items[m], 64))) return st;
    }
    pgi__gpu_timestamp(g, "gpu_cells");
    if ((st = pgi__gpu_dispatch_1d(g, s->k[K_BOUNDS], (pgi__gpu_buffer *[]){f->vs, s->bounds}, &f->p, f->p.ntiles,
                                   64)) ||
        (st = pgi__gpu_dispatch(g, s->k[K_FRAME], (pgi__gpu_buffer *[]){s->bounds, s->frame}, &f->p, 1, 1, 1)))
        return st;
    pgi__gpu_timestamp(g, "gpu_bounds");
    pgi__gpu_buffer *lists[7] = {photons, s->bounds, s->frame, s->grid, s->cbox, s->counts, s->counters};
    if ((st = pgi__gpu_dispatch_1d(g, s->k[K_COUNT], lists, &f->p, f->p.nchunks, 64))) return st;
    pgi__gpu_timestamp(g, "gpu_count");
    if ((st = pgi__gpu_scan_record(&s->scan, s->counts))) return st;
    pgi__gpu_timestamp(g, "gpu_scan");
    return PGI_OK;
}

/* sequence 1, then the number of copies read back (8 + 4 bytes) and the lists' buffer sized to it */
static pgi_status tl_build(tl_state *s, tl_frame *f, pgi__gpu_buffer *photons, pgi_estimator_stats *es) {
    pgi_status st = pgi__gpu_est_sequence(s->g, record_counts, s, f, photons, f->t + 2, es, gather_passes,
                                          &f->gpu_build, &f->gpu_gather);
    return st ? st : pgi__gpu_est_copies(s->g, "tiled", s->counts, f->ncounts, s->counters, &s->ids, &f->copies);
}

/* Records sequence 2's work: the lists (photon order), the gather. */
static pgi_status record_gather(void *state, const void *frame, pgi__gpu_buffer *photons) {
    tl_state *s = state;
    const tl_frame *f = frame;
    pgi__gpu *g = s->g;
    pgi_status st;
    pgi__gpu_buffer *lists[7] = {photons, s->bounds, s->frame, s->grid, s->cbox, s->counts, s->ids};
    if ((st = pgi__gpu_dispatch_1d(g, s->k[K_COPY], lists, &f->p, f->p.nchunks, 64))) return st;
    pgi__gpu_timestamp(g, "gpu_copy");
    if ((st = pgi__gpu_dispatch(g, s->k[K_GATHER],
                                (pgi__gpu_buffer *[]){f->vs, f->lobes, photons, s->counts, s->ids, s->cell_of, s->out,
                                                      s->counters},
                                &f->p, (f->p.width + 7) / 8, (f->p.height + 7) / 8, 1)))
        return st;
    pgi__gpu_timestamp(g, "gpu_gather");
    return PGI_OK;
}

/* The counters (photons read, contributing, lists tested) into the stats. */
static pgi_status tl_counters(tl_state *s, pgi_estimator_stats *es) {
    uint32_t cnt[8];
    pgi_status st = pgi__gpu_download(s->g, s->counters, 0, cnt, sizeof cnt);
    if (st) return st;
    es->reads = pgi__gpu_u64(cnt);
    es->contributing = pgi__gpu_u64(cnt + 2);
    es->nodes_visited = pgi__gpu_u64(cnt + 6);
    return PGI_OK;
}

static pgi_status tl_run(void *state, const pgi_estimate_args *a, pgi_estimator_stats *es) {
    tl_state *s = state;
    pgi__gpu *g = s->g;
    pgi_status st;
    memset(es, 0, sizeof *es);
    if (a->photons->radius)
        return pgi__fail(PGI_ERR_UNSUPPORTED, "tiled on the GPU: per-photon footprints are not supported");
    const pgi__gpu_est_in in = pgi__gpu_est_in_args(a);
    tl_frame f;
    if ((st = tl_plan(s, &in, &f)) || (st = tl_upload(s, a, &f)) || (st = tl_build(s, &f, s->photons, es))) return st;
    f.t[4] = pgi__now_ms();
    if ((st = pgi__gpu_est_sequence(g, record_gather, s, &f, s->photons, f.t + 5, es, gather_passes, &f.gpu_build,
                                    &f.gpu_gather)))
        return st;
    if ((st = pgi__gpu_download(g, s->out, 0, a->out_rgb, 3 * f.ns * sizeof(float))) || (st = tl_counters(s, es)))
        return st;
    f.t[7] = pgi__now_ms();

    /* stats: host passes (wall clock) and the device's (timestamps) */
    pgi__gpu_est_two_sequence_times(g, es, f.t, f.gpu_build, f.gpu_gather);
    pgi__stats_mem(es, "gpu_host_upload", s->packed_cap * sizeof(pgi__packed_photon) + pgi__gpu_vs_pack_bytes(&s->pk));
    return PGI_OK;
}

/* Device inputs: sequence 1 (cells, bounds, counts, offsets) runs here on the frame's photons and
 * view samples, and the number of copies comes back to size the lists. */
static pgi_status tl_device_reserve(void *state, const pgi__gpu_est_inputs *in, pgi__gpu_buffer **out) {
    tl_state *s = state;
    pgi_status st;
    memset(&s->dev_es, 0, sizeof s->dev_es);
    const pgi__gpu_est_in ti = pgi__gpu_est_in_device(in);
    tl_frame *f = &s->dev;
    if ((st = tl_plan(s, &ti, f))) return st;
    f->vs = in->samples;
    f->lobes = in->lobes;
    f->t[0] = f->t[1] = pgi__now_ms();
    if ((st = tl_build(s, f, in->photons, &s->dev_es))) return st;
    *out = s->out;
    return PGI_OK;
}

static pgi_status tl_device_record(void *state, const pgi__gpu_est_inputs *in) {
    tl_state *s = state;
    if (in->nphotons != s->dev.n || in->samples != s->dev.vs)
        return pgi__fail(PGI_ERR_INTERNAL, "tiled on the GPU: recorded on inputs it was not reserved for");
    return record_gather(s, &s->dev, in->photons);
}

static pgi_status tl_device_finish(void *state, const pgi_named_value *t, int nt, pgi_estimator_stats *es) {
    tl_state *s = state;
    tl_frame *f = &s->dev; /* its stats: sequence 1's passes, then its own of the caller's sequence */
    pgi__gpu_est_finish(s->g, es, &s->dev_es, t, nt, own_passes, gather_passes, f->t, &f->gpu_build, &f->gpu_gather);
    return tl_counters(s, es);
}


const pgi__gpu_est_vtbl pgi__gpu_est_tiled = {
    .name = "tiled",
    .create = tl_create,
    .run = tl_run,
    .destroy = tl_destroy,
    .device_reserve = tl_device_reserve,
    .device_record = tl_device_record,
    .device_finish = tl_device_finish,
};

#endif /* PGI__HAVE_VULKAN */
