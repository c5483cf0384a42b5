/* cluster-trivial on the GPU (docs/gpu.md): the CPU estimator's method (src/estimators/est_cluster.c,
 * cluster_build.c; Moreau et al., HPG 2016, §4.1-4.6) in a GPU-friendly form, exact like it.
 *
 * Clusters (the paper's screen-space clustering, as cluster_build.c): a screen tile of T x T pixels
 * (--cluster-tile, at most 16 here) x a view-depth slice (the CPU's near depth, slice width and
 * fast_log2, operation for operation: the same slices); samples seen through mirrors or glass are
 * clustered apart, by their cell in a uniform grid over their box (as the CPU's subtree under the
 * top key bit), so that a curved mirror's pixels do not make clusters that span the scene. Each
 * cluster (leaf) is bounded by the world-space box of its samples and a normal cone.
 *
 * Photons are packed in the order of their cell in a coarse Morton grid (pack_photons: coherent
 * splat lanes, nearby list records); that packed index is the photon order of every list and sum.
 *
 * The hierarchy has four fixed levels instead of the CPU's sparse 32-ary key tree: roots (4 x 4
 * supertiles), supertiles (8 x 8 tiles), tiles, clusters, each level with separate nodes for the primary and the
 * mirror-seen samples (shaders/cluster.glsl: the layout). One command sequence builds it:
 *   cl_reduce   near depth, the mirror-seen samples' box (atomic min/max: order-independent)
 *   cl_tiles    a workgroup a tile: keys, a sort by (key, pixel), runs = clusters, leaf bounds
 *   cl_bounds   supertile, tile and root nodes: boxes, cones, Lambert flags (fixed reductions)
 *   cl_splat    per photon: the traversal of est_cluster.c's walk/decide; each output, a (node
 *               entry, photon) pair, appended at an atomic counter (any order: the lists are sorted)
 * then, after reading back the number of pairs (a larger buffer and the splat again when they did
 * not fit; the capacity is kept for the next frame), a second one:
 *   cl_group    pairs per entry (atomic counts), hg_scan, scatter into the entries' ranges
 *   cl_rank     each pair placed by its rank among its range's photons: photon order (as the CPU's
 *               lists), whatever order the atomics ran in (a pure function of the range)
 *   cl_node_flux  each node's trivially accepted flux, summed in photon order
 *   cl_radiance per view sample: its four nodes' lists through gather.glsl, plus their trivial flux
 * Every float sum is made in an order fixed by the inputs: the same image bit for bit every run.
 * Exactness: the radiance applies gather's test to every listed photon; culling and trivial accept
 * are conservative (box tests in the gather's operation order, margins as the CPU's load_photon;
 * cone thresholds from the smallest cosine, with margins: shaders/cluster.glsl cone_thresholds). */
#include "gpu/gpu_estimator.h"
#include "gpu/gpu_scan.h"

#include <stdio.h>
#include <string.h>

#include "core/core.h"
#include "estimators/estimator_internal.h"

#ifndef PGI__HAVE_VULKAN

static pgi_status ct_create(pgi__gpu *g, const pgi_estimator_desc *d, void **state) {
    (void)g, (void)d;
    *state = NULL;
    return pgi__fail(PGI_ERR_UNSUPPORTED, "this build of photongi has no Vulkan backend (built without Vulkan/glslc)");
}
static pgi_status ct_run(void *state, const pgi_estimate_args *a, pgi_estimator_stats *st) {
    (void)state, (void)a, (void)st;
    return pgi__fail(PGI_ERR_UNSUPPORTED, "this build of photongi has no Vulkan backend (built without Vulkan/glslc)");
}
static void ct_destroy(void *state) { (void)state; }
static pgi_status dir_create(pgi__gpu *g, const pgi_estimator_desc *d, void **state) { return ct_create(g, d, state); }

#else

#include "gpu/spirv.h"

#define GGX_NMU PGI__GGX_NMU
#define SUPER 8     /* supertile edge in tiles */
#define ROOT 4      /* root edge in supertiles */
#define MAX_TILE 16 /* cl_tiles sorts a tile in shared memory (256 samples) */

typedef pgi__gpu_vs gpu_vs;
typedef pgi__gpu_lobe gpu_lobe;

/* shaders/cluster.glsl Push */
typedef struct {
    float r, r2, inv_step, slack;
    uint32_t n, width, height, T, G, ntx, nty, nrx, nry, mode, bits, NS0, NT0, NL0, nnodes, npairs, R, D, blur, dir;
} cl_push;
_Static_assert(sizeof(cl_push) == 96 && offsetof(cl_push, n) == 16 && offsetof(cl_push, dir) == 92,
               "cluster.glsl Push");

