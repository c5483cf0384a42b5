/* bounds3d and bounds25d on the GPU (docs/gpu.md): the CPU estimators' method (src/estimators/
 * est_bounds.c; Mara et al. 2013 §2.2, Mara & McGuire 2013) on the device, exact like them.
 *
 * Photon-major scatter: every photon's sphere is bounded on the screen (bounds3d: the projected
 * circumscribed icosahedron's convex hull; bounds25d: the tight N-gon and the sphere's depth range;
 * the clipped case for spheres reaching the eye plane), and every pixel the bound covers is tested.
 * Screen tiles of T x T pixels (--tile, default 32) bin the photons; samples seen through mirrors or
 * glass are grouped in tiled's view-space cells (tl_cells.comp), one more bin per cell, whose
 * photons are tested against every sample of the cell (they are not where their pixel's ray says).
 * One command sequence builds the bins' sizes:
 *   tl_cells    the mirror-seen samples' cells (GPU tiled's pass)
 *   tl_bounds   per tile, whether it has valid primary samples (GPU tiled's pass: its box's flag)
 *   bd_shape    per photon, its bound (shaders/bounds.glsl make_shape: est_bounds.c's, in float)
 *   bd_count    per chunk of photons (one invocation a chunk, photons in order): the tiles under the
 *               bound's rectangle with primary samples, then the cells its sphere reaches
 *               (est_bounds.c FOR_EACH_BIN: shaders/bd_lists.glsl); counts[bin][chunk], no atomics
 *   hg_scan     exclusive prefix sum over (bin, chunk)
 * then, after reading back the number of copies (the bins' buffer sized to it), a second one:
 *   bd_copy     the same walk, each photon's index at its chunk's next offset: bins in photon order
 *   bd_gather   per view sample: its tile's bin, each photon whose bound covers the pixel (2.5D:
 *               and whose depth range holds the sample) through gather.glsl's test and sums (tiles
 *               a multiple of 8 pixels: the bin through shared memory, 64 photons at a time, those
 *               whose rectangle reaches the workgroup's 8 x 8 block kept in a mask walked in order);
 *               a mirror-seen sample: its cell's bin, every photon
 * Every float sum is in photon order: the same image bit for bit every run. Exactness: the bounds
 * are conservative (padded sphere, 0.05 pixel and the jitter, as the CPU's; the clipped case with
 * a larger radius and no bound from a wedge end near the eye plane), so no photon the gather accepts
 * is left out. Stats as the CPU's: reads = sphere tests, contributing, nodes_visited = covered pixels
 * with a valid primary sample (before the depth test).
 * Limits: at most 4096 chunks of photons; --subsample and per-photon footprints are refused, as are
 * more than 2^30 photon copies or (bin, chunk) counts. */
#include "gpu/gpu_estimator.h"
#include "gpu/gpu_scan.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "core/core.h"
#include "estimators/estimator_internal.h"

#ifndef PGI__HAVE_VULKAN

const pgi__gpu_est_vtbl pgi__gpu_est_bounds3d = PGI__GPU_EST_NONE("bounds3d");
const pgi__gpu_est_vtbl pgi__gpu_est_bounds25d = PGI__GPU_EST_NONE("bounds25d");

#else

#include "gpu/spirv.h"

#define MAX_CHUNKS 4096u /* count/copy invocations */
#define SHAPE_HEAD 12    /* shaders/bounds.glsl BD_HEAD */

/* shaders/tiled.glsl Push (the tl_cells and tl_bounds passes read it too) */
typedef struct {
    float e[3], rt[3], up[3], fw[3];
    float sx, sy, r, r2;
    uint32_t width, height, T, ntx, nty, ntiles, nlists, n, chunk, nchunks, kernel;
    float scale;
    uint32_t G, mode;
} bd_push;
_Static_assert(sizeof(bd_push) == 120 && offsetof(bd_push, sx) == 48 && offsetof(bd_push, width) == 64 &&
                   offsetof(bd_push, kernel) == 104 && offsetof(bd_push, G) == 112,
               "tiled.glsl Push");

/* shaders/bounds.glsl BdParams */
typedef struct {
    float jitter;
    uint32_t mode3d, nverts, stride;
    float cs[32], sn[32], ccs[32], csn[32];
} bd_params;
_Static_assert(sizeof(bd_params) == 528, "bounds.glsl BdParams");

#define GRID_BYTES 56 /* shaders/tiled.glsl CellGrid */

