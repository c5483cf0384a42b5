/* The ray-tracing BVH of the GPU backend (issue "The GPU backend", item 2): built on the CPU with
 * Embree's BVH builder (rtcBuildBVH: SAH, our own node callbacks), flattened into plain arrays the
 * compute shaders read as std430 storage buffers (src/gpu/shaders/bvh.glsl), uploaded once per
 * geometry change. The CPU traversal here runs exactly the shader's algorithm on exactly that
 * layout (tests/test_gpu_bvh.c checks it against Embree; the GPU kernel is checked against it).
 *
 * Layout (all little-endian 32-bit words; the GLSL declarations in bvh.glsl match byte for byte):
 *
 *   nodes[nnodes]: pgi__tri_bvh_node, 112 bytes, 4-wide. Node 0 is the root. Child slot i:
 *     AABB (lo_x[i], lo_y[i], lo_z[i]) .. (hi_x[i], hi_y[i], hi_z[i]) as floats (rounded
 *     outwards: the builder's float bounds), SoA so that a shader reads six vec4s and one uvec4;
 *     child[i]: PGI__BVH_EMPTY (unused slot: its box is empty, lo = +inf, hi = -inf), an inner
 *     node's index (bit 31 clear), or a leaf: bit 31 set, bits 27..30 count - 1 (1..16
 *     triangles), bits 0..26 the leaf's first entry in tris[].
 *     GLSL: struct Node { vec4 lo_x, hi_x, lo_y, hi_y, lo_z, hi_z; uvec4 child; };
 *
 *   tris[ntris]: pgi__tri_bvh_tri, 48 bytes, in leaf order (a leaf's triangles are contiguous; with
 *     spatial splits a scene triangle may appear in several leaves). Precomputed for Embree's
 *     Moeller-Trumbore test (its triangle4 layout): v0, e1 = v0 - v1, e2 = v2 - v0, and in the
 *     w components the scene triangle index (prim, v0's w) and flags (e1's w): bit 0
 *     (PGI__BVH_TRI_MASKED) the material has a cut-out mask, bits 1..31 then its entry in masks[].
 *     GLSL: struct Tri { vec4 v0_prim; vec4 e1_flags; vec4 e2; };   prim = floatBitsToUint(v0_prim.w)
 *
 *   masks[nmasks]: pgi__tri_bvh_mask, 48 bytes, one a cut-out scene triangle: its vertices' texture
 *     coordinates, the material's alpha cutoff, and its alpha texture (texel0: first texel in
 *     alpha[], width x height; width 0: no texture, alpha 1).
 *     GLSL: struct Mask { vec4 uv01; vec2 uv2; float cutoff; uint texel0; uint width, height, pad0, pad1; };
 *
 *   alpha[nalpha]: uint32 words holding the 8-bit alpha channel of the cut-out textures, four
 *     texels a word (texel k: byte k & 3 of word k >> 2, the least significant first), rows from
 *     the top as pgi__texture; each texture starts at a word.
 *   A hit on a masked triangle is refused where the alpha (bilinear, wrapping, as
 *   pgi__texture_alpha) is below the cutoff: pgi__tri_bvh_mask_filter, bvh.glsl's bvh_cut_out, and
 *   the renderer's pgi__scene_cut_out give the same answer.
 *
 * Traversal (pgi__tri_bvh_intersect / pgi__tri_bvh_occluded and bvh.glsl alike): a stack of child
 * references (PGI__BVH_STACK entries; the builder checks the tree never needs more), root first;
 * at an inner node the four slab tests (reciprocal direction, tiny components replaced by
 * +-1e-18 as Embree does, the far distance widened by 2 gamma(3) so that rounding never loses a
 * box) give the children the ray enters within (tnear, t_closest]; they are pushed farthest first,
 * so the nearest is popped next. At a leaf each triangle gets Embree's Moeller-Trumbore test: hit
 * when den != 0, U >= 0, V >= 0, U + V <= |den|, and tnear < t <= tfar (both faces: no culling),
 * t = T / |den|, u = U / |den|, v = V / |den| (barycentrics of vertices 1 and 2, as Embree's).
 * A hit on a masked triangle then goes through the cut-out test (the CPU traversal: a filter
 * callback, pgi__tri_bvh_mask_filter for the shader's, pgi__tri_bvh_scene_filter for the renderer's).
 * Closest hit shrinks tfar to each hit's t (a later hit at an equal t replaces an earlier one, as
 * Embree's `T <= tfar`); any hit stops at the first hit. Rays of ray.mask -1 only (no ray masks). */
