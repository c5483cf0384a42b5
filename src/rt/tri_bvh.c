/* The GPU backend's triangle BVH (tri_bvh.h): Embree's rtcBuildBVH with our own node callbacks builds a
 * temporary tree in Embree's thread-local memory; a depth-first walk flattens it into the
 * 4-wide node array and the leaf-ordered triangle array the shaders read. The CPU traversal at
 * the end is the shader's algorithm (src/gpu/shaders/bvh.glsl) line for line. */
#include "rt/tri_bvh.h"

#include <embree3/rtcore.h>
#include <stdatomic.h>
#include <stdio.h>
#include <string.h>

/* ------------------------------------------------------------ temporary tree (Embree's memory) */

typedef struct tnode {
    uint32_t leaf; /* 1: a tleaf */
    uint32_t n;    /* children or triangles */
} tnode;

typedef struct tinner {
    tnode h;
    tnode *c[4];
    struct RTCBounds b[4];
} tinner;

typedef struct tleaf {
    tnode h;
    struct RTCBounds box; /* of its primitives (the root's box when the root is a leaf) */
    uint32_t prim[];
} tleaf;

typedef struct build_ctx {
    const pgi_scene *s;
    _Atomic long long bytes, peak; /* Embree's memory monitor */
} build_ctx;

static void *create_node(RTCThreadLocalAllocator alloc, unsigned n, void *user) {
    (void)user;
    tinner *t = rtcThreadLocalAlloc(alloc, sizeof *t, 16);
    if (!t) return NULL;
    memset(t, 0, sizeof *t);
    t->h.n = n;
    return t;
}

static void set_children(void *node, void **children, unsigned n, void *user) {
    (void)user;
    tinner *t = node;
    for (unsigned i = 0; i < n && i < 4; i++) t->c[i] = children[i];
    t->h.n = n;
}

static void set_bounds(void *node, const struct RTCBounds **bounds, unsigned n, void *user) {
    (void)user;
    tinner *t = node;
    for (unsigned i = 0; i < n && i < 4; i++) t->b[i] = *bounds[i];
}

static void *create_leaf(RTCThreadLocalAllocator alloc, const struct RTCBuildPrimitive *p, size_t n, void *user) {
    (void)user;
    tleaf *l = rtcThreadLocalAlloc(alloc, sizeof *l + n * sizeof(uint32_t), 16);
    if (!l) return NULL;
    l->h.leaf = 1;
    l->h.n = (uint32_t)n;
    l->box = (struct RTCBounds){INFINITY, INFINITY, INFINITY, 0.f, -INFINITY, -INFINITY, -INFINITY, 0.f};
    for (size_t i = 0; i < n; i++) {
        l->prim[i] = p[i].primID;
        l->box.lower_x = fminf(l->box.lower_x, p[i].lower_x);
        l->box.lower_y = fminf(l->box.lower_y, p[i].lower_y);
        l->box.lower_z = fminf(l->box.lower_z, p[i].lower_z);
        l->box.upper_x = fmaxf(l->box.upper_x, p[i].upper_x);
        l->box.upper_y = fmaxf(l->box.upper_y, p[i].upper_y);
        l->box.upper_z = fmaxf(l->box.upper_z, p[i].upper_z);
    }
    return l;
}

static inline void box_grow(float lo[3], float hi[3], const float p[3]) {
    for (int k = 0; k < 3; k++) {
        lo[k] = fminf(lo[k], p[k]);
        hi[k] = fmaxf(hi[k], p[k]);
    }
}

/* Spatial split of a (fragment of a) triangle at plane x[dim] = pos: the bounds of the triangle's
 * parts on either side, clipped to the fragment's box. The crossing points are computed in float;
 * each side's box is widened by a few ulps of the coordinates (then clipped to the fragment's box
 * again) so that rounding never leaves part of the triangle outside the boxes. */