#define NODE_BYTES 64 /* shaders/cluster.glsl Node */

enum {
    K_REDUCE,
    K_TILES,
    K_BOUNDS,
    K_SPLAT,
    K_GROUP,
    K_NODE_FLUX,
    K_RADIANCE,
    K_RANK,
    K_DIR_FLUX,
    K_DIR_RADIANCE,
    K_DIR_BLUR,
    K_N
};

#define DIR_TAB_HEAD 12 /* shaders/cl_dir_flux.comp Tab: the view axes (right, up, fwd) */

typedef struct {
    pgi__gpu *g;
    pgi_estimator_desc desc;
    pgi__gpu_kernel *k[K_N];
    int dir;          /* directional (pgi__gpu_est_directional) */
    uint32_t D, blur; /* directional: bucket level (0 roots .. 3 clusters), blur radius */
    pgi__gpu_buffer *buckets, *planes, *dirtab;
    pgi__gpu_buffer *photons, *vs, *lobes, *depth, *out, *frame, *nodes, *pix_node, *tile_ncl, *pairs, *estart, *ecur,
        *eidx, *ranked, *flux, *counters;
    pgi__gpu_scan scan; /* the photon lists' starts */
    size_t pair_cap;    /* pairs the buffer holds */
    /* host-side upload arrays */
    pgi__packed_photon *packed;
    size_t packed_cap;
    pgi__gpu_vs_pack pk;             /* the view samples in the shaders' form */
    uint32_t *porder, *pkey, *pcell; /* photons in Morton cell order (pack_photons) */
    size_t porder_cap, pkey_cap, pcell_cap;
} ct_state;

static void ct_destroy(void *state) {
    ct_state *s = state;
    if (!s) return;
    for (int i = 0; i < K_N; i++) pgi__gpu_kernel_destroy(s->g, s->k[i]);
    pgi__gpu_buffer *b[] = {s->photons,  s->vs,    s->lobes,  s->depth, s->out,  s->frame,  s->nodes, s->pix_node,
                            s->tile_ncl, s->pairs, s->estart, s->ecur,  s->eidx, s->ranked, s->flux,  s->counters};
    for (size_t i = 0; i < sizeof b / sizeof b[0]; i++) pgi__gpu_buffer_destroy(s->g, b[i]);
    pgi__gpu_scan_destroy(&s->scan);
    pgi__gpu_buffer_destroy(s->g, s->buckets);
    pgi__gpu_buffer_destroy(s->g, s->planes);
    pgi__gpu_buffer_destroy(s->g, s->dirtab);
    pgi__afree(s->packed);
    pgi__gpu_vs_pack_free(&s->pk);
    pgi__afree(s->porder);
    pgi__afree(s->pkey);
    pgi__afree(s->pcell);
    free(s);
}

static pgi_status cl_create(pgi__gpu *g, const pgi_estimator_desc *d, void **state, int dir) {
    *state = NULL;
    const char *nm = dir ? "directional" : "cluster-trivial";
    if (d->subsample > 1)
        return pgi__fail(PGI_ERR_UNSUPPORTED, "%s on the GPU: --subsample is not supported (CPU only)", nm);
    if (d->kernel != PGI_KERNEL_CONSTANT)
        return pgi__fail(PGI_ERR_UNSUPPORTED, "%s: only the constant kernel (as on the CPU)", nm);
    if (d->cluster.tile < (dir ? 0 : 1) || d->cluster.tile > MAX_TILE) /* directional: 0, from the image size */
        return pgi__fail(PGI_ERR_UNSUPPORTED,
                         "%s on the GPU: --cluster-tile must be 1..%d (a tile is sorted in shared "
                         "memory), got %d",
                         nm, MAX_TILE, d->cluster.tile);
    ct_state *s = calloc(1, sizeof *s);
    if (!s) return pgi__fail(PGI_ERR_OOM, "out of memory");
    s->g = g;
    s->desc = *d;
    s->dir = dir;
    if (dir) {
        /* est_cluster.c: D = L - level (levels above the leaves), here of the four levels */
        int up = d->directional.level == PGI_DIRECTIONAL_LEAVES ? 0 : d->directional.level;
        s->D = up >= 3 ? 0u : (uint32_t)(3 - up);
        s->blur = d->directional.blur == PGI_DIRECTIONAL_NO_BLUR ? 0u : (uint32_t)d->directional.blur;
    }
    static const pgi__gpu_kernel_spec k[K_N] = {
        [K_REDUCE] = PGI__GPU_KERNEL(cl_reduce, 3, sizeof(cl_push)),
        [K_TILES] = PGI__GPU_KERNEL(cl_tiles, 6, sizeof(cl_push)),
        [K_BOUNDS] = PGI__GPU_KERNEL(cl_bounds, 3, sizeof(cl_push)),
        [K_SPLAT] = PGI__GPU_KERNEL(cl_splat, 4, sizeof(cl_push)),
        [K_GROUP] = PGI__GPU_KERNEL(cl_group, 4, sizeof(cl_push)),
        [K_NODE_FLUX] = PGI__GPU_KERNEL(cl_node_flux, 4, sizeof(cl_push)),
        [K_RADIANCE] = PGI__GPU_KERNEL(cl_radiance, 9, sizeof(cl_push)),
        [K_RANK] = PGI__GPU_KERNEL(cl_rank, 4, sizeof(cl_push)),
        [K_DIR_FLUX] = PGI__GPU_KERNEL(cl_dir_flux, 5, sizeof(cl_push)),
        [K_DIR_RADIANCE] = PGI__GPU_KERNEL(cl_dir_radiance, 4, sizeof(cl_push)),
        [K_DIR_BLUR] = PGI__GPU_KERNEL(cl_dir_blur, 4, sizeof(cl_push)),
    };
    /* directional has its own flux and radiance kernels */
    const uint32_t skip =
        dir ? (1u << K_NODE_FLUX | 1u << K_RADIANCE) : (1u << K_DIR_FLUX | 1u << K_DIR_RADIANCE | 1u << K_DIR_BLUR);
    pgi_status st = pgi__gpu_kernels_create(g, k, K_N, skip, s->k);
    if (!st) st = pgi__gpu_scan_create(g, "gpu_photon_lists", &s->scan);
    if (st) {
        ct_destroy(s);
        return st;
    }
    *state = s;
    return PGI_OK;
}