enum { K_CELLS, K_BOUNDS, K_SHAPE, K_COUNT, K_COPY, K_GATHER, K_N };

typedef struct bd_frame {
    bd_push p;
    bd_params prm;
    size_t n, ns, ncells, ncounts;
    uint32_t copies;
    pgi__gpu_buffer *vs, *lobes;
    double t[8]; /* host: upload t0..t1, sequence 1 t2..t3, sequence 2 t4..t6, read back t7 */
    double gpu_build, gpu_gather;
} bd_frame;

typedef struct {
    pgi__gpu *g;
    pgi_estimator_desc desc;
    int mode3d;
    const char *name;
    pgi__gpu_kernel *k[K_N];
    pgi__gpu_buffer *photons, *vs, *lobes, *out, *bounds, *grid, *cord, *cbox, *cell_of, *counts, *ids, *counters,
        *shapes, *params;
    pgi__gpu_scan scan;
    pgi__packed_photon *packed;
    size_t packed_cap;
    pgi__gpu_vs_pack pk;
    bd_frame dev;
    pgi_estimator_stats dev_es;
} bd_state;

static void bd_destroy(void *state) {
    bd_state *s = state;
    if (!s) return;
    for (int i = 0; i < K_N; i++) pgi__gpu_kernel_destroy(s->g, s->k[i]);
    pgi__gpu_buffer *b[] = {s->photons, s->vs,      s->lobes,  s->out, s->bounds,   s->grid,   s->cord,
                            s->cbox,    s->cell_of, s->counts, s->ids, s->counters, s->shapes, s->params};
    for (size_t i = 0; i < sizeof b / sizeof b[0]; i++) pgi__gpu_buffer_destroy(s->g, b[i]);
    pgi__gpu_scan_destroy(&s->scan);
    pgi__afree(s->packed);
    pgi__gpu_vs_pack_free(&s->pk);
    free(s);
}

static pgi_status bd_create(pgi__gpu *g, const pgi_estimator_desc *d, void **state, int mode3d) {
    *state = NULL;
    const char *name = mode3d ? "bounds3d" : "bounds25d";
    if (d->subsample > 1)
        return pgi__fail(PGI_ERR_UNSUPPORTED, "%s on the GPU: --subsample is not supported (CPU only)", name);
    if (d->tiled.tile_size < 1)
        return pgi__fail(PGI_ERR_INVALID_ARG, "%s on the GPU: --tile must be at least 1, got %d", name,
                         d->tiled.tile_size);
    if (!mode3d && (d->bounds.polygon < 4 || d->bounds.polygon > 64 || d->bounds.polygon % 2))
        return pgi__fail(PGI_ERR_INVALID_ARG, "%s on the GPU: --polygon must be even, 4..64, got %d", name,
                         d->bounds.polygon);
    bd_state *s = calloc(1, sizeof *s);
    if (!s) return pgi__fail(PGI_ERR_OOM, "out of memory");
    s->g = g;
    s->desc = *d;
    s->mode3d = mode3d;
    s->name = name;
    static const pgi__gpu_kernel_spec k[K_N] = {
        [K_CELLS] = PGI__GPU_KERNEL(tl_cells, 5, sizeof(bd_push)),
        [K_BOUNDS] = PGI__GPU_KERNEL(tl_bounds, 2, sizeof(bd_push)),
        [K_SHAPE] = PGI__GPU_KERNEL(bd_shape, 3, sizeof(bd_push)),
        [K_COUNT] = PGI__GPU_KERNEL(bd_count, 7, sizeof(bd_push)),
        [K_COPY] = PGI__GPU_KERNEL(bd_copy, 7, sizeof(bd_push)),
        [K_GATHER] = PGI__GPU_KERNEL(bd_gather, 10, sizeof(bd_push)),
    };
    pgi_status st = pgi__gpu_kernels_create(g, k, K_N, 0, s->k);
    if (!st) st = pgi__gpu_scan_create(g, "gpu_tile_offsets", &s->scan);
    if (st) {
        bd_destroy(s);
        return st;
    }
    *state = s;
    return PGI_OK;
}
static pgi_status bd_create3(pgi__gpu *g, const pgi_estimator_desc *d, void **state) {
    return bd_create(g, d, state, 1);
}
static pgi_status bd_create25(pgi__gpu *g, const pgi_estimator_desc *d, void **state) {
    return bd_create(g, d, state, 0);
}