static void split_prim(const struct RTCBuildPrimitive *p, unsigned dim, float pos, struct RTCBounds *lb,
                       struct RTCBounds *rb, void *user) {
    const build_ctx *bc = user;
    const uint32_t *t = bc->s->tri + 3 * (size_t)p->primID;
    float v[3][3];
    for (int i = 0; i < 3; i++) memcpy(v[i], bc->s->pos + 3 * (size_t)t[i], sizeof v[i]);
    float llo[3] = {INFINITY, INFINITY, INFINITY}, lhi[3] = {-INFINITY, -INFINITY, -INFINITY};
    float rlo[3] = {INFINITY, INFINITY, INFINITY}, rhi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (int i = 0; i < 3; i++) {
        const float *a = v[i], *b = v[(i + 1) % 3];
        if (a[dim] <= pos) box_grow(llo, lhi, a);
        if (a[dim] >= pos) box_grow(rlo, rhi, a);
        if ((a[dim] < pos && b[dim] > pos) || (a[dim] > pos && b[dim] < pos)) {
            float f = (pos - a[dim]) / (b[dim] - a[dim]);
            float c[3];
            for (int k = 0; k < 3; k++) c[k] = a[k] + f * (b[k] - a[k]);
            c[dim] = pos;
            box_grow(llo, lhi, c);
            box_grow(rlo, rhi, c);
        }
    }
    const float plo[3] = {p->lower_x, p->lower_y, p->lower_z}, phi[3] = {p->upper_x, p->upper_y, p->upper_z};
    for (int k = 0; k < 3; k++) {
        float e = 4e-7f * fmaxf(fabsf(plo[k]), fabsf(phi[k]));
        llo[k] = fmaxf(llo[k] - e, plo[k]);
        lhi[k] = fminf(lhi[k] + e, phi[k]);
        rlo[k] = fmaxf(rlo[k] - e, plo[k]);
        rhi[k] = fminf(rhi[k] + e, phi[k]);
    }
    lhi[dim] = fminf(lhi[dim], pos);
    rlo[dim] = fmaxf(rlo[dim], pos);
    *lb = (struct RTCBounds){llo[0], llo[1], llo[2], 0.f, lhi[0], lhi[1], lhi[2], 0.f};
    *rb = (struct RTCBounds){rlo[0], rlo[1], rlo[2], 0.f, rhi[0], rhi[1], rhi[2], 0.f};
}

static bool on_memory(void *user, ssize_t bytes, bool post) {
    (void)post;
    build_ctx *bc = user;
    long long now = atomic_fetch_add_explicit(&bc->bytes, (long long)bytes, memory_order_relaxed) + bytes;
    long long peak = atomic_load_explicit(&bc->peak, memory_order_relaxed);
    while (now > peak &&
           !atomic_compare_exchange_weak_explicit(&bc->peak, &peak, now, memory_order_relaxed, memory_order_relaxed)) {}
    return true;
}

static _Thread_local char g_bvh_error[256];
static void on_error(void *user, enum RTCError code, const char *str) {
    (void)user;
    snprintf(g_bvh_error, sizeof g_bvh_error, "Embree error %d: %s", (int)code, str ? str : "");
}

/* ------------------------------------------------------------ flattening */

typedef struct flat_ctx {
    const pgi_scene *s;
    pgi__bvh *b;
    const uint32_t *mask_of; /* scene triangle -> masks[] entry (NULL: no cut-outs) */
    size_t nnodes, ntris;
    double sah; /* sum of Ct SA(inner) + Ci n SA(leaf), unnormalised */
    int max_depth;
} flat_ctx;

static double box_area(const struct RTCBounds *b) {
    double dx = (double)b->upper_x - b->lower_x, dy = (double)b->upper_y - b->lower_y,
           dz = (double)b->upper_z - b->lower_z;
    if (!(dx >= 0 && dy >= 0 && dz >= 0)) return 0.0;
    return 2.0 * (dx * dy + dy * dz + dz * dx);
}

/* Inner nodes and triangle references of a subtree. */
static void count_tree(const tnode *n, size_t *inner, size_t *refs) {
    if (n->leaf) {
        *refs += n->n;
        return;
    }
    (*inner)++;
    const tinner *t = (const tinner *)n;
    for (uint32_t i = 0; i < n->n; i++) count_tree(t->c[i], inner, refs);
}

static void write_tri(const pgi_scene *s, const uint32_t *mask_of, uint32_t prim, pgi__tri_bvh_tri *o) {
    const uint32_t *t = s->tri + 3 * (size_t)prim;
    const float *v0 = s->pos + 3 * (size_t)t[0], *v1 = s->pos + 3 * (size_t)t[1], *v2 = s->pos + 3 * (size_t)t[2];
    for (int k = 0; k < 3; k++) {
        o->v0[k] = v0[k];
        o->e1[k] = v0[k] - v1[k];
        o->e2[k] = v2[k] - v0[k];
    }
    o->prim = prim;
    o->flags = pgi__mat_masked(&s->mats[s->tri_mat[prim]]) ? PGI__BVH_TRI_MASKED | (mask_of[prim] << 1) : 0u;
    o->pad = 0.f;
}