static pgi_status ct_create(pgi__gpu *g, const pgi_estimator_desc *d, void **state) {
    return cl_create(g, d, state, 0);
}

static pgi_status dir_create(pgi__gpu *g, const pgi_estimator_desc *d, void **state) {
    return cl_create(g, d, state, 1);
}

#define PCELL_BITS 5 /* photon order: Morton code of a 32^3 grid over the photons' box */

/* Spreads the low 5 bits of v to every third bit. */
static uint32_t spread3_5(uint32_t v) {
    uint32_t o = 0;
    for (int b = 0; b < PCELL_BITS; b++) o |= (v >> b & 1u) << (3 * b);
    return o;
}

/* The photons packed in the order of their cell in a 32^3 grid over their box (Morton order;
 * photon order inside a cell: a stable counting sort), a deterministic function of the photons.
 * Neighbouring splat invocations then walk the same nodes (coherent SIMD lanes and warps), and a
 * node's list, sorted by packed index, reads nearby records. The packed index is the "photon
 * order" of the lists and sums. */
static pgi_status pack_photons(ct_state *s, const pgi_photons *ph, int threads) {
    const size_t n = ph->count, ncell = (size_t)1 << (3 * PCELL_BITS);
    pgi_status st;
    if ((st = pgi__ensure((void **)&s->packed, &s->packed_cap, n + 1, sizeof(pgi__packed_photon))) ||
        (st = pgi__ensure((void **)&s->porder, &s->porder_cap, n + 1, sizeof(uint32_t))) ||
        (st = pgi__ensure((void **)&s->pkey, &s->pkey_cap, n + 1, sizeof(uint32_t))) ||
        (st = pgi__ensure((void **)&s->pcell, &s->pcell_cap, ncell + 1, sizeof(uint32_t))))
        return st;
    float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    const float *P[3] = {ph->px, ph->py, ph->pz};
    for (int d = 0; d < 3; d++)
        for (size_t j = 0; j < n; j++) {
            lo[d] = P[d][j] < lo[d] ? P[d][j] : lo[d]; /* NaN: skipped */
            hi[d] = P[d][j] > hi[d] ? P[d][j] : hi[d];
        }
    float inv[3];
    const float cells = (float)(1u << PCELL_BITS);
    for (int d = 0; d < 3; d++) inv[d] = hi[d] > lo[d] && isfinite(hi[d] - lo[d]) ? cells / (hi[d] - lo[d]) : 0.f;
#pragma omp parallel for schedule(static) num_threads(pgi__threads(threads))
    for (long long jj = 0; jj < (long long)n; jj++) {
        uint32_t key = 0;
        for (int d = 0; d < 3; d++) {
            float f = (P[d][jj] - lo[d]) * inv[d];
            uint32_t c = f >= 1.f ? (f < cells ? (uint32_t)f : (uint32_t)cells - 1u) : 0u; /* NaN: 0 */
            key |= spread3_5(c) << (2 - d);
        }
        s->pkey[jj] = key;
    }
    memset(s->pcell, 0, (ncell + 1) * sizeof(uint32_t));
    for (size_t j = 0; j < n; j++) s->pcell[s->pkey[j] + 1]++;
    for (size_t c = 0; c < ncell; c++) s->pcell[c + 1] += s->pcell[c];
    for (size_t j = 0; j < n; j++) s->porder[s->pcell[s->pkey[j]]++] = (uint32_t)j;
#pragma omp parallel for schedule(static) num_threads(pgi__threads(threads))
    for (long long k = 0; k < (long long)n; k++) pgi__pack_photon(ph, s->porder[k], &s->packed[k]);
    return PGI_OK;
}

