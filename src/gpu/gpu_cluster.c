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
#include "gpu/gpu_sort.h"

#include <stdio.h>
#include <string.h>

#include "core/core.h"
#include "estimators/estimator_internal.h"

#ifndef PGI__HAVE_VULKAN

const pgi__gpu_est_vtbl pgi__gpu_est_cluster = PGI__GPU_EST_NONE("cluster");
const pgi__gpu_est_vtbl pgi__gpu_est_cluster_cone = PGI__GPU_EST_NONE("cluster-cone");
const pgi__gpu_est_vtbl pgi__gpu_est_cluster_trivial = PGI__GPU_EST_NONE("cluster-trivial");
const pgi__gpu_est_vtbl pgi__gpu_est_directional = PGI__GPU_EST_NONE("directional");

#else

#include "gpu/spirv.h"

#define GGX_NMU PGI__GGX_NMU
#define SUPER 8       /* supertile edge in tiles */
#define ROOT 4        /* root edge in supertiles */
#define MAX_TILE 16   /* cl_tiles sorts a tile in shared memory (256 samples) */
enum { V_CONE = 1, V_TRIVIAL = 2, V_DIR = 4 }; /* shaders/cluster.glsl Push.variant, as est_cluster.c's */
#define PCELL_BITS 15 /* photon order: Morton code of a 32^3 grid over the photons' box (cl_prep) */

typedef pgi__gpu_vs gpu_vs;
typedef pgi__gpu_lobe gpu_lobe;

/* shaders/cluster.glsl Push */
typedef struct {
    float r, r2, inv_step, slack;
    uint32_t n, width, height, T, G, ntx, nty, nrx, nry, mode, bits, NS0, NT0, NL0, nnodes, npairs, R, D, blur, variant;
} cl_push;
_Static_assert(sizeof(cl_push) == 96 && offsetof(cl_push, n) == 16 && offsetof(cl_push, variant) == 92,
               "cluster.glsl Push");

#define NODE_BYTES 64 /* shaders/cluster.glsl Node */

enum {
    K_PREP,
    K_REDUCE,
    K_TILES,
    K_BOUNDS,
    K_SPLAT,
    K_GROUP,
    K_NODE_FLUX,
    K_RADIANCE,
    K_DIR_FLUX,
    K_DIR_RADIANCE,
    K_DIR_BLUR,
    K_N
};

#define DIR_TAB_HEAD 12 /* shaders/cl_dir_flux.comp Tab: the view axes (right, up, fwd) */

/* A frame: its sizes (shaders/cluster.glsl: the node layout), the kernels' push constants, the
 * splat's pairs, the input buffers it reads, and the clocks (pgi__gpu_est_two_sequence_times). */
typedef struct cl_frame {
    size_t n, ns, ntiles, NS0, nss, nnodes, nent, nlobes;
    uint32_t W, H;
    cl_push p;
    uint32_t npairs;
    pgi__gpu_buffer *vs, *lobes;  /* the view samples and lobes the frame reads */
    pgi__gpu_buffer *ranked;      /* the lists' photons (the sort's output) */
    double t[8];                  /* host: upload t0..t1, sequence 1 t2..t3, sequence 2 t4..t6, read back t7 */
    double gpu_build, gpu_gather; /* device timestamps */
} cl_frame;

typedef struct {
    pgi__gpu *g;
    pgi_estimator_desc desc;
    pgi__gpu_kernel *k[K_N];
    const char *name; /* the estimator's */
    uint32_t variant; /* est_cluster.c's V_* (shaders/cluster.glsl Push.variant) */
    int dir;          /* variant & V_DIR: directional (pgi__gpu_est_directional) */
    uint32_t D, blur; /* directional: bucket level (0 roots .. 3 clusters), blur radius */
    pgi__gpu_buffer *buckets, *planes, *dirtab;
    pgi__gpu_buffer *raw, *pbox, *pkeys; /* the photons as given, their box, their (cell, index) pairs */
    pgi__gpu_buffer *photons, *vs, *lobes, *depth, *out, *frame, *nodes, *pix_node, *tile_ncl, *pairs, *estart, *flux,
        *counters;
    pgi__gpu_scan scan;  /* the photon lists' starts */
    pgi__gpu_sort psort; /* the photons in cell order */
    pgi__gpu_sort lsort; /* the lists: pairs by (entry, photon) */
    size_t pair_cap;     /* pairs the buffer holds */
    /* host-side upload arrays (pgi_estimate_args inputs) */
    pgi__packed_photon *packed;
    size_t packed_cap;
    pgi__gpu_vs_pack pk; /* the view samples in the shaders' form */
    /* device inputs: the frame device_reserve built, its sequence's passes (for device_finish) */
    cl_frame dev;
    pgi_estimator_stats dev_es;
} ct_state;