static const char *const gather_passes[] = {"gpu_gather", NULL};
static const char *const own_passes[] = {"gpu_cells", "gpu_bounds", "gpu_shape",  "gpu_count",
                                         "gpu_scan",  "gpu_copy",   "gpu_gather", NULL};


/* The frame's sizes, push constants and parameters (uploaded); every buffer but the inputs' and
 * the bins' reserved. */
static pgi_status bd_plan(bd_state *s, const pgi__gpu_est_in *in, bd_frame *f) {
    pgi__gpu *g = s->g;
    const pgi_camera *cam = in->cam;
    if (!cam || in->width != cam->width || in->height != cam->height)
        return pgi__fail(PGI_ERR_INVALID_ARG, "%s on the GPU: view samples are %dx%d but the camera is %dx%d", s->name,
                         in->width, in->height, cam ? cam->width : 0, cam ? cam->height : 0);
    const float r = in->radius;
    const size_t n = in->n, ns = (size_t)in->width * (size_t)in->height;
    const uint32_t W = (uint32_t)in->width, H = (uint32_t)in->height, T = (uint32_t)s->desc.tiled.tile_size;
    const uint32_t ntx = (W + T - 1) / T, nty = (H + T - 1) / T, ntiles = ntx * nty;
    if (n > UINT32_MAX / 4 || ns > UINT32_MAX / 4)
        return pgi__fail(PGI_ERR_UNSUPPORTED, "%s on the GPU: at most 2^30 photons and view samples", s->name);
    const pgi__view_xf x = pgi__view_xf_make(cam, (int)W, (int)H);
    uint32_t G = 8; /* mirror cells: as GPU tiled's */
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
                         "%s on the GPU: %zu bins x %zu photon chunks is too many; use larger tiles", s->name, nlists,
                         nchunks);
    *f = (bd_frame){.n = n, .ns = ns, .ncells = ncells, .ncounts = ncounts, .vs = s->vs, .lobes = s->lobes};
    f->p = (bd_push){.e = {x.eye.x, x.eye.y, x.eye.z},
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
    /* est_bounds.c's slices: make_shape's in float, clipped_shape's in double */
    bd_params *q = &f->prm;
    const int nverts = s->mode3d ? 0 : s->desc.bounds.polygon;
    const int m = nverts / 2, mc = s->mode3d ? 2 : m;
    const size_t maxe = s->mode3d ? 12 : (size_t)nverts;
    q->jitter = in->jitter;
    q->mode3d = (uint32_t)s->mode3d;
    q->nverts = (uint32_t)nverts;
    q->stride = (uint32_t)(SHAPE_HEAD + 3 * maxe);
    for (int k = 0; k < m; k++) {
        float th = PGI__PI * (float)k / (float)m;
        q->cs[k] = cosf(th);
        q->sn[k] = sinf(th);
    }
    for (int k = 0; k < mc; k++) {
        double th = 3.14159265358979323846 * (double)k / (double)mc;
        q->ccs[k] = (float)cos(th);
        q->csn[k] = (float)sin(th);
    }
    if ((n + 1) * q->stride > UINT32_MAX) /* the shaders index the shapes with 32 bits */
        return pgi__fail(PGI_ERR_UNSUPPORTED, "%s on the GPU: at most %zu photons with %zu-float bounds", s->name,
                         (size_t)(UINT32_MAX / q->stride) - 1, (size_t)q->stride);
    pgi_status st;
    if ((st = pgi__gpu_buffer_reserve(g, &s->out, (3 * ns + 1) * sizeof(float), "gpu_radiance")) ||
        (st = pgi__gpu_buffer_reserve(g, &s->bounds, ((size_t)ntiles + 1) * 32, "gpu_tile_bounds")) ||
        (st = pgi__gpu_buffer_reserve(g, &s->grid, GRID_BYTES, "gpu_mirror_cells")) ||
        (st = pgi__gpu_buffer_reserve(g, &s->cord, (6 + 6 * ncells) * 4, "gpu_mirror_cells")) ||
        (st = pgi__gpu_buffer_reserve(g, &s->cbox, 6 * ncells * 4, "gpu_mirror_cells")) ||
        (st = pgi__gpu_buffer_reserve(g, &s->cell_of, (ns + 1) * 4, "gpu_mirror_cells")) ||
        (st = pgi__gpu_buffer_reserve(g, &s->counts, (ncounts + 1) * 4, "gpu_tile_offsets")) ||
        (st = pgi__gpu_buffer_reserve(g, &s->counters, 8 * 4, "gpu_tile_offsets")) ||
        (st = pgi__gpu_buffer_reserve(g, &s->shapes, (n + 1) * q->stride * sizeof(float), "gpu_photon_bounds")) ||
        (st = pgi__gpu_buffer_reserve(g, &s->params, sizeof *q, "gpu_photon_bounds")) ||
        (st = pgi__gpu_upload(g, s->params, 0, q, sizeof *q)) || (st = pgi__gpu_scan_reserve(&s->scan, ncounts + 1)))
        return st;
    return PGI_OK;
}