static int bits_for(uint32_t n) {
    int b = 0;
    while (b < 31 && (1u << b) < n) b++;
    return b;
}

/* Appends the last sequence's timings to the stats; returns the gather's share in *gather. */
/* the passes that are the gather (the rest is the build) */
static const char *const gather_passes[] = {"gpu_radiance", "gpu_blur", NULL};

/* A frame: its sizes (shaders/cluster.glsl: the node layout), the kernels' push constants, the
 * splat's pairs, and the clocks (pgi__gpu_est_two_sequence_times). */
typedef struct cl_frame {
    size_t n, ns, ntiles, NS0, nss, nnodes, nent, nlobes;
    uint32_t W, H;
    cl_push p;
    uint32_t npairs;
    double t[8];                  /* host: upload t0..t1, sequence 1 t2..t3, sequence 2 t4..t6, read back t7 */
    double gpu_build, gpu_gather; /* device timestamps */
} cl_frame;

/* A sequence that could not be recorded: closed, so that the next frame can begin one. */
static pgi_status cl_abandon(pgi__gpu *g, pgi_status st) {
    (void)pgi__gpu_submit_wait(g);
    return st;
}

/* The frame's sizes and push constants, after the checks of what the GPU estimator supports. */
static pgi_status cl_plan(const ct_state *s, const pgi_estimate_args *a, cl_frame *f) {
    const char *nm = s->dir ? "directional" : "cluster-trivial";
    if (a->photons->radius)
        return pgi__fail(PGI_ERR_UNSUPPORTED, "%s on the GPU: per-photon footprints are not supported", nm);
    const pgi_photons *ph = a->photons;
    const pgi_view_samples *vs = a->samples;
    const pgi_camera *cam = a->camera;
    if (!cam || vs->width != cam->width || vs->height != cam->height)
        return pgi__fail(PGI_ERR_INVALID_ARG, "%s on the GPU: view samples are %dx%d but the camera is %dx%d", nm,
                         vs->width, vs->height, cam ? cam->width : 0, cam ? cam->height : 0);
    const float r = a->radius;
    const size_t n = ph->count, ns = vs->count;
    const uint32_t W = (uint32_t)vs->width, H = (uint32_t)vs->height,
                   T = (uint32_t)pgi__cluster_tile(s->desc.cluster.tile, vs->width, vs->height);
    const uint32_t ntx = (W + T - 1) / T, nty = (H + T - 1) / T, nsx = (ntx + SUPER - 1) / SUPER,
                   nsy = (nty + SUPER - 1) / SUPER, nrx = (nsx + ROOT - 1) / ROOT, nry = (nsy + ROOT - 1) / ROOT;
    /* shaders/cluster.glsl: the node layout (supertile slots root-major, tile slots supertile-major) */
    const size_t ntiles = (size_t)ntx * nty, NS0 = 2 * (size_t)nrx * nry, nss = (size_t)nrx * nry * ROOT * ROOT,
                 NT0 = NS0 + 2 * nss, NL0 = NT0 + 2 * nss * SUPER * SUPER, nnodes = NL0 + ntiles * T * T,
                 nent = 2 * nnodes;
    if (n > UINT32_MAX / 4 || ns > UINT32_MAX / 4 || nent > UINT32_MAX / 4)
        return pgi__fail(PGI_ERR_UNSUPPORTED,
                         "cluster-trivial on the GPU: at most 2^30 photons, view samples and nodes");
    int bits = (bits_for(ntx) + 2 * bits_for(nty)) / 3;
    bits = bits < 1 ? 1 : bits > 10 ? 10 : bits;
    *f = (cl_frame){.n = n,
                    .ns = ns,
                    .ntiles = ntiles,
                    .NS0 = NS0,
                    .nss = nss,
                    .nnodes = nnodes,
                    .nent = nent,
                    .W = W,
                    .H = H};
    f->p = (cl_push){.r = r,
                     .r2 = r * r,
                     .inv_step = (float)(1.0 / log2(1.0 + 2.0 * (double)cam->tan_half_fov_y / (double)nty)),
                     .n = (uint32_t)n,
                     .width = W,
                     .height = H,
                     .T = T,
                     .G = SUPER,
                     .ntx = ntx,
                     .nty = nty,
                     .nrx = nrx,
                     .nry = nry,
                     .bits = (uint32_t)bits,
                     .NS0 = (uint32_t)NS0,
                     .NT0 = (uint32_t)NT0,
                     .NL0 = (uint32_t)NL0,
                     .nnodes = (uint32_t)nnodes,
                     .R = ROOT,
                     .D = s->D,
                     .blur = s->blur,
                     .dir = (uint32_t)s->dir};
    return PGI_OK;
}