static void ct_destroy(void *state) {
    ct_state *s = state;
    if (!s) return;
    for (int i = 0; i < K_N; i++) pgi__gpu_kernel_destroy(s->g, s->k[i]);
    pgi__gpu_buffer *b[] = {s->raw,  s->pbox,     s->pkeys,   s->photons,  s->vs,       s->lobes, s->depth,
                            s->out,  s->frame,    s->nodes,   s->pix_node, s->tile_ncl, s->pairs, s->estart,
                            s->flux, s->counters, s->buckets, s->planes,   s->dirtab};
    for (size_t i = 0; i < sizeof b / sizeof b[0]; i++) pgi__gpu_buffer_destroy(s->g, b[i]);
    pgi__gpu_scan_destroy(&s->scan);
    pgi__gpu_sort_destroy(&s->psort);
    pgi__gpu_sort_destroy(&s->lsort);
    pgi__afree(s->packed);
    pgi__gpu_vs_pack_free(&s->pk);
    free(s);
}

static pgi_status cl_create(pgi__gpu *g, const pgi_estimator_desc *d, void **state, const char *nm, uint32_t variant) {
    *state = NULL;
    const int dir = (variant & V_DIR) != 0;
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
    s->name = nm;
    s->variant = variant;
    s->dir = dir;
    if (dir) {
        /* est_cluster.c: D = L - level (levels above the leaves), here of the four levels */
        int up = d->directional.level == PGI_DIRECTIONAL_LEAVES ? 0 : d->directional.level;
        s->D = up >= 3 ? 0u : (uint32_t)(3 - up);
        s->blur = d->directional.blur == PGI_DIRECTIONAL_NO_BLUR ? 0u : (uint32_t)d->directional.blur;
    }
    static const pgi__gpu_kernel_spec k[K_N] = {
        [K_PREP] = PGI__GPU_KERNEL(cl_prep, 4, sizeof(cl_push)),
        [K_REDUCE] = PGI__GPU_KERNEL(cl_reduce, 3, sizeof(cl_push)),
        [K_TILES] = PGI__GPU_KERNEL(cl_tiles, 6, sizeof(cl_push)),
        [K_BOUNDS] = PGI__GPU_KERNEL(cl_bounds, 3, sizeof(cl_push)),
        [K_SPLAT] = PGI__GPU_KERNEL(cl_splat, 4, sizeof(cl_push)),
        [K_GROUP] = PGI__GPU_KERNEL(cl_group, 2, sizeof(cl_push)),
        [K_NODE_FLUX] = PGI__GPU_KERNEL(cl_node_flux, 4, sizeof(cl_push)),
        [K_RADIANCE] = PGI__GPU_KERNEL(cl_radiance, 9, sizeof(cl_push)),
        [K_DIR_FLUX] = PGI__GPU_KERNEL(cl_dir_flux, 5, sizeof(cl_push)),
        [K_DIR_RADIANCE] = PGI__GPU_KERNEL(cl_dir_radiance, 4, sizeof(cl_push)),
        [K_DIR_BLUR] = PGI__GPU_KERNEL(cl_dir_blur, 4, sizeof(cl_push)),
    };
    /* directional has its own flux and radiance kernels */
    const uint32_t skip =
        dir ? (1u << K_NODE_FLUX | 1u << K_RADIANCE) : (1u << K_DIR_FLUX | 1u << K_DIR_RADIANCE | 1u << K_DIR_BLUR);
    pgi_status st = pgi__gpu_kernels_create(g, k, K_N, skip, s->k);
    if (!st) st = pgi__gpu_scan_create(g, "gpu_photon_lists", &s->scan);
    if (!st) st = pgi__gpu_sort_create(g, "gpu_photon_order", &s->psort);
    if (!st) st = pgi__gpu_sort_create(g, "gpu_photon_lists", &s->lsort);
    if (st) {
        ct_destroy(s);
        return st;
    }
    *state = s;
    return PGI_OK;
}