#ifndef PGI__RT_TRI_BVH_H
#define PGI__RT_TRI_BVH_H

#include "rt/rt.h"

#define PGI__BVH_EMPTY 0xFFFFFFFFu
#define PGI__BVH_LEAF 0x80000000u
#define PGI__BVH_LEAF_SHIFT 27
#define PGI__BVH_MAX_LEAF 16
#define PGI__BVH_MAX_TRIS (1u << PGI__BVH_LEAF_SHIFT)
#define PGI__BVH_STACK 64
#define PGI__BVH_TRI_MASKED 1u

typedef struct pgi__tri_bvh_node {
    float lo_x[4], hi_x[4], lo_y[4], hi_y[4], lo_z[4], hi_z[4];
    uint32_t child[4];
} pgi__tri_bvh_node;
_Static_assert(sizeof(pgi__tri_bvh_node) == 112 && offsetof(pgi__tri_bvh_node, child) == 96, "bvh.glsl Node");

typedef struct pgi__tri_bvh_tri {
    float v0[3];
    uint32_t prim;
    float e1[3];
    uint32_t flags;
    float e2[3];
    float pad;
} pgi__tri_bvh_tri;
_Static_assert(sizeof(pgi__tri_bvh_tri) == 48 && offsetof(pgi__tri_bvh_tri, e1) == 16 &&
                   offsetof(pgi__tri_bvh_tri, e2) == 32,
               "bvh.glsl Tri");

typedef struct pgi__tri_bvh_mask {
    float uv0[2], uv1[2], uv2[2];
    float cutoff;
    uint32_t texel0;
    uint32_t width, height;
    uint32_t pad[2];
} pgi__tri_bvh_mask;
_Static_assert(sizeof(pgi__tri_bvh_mask) == 48 && offsetof(pgi__tri_bvh_mask, cutoff) == 24 &&
                   offsetof(pgi__tri_bvh_mask, width) == 32,
               "bvh.glsl Mask");

/* A ray as rays.comp reads it (32 bytes; GLSL: struct Ray { vec4 org_tnear; vec4 dir_tfar; }):
 * the segment org + t dir, tnear < t <= tfar. Its answer is a pgi__hit (16 bytes; GLSL: struct
 * Hit { float t, u, v; uint prim; }): prim UINT32_MAX for a miss. */
typedef struct pgi__tri_bvh_ray {
    float org[3];
    float tnear;
    float dir[3];
    float tfar;
} pgi__tri_bvh_ray;
_Static_assert(sizeof(pgi__tri_bvh_ray) == 32 && offsetof(pgi__tri_bvh_ray, dir) == 16, "rays.comp Ray");

/* Build settings. quality: 1 Embree's binned SAH (RTC_BUILD_QUALITY_MEDIUM), 2 SAH with spatial
 * splits (RTC_BUILD_QUALITY_HIGH; triangles may be referenced from several leaves). width: 2 or 4
 * children a node (the layout is 4-wide either way; 2 leaves two slots empty, for comparison).
 * max_leaf: 1..16 triangles a leaf. */
typedef struct pgi__tri_bvh_config {
    int quality;
    int width;
    int max_leaf;
    float traversal_cost, intersection_cost; /* SAH weights given to the builder */
} pgi__tri_bvh_config;

/* The default: quality 1 (binned SAH), width 4, max_leaf 4, costs 1 and 1. On Sibenik (docs/gpu_rays.md)
 * spatial splits save 8 % of the node visits but build in 670 ms instead of 25 ms (2 threads), too
 * slow for a rebuild per animation frame; binary nodes visit twice the nodes; leaves above 4 barely
 * change the tree (the SAH with these costs stops splitting earlier). */