/* upload: photons packed in cell order, the view samples, lobes and depths (and directional's view
 * axes); every buffer of the frame reserved but the splat's and the lists' (their sizes come later) */
static pgi_status cl_upload(ct_state *s, const pgi_estimate_args *a, cl_frame *f) {
    pgi__gpu *g = s->g;
    const pgi_view_samples *vs = a->samples;
    const size_t n = f->n, ns = f->ns, nnodes = f->nnodes, nent = f->nent;
    pgi_status st;
    f->t[0] = pgi__now_ms();
    if ((st = pack_photons(s, a->photons, a->threads))) return st;
    if ((st = pgi__gpu_pack_samples(&s->pk, vs, a->threads, &f->nlobes))) return st;
    const size_t psz = sizeof(pgi__packed_photon), nlobes = f->nlobes;
    if ((st = pgi__gpu_buffer_reserve(g, &s->photons, (n + 1) * psz, "gpu_photons")) ||
        (st = pgi__gpu_buffer_reserve(g, &s->vs, (ns + 1) * sizeof(gpu_vs), "gpu_view_samples")) ||
        (st = pgi__gpu_buffer_reserve(g, &s->lobes, (nlobes + 1) * sizeof(gpu_lobe), "gpu_view_samples")) ||
        (st = pgi__gpu_buffer_reserve(g, &s->depth, (ns + 1) * sizeof(float), "gpu_view_samples")) ||
        (st = pgi__gpu_buffer_reserve(g, &s->out, (3 * ns + 1) * sizeof(float), "gpu_radiance")) ||
        (st = pgi__gpu_buffer_reserve(g, &s->frame, 8 * sizeof(uint32_t), "gpu_clusters")) ||
        (st = pgi__gpu_buffer_reserve(g, &s->nodes, nnodes * NODE_BYTES, "gpu_cluster_nodes")) ||
        (st = pgi__gpu_buffer_reserve(g, &s->pix_node, (ns + 1) * 4, "gpu_clusters")) ||
        (st = pgi__gpu_buffer_reserve(g, &s->tile_ncl, (2 * f->ntiles + 1) * 4, "gpu_clusters")) ||
        (st = pgi__gpu_buffer_reserve(g, &s->estart, (nent + 1) * 4, "gpu_photon_lists")) ||
        (st = pgi__gpu_buffer_reserve(g, &s->ecur, nent * 4, "gpu_photon_lists")) ||
        (st = pgi__gpu_buffer_reserve(g, &s->flux, nnodes * 16, "gpu_node_flux")) ||
        (st = pgi__gpu_buffer_reserve(g, &s->counters, 8 * sizeof(uint32_t), "gpu_photon_lists")) ||
        (st = pgi__gpu_scan_reserve(&s->scan, nent + 1)))
        return st;
    if (s->dir) { /* view axes (shaders/cl_dir_flux.comp Tab), buckets, irradiance planes */
        float head[DIR_TAB_HEAD] = {0};
        const pgi__view_xf x = pgi__view_xf_make(a->camera, vs->width, vs->height);
        const pgi__v3 ax[3] = {x.right, x.up, x.fwd};
        for (int k = 0; k < 3; k++) head[3 * k] = ax[k].x, head[3 * k + 1] = ax[k].y, head[3 * k + 2] = ax[k].z;
        if ((st = pgi__gpu_buffer_reserve(g, &s->dirtab, sizeof head, "gpu_directional")) ||
            (st = pgi__gpu_buffer_reserve(g, &s->buckets, nnodes * 8 * PGI__DIR_BUCKET * sizeof(float),
                                          "gpu_directional")) ||
            (st = pgi__gpu_buffer_reserve(g, &s->planes, (6 * ns + 1) * sizeof(float), "gpu_directional")) ||
            (st = pgi__gpu_upload(g, s->dirtab, 0, head, sizeof head)))
            return st;
    }
    if ((st = pgi__gpu_upload(g, s->photons, 0, s->packed, n * psz)) ||
        (st = pgi__gpu_upload(g, s->vs, 0, s->pk.hvs, ns * sizeof(gpu_vs))) ||
        (st = pgi__gpu_upload(g, s->lobes, 0, s->pk.hlobes, nlobes * sizeof(gpu_lobe))) ||
        (st = pgi__gpu_upload(g, s->depth, 0, vs->depth, ns * sizeof(float))))
        return st;
    f->t[1] = pgi__now_ms();
    return PGI_OK;
}