/* pgi_estimate_args inputs: photons in photon order, the view samples and lobes uploaded */
static pgi_status bd_upload(bd_state *s, const pgi_estimate_args *a, bd_frame *f) {
    f->t[0] = pgi__now_ms();
    pgi_status st = pgi__gpu_est_upload(s->g, a, &s->packed, &s->packed_cap, &s->pk, &s->photons, &s->vs, &s->lobes);
    if (st) return st;
    f->vs = s->vs;
    f->lobes = s->lobes;
    f->t[1] = pgi__now_ms();
    return PGI_OK;
}

/* Records sequence 1: the mirror cells, the tiles' flags, the shapes, counts, offsets. */
static pgi_status record_counts(void *state, const void *frame, pgi__gpu_buffer *photons) {
    bd_state *s = state;
    const bd_frame *f = frame;
    pgi__gpu *g = s->g;
    pgi_status st;
    bd_push q = f->p;
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
    if ((st = pgi__gpu_dispatch_1d(g, s->k[K_BOUNDS], (pgi__gpu_buffer *[]){f->vs, s->bounds}, &f->p, f->p.ntiles, 64)))
        return st;
    pgi__gpu_timestamp(g, "gpu_bounds");
    if (f->n && (st = pgi__gpu_dispatch_1d(g, s->k[K_SHAPE], (pgi__gpu_buffer *[]){photons, s->params, s->shapes},
                                           &f->p, f->n, 64)))
        return st;
    pgi__gpu_timestamp(g, "gpu_shape");
    pgi__gpu_buffer *lists[7] = {s->shapes, s->bounds, s->params, s->grid, s->cbox, s->counts, s->counters};
    if ((st = pgi__gpu_dispatch_1d(g, s->k[K_COUNT], lists, &f->p, f->p.nchunks, 64))) return st;
    pgi__gpu_timestamp(g, "gpu_count");
    if ((st = pgi__gpu_scan_record(&s->scan, s->counts))) return st;
    pgi__gpu_timestamp(g, "gpu_scan");
    return PGI_OK;
}

/* sequence 1, then the number of copies read back and the bins' buffer sized to it */
static pgi_status bd_build(bd_state *s, bd_frame *f, pgi__gpu_buffer *photons, pgi_estimator_stats *es) {
    pgi_status st = pgi__gpu_est_sequence(s->g, record_counts, s, f, photons, f->t + 2, es, gather_passes,
                                          &f->gpu_build, &f->gpu_gather);
    return st ? st : pgi__gpu_est_copies(s->g, s->name, s->counts, f->ncounts, s->counters, &s->ids, &f->copies);
}

/* Records sequence 2's work: the bins (photon order), the gather. */
static pgi_status record_gather(void *state, const void *frame, pgi__gpu_buffer *photons) {
    bd_state *s = state;
    const bd_frame *f = frame;
    pgi__gpu *g = s->g;
    pgi_status st;
    pgi__gpu_buffer *lists[7] = {s->shapes, s->bounds, s->params, s->grid, s->cbox, s->counts, s->ids};
    if ((st = pgi__gpu_dispatch_1d(g, s->k[K_COPY], lists, &f->p, f->p.nchunks, 64))) return st;
    pgi__gpu_timestamp(g, "gpu_copy");
    if ((st = pgi__gpu_dispatch(g, s->k[K_GATHER],
                                (pgi__gpu_buffer *[]){f->vs, f->lobes, photons, s->counts, s->ids, s->cell_of, s->out,
                                                      s->counters, s->params, s->shapes},
                                &f->p, (f->p.width + 7) / 8, (f->p.height + 7) / 8, 1)))
        return st;
    pgi__gpu_timestamp(g, "gpu_gather");
    return PGI_OK;
}