/* The reference of a leaf: its triangles are appended to tris[]. */
static uint32_t flatten_leaf(flat_ctx *fc, const tleaf *l) {
    uint32_t first = (uint32_t)fc->ntris;
    for (uint32_t i = 0; i < l->h.n; i++) write_tri(fc->s, fc->mask_of, l->prim[i], &fc->b->tris[fc->ntris++]);
    return PGI__BVH_LEAF | ((l->h.n - 1) << PGI__BVH_LEAF_SHIFT) | first;
}

/* Slot i of node nd. `+ 0.f` turns -0 into +0: Embree's parallel reductions give either for a
 * zero coordinate, and the build is the same bytes every time. */
static void set_slot(pgi__tri_bvh_node *nd, int i, const struct RTCBounds *b, uint32_t child) {
    nd->lo_x[i] = b->lower_x + 0.f;
    nd->lo_y[i] = b->lower_y + 0.f;
    nd->lo_z[i] = b->lower_z + 0.f;
    nd->hi_x[i] = b->upper_x + 0.f;
    nd->hi_y[i] = b->upper_y + 0.f;
    nd->hi_z[i] = b->upper_z + 0.f;
    nd->child[i] = child;
}

static void clear_node(pgi__tri_bvh_node *nd) {
    static const struct RTCBounds empty = {INFINITY, INFINITY, INFINITY, 0.f, -INFINITY, -INFINITY, -INFINITY, 0.f};
    for (int i = 0; i < 4; i++) set_slot(nd, i, &empty, PGI__BVH_EMPTY);
}

/* Writes inner node t (depth: its level, the root 1) and its subtree depth-first (a node's first
 * child right after it); returns its index; *need receives the traversal stack entries the
 * subtree can need (k - 1 pushed at a node whose k children are all entered, plus the most of
 * any child's). */
static uint32_t flatten_inner(flat_ctx *fc, const tinner *t, int depth, int *need) {
    uint32_t idx = (uint32_t)fc->nnodes++;
    pgi__tri_bvh_node *nd = &fc->b->nodes[idx];
    clear_node(nd);
    if (depth > fc->max_depth) fc->max_depth = depth;
    int most = 0;
    for (uint32_t i = 0; i < t->h.n; i++) {
        const tnode *c = t->c[i];
        uint32_t ref;
        int cneed = 0;
        if (c->leaf) {
            ref = flatten_leaf(fc, (const tleaf *)c);
            fc->sah += (double)c->n * box_area(&t->b[i]);
        } else {
            ref = flatten_inner(fc, (const tinner *)c, depth + 1, &cneed);
            fc->sah += box_area(&t->b[i]);
        }
        if (cneed > most) most = cneed;
        set_slot(&fc->b->nodes[idx], (int)i, &t->b[i], ref);
    }
    *need = (int)t->h.n - 1 + most;
    return idx;
}

pgi__tri_bvh_config pgi__tri_bvh_default_config(void) {
    pgi__tri_bvh_config c = {.quality = 1, .width = 4, .max_leaf = 4, .traversal_cost = 1.f, .intersection_cost = 1.f};
    return c;
}

void pgi__tri_bvh_destroy(pgi__bvh *b) {
    if (!b) return;
    free(b->nodes);
    free(b->tris);
    free(b->masks);
    free(b->alpha);
    free(b);
}

static size_t arrays_bytes(const pgi__bvh *b) {
    return b->nnodes * sizeof(pgi__tri_bvh_node) + b->ntris * sizeof(pgi__tri_bvh_tri) +
           b->nmasks * sizeof(pgi__tri_bvh_mask) + b->nalpha * sizeof(uint32_t);
}

size_t pgi__tri_bvh_memory(const pgi__bvh *b) { return b ? sizeof *b + arrays_bytes(b) : 0; }

/* The cut-out records: one per masked scene triangle (in triangle order), and the alpha
 * channels of their textures packed into b->alpha; *mask_of (ntris entries) maps a scene
 * triangle to its record. Nothing (and *mask_of NULL) when no triangle is masked. */