/* Records sequence 1 (after its "start"): the frame's counters cleared, near depth, clusters,
 * bounds, the splat's pairs. */
static pgi_status record_build(ct_state *s, const cl_frame *f) {
    pgi__gpu *g = s->g;
    const cl_push *p = &f->p;
    pgi_status st;
    if ((st = pgi__gpu_fill(g, s->frame, 0, 4, 0x7f800000u)) || (st = pgi__gpu_fill(g, s->frame, 4, 12, 0xffffffffu)) ||
        (st = pgi__gpu_fill(g, s->frame, 16, 16, 0)) || (st = pgi__gpu_fill(g, s->counters, 0, 8 * 4, 0)) ||
        (st = pgi__gpu_dispatch_1d(g, s->k[K_REDUCE], (pgi__gpu_buffer *[]){s->vs, s->depth, s->frame}, p, f->ns, 64)))
        return st;
    if ((st = pgi__gpu_dispatch_1d(g, s->k[K_TILES],
                                   (pgi__gpu_buffer *[]){s->vs, s->depth, s->frame, s->nodes, s->pix_node, s->tile_ncl},
                                   p, f->ntiles, 1)))
        return st;
    pgi__gpu_timestamp(g, "gpu_clusters");
    cl_push q = *p;
    const size_t groups[3] = {2 * f->nss, 2 * f->nss * SUPER * SUPER, f->NS0}; /* supertiles, tiles, roots */
    for (uint32_t m = 0; m < 3; m++) {
        q.mode = m;
        if ((st = pgi__gpu_dispatch_1d(g, s->k[K_BOUNDS], (pgi__gpu_buffer *[]){s->vs, s->nodes, s->tile_ncl}, &q,
                                       groups[m], 1)))
            return st;
    }
    pgi__gpu_timestamp(g, "gpu_bounds");
    if ((st = pgi__gpu_dispatch_1d(g, s->k[K_SPLAT], (pgi__gpu_buffer *[]){s->photons, s->nodes, s->pairs, s->counters},
                                   p, f->n, 64)))
        return st;
    pgi__gpu_timestamp(g, "gpu_splat");
    return PGI_OK;
}

/* The splat's pairs did not fit: a larger buffer (kept for the next frame), the splat again. */
static pgi_status splat_again(ct_state *s, cl_frame *f, pgi_estimator_stats *es) {
    pgi__gpu *g = s->g;
    pgi_status st;
    const uint32_t npairs = f->npairs;
    if (npairs > UINT32_MAX / 4)
        return pgi__fail(PGI_ERR_UNSUPPORTED, "cluster-trivial on the GPU: %u photon list entries (at most 2^30)",
                         npairs);
    s->pair_cap = (size_t)npairs + npairs / 4;
    if (s->pair_cap > UINT32_MAX / 4) s->pair_cap = UINT32_MAX / 4;
    if ((st = pgi__gpu_buffer_reserve(g, &s->pairs, s->pair_cap * 8, "gpu_splat"))) return st;
    f->p.npairs = (uint32_t)s->pair_cap;
    double t2b = pgi__now_ms();
    if ((st = pgi__gpu_begin(g))) return st;
    pgi__gpu_timestamp(g, "start");
    if ((st = pgi__gpu_fill(g, s->counters, 0, 8 * 4, 0)) ||
        (st = pgi__gpu_dispatch_1d(g, s->k[K_SPLAT], (pgi__gpu_buffer *[]){s->photons, s->nodes, s->pairs, s->counters},
                                   &f->p, f->n, 64)))
        return cl_abandon(g, st);
    pgi__gpu_timestamp(g, "gpu_splat_again");
    if ((st = pgi__gpu_submit_wait(g))) return st;
    f->t[3] += pgi__now_ms() - t2b;
    pgi__gpu_est_add_timings(g, es, gather_passes, &f->gpu_build, &f->gpu_gather);
    if ((st = pgi__gpu_download(g, s->counters, 6 * 4, &f->npairs, 4))) return st;
    PGI__ASSERT(f->npairs <= s->pair_cap);
    return PGI_OK;
}