/* The counters (sphere tests, contributing, covered pixels) into the stats. */
static pgi_status bd_counters(bd_state *s, pgi_estimator_stats *es) {
    uint32_t cnt[8];
    pgi_status st = pgi__gpu_download(s->g, s->counters, 0, cnt, sizeof cnt);
    if (st) return st;
    es->reads = pgi__gpu_u64(cnt);
    es->contributing = pgi__gpu_u64(cnt + 2);
    es->nodes_visited = pgi__gpu_u64(cnt + 4);
    return PGI_OK;
}

static pgi_status bd_run(void *state, const pgi_estimate_args *a, pgi_estimator_stats *es) {
    bd_state *s = state;
    pgi__gpu *g = s->g;
    pgi_status st;
    memset(es, 0, sizeof *es);
    if (a->photons->radius)
        return pgi__fail(PGI_ERR_UNSUPPORTED, "%s on the GPU: per-photon footprints are not supported", s->name);
    const pgi__gpu_est_in in = pgi__gpu_est_in_args(a);
    bd_frame f;
    if ((st = bd_plan(s, &in, &f)) || (st = bd_upload(s, a, &f)) || (st = bd_build(s, &f, s->photons, es))) return st;
    f.t[4] = pgi__now_ms();
    if ((st = pgi__gpu_est_sequence(g, record_gather, s, &f, s->photons, f.t + 5, es, gather_passes, &f.gpu_build,
                                    &f.gpu_gather)))
        return st;
    if ((st = pgi__gpu_download(g, s->out, 0, a->out_rgb, 3 * f.ns * sizeof(float))) || (st = bd_counters(s, es)))
        return st;
    f.t[7] = pgi__now_ms();
    pgi__gpu_est_two_sequence_times(g, es, f.t, f.gpu_build, f.gpu_gather);
    pgi__stats_mem(es, "gpu_host_upload", s->packed_cap * sizeof(pgi__packed_photon) + pgi__gpu_vs_pack_bytes(&s->pk));
    return PGI_OK;
}

/* Device inputs: sequence 1 runs here on the frame's photons and view samples, and the number of
 * copies comes back to size the bins. */
static pgi_status bd_device_reserve(void *state, const pgi__gpu_est_inputs *in, pgi__gpu_buffer **out) {
    bd_state *s = state;
    pgi_status st;
    memset(&s->dev_es, 0, sizeof s->dev_es);
    const pgi__gpu_est_in bi = pgi__gpu_est_in_device(in);
    bd_frame *f = &s->dev;
    if ((st = bd_plan(s, &bi, f))) return st;
    f->vs = in->samples;
    f->lobes = in->lobes;
    f->t[0] = f->t[1] = pgi__now_ms();
    if ((st = bd_build(s, f, in->photons, &s->dev_es))) return st;
    *out = s->out;
    return PGI_OK;
}

static pgi_status bd_device_record(void *state, const pgi__gpu_est_inputs *in) {
    bd_state *s = state;
    if (in->nphotons != s->dev.n || in->samples != s->dev.vs)
        return pgi__fail(PGI_ERR_INTERNAL, "%s on the GPU: recorded on inputs it was not reserved for", s->name);
    return record_gather(s, &s->dev, in->photons);
}

static pgi_status bd_device_finish(void *state, const pgi_named_value *t, int nt, pgi_estimator_stats *es) {
    bd_state *s = state;
    bd_frame *f = &s->dev; /* its stats: sequence 1's passes, then its own of the caller's sequence */
    pgi__gpu_est_finish(s->g, es, &s->dev_es, t, nt, own_passes, gather_passes, f->t, &f->gpu_build, &f->gpu_gather);
    return bd_counters(s, es);
}


const pgi__gpu_est_vtbl pgi__gpu_est_bounds3d = {
    .name = "bounds3d",
    .create = bd_create3,
    .run = bd_run,
    .destroy = bd_destroy,
    .device_reserve = bd_device_reserve,
    .device_record = bd_device_record,
    .device_finish = bd_device_finish,
};

const pgi__gpu_est_vtbl pgi__gpu_est_bounds25d = {
    .name = "bounds25d",
    .create = bd_create25,
    .run = bd_run,
    .destroy = bd_destroy,
    .device_reserve = bd_device_reserve,
    .device_record = bd_device_record,
    .device_finish = bd_device_finish,
};

#endif /* PGI__HAVE_VULKAN */