static pgi_status cl0_create(pgi__gpu *g, const pgi_estimator_desc *d, void **state) {
    return cl_create(g, d, state, "cluster", 0);
}

static pgi_status cone_create(pgi__gpu *g, const pgi_estimator_desc *d, void **state) {
    return cl_create(g, d, state, "cluster-cone", V_CONE);
}

static pgi_status ct_create(pgi__gpu *g, const pgi_estimator_desc *d, void **state) {
    return cl_create(g, d, state, "cluster-trivial", V_CONE | V_TRIVIAL);
}

static pgi_status dir_create(pgi__gpu *g, const pgi_estimator_desc *d, void **state) {
    return cl_create(g, d, state, "directional", V_DIR);
}

static int bits_for(size_t n) {
    int b = 0;
    while (b < 32 && ((size_t)1 << b) < n) b++;
    return b;
}

/* the passes that are the gather (the rest is the build) */
static const char *const gather_passes[] = {"gpu_radiance", "gpu_blur", NULL};
/* every pass this estimator times (device_finish keeps these from the caller's sequence) */
static const char *const own_passes[] =
    {"gpu_photon_order", "gpu_clusters", "gpu_bounds", "gpu_splat", "gpu_splat_again", "gpu_lists", "gpu_node_flux",
     "gpu_buckets",      "gpu_radiance", "gpu_blur",   NULL};

/* What a frame is made from, on either path. */
typedef struct cl_in {
    size_t n, ns;
    int width, height;
    const pgi_camera *cam;
    float radius;
} cl_in;

/* The frame's sizes and push constants, after the checks of what the GPU estimator supports. */
static pgi_status cl_plan(const ct_state *s, const cl_in *in, cl_frame *f) {
    const char *nm = s->name;
    const pgi_camera *cam = in->cam;
    if (!cam || in->width != cam->width || in->height != cam->height)
        return pgi__fail(PGI_ERR_INVALID_ARG, "%s on the GPU: view samples are %dx%d but the camera is %dx%d", nm,
                         in->width, in->height, cam ? cam->width : 0, cam ? cam->height : 0);
    const float r = in->radius;
    const size_t n = in->n, ns = in->ns;
    const uint32_t W = (uint32_t)in->width, H = (uint32_t)in->height,
                   T = (uint32_t)pgi__cluster_tile(s->desc.cluster.tile, in->width, in->height);
    const uint32_t ntx = (W + T - 1) / T, nty = (H + T - 1) / T, nsx = (ntx + SUPER - 1) / SUPER,
                   nsy = (nty + SUPER - 1) / SUPER, nrx = (nsx + ROOT - 1) / ROOT, nry = (nsy + ROOT - 1) / ROOT;
    /* shaders/cluster.glsl: the node layout (supertile slots root-major, tile slots supertile-major) */
    const size_t ntiles = (size_t)ntx * nty, NS0 = 2 * (size_t)nrx * nry, nss = (size_t)nrx * nry * ROOT * ROOT,
                 NT0 = NS0 + 2 * nss, NL0 = NT0 + 2 * nss * SUPER * SUPER, nnodes = NL0 + ntiles * T * T,
                 nent = 2 * nnodes;
    if (n > UINT32_MAX / 4 || ns > UINT32_MAX / 4 || nent > UINT32_MAX / 4)
        return pgi__fail(PGI_ERR_UNSUPPORTED, "%s on the GPU: at most 2^30 photons, view samples and nodes", nm);
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
                    .H = H,
                    .vs = s->vs,
                    .lobes = s->lobes};
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
                     .variant = s->variant};
    return PGI_OK;
}