/* sequence 1: clusters, bounds, the splat's pairs; then their number read back (the splat again
 * when they did not fit) and the lists' buffers reserved for them */
static pgi_status cl_build(ct_state *s, cl_frame *f, pgi_estimator_stats *es) {
    pgi__gpu *g = s->g;
    pgi_status st;
    if (s->pair_cap < 4 * f->n + 1024) s->pair_cap = 4 * f->n + 1024;
    if (s->pair_cap > UINT32_MAX / 4) s->pair_cap = UINT32_MAX / 4;
    if ((st = pgi__gpu_buffer_reserve(g, &s->pairs, s->pair_cap * 8, "gpu_splat"))) return st;
    f->p.npairs = (uint32_t)s->pair_cap;
    if ((st = pgi__gpu_begin(g))) return st;
    pgi__gpu_timestamp(g, "start");
    if ((st = record_build(s, f))) return cl_abandon(g, st);
    f->t[2] = pgi__now_ms();
    if ((st = pgi__gpu_submit_wait(g))) return st;
    f->t[3] = pgi__now_ms();
    pgi__gpu_est_add_timings(g, es, gather_passes, &f->gpu_build, &f->gpu_gather);
    f->npairs = 0;
    if ((st = pgi__gpu_download(g, s->counters, 6 * 4, &f->npairs, 4))) return st;
    if (f->npairs > s->pair_cap && (st = splat_again(s, f, es))) return st;
    if ((st = pgi__gpu_buffer_reserve(g, &s->eidx, ((size_t)f->npairs + 1) * 4, "gpu_photon_lists")) ||
        (st = pgi__gpu_buffer_reserve(g, &s->ranked, ((size_t)f->npairs + 1) * 4, "gpu_photon_lists")))
        return st;
    f->p.npairs = f->npairs;
    return PGI_OK;
}

/* Records the pairs grouped per node entry, and the lists in photon order. */
static pgi_status record_lists(ct_state *s, const cl_frame *f) {
    pgi__gpu *g = s->g;
    pgi_status st;
    cl_push q = f->p;
    if ((st = pgi__gpu_fill(g, s->estart, 0, (f->nent + 1) * 4, 0)) ||
        (st = pgi__gpu_fill(g, s->ecur, 0, f->nent * 4, 0)))
        return st;
    q.mode = 0;
    if ((st = pgi__gpu_dispatch_1d(g, s->k[K_GROUP], (pgi__gpu_buffer *[]){s->pairs, s->estart, s->ecur, s->eidx}, &q,
                                   f->npairs, 64)) ||
        (st = pgi__gpu_scan_record(&s->scan, s->estart)))
        return st;
    q.mode = 1;
    if ((st = pgi__gpu_dispatch_1d(g, s->k[K_GROUP], (pgi__gpu_buffer *[]){s->pairs, s->estart, s->ecur, s->eidx}, &q,
                                   f->npairs, 64)))
        return st;
    pgi__gpu_timestamp(g, "gpu_lists");
    if ((st = pgi__gpu_dispatch_1d(g, s->k[K_RANK], (pgi__gpu_buffer *[]){s->pairs, s->estart, s->eidx, s->ranked},
                                   &f->p, f->npairs, 64)))
        return st;
    pgi__gpu_timestamp(g, "gpu_rank");
    return PGI_OK;
}

/* Records directional's shading: the buckets, the irradiance, the blur and shading. */
static pgi_status record_directional(ct_state *s, const cl_frame *f) {
    pgi__gpu *g = s->g;
    const cl_push *p = &f->p;
    pgi_status st;
    if ((st = pgi__gpu_dispatch_1d(g, s->k[K_DIR_FLUX],
                                   (pgi__gpu_buffer *[]){s->photons, s->estart, s->ranked, s->dirtab, s->buckets}, p,
                                   f->nnodes, 64)))
        return st;
    pgi__gpu_timestamp(g, "gpu_buckets");
    if ((st = pgi__gpu_dispatch(g, s->k[K_DIR_RADIANCE],
                                (pgi__gpu_buffer *[]){s->vs, s->pix_node, s->buckets, s->planes}, p, (f->W + 7) / 8,
                                (f->H + 7) / 8, 1)))
        return st;
    pgi__gpu_timestamp(g, "gpu_radiance");
    cl_push q = *p;
    for (uint32_t m = s->blur > 0 ? 0u : 1u; m < 2u; m++) {
        q.mode = m;
        if ((st = pgi__gpu_dispatch(g, s->k[K_DIR_BLUR], (pgi__gpu_buffer *[]){s->vs, s->depth, s->planes, s->out}, &q,
                                    (f->W + 7) / 8, (f->H + 7) / 8, 1)))
            return st;
    }
    pgi__gpu_timestamp(g, "gpu_blur");
    return PGI_OK;
}