static pgi_status build_masks(const pgi_scene *s, pgi__bvh *b, uint32_t **mask_of) {
    *mask_of = NULL;
    size_t n = 0;
    for (size_t t = 0; t < s->ntris; t++) n += pgi__mat_masked(&s->mats[s->tri_mat[t]]);
    if (!n) return PGI_OK;
    if (n >= (1u << 31)) return pgi__fail(PGI_ERR_UNSUPPORTED, "GPU BVH: %zu cut-out triangles, at most 2^31", n);
    uint32_t *map = malloc(s->ntris * sizeof *map);
    int64_t *tex_at = malloc((s->ntexs ? s->ntexs : 1) * sizeof *tex_at);
    b->masks = calloc(n, sizeof *b->masks);
    if (!map || !tex_at || !b->masks) {
        free(map);
        free(tex_at);
        return pgi__fail(PGI_ERR_OOM, "out of memory for the GPU BVH's %zu cut-out triangles", n);
    }
    /* the textures' places in alpha[] (texels, a multiple of 4) */
    size_t texels = 0;
    for (size_t i = 0; i < s->ntexs; i++) tex_at[i] = -1;
    for (size_t t = 0; t < s->ntris; t++) {
        const pgi__material *m = &s->mats[s->tri_mat[t]];
        if (!pgi__mat_masked(m) || m->tex_alpha < 0) continue;
        const pgi__texture *tx = &s->texs[m->tex_alpha];
        if (tex_at[m->tex_alpha] >= 0 || !tx->rgba || tx->width <= 0 || tx->height <= 0) continue;
        tex_at[m->tex_alpha] = (int64_t)texels;
        texels += ((size_t)tx->width * (size_t)tx->height + 3) & ~(size_t)3;
    }
    pgi_status st = PGI_OK;
    if (texels >= ((size_t)1 << 32))
        st = pgi__fail(PGI_ERR_UNSUPPORTED, "GPU BVH: the cut-out textures hold %zu texels, at most 2^32", texels);
    else if (texels && !(b->alpha = calloc(texels / 4, sizeof *b->alpha)))
        st = pgi__fail(PGI_ERR_OOM, "out of memory for the GPU BVH's cut-out textures (%zu texels)", texels);
    if (st) {
        free(map);
        free(tex_at);
        return st;
    }
    b->nalpha = texels / 4;
    for (size_t i = 0; i < s->ntexs; i++) {
        if (tex_at[i] < 0) continue;
        const pgi__texture *tx = &s->texs[i];
        size_t nt = (size_t)tx->width * (size_t)tx->height, at = (size_t)tex_at[i];
        for (size_t k = 0; k < nt; k++)
            b->alpha[(at + k) >> 2] |= (uint32_t)tx->rgba[4 * k + 3] << (8 * ((at + k) & 3));
    }
    for (size_t t = 0; t < s->ntris; t++) {
        const pgi__material *m = &s->mats[s->tri_mat[t]];
        if (!pgi__mat_masked(m)) continue;
        pgi__tri_bvh_mask *k = &b->masks[b->nmasks];
        map[t] = (uint32_t)b->nmasks++;
        if (s->uv) {
            const uint32_t *ti = s->tri + 3 * t;
            memcpy(k->uv0, s->uv + 2 * (size_t)ti[0], sizeof k->uv0);
            memcpy(k->uv1, s->uv + 2 * (size_t)ti[1], sizeof k->uv1);
            memcpy(k->uv2, s->uv + 2 * (size_t)ti[2], sizeof k->uv2);
        }
        k->cutoff = m->alpha_cutoff;
        if (m->tex_alpha >= 0 && tex_at[m->tex_alpha] >= 0) {
            k->texel0 = (uint32_t)tex_at[m->tex_alpha];
            k->width = (uint32_t)s->texs[m->tex_alpha].width;
            k->height = (uint32_t)s->texs[m->tex_alpha].height;
        }
    }
    free(tex_at);
    *mask_of = map;
    return PGI_OK;
}

int pgi__tri_bvh_needs_update(const pgi__bvh *b, const pgi_scene *s) {
    return b->static_version != s->static_version || b->dynamic_version != s->dynamic_version;
}

/* Bounds of scene triangle t into p; 0 when no ray can hit it (a non-finite coordinate, or
 * e1 x e2 = 0 exactly: Embree's test refuses den = 0 for every ray). */
static int prim_bounds(const pgi_scene *s, uint32_t t, struct RTCBuildPrimitive *p) {
    const uint32_t *ti = s->tri + 3 * (size_t)t;
    float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    const float *v[3];
    for (int i = 0; i < 3; i++) {
        v[i] = s->pos + 3 * (size_t)ti[i];
        for (int k = 0; k < 3; k++)
            if (!isfinite(v[i][k])) return 0;
        box_grow(lo, hi, v[i]);
    }
    float e1[3], e2[3];
    for (int k = 0; k < 3; k++) {
        e1[k] = v[0][k] - v[1][k];
        e2[k] = v[2][k] - v[0][k];
    }
    float ng[3] = {e2[1] * e1[2] - e2[2] * e1[1], e2[2] * e1[0] - e2[0] * e1[2], e2[0] * e1[1] - e2[1] * e1[0]};
    if (ng[0] == 0.f && ng[1] == 0.f && ng[2] == 0.f) return 0;
    *p = (struct RTCBuildPrimitive){lo[0], lo[1], lo[2], 0u, hi[0], hi[1], hi[2], t};
    return 1;
}