/* Every buffer of the frame but the inputs' and the lists' (their sizes come with the splat); the
 * directional view axes uploaded (48 bytes). */
static pgi_status cl_reserve(ct_state *s, const cl_in *in, cl_frame *f) {
    pgi__gpu *g = s->g;
    const size_t n = f->n, ns = f->ns, nnodes = f->nnodes, nent = f->nent, psz = sizeof(pgi__packed_photon);
    pgi_status st;
    if ((st = pgi__gpu_buffer_reserve(g, &s->photons, (n + 1) * psz, "gpu_photons")) ||
        (st = pgi__gpu_buffer_reserve(g, &s->pbox, 8 * sizeof(uint32_t), "gpu_photon_order")) ||
        (st = pgi__gpu_buffer_reserve(g, &s->pkeys, (n + 1) * 8, "gpu_photon_order")) || /* (cell, index) */
        (st = pgi__gpu_sort_reserve(&s->psort, n)) ||
        (st = pgi__gpu_buffer_reserve(g, &s->depth, (ns + 1) * sizeof(float), "gpu_view_samples")) ||
        (st = pgi__gpu_buffer_reserve(g, &s->out, (3 * ns + 1) * sizeof(float), "gpu_radiance")) ||
        (st = pgi__gpu_buffer_reserve(g, &s->frame, 8 * sizeof(uint32_t), "gpu_clusters")) ||
        (st = pgi__gpu_buffer_reserve(g, &s->nodes, nnodes * NODE_BYTES, "gpu_cluster_nodes")) ||
        (st = pgi__gpu_buffer_reserve(g, &s->pix_node, (ns + 1) * 4, "gpu_clusters")) ||
        (st = pgi__gpu_buffer_reserve(g, &s->tile_ncl, (2 * f->ntiles + 1) * 4, "gpu_clusters")) ||
        (st = pgi__gpu_buffer_reserve(g, &s->estart, (nent + 1) * 4, "gpu_photon_lists")) ||
        (st = pgi__gpu_buffer_reserve(g, &s->flux, nnodes * 16, "gpu_node_flux")) ||
        (st = pgi__gpu_buffer_reserve(g, &s->counters, 8 * sizeof(uint32_t), "gpu_photon_lists")) ||
        (st = pgi__gpu_scan_reserve(&s->scan, nent + 1)))
        return st;
    if (s->dir) { /* view axes (shaders/cl_dir_flux.comp Tab), buckets, irradiance planes */
        float head[DIR_TAB_HEAD] = {0};
        const pgi__view_xf x = pgi__view_xf_make(in->cam, in->width, in->height);
        const pgi__v3 ax[3] = {x.right, x.up, x.fwd};
        for (int k = 0; k < 3; k++) head[3 * k] = ax[k].x, head[3 * k + 1] = ax[k].y, head[3 * k + 2] = ax[k].z;
        if ((st = pgi__gpu_buffer_reserve(g, &s->dirtab, sizeof head, "gpu_directional")) ||
            (st = pgi__gpu_buffer_reserve(g, &s->buckets, nnodes * 8 * PGI__DIR_BUCKET * sizeof(float),
                                          "gpu_directional")) ||
            (st = pgi__gpu_buffer_reserve(g, &s->planes, (6 * ns + 1) * sizeof(float), "gpu_directional")) ||
            (st = pgi__gpu_upload(g, s->dirtab, 0, head, sizeof head)))
            return st;
    }
    return PGI_OK;
}

/* pgi_estimate_args inputs: the photons packed in photon order and the view samples, lobes and
 * depths uploaded (the device inputs are these, made on the device) */