/* Records cluster-trivial's shading: each node's trivially accepted flux, the radiance. */
static pgi_status record_trivial(ct_state *s, const cl_frame *f) {
    pgi__gpu *g = s->g;
    pgi_status st;
    if ((st = pgi__gpu_dispatch_1d(g, s->k[K_NODE_FLUX],
                                   (pgi__gpu_buffer *[]){s->photons, s->estart, s->ranked, s->flux}, &f->p, f->nnodes,
                                   64)))
        return st;
    pgi__gpu_timestamp(g, "gpu_node_flux");
    if ((st = pgi__gpu_dispatch(g, s->k[K_RADIANCE],
                                (pgi__gpu_buffer *[]){s->vs, s->lobes, s->photons, s->pix_node, s->estart, s->ranked,
                                                      s->flux, s->out, s->counters},
                                &f->p, (f->W + 7) / 8, (f->H + 7) / 8, 1)))
        return st;
    pgi__gpu_timestamp(g, "gpu_radiance");
    return PGI_OK;
}

/* sequence 2: the pairs, the lists in photon order, the trivial flux, the radiance */
static pgi_status cl_gather(ct_state *s, cl_frame *f, pgi_estimator_stats *es) {
    pgi__gpu *g = s->g;
    pgi_status st;
    f->t[4] = pgi__now_ms();
    if ((st = pgi__gpu_begin(g))) return st;
    pgi__gpu_timestamp(g, "start");
    if ((st = record_lists(s, f)) || (st = s->dir ? record_directional(s, f) : record_trivial(s, f)))
        return cl_abandon(g, st);
    f->t[5] = pgi__now_ms();
    if ((st = pgi__gpu_submit_wait(g))) return st;
    f->t[6] = pgi__now_ms();
    pgi__gpu_est_add_timings(g, es, gather_passes, &f->gpu_build, &f->gpu_gather);
    return PGI_OK;
}

static pgi_status ct_run(void *state, const pgi_estimate_args *a, pgi_estimator_stats *es) {
    ct_state *s = state;
    pgi__gpu *g = s->g;
    pgi_status st;
    memset(es, 0, sizeof *es);
    cl_frame f;
    if ((st = cl_plan(s, a, &f)) || (st = cl_upload(s, a, &f)) || (st = cl_build(s, &f, es)) ||
        (st = cl_gather(s, &f, es)))
        return st;
    uint32_t c[6];
    if ((st = pgi__gpu_download(g, s->out, 0, a->out_rgb, 3 * f.ns * sizeof(float))) ||
        (st = pgi__gpu_download(g, s->counters, 0, c, sizeof c)))
        return st;
    f.t[7] = pgi__now_ms();

    /* stats: host passes (wall clock) and the device's (timestamps) */
    pgi__gpu_est_two_sequence_times(g, es, f.t, f.gpu_build, f.gpu_gather);
    es->reads = pgi__gpu_u64(c);
    es->contributing = pgi__gpu_u64(c + 2);
    es->nodes_visited = pgi__gpu_u64(c + 4);
    if (s->dir) es->reads = es->contributing = f.npairs; /* as the CPU directional: bucket deposits */
    pgi__stats_mem(es, "gpu_host_upload",
                   s->packed_cap * sizeof(pgi__packed_photon) + s->pk.hvs_cap * sizeof(gpu_vs) +
                       s->pk.hlobes_cap * sizeof(gpu_lobe) +
                       (s->pk.lobe_of_cap + s->porder_cap + s->pkey_cap + s->pcell_cap) * sizeof(uint32_t));
    return PGI_OK;
}

#endif /* PGI__HAVE_VULKAN */

const pgi__gpu_est_vtbl pgi__gpu_est_cluster_trivial = {
    .name = "cluster-trivial",
    .create = ct_create,
    .run = ct_run,
    .destroy = ct_destroy,
};

/* directional (est_directional.c, Moreau et al. 2016 §4.7) on the same clusters, hierarchy and
 * lists: cl_splat deposits (pc.dir), cl_dir_flux sums each node's octant buckets in photon order,
 * cl_dir_radiance and cl_dir_blur shade. Approximate, like the CPU's; its levels are the four here. */
const pgi__gpu_est_vtbl pgi__gpu_est_directional = {
    .name = "directional",
    .create = dir_create,
    .run = ct_run,
    .destroy = ct_destroy,
};