pgi_status pgi__tri_bvh_build(const pgi_scene *s, const pgi__tri_bvh_config *cfg_in, pgi__bvh **out) {
    *out = NULL;
    const pgi__tri_bvh_config cfg = cfg_in ? *cfg_in : pgi__tri_bvh_default_config();
    if ((cfg.width != 2 && cfg.width != 4) || cfg.max_leaf < 1 || cfg.max_leaf > PGI__BVH_MAX_LEAF ||
        (cfg.quality != 1 && cfg.quality != 2))
        return pgi__fail(PGI_ERR_INVALID_ARG, "GPU BVH: width %d (2 or 4), max_leaf %d (1..%d), quality %d (1 or 2)",
                         cfg.width, cfg.max_leaf, PGI__BVH_MAX_LEAF, cfg.quality);
    double t0 = pgi__now_ms();
    pgi__bvh *b = calloc(1, sizeof *b);
    if (!b) return pgi__fail(PGI_ERR_OOM, "out of memory creating the GPU BVH");
    b->static_version = s->static_version;
    b->dynamic_version = s->dynamic_version;
    build_ctx bc = {.s = s};
    const int high = cfg.quality == 2;
    size_t cap = s->ntris * (high ? 2 : 1);
    struct RTCBuildPrimitive *prims = NULL;
    if (cap && !(prims = aligned_alloc(32, cap * sizeof *prims))) {
        free(b);
        return pgi__fail(PGI_ERR_OOM, "out of memory building the GPU BVH over %zu triangles", s->ntris);
    }
    size_t n = 0;
    for (size_t t = 0; t < s->ntris; t++) n += prim_bounds(s, (uint32_t)t, &prims[n]);
    b->stats.scene_tris = n;

    RTCDevice dev = NULL;
    RTCBVH bvh = NULL;
    tnode *root = NULL;
    pgi_status st = PGI_OK;
    g_bvh_error[0] = 0;
    if (n > 0) {
        dev = rtcNewDevice(NULL);
        if (!dev) {
            st = pgi__fail(PGI_ERR_INTERNAL, "cannot create an Embree device (error %d)", (int)rtcGetDeviceError(NULL));
            goto done;
        }
        rtcSetDeviceErrorFunction(dev, on_error, NULL);
        rtcSetDeviceMemoryMonitorFunction(dev, on_memory, &bc);
        bvh = rtcNewBVH(dev);
        struct RTCBuildArguments a;
        memset(&a, 0, sizeof a);
        a.byteSize = sizeof a;
        a.buildQuality = high ? RTC_BUILD_QUALITY_HIGH : RTC_BUILD_QUALITY_MEDIUM;
        a.buildFlags = RTC_BUILD_FLAG_NONE;
        a.maxBranchingFactor = (unsigned)cfg.width;
        a.maxDepth = 48;
        a.sahBlockSize = 1;
        a.minLeafSize = 1;
        a.maxLeafSize = (unsigned)cfg.max_leaf;
        a.traversalCost = cfg.traversal_cost;
        a.intersectionCost = cfg.intersection_cost;
        a.bvh = bvh;
        a.primitives = prims;
        a.primitiveCount = n;
        a.primitiveArrayCapacity = high ? cap : n;
        a.createNode = create_node;
        a.setNodeChildren = set_children;
        a.setNodeBounds = set_bounds;
        a.createLeaf = create_leaf;
        a.splitPrimitive = high ? split_prim : NULL;
        a.userPtr = &bc;
        root = bvh ? rtcBuildBVH(&a) : NULL;
        if (!root || rtcGetDeviceError(dev) != RTC_ERROR_NONE || g_bvh_error[0]) {
            st = pgi__fail(PGI_ERR_INTERNAL, "building the GPU BVH over %zu triangles failed: %s", n,
                           g_bvh_error[0] ? g_bvh_error : "no tree");
            goto done;
        }
    }
    {
        size_t inner = 0, refs = 0;
        if (root) count_tree(root, &inner, &refs);
        if (!root || root->leaf) inner++; /* the root is always an inner node */
        if (refs >= PGI__BVH_MAX_TRIS) {
            st =
                pgi__fail(PGI_ERR_UNSUPPORTED, "the GPU BVH holds at most %u triangle references; this scene needs %zu",
                          PGI__BVH_MAX_TRIS, refs);
            goto done;
        }
        b->nodes = malloc(inner * sizeof *b->nodes);
        b->tris = malloc((refs ? refs : 1) * sizeof *b->tris);
        if (!b->nodes || !b->tris) {
            st = pgi__fail(PGI_ERR_OOM, "out of memory flattening the GPU BVH (%zu nodes, %zu triangles)", inner, refs);
            goto done;
        }
        uint32_t *mask_of = NULL;
        if ((st = build_masks(s, b, &mask_of))) goto done;
        flat_ctx fc = {.s = s, .b = b, .mask_of = mask_of};
        int need = 0;
        double root_area = 0.0;
        if (!root) {
            clear_node(&b->nodes[fc.nnodes++]);
            fc.max_depth = 1;
        } else if (root->leaf) {
            const tleaf *l = (const tleaf *)root;
            clear_node(&b->nodes[fc.nnodes++]);
            set_slot(&b->nodes[0], 0, &l->box, flatten_leaf(&fc, l));
            root_area = box_area(&l->box);
            fc.sah = root_area + (double)l->h.n * root_area;
            fc.max_depth = 1;
        } else {
            const tinner *t = (const tinner *)root;
            struct RTCBounds rb = t->b[0];
            for (uint32_t i = 1; i < t->h.n; i++) {
                rb.lower_x = fminf(rb.lower_x, t->b[i].lower_x);
                rb.lower_y = fminf(rb.lower_y, t->b[i].lower_y);
                rb.lower_z = fminf(rb.lower_z, t->b[i].lower_z);
                rb.upper_x = fmaxf(rb.upper_x, t->b[i].upper_x);
                rb.upper_y = fmaxf(rb.upper_y, t->b[i].upper_y);
                rb.upper_z = fmaxf(rb.upper_z, t->b[i].upper_z);
            }
            root_area = box_area(&rb);
            flatten_inner(&fc, t, 1, &need);
            fc.sah += root_area; /* the root's own visit */
        }
        free(mask_of);
        PGI__ASSERT(fc.nnodes == inner && fc.ntris == refs);
        b->nnodes = fc.nnodes;
        b->ntris = fc.ntris;
        pgi__tri_bvh_stats *S = &b->stats;
        S->inner = b->nnodes;
        S->tri_refs = b->ntris;
        S->max_depth = fc.max_depth;
        S->stack_need = need;
        S->sah_cost = root_area > 0.0 ? fc.sah / root_area : 0.0;
        for (size_t i = 0; i < b->nnodes; i++)
            for (int k = 0; k < 4; k++) {
                uint32_t c = b->nodes[i].child[k];
                S->empty_slots += c == PGI__BVH_EMPTY;
                S->leaves += c != PGI__BVH_EMPTY && (c & PGI__BVH_LEAF);
            }
        if (need > PGI__BVH_STACK) {
            st = pgi__fail(PGI_ERR_UNSUPPORTED,
                           "the GPU BVH over %zu triangles is too deep: its traversal needs %d stack entries, the "
                           "shaders have %d",
                           n, need, PGI__BVH_STACK);
            goto done;
        }
    }
done:
    if (bvh) rtcReleaseBVH(bvh);
    if (dev) rtcReleaseDevice(dev);
    free(prims);
    if (st) {
        pgi__tri_bvh_destroy(b);
        return st;
    }
    long long pk = atomic_load_explicit(&bc.peak, memory_order_relaxed);
    b->stats.build_bytes = cap * sizeof(struct RTCBuildPrimitive) + (pk > 0 ? (size_t)pk : 0);
    b->stats.bytes = arrays_bytes(b);
    b->stats.build_ms = pgi__now_ms() - t0;
    *out = b;
    return PGI_OK;
}