static pgi_status cl_upload(ct_state *s, const pgi_estimate_args *a, cl_frame *f) {
    f->t[0] = pgi__now_ms();
    pgi_status st;
    if ((st = pgi__gpu_est_upload(s->g, a, &s->packed, &s->packed_cap, &s->pk, &s->raw, &s->vs, &s->lobes)) ||
        (st = pgi__gpu_upload(s->g, s->depth, 0, a->samples->depth, f->ns * sizeof(float))))
        return st;
    f->vs = s->vs;
    f->lobes = s->lobes;
    f->t[1] = pgi__now_ms();
    return PGI_OK;
}

/* Records the photons in cell order (cl_prep: box, keys; gpu_sort; the copy) into s->photons, and
 * the view samples' depths from PixelExtra when `extra` is given (device inputs). */
static pgi_status record_prep(ct_state *s, const cl_frame *f, pgi__gpu_buffer *photons, pgi__gpu_buffer *extra) {
    pgi__gpu *g = s->g;
    pgi_status st;
    cl_push q = f->p;
    if (extra) {
        q.mode = 3;
        q.n = (uint32_t)f->ns;
        if ((st = pgi__gpu_dispatch_1d(g, s->k[K_PREP], (pgi__gpu_buffer *[]){extra, s->pbox, s->pkeys, s->depth}, &q,
                                       f->ns, 256)))
            return st;
        q.n = f->p.n;
    }
    if (f->n) {
        pgi__gpu_buffer *keys, *order;
        pgi__gpu_buffer *b[] = {photons, s->pbox, s->pkeys, s->photons};
        if ((st = pgi__gpu_fill(g, s->pbox, 0, 12, 0xffffffffu)) || (st = pgi__gpu_fill(g, s->pbox, 12, 20, 0)))
            return st;
        for (uint32_t m = 0; m < 2; m++) {
            q.mode = m;
            if ((st = pgi__gpu_dispatch_1d(g, s->k[K_PREP], b, &q, f->n, 256))) return st;
        }
        if ((st = pgi__gpu_sort_record(&s->psort, s->pkeys, f->n, 0, PCELL_BITS, &keys, &order))) return st;
        q.mode = 2;
        if ((st = pgi__gpu_dispatch_1d(g, s->k[K_PREP], (pgi__gpu_buffer *[]){photons, s->pbox, order, s->photons}, &q,
                                       f->n, 256)))
            return st;
    }
    pgi__gpu_timestamp(g, "gpu_photon_order");
    return PGI_OK;
}

/* Records sequence 1 (after its "start" and record_prep): the frame's counters cleared, near
 * depth, clusters, bounds, the splat's pairs. */