pgi__tri_bvh_config pgi__tri_bvh_default_config(void);

typedef struct pgi__tri_bvh_stats {
    size_t inner, leaves, empty_slots; /* nodes, leaves, unused child slots */
    size_t tri_refs;                   /* entries of tris[] (scene triangles + split duplicates) */
    size_t scene_tris;                 /* triangles given (degenerate or non-finite ones left out) */
    int max_depth;                     /* levels of inner nodes on the longest root-leaf path */
    int stack_need;                    /* entries the traversal stack can hold at most */
    double sah_cost;                   /* Ct sum SA(inner)/SA(root) + Ci sum n SA(leaf)/SA(root), Ct = Ci = 1 */
    double build_ms;                   /* Embree build + flatten */
    size_t bytes;                      /* nodes + tris (what is uploaded) */
    size_t build_bytes;                /* the builder's scratch at its peak (primitive array, Embree's tree) */
} pgi__tri_bvh_stats;

typedef struct pgi__bvh {
    pgi__tri_bvh_node *nodes;
    size_t nnodes;
    pgi__tri_bvh_tri *tris;
    size_t ntris;
    pgi__tri_bvh_mask *masks; /* NULL when nothing is cut out */
    size_t nmasks;
    uint32_t *alpha;
    size_t nalpha; /* words */
    pgi__tri_bvh_stats stats;
    uint64_t static_version, dynamic_version; /* of the scene it was built from */
} pgi__bvh;

/* Builds the BVH over the scene's current triangles (cfg NULL: the default). Triangles with
 * non-finite or collinear vertices are left out (no ray can hit them, as in Embree).
 * PGI_ERR_UNSUPPORTED when the scene has more than 2^27 triangle references or the tree would
 * need a deeper stack than PGI__BVH_STACK. */
pgi_status pgi__tri_bvh_build(const pgi_scene *s, const pgi__tri_bvh_config *cfg, pgi__bvh **out);
void pgi__tri_bvh_destroy(pgi__bvh *b);
/* 1 when the scene's geometry moved since the BVH was built (rebuild then: pgi__tri_bvh_build). */
int pgi__tri_bvh_needs_update(const pgi__bvh *b, const pgi_scene *s);
/* Bytes held (the arrays, the struct). */
size_t pgi__tri_bvh_memory(const pgi__bvh *b);

/* Called for candidate hits on PGI__BVH_TRI_MASKED triangles (tnear < t <= tfar): 1 refuses the
 * hit (traversal goes on behind it), as rt.c's Embree filter. */
typedef int (*pgi__tri_bvh_filter)(void *user, const pgi__tri_bvh_tri *tri, float u, float v);

/* Work counters of one traversal (NULL: not counted). */
typedef struct pgi__tri_bvh_counters {
    uint64_t nodes, leaves, tris;
} pgi__tri_bvh_counters;

/* Closest hit in (tnear, tfar]; 1 on a hit (h filled as pgi__rt_intersect's), else 0 and
 * h->prim = UINT32_MAX. filter NULL: masked triangles are solid. */
int pgi__tri_bvh_intersect(const pgi__bvh *b, const float o[3], const float d[3], float tnear, float tfar, pgi__hit *h,
                           pgi__tri_bvh_filter filter, void *user, pgi__tri_bvh_counters *c);
/* 1 when anything lies in (tnear, tfar]. */
int pgi__tri_bvh_occluded(const pgi__bvh *b, const float o[3], const float d[3], float tnear, float tfar,
                          pgi__tri_bvh_filter filter, void *user, pgi__tri_bvh_counters *c);

/* The renderer's cut-out filter (user = the scene): pgi__scene_cut_out. */
int pgi__tri_bvh_scene_filter(void *scene, const pgi__tri_bvh_tri *tri, float u, float v);
/* The shader's (user = the pgi__bvh): the triangle's mask record and alpha[] (bvh_cut_out). */
int pgi__tri_bvh_mask_filter(void *bvh, const pgi__tri_bvh_tri *tri, float u, float v);

#endif