int pgi__tri_bvh_scene_filter(void *scene, const pgi__tri_bvh_tri *tri, float u, float v) {
    return pgi__scene_cut_out((const pgi_scene *)scene, tri->prim, u, v);
}

static inline int wrap_index(int i, int n) { return i < 0 ? i + n : i >= n ? i - n : i; }

/* pgi__scene_cut_out on the layout's arrays: pgi__scene_uv, then pgi__texture_alpha's bilinear
 * lookup, operation for operation (bvh.glsl's bvh_cut_out is this again). */
int pgi__tri_bvh_mask_filter(void *bvh, const pgi__tri_bvh_tri *tri, float b1, float b2) {
    const pgi__bvh *b = bvh;
    const pgi__tri_bvh_mask *m = &b->masks[tri->flags >> 1];
    float bw = 1.f - b1 - b2;
    float u = bw * m->uv0[0] + b1 * m->uv1[0] + b2 * m->uv2[0];
    float v = bw * m->uv0[1] + b1 * m->uv1[1] + b2 * m->uv2[1];
    float alpha = 1.f;
    if (m->width > 0) {
        const int w = (int)m->width, h = (int)m->height;
        if (!isfinite(u)) u = 0.f;
        if (!isfinite(v)) v = 0.f;
        float fu = u - floorf(u), fv = v - floorf(v);
        float x = fu * (float)w - 0.5f, y = (1.f - fv) * (float)h - 0.5f;
        float x0f = floorf(x), y0f = floorf(y);
        float tx = x - x0f, ty = y - y0f;
        int x0 = wrap_index((int)x0f, w), x1 = wrap_index((int)x0f + 1, w);
        int y0 = wrap_index((int)y0f, h), y1 = wrap_index((int)y0f + 1, h);
#define TEXEL(X, Y)                                                                                                    \
    (float)((b->alpha[(m->texel0 + (uint32_t)(Y)*m->width + (uint32_t)(X)) >> 2] >>                                    \
             (8u * ((m->texel0 + (uint32_t)(Y)*m->width + (uint32_t)(X)) & 3u))) &                                     \
            0xFFu)
        float a = TEXEL(x0, y0), bb = TEXEL(x1, y0), c = TEXEL(x0, y1), d = TEXEL(x1, y1);
#undef TEXEL
        float top = a + (bb - a) * tx, bot = c + (d - c) * tx;
        alpha = (top + (bot - top) * ty) * (1.f / 255.f);
    }
    return alpha < m->cutoff;
}