static pgi_status record_build(ct_state *s, const cl_frame *f) {
    pgi__gpu *g = s->g;
    const cl_push *p = &f->p;
    pgi_status st;
    if ((st = pgi__gpu_fill(g, s->frame, 0, 4, 0x7f800000u)) || (st = pgi__gpu_fill(g, s->frame, 4, 12, 0xffffffffu)) ||
        (st = pgi__gpu_fill(g, s->frame, 16, 16, 0)) || (st = pgi__gpu_fill(g, s->counters, 0, 8 * 4, 0)) ||
        (st = pgi__gpu_dispatch_1d(g, s->k[K_REDUCE], (pgi__gpu_buffer *[]){f->vs, s->depth, s->frame}, p, f->ns, 64)))
        return st;
    if ((st = pgi__gpu_dispatch_1d(g, s->k[K_TILES],
                                   (pgi__gpu_buffer *[]){f->vs, s->depth, s->frame, s->nodes, s->pix_node, s->tile_ncl},
                                   p, f->ntiles, 1)))
        return st;
    pgi__gpu_timestamp(g, "gpu_clusters");
    cl_push q = *p;
    const size_t groups[3] = {2 * f->nss, 2 * f->nss * SUPER * SUPER, f->NS0}; /* supertiles, tiles, roots */
    for (uint32_t m = 0; m < 3; m++) {
        q.mode = m;
        if ((st = pgi__gpu_dispatch_1d(g, s->k[K_BOUNDS], (pgi__gpu_buffer *[]){f->vs, s->nodes, s->tile_ncl}, &q,
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
        return pgi__fail(PGI_ERR_UNSUPPORTED, "%s on the GPU: %u photon list entries (at most 2^30)", s->name, npairs);
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
        return pgi__gpu_abandon(g, st);
    pgi__gpu_timestamp(g, "gpu_splat_again");
    if ((st = pgi__gpu_submit_wait(g))) return st;
    f->t[3] += pgi__now_ms() - t2b;
    pgi__gpu_est_add_timings(g, es, gather_passes, &f->gpu_build, &f->gpu_gather);
    if ((st = pgi__gpu_download(g, s->counters, 6 * 4, &f->npairs, 4))) return st;
    PGI__ASSERT(f->npairs <= s->pair_cap);
    return PGI_OK;
}

/* sequence 1: the photon order (and depths), clusters, bounds, the splat's pairs; then their number
 * read back (4 bytes; the splat again when they did not fit) and the lists' buffers reserved */
static pgi_status cl_build(ct_state *s, cl_frame *f, pgi__gpu_buffer *photons, pgi__gpu_buffer *extra,
                           pgi_estimator_stats *es) {
    pgi__gpu *g = s->g;
    pgi_status st;
    if (s->pair_cap < 4 * f->n + 1024) s->pair_cap = 4 * f->n + 1024;
    if (s->pair_cap > UINT32_MAX / 4) s->pair_cap = UINT32_MAX / 4;
    if ((st = pgi__gpu_buffer_reserve(g, &s->pairs, s->pair_cap * 8, "gpu_splat"))) return st;
    f->p.npairs = (uint32_t)s->pair_cap;
    if ((st = pgi__gpu_begin(g))) return st;
    pgi__gpu_timestamp(g, "start");
    if ((st = record_prep(s, f, photons, extra)) || (st = record_build(s, f))) return pgi__gpu_abandon(g, st);
    f->t[2] = pgi__now_ms();
    if ((st = pgi__gpu_submit_wait(g))) return st;
    f->t[3] = pgi__now_ms();
    pgi__gpu_est_add_timings(g, es, gather_passes, &f->gpu_build, &f->gpu_gather);
    f->npairs = 0;
    if ((st = pgi__gpu_download(g, s->counters, 6 * 4, &f->npairs, 4))) return st;
    if (f->npairs > s->pair_cap && (st = splat_again(s, f, es))) return st;
    if ((st = pgi__gpu_sort_reserve(&s->lsort, f->npairs))) return st;
    f->p.npairs = f->npairs;
    return PGI_OK;
}

/* Records the lists: photons per entry (counts, then their exclusive sum: each entry's start) and
 * the pairs sorted by (entry, photon), whose photons are then every list in photon order. */
static pgi_status record_lists(ct_state *s, cl_frame *f) {
    pgi__gpu *g = s->g;
    pgi_status st;
    pgi__gpu_buffer *keys;
    if ((st = pgi__gpu_fill(g, s->estart, 0, (f->nent + 1) * 4, 0)) ||
        (st = pgi__gpu_dispatch_1d(g, s->k[K_GROUP], (pgi__gpu_buffer *[]){s->pairs, s->estart}, &f->p, f->npairs,
                                   64)) ||
        (st = pgi__gpu_scan_record(&s->scan, s->estart)) ||
        (st = pgi__gpu_sort_record(&s->lsort, s->pairs, f->npairs, bits_for(f->n), bits_for(f->nent), &keys,
                                   &f->ranked)))
        return st;
    pgi__gpu_timestamp(g, "gpu_lists");
    return PGI_OK;
}

/* Records directional's shading: the buckets, the irradiance, the blur and shading. */
static pgi_status record_directional(ct_state *s, const cl_frame *f) {
    pgi__gpu *g = s->g;
    const cl_push *p = &f->p;
    pgi_status st;
    if ((st = pgi__gpu_dispatch_1d(g, s->k[K_DIR_FLUX],
                                   (pgi__gpu_buffer *[]){s->photons, s->estart, f->ranked, s->dirtab, s->buckets}, p,
                                   f->nnodes, 64)))
        return st;
    pgi__gpu_timestamp(g, "gpu_buckets");
    if ((st = pgi__gpu_dispatch(g, s->k[K_DIR_RADIANCE],
                                (pgi__gpu_buffer *[]){f->vs, s->pix_node, s->buckets, s->planes}, p, (f->W + 7) / 8,
                                (f->H + 7) / 8, 1)))
        return st;
    pgi__gpu_timestamp(g, "gpu_radiance");
    cl_push q = *p;
    for (uint32_t m = s->blur > 0 ? 0u : 1u; m < 2u; m++) {
        q.mode = m;
        if ((st = pgi__gpu_dispatch(g, s->k[K_DIR_BLUR], (pgi__gpu_buffer *[]){f->vs, s->depth, s->planes, s->out}, &q,
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
                                   (pgi__gpu_buffer *[]){s->photons, s->estart, f->ranked, s->flux}, &f->p, f->nnodes,
                                   64)))
        return st;
    pgi__gpu_timestamp(g, "gpu_node_flux");
    if ((st = pgi__gpu_dispatch(g, s->k[K_RADIANCE],
                                (pgi__gpu_buffer *[]){f->vs, f->lobes, s->photons, s->pix_node, s->estart, f->ranked,
                                                      s->flux, s->out, s->counters},
                                &f->p, (f->W + 7) / 8, (f->H + 7) / 8, 1)))
        return st;
    pgi__gpu_timestamp(g, "gpu_radiance");
    return PGI_OK;
}

/* Records sequence 2's work: the lists, then the shading. */
static pgi_status record_gather(ct_state *s, cl_frame *f) {
    pgi_status st = record_lists(s, f);
    if (!st) st = s->dir ? record_directional(s, f) : record_trivial(s, f);
    return st;
}

/* sequence 2 of the host inputs' path */
static pgi_status cl_gather(ct_state *s, cl_frame *f, pgi_estimator_stats *es) {
    pgi__gpu *g = s->g;
    pgi_status st;
    f->t[4] = pgi__now_ms();
    if ((st = pgi__gpu_begin(g))) return st;
    pgi__gpu_timestamp(g, "start");
    if ((st = record_gather(s, f))) return pgi__gpu_abandon(g, st);
    f->t[5] = pgi__now_ms();
    if ((st = pgi__gpu_submit_wait(g))) return st;
    f->t[6] = pgi__now_ms();
    pgi__gpu_est_add_timings(g, es, gather_passes, &f->gpu_build, &f->gpu_gather);
    return PGI_OK;
}

/* The counters (photons read, contributing, nodes visited) into the stats. */
static pgi_status cl_counters(ct_state *s, const cl_frame *f, pgi_estimator_stats *es) {
    uint32_t c[6];
    pgi_status st = pgi__gpu_download(s->g, s->counters, 0, c, sizeof c);
    if (st) return st;
    es->reads = pgi__gpu_u64(c);
    es->contributing = pgi__gpu_u64(c + 2);
    es->nodes_visited = pgi__gpu_u64(c + 4);
    if (s->dir) es->reads = es->contributing = f->npairs; /* as the CPU directional: bucket deposits */
    return PGI_OK;
}

static pgi_status ct_run(void *state, const pgi_estimate_args *a, pgi_estimator_stats *es) {
    ct_state *s = state;
    pgi__gpu *g = s->g;
    pgi_status st;
    memset(es, 0, sizeof *es);
    if (a->photons->radius)
        return pgi__fail(PGI_ERR_UNSUPPORTED, "%s on the GPU: per-photon footprints are not supported", s->name);
    const cl_in in = {.n = a->photons->count,
                      .ns = a->samples->count,
                      .width = a->samples->width,
                      .height = a->samples->height,
                      .cam = a->camera,
                      .radius = a->radius};
    cl_frame f;
    if ((st = cl_plan(s, &in, &f)) || (st = cl_reserve(s, &in, &f)) || (st = cl_upload(s, a, &f)) ||
        (st = cl_build(s, &f, s->raw, NULL, es)) || (st = cl_gather(s, &f, es)))
        return st;
    if ((st = pgi__gpu_download(g, s->out, 0, a->out_rgb, 3 * f.ns * sizeof(float))) || (st = cl_counters(s, &f, es)))
        return st;
    f.t[7] = pgi__now_ms();

    /* stats: host passes (wall clock) and the device's (timestamps) */
    pgi__gpu_est_two_sequence_times(g, es, f.t, f.gpu_build, f.gpu_gather);
    pgi__stats_mem(es, "gpu_host_upload", s->packed_cap * sizeof(pgi__packed_photon) + pgi__gpu_vs_pack_bytes(&s->pk));
    return PGI_OK;
}

/* Device inputs: sequence 1 (photon order, clusters, bounds, splat) runs here on the frame's
 * photons and view samples, and the number of list entries comes back (4 bytes) to size the lists. */
static pgi_status ct_device_reserve(void *state, const pgi__gpu_est_inputs *in, pgi__gpu_buffer **out) {
    ct_state *s = state;
    pgi_status st;
    memset(&s->dev_es, 0, sizeof s->dev_es);
    const cl_in ci = {.n = in->nphotons,
                      .ns = (size_t)in->width * (size_t)in->height,
                      .width = in->width,
                      .height = in->height,
                      .cam = in->camera,
                      .radius = in->radius};
    cl_frame *f = &s->dev;
    if ((st = cl_plan(s, &ci, f)) || (st = cl_reserve(s, &ci, f))) return st;
    f->vs = in->samples;
    f->lobes = in->lobes;
    f->t[0] = f->t[1] = pgi__now_ms();
    if ((st = cl_build(s, f, in->photons, in->extra, &s->dev_es))) return st;
    *out = s->out;
    return PGI_OK;
}

static pgi_status ct_device_record(void *state, const pgi__gpu_est_inputs *in) {
    ct_state *s = state;
    if (in->nphotons != s->dev.n || in->samples != s->dev.vs)
        return pgi__fail(PGI_ERR_INTERNAL, "cluster on the GPU: recorded on inputs it was not reserved for");
    return record_gather(s, &s->dev);
}

static pgi_status ct_device_finish(void *state, const pgi_named_value *t, int nt, pgi_estimator_stats *es) {
    ct_state *s = state;
    cl_frame *f = &s->dev; /* its stats: sequence 1's passes, then its own of the caller's sequence */
    pgi__gpu_est_finish(s->g, es, &s->dev_es, t, nt, own_passes, gather_passes, f->t, &f->gpu_build, &f->gpu_gather);
    return cl_counters(s, f, es);
}


/* The four share every entry but create (the variant). cluster (Moreau et al. 2016 §4.1-4.4) and
 * cluster-cone (+ §4.5's cones): cluster-trivial's code with the cone test and trivial accept off
 * (shaders/cl_splat.comp, Push.variant), as on the CPU. directional (est_directional.c, §4.7) on the
 * same clusters, hierarchy and lists: cl_splat deposits (V_DIR), cl_dir_flux sums each node's octant
 * buckets in photon order, cl_dir_radiance and cl_dir_blur shade; approximate, like the CPU's, its
 * levels the four here. */
#define CL_VTBL(NAME, CREATE)                                                                                          \
    {                                                                                                                  \
        .name = NAME, .create = CREATE, .run = ct_run, .destroy = ct_destroy, .device_reserve = ct_device_reserve,     \
        .device_record = ct_device_record, .device_finish = ct_device_finish                                           \
    }
const pgi__gpu_est_vtbl pgi__gpu_est_cluster = CL_VTBL("cluster", cl0_create);
const pgi__gpu_est_vtbl pgi__gpu_est_cluster_cone = CL_VTBL("cluster-cone", cone_create);
const pgi__gpu_est_vtbl pgi__gpu_est_cluster_trivial = CL_VTBL("cluster-trivial", ct_create);
const pgi__gpu_est_vtbl pgi__gpu_est_directional = CL_VTBL("directional", dir_create);

#endif /* PGI__HAVE_VULKAN */