/* ------------------------------------------------------------ traversal (bvh.glsl's algorithm) */

/* 1 + 2 gamma(3), gamma(n) = n u / (1 - n u), u = 2^-24: widens a box's far distance so that the
 * rounding of the slab test never misses a box the ray touches (Ize 2013). */
#define BOX_WIDEN 1.00000036f
/* Embree's rcp_safe: direction components below this in magnitude become +-this. */
#define MIN_RCP_INPUT 1e-18f

typedef struct ray_pre {
    float o[3], rd[3];
    int neg[3];
} ray_pre;

static inline void ray_prepare(ray_pre *r, const float o[3], const float d[3]) {
    for (int k = 0; k < 3; k++) {
        float dk = d[k];
        if (fabsf(dk) < MIN_RCP_INPUT) dk = dk < 0.f ? -MIN_RCP_INPUT : MIN_RCP_INPUT;
        r->o[k] = o[k];
        r->rd[k] = 1.f / dk;
        r->neg[k] = r->rd[k] < 0.f;
    }
}

/* The children of node nd the ray enters within (tnear, tfar]: their references and entry
 * distances, nearest first (ties: slot order). Returns their count. */
static inline int node_children(const pgi__tri_bvh_node *nd, const ray_pre *r, float tnear, float tfar,
                                uint32_t ref[4]) {
    float dist[4];
    int cnt = 0;
    for (int i = 0; i < 4; i++) {
        float lx = r->neg[0] ? nd->hi_x[i] : nd->lo_x[i], fx = r->neg[0] ? nd->lo_x[i] : nd->hi_x[i];
        float ly = r->neg[1] ? nd->hi_y[i] : nd->lo_y[i], fy = r->neg[1] ? nd->lo_y[i] : nd->hi_y[i];
        float lz = r->neg[2] ? nd->hi_z[i] : nd->lo_z[i], fz = r->neg[2] ? nd->lo_z[i] : nd->hi_z[i];
        float n0 = (lx - r->o[0]) * r->rd[0], n1 = (ly - r->o[1]) * r->rd[1], n2 = (lz - r->o[2]) * r->rd[2];
        float f0 = (fx - r->o[0]) * r->rd[0], f1 = (fy - r->o[1]) * r->rd[1], f2 = (fz - r->o[2]) * r->rd[2];
        float tn = fmaxf(fmaxf(n0, n1), fmaxf(n2, tnear));
        float tf = fminf(fminf(f0, f1), fminf(f2, tfar));
        if (tn <= tf * BOX_WIDEN) {
            /* insertion by distance, after equal ones */
            int j = cnt++;
            while (j > 0 && dist[j - 1] > tn) {
                dist[j] = dist[j - 1];
                ref[j] = ref[j - 1];
                j--;
            }
            dist[j] = tn;
            ref[j] = nd->child[i];
        }
    }
    return cnt;
}

/* Embree's Moeller-Trumbore (triangle4 layout): 1 and t, u, v when the ray hits tri within
 * (tnear, tfar]. */
static inline int tri_hit(const pgi__tri_bvh_tri *tr, const float o[3], const float d[3], float tnear, float tfar,
                          float *t, float *u, float *v) {
    const float *e1 = tr->e1, *e2 = tr->e2;
    float C[3] = {tr->v0[0] - o[0], tr->v0[1] - o[1], tr->v0[2] - o[2]};
    float R[3] = {C[1] * d[2] - C[2] * d[1], C[2] * d[0] - C[0] * d[2], C[0] * d[1] - C[1] * d[0]};
    float Ng[3] = {e2[1] * e1[2] - e2[2] * e1[1], e2[2] * e1[0] - e2[0] * e1[2], e2[0] * e1[1] - e2[1] * e1[0]};
    float den = Ng[0] * d[0] + Ng[1] * d[1] + Ng[2] * d[2];
    float absden = fabsf(den);
    float sgn = den < 0.f ? -1.f : 1.f;
    float U = (R[0] * e2[0] + R[1] * e2[1] + R[2] * e2[2]) * sgn;
    float V = (R[0] * e1[0] + R[1] * e1[1] + R[2] * e1[2]) * sgn;
    if (!(den != 0.f && U >= 0.f && V >= 0.f && U + V <= absden)) return 0;
    float T = (Ng[0] * C[0] + Ng[1] * C[1] + Ng[2] * C[2]) * sgn;
    if (!(absden * tnear < T && T <= absden * tfar)) return 0;
    float rcp = 1.f / absden;
    *t = T * rcp;
    *u = U * rcp;
    *v = V * rcp;
    return 1;
}

/* The traversal; any: stop at the first hit. */
static int traverse(const pgi__bvh *b, const float o[3], const float d[3], float tnear, float tfar, int any,
                    pgi__hit *h, pgi__tri_bvh_filter filter, void *user, pgi__tri_bvh_counters *c) {
    ray_pre r;
    ray_prepare(&r, o, d);
    uint32_t stack[PGI__BVH_STACK];
    int sp = 0, found = 0;
    uint32_t ref = 0;
    uint64_t nn = 0, nl = 0, nt = 0;
    for (;;) {
        if (!(ref & PGI__BVH_LEAF)) {
            nn++;
            uint32_t ch[4];
            int k = node_children(&b->nodes[ref], &r, tnear, tfar, ch);
            if (k > 0) {
                for (int i = k - 1; i >= 1; i--) stack[sp++] = ch[i];
                ref = ch[0];
                continue;
            }
        } else {
            nl++;
            uint32_t first = ref & (PGI__BVH_MAX_TRIS - 1), cnt = ((ref >> PGI__BVH_LEAF_SHIFT) & 15u) + 1u;
            for (uint32_t i = first; i < first + cnt; i++) {
                const pgi__tri_bvh_tri *tr = &b->tris[i];
                float t, u, v;
                nt++;
                if (!tri_hit(tr, o, d, tnear, tfar, &t, &u, &v)) continue;
                if ((tr->flags & PGI__BVH_TRI_MASKED) && filter && filter(user, tr, u, v)) continue;
                found = 1;
                tfar = t;
                if (h) {
                    h->t = t;
                    h->u = u;
                    h->v = v;
                    h->prim = tr->prim;
                }
                if (any) goto out;
            }
        }
        if (sp == 0) break;
        ref = stack[--sp];
    }
out:
    if (c) {
        c->nodes += nn;
        c->leaves += nl;
        c->tris += nt;
    }
    return found;
}

int pgi__tri_bvh_intersect(const pgi__bvh *b, const float o[3], const float d[3], float tnear, float tfar, pgi__hit *h,
                           pgi__tri_bvh_filter filter, void *user, pgi__tri_bvh_counters *c) {
    h->prim = UINT32_MAX;
    return traverse(b, o, d, tnear, tfar, 0, h, filter, user, c);
}

int pgi__tri_bvh_occluded(const pgi__bvh *b, const float o[3], const float d[3], float tnear, float tfar,
                          pgi__tri_bvh_filter filter, void *user, pgi__tri_bvh_counters *c) {
    return traverse(b, o, d, tnear, tfar, 1, NULL, filter, user, c);
}
