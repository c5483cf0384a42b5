/* View samples and direct light. */
#include "view.h"

#include <stdint.h>
#include <string.h>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "core/core.h"
/* AVX2 builds of a tile's directions and surfaces, picked at run time (tile_dirs_avx2,
 * tile_surfaces_avx2). */
#define VIEW_AVX2 PGI__AVX2_TARGET
#if VIEW_AVX2
#include <immintrin.h>
#endif

#include "scene/bsdf.h"
#include "scene/portal.h"

#define PGI__MAX_SPECULAR_DEPTH 8

/* The view pass shades blocks of BLOCK_TILES 4x4-pixel tiles side by side (32x4 pixels) into a
 * staging block on the stack (11 KB) and then writes each plane's rows out whole: 32 samples of
 * a vector plane are 384 bytes, of a scalar plane 128, whole cache lines where the image width
 * is a multiple of 32 (the planes are 64-byte aligned; 16x4 blocks measured a little slower). Those rows go out with non-temporal
 * stores: the 93 bytes a pixel of the G-buffer (86 MB at 1280x720) then neither read their
 * lines before writing them (write-allocate) nor evict the textures and the scene from the
 * caches. */
#define BLOCK_TILES 8
#define BLOCK_W (4 * BLOCK_TILES)
#define BLOCK_N (4 * BLOCK_W)
_Static_assert(BLOCK_W == PGI__FILL_W, "a pgi__view_fill entry is a block's row");

/* One block's view samples and emitted radiance; sample j = row * BLOCK_W + column. */
typedef struct view_block {
    float pos[3 * BLOCK_N], nrm[3 * BLOCK_N], ngeo[3 * BLOCK_N], wo[3 * BLOCK_N], kd[3 * BLOCK_N], ks[3 * BLOCK_N],
        weight[3 * BLOCK_N], emit[3 * BLOCK_N];
    float shininess[BLOCK_N], ior[BLOCK_N], depth[BLOCK_N];
    uint8_t flags[BLOCK_N];
} view_block;

/* Copies n floats to dst: streaming stores where dst is 16-byte aligned and n a multiple of 4,
 * else plain ones. */
static inline void put_floats(float *dst, const float *src, size_t n) {
#if defined(__SSE2__)
    if (((uintptr_t)dst & 15u) == 0 && (n & 3u) == 0) {
        for (size_t k = 0; k < n; k += 4) _mm_stream_ps(dst + k, _mm_loadu_ps(src + k));
        return;
    }
#endif
    memcpy(dst, src, n * sizeof(float));
}

/* Do the n floats at p all hold the bits v? */
static inline int all_bits(const float *p, size_t n, uint32_t v) {
    uint32_t acc = 0;
    for (size_t k = 0; k < n; k++) {
        uint32_t u;
        memcpy(&u, p + k, sizeof u);
        acc |= u ^ v;
    }
    return acc == 0;
}

#if VIEW_AVX2
/* put_floats with 32-byte streaming stores where dst is 32-byte aligned and n a multiple of 8. */
__attribute__((target("avx2"))) static inline void put_floats_avx2(float *dst, const float *src, size_t n) {
    if (((uintptr_t)dst & 31u) == 0 && (n & 7u) == 0) {
        for (size_t k = 0; k < n; k += 8) _mm256_stream_ps(dst + k, _mm256_loadu_ps(src + k));
        return;
    }
    put_floats(dst, src, n);
}

/* all_bits eight floats an instruction (n a multiple of 8, else all_bits). */
__attribute__((target("avx2"))) static inline int all_bits_avx2(const float *p, size_t n, uint32_t v) {
    if (n & 7u) return all_bits(p, n, v);
    const __m256i want = _mm256_set1_epi32((int)v);
    __m256i acc = _mm256_setzero_si256();
    for (size_t k = 0; k < n; k += 8)
        acc = _mm256_or_si256(acc, _mm256_xor_si256(_mm256_loadu_si256((const __m256i *)(const void *)(p + k)), want));
    return _mm256_testz_si256(acc, acc);
}
#endif

/* Writes rows [0, rows) of a block, n samples each, whose first sample is pixel i0 of the image.
 * fill (NULL: none) is the block's entry of its first row in a pgi__view_fill, `stride` entries
 * a row: a plane whose row holds its defaults there already and receives them again is left
 * alone (a float compares equal to the default's bits only when it is those bytes: -0 is not
 * +0), and each entry then says what its row holds. The body of put_block and, where the CPU
 * has AVX2, of put_block_avx2 (32-byte stores and tests). */
#define PUT_BLOCK_BODY(PUT, ALL_BITS)                                                                                  \
    const size_t m = (size_t)n;                                                                                        \
    for (int r = 0; r < rows; r++) {                                                                                   \
        size_t i = i0 + (size_t)r * W, j = (size_t)r * BLOCK_W;                                                        \
        unsigned skip = 0;                                                                                             \
        if (fill) {                                                                                                    \
            const unsigned now =                                                                                       \
                (ALL_BITS(b->ks + 3 * j, 3 * m, 0) && ALL_BITS(b->shininess + j, m, 0) && ALL_BITS(b->ior + j, m, 0)   \
                     ? PGI__FILL_LOBE                                                                                  \
                     : 0) |                                                                                            \
                (ALL_BITS(b->weight + 3 * j, 3 * m, 0x3f800000u) ? PGI__FILL_WEIGHT : 0) |                             \
                (ALL_BITS(b->emit + 3 * j, 3 * m, 0) ? PGI__FILL_EMIT : 0);                                            \
            uint8_t *f = fill + (size_t)r * stride;                                                                    \
            skip = *f & now;                                                                                           \
            *f = (uint8_t)now;                                                                                         \
            PUT_BLOCK_CHECK                                                                                            \
        }                                                                                                              \
        PUT(vs->pos + 3 * i, b->pos + 3 * j, 3 * m);                                                                   \
        PUT(vs->nrm + 3 * i, b->nrm + 3 * j, 3 * m);                                                                   \
        PUT(vs->ngeo + 3 * i, b->ngeo + 3 * j, 3 * m);                                                                 \
        PUT(vs->wo + 3 * i, b->wo + 3 * j, 3 * m);                                                                     \
        PUT(vs->kd + 3 * i, b->kd + 3 * j, 3 * m);                                                                     \
        if (!(skip & PGI__FILL_LOBE)) {                                                                                \
            PUT(vs->ks + 3 * i, b->ks + 3 * j, 3 * m);                                                                 \
            PUT(vs->shininess + i, b->shininess + j, m);                                                               \
            PUT(vs->ior + i, b->ior + j, m);                                                                           \
        }                                                                                                              \
        if (!(skip & PGI__FILL_WEIGHT)) PUT(vs->weight + 3 * i, b->weight + 3 * j, 3 * m);                             \
        if (!(skip & PGI__FILL_EMIT)) PUT(emit + 3 * i, b->emit + 3 * j, 3 * m);                                       \
        PUT(vs->depth + i, b->depth + j, m);                                                                           \
        memcpy(vs->flags + i, b->flags + j, m);                                                                        \
    }

#if defined(__SANITIZE_ADDRESS__) || !defined(NDEBUG)
/* sanitizer and debug builds: a skipped row holds what the stores would have written (a writer
 * of the buffers that did not forget the record breaks this) */
#define PUT_BLOCK_CHECK                                                                                                \
    if (skip & PGI__FILL_LOBE)                                                                                         \
        PGI__ASSERT(!memcmp(vs->ks + 3 * i, b->ks + 3 * j, 3 * m * sizeof(float)) &&                                   \
                    !memcmp(vs->shininess + i, b->shininess + j, m * sizeof(float)) &&                                 \
                    !memcmp(vs->ior + i, b->ior + j, m * sizeof(float)));                                              \
    if (skip & PGI__FILL_WEIGHT) PGI__ASSERT(!memcmp(vs->weight + 3 * i, b->weight + 3 * j, 3 * m * sizeof(float)));   \
    if (skip & PGI__FILL_EMIT) PGI__ASSERT(!memcmp(emit + 3 * i, b->emit + 3 * j, 3 * m * sizeof(float)));
#else
#define PUT_BLOCK_CHECK
#endif

static void put_block(const view_block *b, int rows, int n, size_t i0, size_t W, pgi_view_samples *vs, float *emit,
                      uint8_t *fill, size_t stride) {
    PUT_BLOCK_BODY(put_floats, all_bits)
}

#if VIEW_AVX2
__attribute__((target("avx2"))) static void put_block_avx2(const view_block *b, int rows, int n, size_t i0, size_t W,
                                                           pgi_view_samples *vs, float *emit, uint8_t *fill,
                                                           size_t stride) {
    PUT_BLOCK_BODY(put_floats_avx2, all_bits_avx2)
}
#endif

void pgi__view_fill_free(pgi__view_fill *f) {
    free(f->rows);
    *f = (pgi__view_fill){0};
}

/* Makes f describe a W x H destination: kept as it is for that size, else nothing known. Returns
 * 0 when out of memory (f is then empty). */
static int view_fill_fit(pgi__view_fill *f, int W, int H) {
    if (f->rows && f->width == W && f->height == H) return 1;
    pgi__view_fill_free(f);
    const int cols = (W + PGI__FILL_W - 1) / PGI__FILL_W;
    f->rows = calloc((size_t)H * (size_t)cols, 1);
    if (!f->rows) return 0;
    f->width = W;
    f->height = H;
    f->cols = cols;
    return 1;
}

/* pgi__lobe_params of the material last seen (neighbouring samples mostly share one). */
typedef struct lobe_cache {
    const pgi__material *m; /* NULL: empty */
    pgi__v3 ks;
    float sh, eta;
    uint8_t flags; /* PGI_VS_LAMBERT, PGI_VS_GGX */
} lobe_cache;

static inline const lobe_cache *lobe_of(lobe_cache *c, const pgi__material *m) {
    if (c->m != m) {
        pgi__lobe_model model = pgi__lobe_params(m, &c->ks, &c->sh, &c->eta);
        c->flags =
            (uint8_t)((model == PGI__LOBE_NONE ? PGI_VS_LAMBERT : 0) | (model == PGI__LOBE_GGX ? PGI_VS_GGX : 0));
        c->m = m;
    }
    return c;
}

/* Writes sample j of a block: the non-specular surface sf (texture applied) seen from wo on
 * `side` of its geometric normal, at the end of a specular chain of throughput `weight`. */
static inline void put_sample(view_block *vs, int j, const pgi__surface *sf, pgi__v3 wo, float side, pgi__v3 weight,
                              int primary, lobe_cache *lc) {
    pgi__v3 ng = v3_scale(sf->ng, side), ns = v3_scale(sf->ns, side);
    v3_store(vs->pos + 3 * j, sf->p);
    v3_store(vs->nrm + 3 * j, ns);
    v3_store(vs->ngeo + 3 * j, ng);
    v3_store(vs->wo + 3 * j, wo);
    v3_store(vs->kd + 3 * j, sf->kd);
    const lobe_cache *l = lobe_of(lc, sf->mat);
    v3_store(vs->ks + 3 * j, l->ks);
    vs->shininess[j] = l->sh;
    vs->ior[j] = l->eta;
    v3_store(vs->weight + 3 * j, weight);
    vs->flags[j] = (uint8_t)(PGI_VS_VALID | (primary ? PGI_VS_PRIMARY : 0) | l->flags);
}

/* The view samples' texture filter (docs/design.md "Textures"): a ray cone (Ray Tracing Gems
 * ch. 20) from the eye, spread angle 2 tan(fov_y / 2) / height (a pixel's), width 0 at the eye
 * and growing by spread x distance along each segment of an eye path; mirrors and glass keep the
 * spread (treated as flat). At the first non-specular hit the width, the cosine to the geometric
 * normal and the triangle's pgi__tri_uv_lod give the level (pgi__texture_cone_lod), looked up
 * trilinearly (pgi__texture_lookup_lod). Every path of the view pass (lane by lane, uniform tiles,
 * eye paths) computes them with these scalar functions from the same values: the same bits. */
typedef struct tex_cone {
    int on;              /* filter (pgi__subpixel.tex_filter, and the scene has texture coordinates) */
    float spread;        /* radians a unit distance */
    const float *tri_uv; /* the triangle records' PGI__TRI_UV floats (pgi__tri_cache.tri_uv) */
} tex_cone;

static inline float cone_width(const tex_cone *tc, float width, float t) { return width + tc->spread * t; }

/* Texture colour of sf (its material textured, tc->on) at triangle prim's (u, v) for a cone of
 * `width` along unit direction d. The cone meets the surface in an ellipse, `width` across and
 * width / |cos| along the direction's projection (anisotropic ray cones: Akenine-Moller et al.
 * 2021, "Improved Shader and Texture Level of Detail Using Ray Cones", JCGT 10(1)); both axes
 * are mapped into texels through the triangle's uv Jacobian. N = ceil(major / minor) probes
 * (at most PGI__TEXTURE_ANISO_MAX) spaced evenly along the major axis, each trilinear at the level
 * of major / N (about the minor axis; with PGI__TEXTURE_LOD_BIAS), are averaged, as a GPU's
 * anisotropic filter does. A degenerate mapping, or a cone along the normal within 1e-4, takes
 * the isotropic level of pgi__texture_cone_lod. */
#define PGI__TEXTURE_ANISO_MAX 8 /* 16 gave the same Sibenik picture (27.74 dB) */
static pgi__v3 cone_lookup(const pgi_scene *s, const tex_cone *tc, const pgi__surface *sf, uint32_t prim, float width,
                           pgi__v3 d) {
    const pgi__texture *t = &s->texs[sf->mat->tex_kd];
    const float *q = tc->tri_uv + PGI__TRI_UV * (size_t)prim;
    const float cosine = v3_dot(d, sf->ng);
    const uint32_t *tri = s->tri + 3 * (size_t)prim;
    const pgi__v3 p0 = pgi__scene_vertex(s, tri[0]);
    const pgi__v3 e1 = v3_sub(pgi__scene_vertex(s, tri[1]), p0), e2 = v3_sub(pgi__scene_vertex(s, tri[2]), p0);
    const float g11 = v3_dot(e1, e1), g12 = v3_dot(e1, e2), g22 = v3_dot(e2, e2);
    const float det = g11 * g22 - g12 * g12;
    pgi__v3 t1 = v3_sub(d, v3_scale(sf->ng, cosine));
    const float s1 = v3_len(t1);
    if (!(det > 0.f) || !(s1 > 1e-4f) || !(fabsf(cosine) > 0.f) || !(width > 0.f))
        return pgi__texture_lookup_lod(t, sf->u, sf->v, pgi__texture_cone_lod(t, q[6], width, cosine));
    t1 = v3_scale(t1, 1.f / s1);
    const pgi__v3 t2 = v3_cross(sf->ng, t1);
    const float du1 = q[2] - q[0], dv1 = q[3] - q[1], du2 = q[4] - q[0], dv2 = q[5] - q[1];
    const float W = (float)t->width, H = (float)t->height;
    float uv[2][2]; /* the axes in uv: [0] major (along t1), [1] minor */
    float len[2];   /* ... in texels */
    const pgi__v3 ax[2] = {v3_scale(t1, width / fabsf(cosine)), v3_scale(t2, width)};
    for (int k = 0; k < 2; k++) {
        const float r1 = v3_dot(ax[k], e1), r2 = v3_dot(ax[k], e2);
        const float a = (g22 * r1 - g12 * r2) / det, b = (g11 * r2 - g12 * r1) / det;
        uv[k][0] = a * du1 + b * du2;
        uv[k][1] = a * dv1 + b * dv2;
        len[k] = sqrtf((uv[k][0] * W) * (uv[k][0] * W) + (uv[k][1] * H) * (uv[k][1] * H));
    }
    const int M = len[0] >= len[1] ? 0 : 1; /* a skewed mapping may stretch the minor axis more */
    const float major = len[M], minor = len[1 - M];
    if (!(minor > 0.f) || !(major < INFINITY))
        return pgi__texture_lookup_lod(t, sf->u, sf->v, pgi__texture_cone_lod(t, q[6], width, cosine));
    const float ratio = major / minor;
    const int n = ratio >= (float)PGI__TEXTURE_ANISO_MAX ? PGI__TEXTURE_ANISO_MAX
                  : ratio > 1.001f                       ? (int)ceilf(ratio - 0.001f)
                                                         : 1;
    const float lod = log2f(major / (float)n) + PGI__TEXTURE_LOD_BIAS;
    if (n == 1) return pgi__texture_lookup_lod(t, sf->u, sf->v, lod);
    pgi__v3 sum = v3(0.f, 0.f, 0.f);
    for (int i = 0; i < n; i++) {
        const float o = ((float)i + 0.5f) / (float)n - 0.5f;
        sum = v3_add(sum, pgi__texture_lookup_lod(t, sf->u + o * uv[M][0], sf->v + o * uv[M][1], lod));
    }
    return v3_scale(sum, 1.f / (float)n);
}

/* Continues the eye path of pixel i from its primary hit to its first non-specular hit and
 * writes every field of view sample i (each once) and its emitted radiance. */
static void shade_eye_path(const pgi_scene *s, const pgi__rt *rt, const pgi_camera *cam, uint64_t seed, float eps,
                           const tex_cone *tc, size_t i, pgi__v3 o, pgi__v3 d, pgi__hit h, view_block *vs, int j,
                           lobe_cache *lc, uint64_t *rays) {
    pgi__v3 weight = v3(1.f, 1.f, 1.f), e = v3(0.f, 0.f, 0.f);
    float width = 0.f; /* the ray cone's (tex_cone): its spread kept through mirrors and glass */
    float depth_v = 0.f;
    int found = 0;
    pgi__rng rng;
    int rng_ready = 0;
    for (int depth = 0; h.prim != UINT32_MAX; depth++) {
        pgi__v3 p = v3_madd(o, d, h.t);
        if (depth == 0) depth_v = v3_dot(v3_sub(p, v3_load(cam->eye)), v3_load(cam->forward));
        pgi__surface sf;
        pgi__scene_surface_untextured(s, h.prim, h.u, h.v, p, &sf);
        pgi__v3 wo = v3_neg(d);
        float side = v3_dot(wo, sf.ng) >= 0.f ? 1.f : -1.f;
        pgi__v3 ke = v3_load(sf.mat->ke);
        if (side > 0.f) e = v3_add(e, v3_mul(weight, ke)); /* one-sided emitters */
        width = cone_width(tc, width, h.t);
        if (!pgi__mat_specular(sf.mat)) {
            if (tc->on && sf.mat->tex_kd >= 0) sf.kd = v3_mul(sf.kd, cone_lookup(s, tc, &sf, h.prim, width, d));
            else pgi__surface_texture(s, &sf);
            put_sample(vs, j, &sf, wo, side, weight, depth == 0, lc);
            found = 1;
            break;
        }
        if (depth + 1 >= PGI__MAX_SPECULAR_DEPTH) break;
        if (!rng_ready) {
            pgi_rng_seed(&rng, seed ^ 0x5eed0f1e11e5ULL, (uint64_t)i);
            rng_ready = 1;
        }
        /* Drawn last to first (the order gcc gave these draws as arguments of one call). */
        float u3 = pgi_rng_f(&rng), u2 = pgi_rng_f(&rng), u1 = pgi_rng_f(&rng);
        pgi__v3 nd, w;
        if (!pgi__bsdf_sample(&sf, wo, u1, u2, u3, &nd, &w)) break;
        weight = v3_mul(weight, w);
        pgi__v3 ng = v3_dot(nd, sf.ng) >= 0.f ? sf.ng : v3_neg(sf.ng);
        o = v3_madd(p, ng, eps);
        d = nd;
        (*rays)++;
        if (!pgi__rt_intersect(rt, o, d, 0.f, INFINITY, &h)) break;
    }
    if (!found) {
        /* An eye path that leaves the scene sees the sky (a window, an open roof). */
        if (h.prim == UINT32_MAX && s->env) e = v3_add(e, v3_mul(weight, pgi__env_eval(s->env, d)));
        float *planes[] = {vs->pos, vs->nrm, vs->ngeo, vs->wo, vs->kd, vs->ks, vs->weight};
        for (int k = 0; k < 7; k++) memset(planes[k] + 3 * j, 0, 3 * sizeof(float));
        vs->shininess[j] = vs->ior[j] = 0.f;
        vs->flags[j] = 0;
    }
    vs->depth[j] = depth_v;
    v3_store(vs->emit + 3 * j, e);
}

/* Both passes go over the image in 4x4-pixel tiles, one 16-wide packet each: lane k of tile
 * (tx, ty) is pixel (4 tx + k % 4, 4 ty + k / 4). Returns 0 for a lane outside the image. */
static inline int tile_lane(int tx, int ty, int k, int W, int H, int *px, int *py) {
    *px = 4 * tx + (k & 3);
    *py = 4 * ty + (k >> 2);
    return *px < W && *py < H;
}

/* The lanes of tile (tx, ty) (tile_lane), their pixels and their directions pgi__view_dir(cam,
 * sp, x, y) (pixel (0, 0)'s for a lane outside the image), bit for bit: with SSE four lanes at a
 * time, the same operations in the same order (IEEE: packed and scalar results agree). The
 * directions come component by component: lane k's is (dsoa[0][k], dsoa[1][k], dsoa[2][k]). */
static void tile_dirs(const pgi_camera *cam, const pgi__subpixel *sp, int tx, int ty, int valid[16], size_t pix[16],
                      float dsoa[3][16]) {
    const int W = cam->width, H = cam->height;
#if defined(__SSE2__)
    float fx[16], fy[16];
    for (int k = 0; k < 16; k++) {
        int px, py;
        valid[k] = tile_lane(tx, ty, k, W, H, &px, &py);
        if (!valid[k]) px = py = 0;
        pix[k] = valid[k] ? (size_t)py * (size_t)W + (size_t)px : 0;
        float jx, jy;
        pgi__pixel_jitter(sp, (size_t)py * (size_t)W + (size_t)px, &jx, &jy);
        fx[k] = (float)px + jx; /* pgi__camera_dir_at's first operations */
        fy[k] = (float)py + jy;
    }
    const __m128 two = _mm_set1_ps(2.f), one = _mm_set1_ps(1.f), zero = _mm_setzero_ps();
    const __m128 w = _mm_set1_ps((float)cam->width), h = _mm_set1_ps((float)cam->height);
    const __m128 th = _mm_set1_ps(cam->tan_half_fov_y), asp = _mm_set1_ps(cam->aspect);
    for (int k = 0; k < 16; k += 4) {
        __m128 u =
            _mm_mul_ps(_mm_mul_ps(_mm_sub_ps(_mm_div_ps(_mm_mul_ps(two, _mm_loadu_ps(fx + k)), w), one), th), asp);
        __m128 v = _mm_mul_ps(_mm_sub_ps(one, _mm_div_ps(_mm_mul_ps(two, _mm_loadu_ps(fy + k)), h)), th);
        __m128 d[3];
        for (int c = 0; c < 3; c++)
            d[c] = _mm_add_ps(_mm_set1_ps(cam->forward[c]), _mm_add_ps(_mm_mul_ps(_mm_set1_ps(cam->right[c]), u),
                                                                       _mm_mul_ps(_mm_set1_ps(cam->up[c]), v)));
        __m128 l =
            _mm_sqrt_ps(_mm_add_ps(_mm_add_ps(_mm_mul_ps(d[0], d[0]), _mm_mul_ps(d[1], d[1])), _mm_mul_ps(d[2], d[2])));
        __m128 pos = _mm_cmpgt_ps(l, zero), r = _mm_div_ps(one, l); /* v3_norm */
        /* (0, 0, 1) where the length is not positive, as v3_norm */
        const __m128 fb[3] = {zero, zero, one};
        for (int c = 0; c < 3; c++)
            _mm_storeu_ps(dsoa[c] + k, _mm_or_ps(_mm_and_ps(pos, _mm_mul_ps(d[c], r)), _mm_andnot_ps(pos, fb[c])));
    }
#else
    for (int k = 0; k < 16; k++) {
        int px, py;
        valid[k] = tile_lane(tx, ty, k, W, H, &px, &py);
        if (!valid[k]) px = py = 0;
        pix[k] = valid[k] ? (size_t)py * (size_t)W + (size_t)px : 0;
        const pgi__v3 d = pgi__view_dir(cam, sp, px, py);
        dsoa[0][k] = d.x;
        dsoa[1][k] = d.y;
        dsoa[2][k] = d.z;
    }
#endif
}

#if VIEW_AVX2
/* tile_dirs eight lanes an instruction (lanes k..k+7 are rows k/4 and k/4 + 1 of the tile): the
 * same operations in the same order, so the same bits. */
__attribute__((target("avx2"))) static void tile_dirs_avx2(const pgi_camera *cam, const pgi__subpixel *sp,
                                                           const float *cu, const float *cv, int tx, int ty,
                                                           int valid[16], size_t pix[16], float dsoa[3][16]) {
    const __m256 two = _mm256_set1_ps(2.f), one = _mm256_set1_ps(1.f), zero = _mm256_setzero_ps();
    const __m256 w = _mm256_set1_ps((float)cam->width), h = _mm256_set1_ps((float)cam->height);
    const __m256 th = _mm256_set1_ps(cam->tan_half_fov_y), asp = _mm256_set1_ps(cam->aspect);
    const __m256i W = _mm256_set1_epi32(cam->width), H = _mm256_set1_epi32(cam->height);
    const __m256i kx = _mm256_setr_epi32(0, 1, 2, 3, 0, 1, 2, 3), ky = _mm256_setr_epi32(0, 0, 0, 0, 1, 1, 1, 1);
    const __m256 fb[3] = {zero, zero, one};
    for (int k = 0; k < 16; k += 8) {
        __m256i px = _mm256_add_epi32(_mm256_set1_epi32(4 * tx), kx);
        __m256i py = _mm256_add_epi32(_mm256_set1_epi32(4 * ty + (k >> 2)), ky);
        const __m256i in = _mm256_and_si256(_mm256_cmpgt_epi32(W, px), _mm256_cmpgt_epi32(H, py));
        px = _mm256_and_si256(px, in); /* pixel (0, 0) outside the image */
        py = _mm256_and_si256(py, in);
        _mm256_storeu_si256((__m256i *)(valid + k), _mm256_and_si256(in, _mm256_set1_epi32(1)));
        const __m256i w64 = _mm256_set1_epi64x(cam->width); /* pix = py W + px in 64 bits, four at a time */
        _mm256_storeu_si256((__m256i *)(pix + k),
                            _mm256_add_epi64(_mm256_mul_epu32(_mm256_cvtepu32_epi64(_mm256_castsi256_si128(py)), w64),
                                             _mm256_cvtepu32_epi64(_mm256_castsi256_si128(px))));
        _mm256_storeu_si256((__m256i *)(pix + k + 4),
                            _mm256_add_epi64(_mm256_mul_epu32(_mm256_cvtepu32_epi64(_mm256_extracti128_si256(py, 1)),
                                                              w64),
                                             _mm256_cvtepu32_epi64(_mm256_extracti128_si256(px, 1))));
        __m256 u, v;
        if (cu) { /* through the pixel centres: u and v of the column and the row, computed once a frame */
            const __m256 inf = _mm256_castsi256_ps(in); /* pixel (0, 0)'s outside the image */
            u = _mm256_blendv_ps(_mm256_set1_ps(cu[0]),
                                 _mm256_broadcast_ps((const __m128 *)(const void *)(cu + 4 * tx)), inf);
            v = _mm256_blendv_ps(_mm256_set1_ps(cv[0]),
                                 _mm256_setr_m128(_mm_set1_ps(cv[4 * ty + (k >> 2)]),
                                                  _mm_set1_ps(cv[4 * ty + (k >> 2) + 1])),
                                 inf);
        } else {
            __m256 fx, fy;
            if (pgi__subpixel_centres(sp)) { /* pgi__pixel_jitter's pixel centre */
                fx = _mm256_add_ps(_mm256_cvtepi32_ps(px), _mm256_set1_ps(0.5f));
                fy = _mm256_add_ps(_mm256_cvtepi32_ps(py), _mm256_set1_ps(0.5f));
            } else {
                float jx[8], jy[8];
                for (int q = 0; q < 8; q++) pgi__pixel_jitter(sp, pix[k + q], &jx[q], &jy[q]);
                fx = _mm256_add_ps(_mm256_cvtepi32_ps(px), _mm256_loadu_ps(jx));
                fy = _mm256_add_ps(_mm256_cvtepi32_ps(py), _mm256_loadu_ps(jy));
            }
            u = _mm256_mul_ps(_mm256_mul_ps(_mm256_sub_ps(_mm256_div_ps(_mm256_mul_ps(two, fx), w), one), th), asp);
            v = _mm256_mul_ps(_mm256_sub_ps(one, _mm256_div_ps(_mm256_mul_ps(two, fy), h)), th);
        }
        __m256 d[3];
        for (int c = 0; c < 3; c++)
            d[c] = _mm256_add_ps(_mm256_set1_ps(cam->forward[c]),
                                 _mm256_add_ps(_mm256_mul_ps(_mm256_set1_ps(cam->right[c]), u),
                                               _mm256_mul_ps(_mm256_set1_ps(cam->up[c]), v)));
        const __m256 l =
            _mm256_sqrt_ps(_mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(d[0], d[0]), _mm256_mul_ps(d[1], d[1])),
                                         _mm256_mul_ps(d[2], d[2])));
        const __m256 pos = _mm256_cmp_ps(l, zero, _CMP_GT_OQ), r = _mm256_div_ps(one, l); /* v3_norm */
        for (int c = 0; c < 3; c++) _mm256_storeu_ps(dsoa[c] + k, _mm256_blendv_ps(fb[c], _mm256_mul_ps(d[c], r), pos));
    }
}
#endif

/* A tile's primary hits (pgi__rt_intersect16_soa): lane k's is triangle prim[k] (UINT32_MAX: none)
 * at distance t[k], barycentrics u[k], v[k]. */
typedef struct tile_hits {
    float t[16], u[16], v[16];
    uint32_t prim[16];
} tile_hits;

/* The surfaces of a tile's primary hits component by component, lane k at [k] (lanes without a
 * hit hold anything): pgi__tri_rec_surface's position and shading normal, pgi__tri_rec_uv's
 * texture coordinates (0 without them) and the depth along the camera's forward axis. */
typedef struct tile_surf {
    float p[3][16], ns[3][16], u[16], v[16], depth[16];
    float ng[3][16];  /* the record's geometric normal (tile_surfaces_avx2 only) */
    uint32_t mat[16]; /* the record's material (tile_surfaces_avx2 only) */
} tile_surf;

/* A tile between the view pass's two sweeps (pgi__view_build): its lanes (tile_dirs), hits and
 * surfaces, and whether all 16 lanes hit one non-specular material (then shaded eight lanes an
 * instruction, tile_put_uniform_avx2) whose texels have been requested (q). */
typedef struct view_tile {
    int valid[16];
    size_t pix[16];
    float dsoa[3][16];
    tile_hits hits;
    tile_surf ts;             /* set where a lane hit something */
    const pgi__material *uni; /* NULL: shade lane by lane */
    int quads;                /* q holds uni's texture's quads */
    pgi__texel_quads16 q;
} view_tile;

/* tile_surf lane by lane with the inline functions: what tile_surfaces_avx2 must equal, and the
 * build for processors without AVX2. */
static void tile_surfaces(const pgi_scene *s, const pgi__tri_cache *tr, const tile_hits *hits, const float (*dsoa)[16],
                          pgi__v3 eye, pgi__v3 fwd, tile_surf *o) {
    for (int k = 0; k < 16; k++) {
        if (hits->prim[k] == UINT32_MAX) continue;
        pgi__surface sf;
        const pgi__v3 p = v3_madd(eye, v3(dsoa[0][k], dsoa[1][k], dsoa[2][k]), hits->t[k]);
        pgi__tri_rec_surface(s, &tr->tris[hits->prim[k]], hits->prim[k], hits->u[k], hits->v[k], p, &sf);
        if (tr->tri_uv)
            pgi__tri_rec_uv(tr->tri_uv + PGI__TRI_UV * (size_t)hits->prim[k], hits->u[k], hits->v[k], &sf.u, &sf.v);
        o->p[0][k] = p.x;
        o->p[1][k] = p.y;
        o->p[2][k] = p.z;
        o->ns[0][k] = sf.ns.x;
        o->ns[1][k] = sf.ns.y;
        o->ns[2][k] = sf.ns.z;
        o->u[k] = sf.u;
        o->v[k] = sf.v;
        o->depth[k] = v3_dot(v3_sub(p, eye), fwd);
    }
}

#if VIEW_AVX2
/* Rows r[0..7] of an 8x8 matrix become its columns. */
__attribute__((target("avx2"))) static inline void transpose8(__m256 r[8]) {
    const __m256 t0 = _mm256_unpacklo_ps(r[0], r[1]), t1 = _mm256_unpackhi_ps(r[0], r[1]);
    const __m256 t2 = _mm256_unpacklo_ps(r[2], r[3]), t3 = _mm256_unpackhi_ps(r[2], r[3]);
    const __m256 t4 = _mm256_unpacklo_ps(r[4], r[5]), t5 = _mm256_unpackhi_ps(r[4], r[5]);
    const __m256 t6 = _mm256_unpacklo_ps(r[6], r[7]), t7 = _mm256_unpackhi_ps(r[6], r[7]);
    const __m256 s0 = _mm256_shuffle_ps(t0, t2, 0x44), s1 = _mm256_shuffle_ps(t0, t2, 0xee);
    const __m256 s2 = _mm256_shuffle_ps(t1, t3, 0x44), s3 = _mm256_shuffle_ps(t1, t3, 0xee);
    const __m256 s4 = _mm256_shuffle_ps(t4, t6, 0x44), s5 = _mm256_shuffle_ps(t4, t6, 0xee);
    const __m256 s6 = _mm256_shuffle_ps(t5, t7, 0x44), s7 = _mm256_shuffle_ps(t5, t7, 0xee);
    r[0] = _mm256_permute2f128_ps(s0, s4, 0x20);
    r[1] = _mm256_permute2f128_ps(s1, s5, 0x20);
    r[2] = _mm256_permute2f128_ps(s2, s6, 0x20);
    r[3] = _mm256_permute2f128_ps(s3, s7, 0x20);
    r[4] = _mm256_permute2f128_ps(s0, s4, 0x31);
    r[5] = _mm256_permute2f128_ps(s1, s5, 0x31);
    r[6] = _mm256_permute2f128_ps(s2, s6, 0x31);
    r[7] = _mm256_permute2f128_ps(s3, s7, 0x31);
}

/* tile_surfaces eight lanes an instruction: the records (two rows of 8 floats each, coordinates
 * one row) transposed into components, then pgi__tri_rec_surface's and
 * pgi__tri_rec_uv's operations in their order, without FMA (-ffp-contract=off; packed IEEE
 * results equal the scalar ones), so the same bits. Lanes without a hit read record 0. */
__attribute__((target("avx2"))) static void tile_surfaces_avx2(const pgi_scene *s, const pgi__tri_cache *tr,
                                                               const tile_hits *hits, const float (*dsoa)[16],
                                                               pgi__v3 eye, pgi__v3 fwd, tile_surf *o) {
    const __m256 zero = _mm256_setzero_ps(), one = _mm256_set1_ps(1.f), inf = _mm256_set1_ps(INFINITY);
    const __m256 sign = _mm256_set1_ps(-0.f);
    const float e[3] = {eye.x, eye.y, eye.z}, f[3] = {fwd.x, fwd.y, fwd.z};
    for (int h = 0; h < 16; h += 8) {
        const __m256 t = _mm256_loadu_ps(hits->t + h), bu = _mm256_loadu_ps(hits->u + h);
        const __m256 bv = _mm256_loadu_ps(hits->v + h);
        __m256 lo[8], hi[8];
        size_t prim[8];
        for (int i = 0; i < 8; i++) {
            prim[i] = hits->prim[h + i] != UINT32_MAX ? hits->prim[h + i] : 0;
            const float *r = tr->tris[prim[i]].ng; /* ng, mat, n[0..3]; n[4..8], pad */
            lo[i] = _mm256_loadu_ps(r);
            hi[i] = _mm256_loadu_ps(r + 8);
        }
        transpose8(lo);
        transpose8(hi);
        const __m256 bw = _mm256_sub_ps(_mm256_sub_ps(one, bu), bv);
        __m256 p[3], ng[3] = {lo[0], lo[1], lo[2]}, ns[3] = {lo[0], lo[1], lo[2]};
        for (int c = 0; c < 3; c++) {
            p[c] = _mm256_add_ps(_mm256_set1_ps(e[c]), _mm256_mul_ps(_mm256_loadu_ps(dsoa[c] + h), t));
            _mm256_storeu_ps(o->p[c] + h, p[c]);
        }
        if (s->nrm) {
            /* n[0..8] are lo[4..7], hi[0..4] */
            const __m256 n0[3] = {lo[4], lo[5], lo[6]}, n1[3] = {lo[7], hi[0], hi[1]}, n2[3] = {hi[2], hi[3], hi[4]};
            __m256 n[3];
            for (int c = 0; c < 3; c++)
                n[c] = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(n0[c], bw), _mm256_mul_ps(n1[c], bu)),
                                     _mm256_mul_ps(n2[c], bv));
            const __m256 l =
                _mm256_sqrt_ps(_mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(n[0], n[0]), _mm256_mul_ps(n[1], n[1])),
                                             _mm256_mul_ps(n[2], n[2])));
            const __m256 ok = _mm256_and_ps(_mm256_cmp_ps(l, zero, _CMP_GT_OQ), _mm256_cmp_ps(l, inf, _CMP_LT_OQ));
            const __m256 rl = _mm256_div_ps(one, l);
            for (int c = 0; c < 3; c++) n[c] = _mm256_mul_ps(n[c], rl);
            const __m256 d = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(n[0], ng[0]), _mm256_mul_ps(n[1], ng[1])),
                                           _mm256_mul_ps(n[2], ng[2]));
            const __m256 flip = _mm256_and_ps(_mm256_cmp_ps(d, zero, _CMP_LT_OQ), sign);
            for (int c = 0; c < 3; c++) ns[c] = _mm256_blendv_ps(ng[c], _mm256_xor_ps(n[c], flip), ok);
        }
        for (int c = 0; c < 3; c++) {
            _mm256_storeu_ps(o->ns[c] + h, ns[c]);
            _mm256_storeu_ps(o->ng[c] + h, ng[c]);
        }
        _mm256_storeu_ps((float *)o->mat + h, lo[3]);
        __m256 u = zero, v = zero;
        if (tr->tri_uv) {
            __m256 q[8];
            for (int i = 0; i < 8; i++) q[i] = _mm256_loadu_ps(tr->tri_uv + PGI__TRI_UV * prim[i]);
            transpose8(q);
            u = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(bw, q[0]), _mm256_mul_ps(bu, q[2])), _mm256_mul_ps(bv, q[4]));
            v = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(bw, q[1]), _mm256_mul_ps(bu, q[3])), _mm256_mul_ps(bv, q[5]));
        }
        _mm256_storeu_ps(o->u + h, u);
        _mm256_storeu_ps(o->v + h, v);
        __m256 dep = zero;
        for (int c = 0; c < 3; c++) {
            const __m256 dc = _mm256_mul_ps(_mm256_sub_ps(p[c], _mm256_set1_ps(e[c])), _mm256_set1_ps(f[c]));
            dep = c ? _mm256_add_ps(dep, dc) : dc;
        }
        _mm256_storeu_ps(o->depth + h, dep);
    }
}

/* Rows a (lanes 0-3 of each component) and b (lanes 4-7) of 4 vectors x, y, z become x0 y0 z0 x1
 * y1 z1 ... at pa and pb (12 floats each). */
__attribute__((target("avx2"))) static inline void aos_rows(float *pa, float *pb, __m256 x, __m256 y, __m256 z) {
    const __m256 t0 = _mm256_unpacklo_ps(x, y), t1 = _mm256_unpackhi_ps(x, y);
    const __m256 o0 = _mm256_shuffle_ps(t0, _mm256_shuffle_ps(z, x, _MM_SHUFFLE(1, 1, 0, 0)), _MM_SHUFFLE(2, 0, 1, 0));
    const __m256 o1 = _mm256_shuffle_ps(_mm256_shuffle_ps(y, z, _MM_SHUFFLE(1, 1, 1, 1)), t1, _MM_SHUFFLE(1, 0, 2, 0));
    const __m256 o2 = _mm256_shuffle_ps(_mm256_shuffle_ps(z, x, _MM_SHUFFLE(3, 3, 2, 2)),
                                        _mm256_shuffle_ps(y, z, _MM_SHUFFLE(3, 3, 3, 3)), _MM_SHUFFLE(2, 0, 2, 0));
    _mm_storeu_ps(pa, _mm256_castps256_ps128(o0));
    _mm_storeu_ps(pa + 4, _mm256_castps256_ps128(o1));
    _mm_storeu_ps(pa + 8, _mm256_castps256_ps128(o2));
    _mm_storeu_ps(pb, _mm256_extractf128_ps(o0, 1));
    _mm_storeu_ps(pb + 4, _mm256_extractf128_ps(o1, 1));
    _mm_storeu_ps(pb + 8, _mm256_extractf128_ps(o2, 1));
}

/* The samples of a tile whose 16 lanes are in the image and hit one non-specular material m
 * (lobe l), written into columns 4 tb.. of blk: what the lane-by-lane path (the lit lanes of
 * pgi__view_build, put_sample) writes, the same operations eight lanes an instruction, so the
 * same bits. vc: the vertex colour at each lane, component by component (NULL: the scene has
 * none); tk: the texture's colour (NULL: untextured). */
__attribute__((target("avx2"))) static void tile_put_uniform_avx2(view_block *blk, int tb, const tile_surf *ts,
                                                                  const float (*dsoa)[16], const float vc[3][16],
                                                                  const float tk[3][16], const pgi__material *m,
                                                                  const lobe_cache *l) {
    const __m256 zero = _mm256_setzero_ps(), one = _mm256_set1_ps(1.f), sign = _mm256_set1_ps(-0.f);
    /* e = (0, 0, 0) + (1, 1, 1) * ke where the lane sees the emitting side */
    const float ek[3] = {0.f + 1.f * m->ke[0], 0.f + 1.f * m->ke[1], 0.f + 1.f * m->ke[2]};
    const uint8_t fl = (uint8_t)(PGI_VS_VALID | PGI_VS_PRIMARY | l->flags);
    for (int h = 0; h < 16; h += 8) {
        const int ja = (h >> 2) * BLOCK_W + 4 * tb, jb = ja + BLOCK_W;
        __m256 wo[3], ng[3], ns[3], kd[3];
        for (int c = 0; c < 3; c++) {
            wo[c] = _mm256_xor_ps(_mm256_loadu_ps(dsoa[c] + h), sign);
            ng[c] = _mm256_loadu_ps(ts->ng[c] + h);
            ns[c] = _mm256_loadu_ps(ts->ns[c] + h);
            kd[c] = _mm256_set1_ps(m->kd[c]);
            if (vc) kd[c] = _mm256_mul_ps(kd[c], _mm256_loadu_ps(vc[c] + h)); /* pgi__scene_kd */
            if (tk) kd[c] = _mm256_mul_ps(kd[c], _mm256_loadu_ps(tk[c] + h));
        }
        const __m256 dot = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(wo[0], ng[0]), _mm256_mul_ps(wo[1], ng[1])),
                                         _mm256_mul_ps(wo[2], ng[2]));
        const __m256 front = _mm256_cmp_ps(dot, zero, _CMP_GE_OQ);
        const __m256 side = _mm256_blendv_ps(_mm256_set1_ps(-1.f), one, front);
        aos_rows(blk->pos + 3 * ja, blk->pos + 3 * jb, _mm256_loadu_ps(ts->p[0] + h), _mm256_loadu_ps(ts->p[1] + h),
                 _mm256_loadu_ps(ts->p[2] + h));
        aos_rows(blk->nrm + 3 * ja, blk->nrm + 3 * jb, _mm256_mul_ps(ns[0], side), _mm256_mul_ps(ns[1], side),
                 _mm256_mul_ps(ns[2], side));
        aos_rows(blk->ngeo + 3 * ja, blk->ngeo + 3 * jb, _mm256_mul_ps(ng[0], side), _mm256_mul_ps(ng[1], side),
                 _mm256_mul_ps(ng[2], side));
        aos_rows(blk->wo + 3 * ja, blk->wo + 3 * jb, wo[0], wo[1], wo[2]);
        aos_rows(blk->kd + 3 * ja, blk->kd + 3 * jb, kd[0], kd[1], kd[2]);
        aos_rows(blk->ks + 3 * ja, blk->ks + 3 * jb, _mm256_set1_ps(l->ks.x), _mm256_set1_ps(l->ks.y),
                 _mm256_set1_ps(l->ks.z));
        aos_rows(blk->weight + 3 * ja, blk->weight + 3 * jb, one, one, one);
        aos_rows(blk->emit + 3 * ja, blk->emit + 3 * jb, _mm256_and_ps(front, _mm256_set1_ps(ek[0])),
                 _mm256_and_ps(front, _mm256_set1_ps(ek[1])), _mm256_and_ps(front, _mm256_set1_ps(ek[2])));
        const __m256 dep = _mm256_loadu_ps(ts->depth + h), sh = _mm256_set1_ps(l->sh), eta = _mm256_set1_ps(l->eta);
        _mm_storeu_ps(blk->depth + ja, _mm256_castps256_ps128(dep));
        _mm_storeu_ps(blk->depth + jb, _mm256_extractf128_ps(dep, 1));
        _mm_storeu_ps(blk->shininess + ja, _mm256_castps256_ps128(sh));
        _mm_storeu_ps(blk->shininess + jb, _mm256_castps256_ps128(sh));
        _mm_storeu_ps(blk->ior + ja, _mm256_castps256_ps128(eta));
        _mm_storeu_ps(blk->ior + jb, _mm256_castps256_ps128(eta));
        memset(blk->flags + ja, fl, 4);
        memset(blk->flags + jb, fl, 4);
    }
}

/* Do the 16 lanes of a tile all lie in the image and hit one material (ts from
 * tile_surfaces_avx2)? */
__attribute__((target("avx2"))) static int tile_uniform_avx2(const int valid[16], const tile_hits *hits,
                                                             const tile_surf *ts) {
    const __m256i none = _mm256_set1_epi32(-1), zero = _mm256_setzero_si256();
    const __m256i m0 = _mm256_set1_epi32((int)ts->mat[0]);
    __m256i bad = zero;
    for (int h = 0; h < 16; h += 8) {
        bad = _mm256_or_si256(bad, _mm256_cmpeq_epi32(_mm256_loadu_si256((const __m256i *)(valid + h)), zero));
        bad = _mm256_or_si256(bad, _mm256_cmpeq_epi32(_mm256_loadu_si256((const __m256i *)(hits->prim + h)), none));
        bad =
            _mm256_or_si256(bad,
                            _mm256_xor_si256(_mm256_cmpeq_epi32(_mm256_loadu_si256((const __m256i *)(ts->mat + h)), m0),
                                             none));
    }
    return _mm256_testz_si256(bad, bad);
}
#endif

pgi_status pgi__view_build(const pgi_scene *s, const pgi__rt *rt, pgi__tri_cache *tris, const pgi_camera *cam,
                           uint64_t seed, const pgi__subpixel *sp, int threads, pgi_view_samples *vs, float *emit,
                           pgi__view_fill *fill, uint64_t *rays_out) {
    const int W = cam->width, H = cam->height;
    if (vs->width != W || vs->height != H)
        return pgi__fail(PGI_ERR_INVALID_ARG, "view-sample buffer is %dx%d, camera %dx%d", vs->width, vs->height, W, H);
    pgi__tri_cache own = {0};
    pgi__tri_cache *const tr = tris ? tris : &own;
    pgi_status st = pgi__tri_cache_update(tr, s, threads);
    if (st) return st;
    vs->jitter = (sp->jitter ? 0.5f : 0.f) + fmaxf(fabsf(sp->shift[0]), fabsf(sp->shift[1]));
    /* without the memory for the record, every row is written (as with none) */
    uint8_t *const fill_rows = fill && view_fill_fit(fill, W, H) ? fill->rows : NULL;
    const size_t fill_cols = fill_rows ? (size_t)fill->cols : 0;
    uint64_t rays = 0;
    const pgi__v3 eye = v3_load(cam->eye), fwd = v3_load(cam->forward);
    const float eps = pgi__scene_epsilon(s);
    const tex_cone tc = {.on = sp->tex_filter && tr->tri_uv,
                         .spread = 2.f * cam->tan_half_fov_y / (float)H * (sp->tex_scale > 0.f ? sp->tex_scale : 1.f),
                         .tri_uv = tr->tri_uv};
#if VIEW_AVX2
    const int avx2 = pgi__cpu_avx2();
    /* Through the pixel centres, a direction's u (tile_dirs_avx2) depends on its column alone and
     * its v on its row: both computed here once, with the operations of tile_dirs_avx2 (whole
     * tiles of columns and rows, so that a tile's four read no farther). Without the memory
     * they are computed lane by lane. */
    float *cu = NULL, *cv = NULL;
    if (avx2 && pgi__subpixel_centres(sp)) {
        cu = malloc(4 * (((size_t)W + 3) / 4 + (size_t)((H + 3) / 4)) * sizeof(float));
        if (cu) {
            cv = cu + 4 * (((size_t)W + 3) / 4);
            const float w = (float)cam->width, h = (float)cam->height, th = cam->tan_half_fov_y, asp = cam->aspect;
            for (int x = 0; x < 4 * ((W + 3) / 4); x++) cu[x] = ((2.f * ((float)x + 0.5f)) / w - 1.f) * th * asp;
            for (int y = 0; y < 4 * ((H + 3) / 4); y++) cv[y] = (1.f - (2.f * ((float)y + 0.5f)) / h) * th;
        }
    }
#endif
    /* 4x4-pixel tiles, one coherent 16-wide packet each (the fastest layout of primary rays:
     * photongi-bench --limits), cast and shaded in turn, BLOCK_TILES of them side by side into
     * one staging block. Prefetching a whole block's texels a sweep ahead of the lookups was
     * measured slower than prefetching a packet's just before them (pgi__texture_lookup_n). */
    const int tiles_x = (W + 3) / 4, tiles_y = (H + 3) / 4;
    const int blocks_x = (tiles_x + BLOCK_TILES - 1) / BLOCK_TILES;
#pragma omp parallel num_threads(pgi__threads(threads)) reduction(+ : rays)
    {
        view_block blk;
        lobe_cache lc = {0};
        view_tile vt[BLOCK_TILES];
#pragma omp for schedule(dynamic, 1)
        for (int ty = 0; ty < tiles_y; ty++) {
            for (int bx = 0; bx < blocks_x; bx++) {
                const int ntb = tiles_x - bx * BLOCK_TILES < BLOCK_TILES ? tiles_x - bx * BLOCK_TILES : BLOCK_TILES;
                /* Two sweeps over the block's tiles: each tile's packet is cast and its surfaces found,
                 * and where all its lanes hit one textured material its texels are requested; then
                 * the tiles are shaded, by when those texels have arrived (the casts of the tiles
                 * between took their cache misses' time). */
                for (int tb = 0; tb < ntb; tb++) {
                    view_tile *const T = &vt[tb];
                    const int tx = bx * BLOCK_TILES + tb;
#if VIEW_AVX2
                    if (avx2) tile_dirs_avx2(cam, sp, cu, cv, tx, ty, T->valid, T->pix, T->dsoa);
                    else
#endif
                        tile_dirs(cam, sp, tx, ty, T->valid, T->pix, T->dsoa);
                    const float *const dirs[3] = {T->dsoa[0], T->dsoa[1], T->dsoa[2]};
                    tile_hits *const hits = &T->hits;
                    pgi__rt_intersect16_soa(rt, T->valid, eye, dirs, hits->t, hits->u, hits->v, hits->prim);
                    int any = 0;
                    for (int k = 0; k < 16; k++) any |= hits->prim[k] != UINT32_MAX;
                    T->uni = NULL;
                    if (!any) continue;
#if VIEW_AVX2
                    if (avx2) {
                        tile_surfaces_avx2(s, tr, hits, (const float(*)[16])T->dsoa, eye, fwd, &T->ts);
                        if (tile_uniform_avx2(T->valid, hits, &T->ts)) {
                            const pgi__material *m = &s->mats[T->ts.mat[0]];
                            if (!pgi__mat_specular(m)) {
                                T->uni = m;
                                T->quads = m->tex_kd >= 0 && !tc.on &&
                                           pgi__texture_quads16(&s->texs[m->tex_kd], T->ts.u, T->ts.v, &T->q);
                            }
                        }
                        continue;
                    }
#endif
                    tile_surfaces(s, tr, hits, (const float(*)[16])T->dsoa, eye, fwd, &T->ts);
                }
                for (int tb = 0; tb < ntb; tb++) {
                    view_tile *const T = &vt[tb];
                    const tile_hits *const hits = &T->hits;
                    const tile_surf *const ts = &T->ts;
#if VIEW_AVX2
                    if (T->uni) {
                        const pgi__material *m = T->uni;
                        float tk[3][16], vc[3][16];
                        if (m->tex_kd >= 0 && tc.on) /* as the lanes' cone_lookup */
                            for (int k = 0; k < 16; k++) {
                                pgi__surface sk = {.ng = v3(ts->ng[0][k], ts->ng[1][k], ts->ng[2][k]),
                                                   .u = ts->u[k],
                                                   .v = ts->v[k],
                                                   .mat = m};
                                const pgi__v3 c =
                                    cone_lookup(s, &tc, &sk, hits->prim[k], cone_width(&tc, 0.f, hits->t[k]),
                                                v3(T->dsoa[0][k], T->dsoa[1][k], T->dsoa[2][k]));
                                tk[0][k] = c.x;
                                tk[1][k] = c.y;
                                tk[2][k] = c.z;
                            }
                        else if (m->tex_kd >= 0) { /* as pgi__surface_texture */
                            if (T->quads) pgi__texture_quads16_lookup(&s->texs[m->tex_kd], &T->q, tk);
                            else pgi__texture_lookup16_soa(&s->texs[m->tex_kd], ts->u, ts->v, tk);
                        }
                        if (s->col) /* as pgi__scene_kd */
                            for (int k = 0; k < 16; k++) {
                                const pgi__v3 c = pgi__scene_col(s, hits->prim[k], hits->u[k], hits->v[k]);
                                vc[0][k] = c.x;
                                vc[1][k] = c.y;
                                vc[2][k] = c.z;
                            }
                        tile_put_uniform_avx2(&blk, tb, ts, (const float(*)[16])T->dsoa,
                                              s->col ? (const float(*)[16])vc : NULL,
                                              m->tex_kd >= 0 ? (const float(*)[16])tk : NULL, m, lobe_of(&lc, m));
                        rays += 16;
                        continue;
                    }
#endif
                    /* Lanes whose primary hit is non-specular (nearly all) are shaded here in
                     * sweeps over the packet: their materials, then the 16 texture lookups one after
                     * the other (independent: their cache misses overlap), then the samples. The
                     * others (sky, mirrors, glass) follow their eye paths. */
                    pgi__surface sf[16];
                    int lit[16];
                    for (int k = 0; k < 16; k++) {
                        lit[k] = 0;
                        if (!T->valid[k]) continue;
                        rays++;
                        const int j = (k >> 2) * BLOCK_W + 4 * tb + (k & 3);
                        if (hits->prim[k] != UINT32_MAX) {
                            /* pgi__scene_surface_untextured from the triangle's record: the same bits */
                            pgi__tri_rec_geometry(s, &tr->tris[hits->prim[k]],
                                                  v3(ts->p[0][k], ts->p[1][k], ts->p[2][k]), &sf[k]);
                            if (!pgi__mat_specular(sf[k].mat)) {
                                sf[k].ns = v3(ts->ns[0][k], ts->ns[1][k], ts->ns[2][k]);
                                sf[k].u = ts->u[k];
                                sf[k].v = ts->v[k];
                                sf[k].kd = pgi__scene_kd(s, sf[k].mat, hits->prim[k], hits->u[k], hits->v[k]);
                                lit[k] = 1;
                                continue;
                            }
                        }
                        const pgi__hit h = {hits->t[k], hits->u[k], hits->v[k], hits->prim[k]};
                        shade_eye_path(s, rt, cam, seed, eps, &tc, T->pix[k], eye,
                                       v3(T->dsoa[0][k], T->dsoa[1][k], T->dsoa[2][k]), h, &blk, j, &lc, &rays);
                    }
                    const pgi__texture *tex[16];
                    float tu[16], tv[16];
                    pgi__v3 texc[16];
                    int lane[16], nt = 0;
                    if (tc.on)
                        for (int k = 0; k < 16; k++)
                            if (lit[k] && sf[k].mat->tex_kd >= 0)
                                sf[k].kd =
                                    v3_mul(sf[k].kd,
                                           cone_lookup(s, &tc, &sf[k], hits->prim[k], cone_width(&tc, 0.f, hits->t[k]),
                                                       v3(T->dsoa[0][k], T->dsoa[1][k], T->dsoa[2][k])));
                    for (int k = 0; k < 16 && !tc.on; k++)
                        if (lit[k] && sf[k].mat->tex_kd >= 0) { /* as pgi__surface_texture */
                            tex[nt] = &s->texs[sf[k].mat->tex_kd];
                            tu[nt] = ts->u[k];
                            tv[nt] = ts->v[k];
                            lane[nt++] = k;
                        }
                    pgi__texture_lookup_n(tex, tu, tv, nt, texc);
                    for (int q = 0; q < nt; q++) sf[lane[q]].kd = v3_mul(sf[lane[q]].kd, texc[q]);
                    for (int k = 0; k < 16; k++) {
                        if (!lit[k]) continue;
                        const int j = (k >> 2) * BLOCK_W + 4 * tb + (k & 3);
                        pgi__v3 wo = v3_neg(v3(T->dsoa[0][k], T->dsoa[1][k], T->dsoa[2][k]));
                        float side = v3_dot(wo, sf[k].ng) >= 0.f ? 1.f : -1.f;
                        /* as shade_eye_path at depth 0: the same operations, the same bits */
                        pgi__v3 e = v3(0.f, 0.f, 0.f);
                        if (side > 0.f) e = v3_add(e, v3_mul(v3(1.f, 1.f, 1.f), v3_load(sf[k].mat->ke)));
                        put_sample(&blk, j, &sf[k], wo, side, v3(1.f, 1.f, 1.f), 1, &lc);
                        blk.depth[j] = ts->depth[k];
                        v3_store(blk.emit + 3 * j, e);
                    }
                }
                const int px0 = bx * BLOCK_W, py0 = 4 * ty;
                const int n = W - px0 < BLOCK_W ? W - px0 : BLOCK_W, rows = H - py0 < 4 ? H - py0 : 4;
                uint8_t *const fr = fill_rows ? fill_rows + (size_t)py0 * fill_cols + (size_t)bx : NULL;
                const size_t i0 = (size_t)py0 * (size_t)W + (size_t)px0;
#if VIEW_AVX2
                if (avx2) put_block_avx2(&blk, rows, n, i0, (size_t)W, vs, emit, fr, fill_cols);
                else
#endif
                    put_block(&blk, rows, n, i0, (size_t)W, vs, emit, fr, fill_cols);
            }
        }
#if defined(__SSE2__)
        _mm_sfence(); /* the streamed rows are visible to the other threads after the barrier */
#endif
    }
#if VIEW_AVX2
    free(cu);
#endif
    pgi__tri_cache_free(&own);
    *rays_out = rays;
    return PGI_OK;
}

/* The view samples of a 4x4-pixel tile (tile_lane) that pgi__direct shades. Position, normals
 * and the ray origin x are loaded for every valid lane; wo, kd and the lobe (pgi__vs_lobe, which
 * interpolates a GGX lobe's albedo table) only when a shadow ray of the lane comes through
 * (tile_brdf), which in a scene with one light skips them for every shadowed pixel. */
typedef struct dtile {
    int on[16], ready[16];
    size_t pix[16];
    pgi__v3 wo[16], kd[16];
    /* x, ns, ng lane by lane (zeros where off): only so, the setup stores each component once */
    float xs[3][16], nss[3][16], ngs[3][16];
    pgi__lobe lobe[16];
} dtile;

static inline pgi__v3 tile_x(const dtile *t, int k) { return v3(t->xs[0][k], t->xs[1][k], t->xs[2][k]); }
static inline pgi__v3 tile_ns(const dtile *t, int k) { return v3(t->nss[0][k], t->nss[1][k], t->nss[2][k]); }
static inline pgi__v3 tile_ng(const dtile *t, int k) { return v3(t->ngs[0][k], t->ngs[1][k], t->ngs[2][k]); }

/* f(wi, wo) of lane k (kd/pi plus its lobe), its shading loaded on first use. */
static inline pgi__v3 tile_brdf(dtile *t, const pgi_view_samples *vs, int k, pgi__v3 wi) {
    if (!t->ready[k]) {
        const size_t i = t->pix[k];
        t->wo[k] = v3_load(vs->wo + 3 * i);
        t->kd[k] = v3_load(vs->kd + 3 * i);
        pgi__vs_lobe(vs, i, &t->lobe[k]);
        t->ready[k] = 1;
    }
    return pgi__brdf_eval(t->kd[k], &t->lobe[k], tile_ns(t, k), wi, t->wo[k]);
}

/* The shadow rays of a run of the sky's samples (env_direct, env_direct_portals), cast as one
 * stream: ray i from org[i] along wi[i] to infinity for lane lane[i], its weight w[i]. */
typedef struct env_rays {
    pgi__v3 org[PGI__RT_STREAM_MAX], wi[PGI__RT_STREAM_MAX], w[PGI__RT_STREAM_MAX];
    float tmax[PGI__RT_STREAM_MAX];
    int occ[PGI__RT_STREAM_MAX];
    unsigned char lane[PGI__RT_STREAM_MAX];
    size_t m;
} env_rays;

static inline void env_ray_add(env_rays *R, int k, pgi__v3 x, pgi__v3 d, pgi__v3 w) {
    R->w[R->m] = w;
    R->wi[R->m] = d;
    R->org[R->m] = x;
    R->tmax[R->m] = INFINITY;
    R->lane[R->m++] = (unsigned char)k;
}

/* Casts the run's rays (occ[i]: ray i blocked) and returns how many there are; the next run's
 * start at 0 (the arrays hold this run's until then). */
static inline size_t env_rays_cast(const pgi__rt *rt, env_rays *R, uint64_t *rays) {
    const size_t m = R->m;
    R->m = 0;
    if (!m) return 0;
    *rays += (uint64_t)m;
    pgi__rt_occluded1M(rt, m, R->org, R->wi, R->tmax, R->occ);
    return m;
}

/* Lane k's sum zeroed, and where it is on (returns 1) its RNG stream and tangent frame. */
static inline int env_lane_init(const dtile *t, int k, uint64_t seed, pgi__rng *rng, pgi__env_frame *fr, pgi__v3 *Le) {
    *Le = v3(0.f, 0.f, 0.f);
    if (!t->on[k]) return 0;
    pgi_rng_seed(rng, seed ^ 0x736b79ULL, (uint64_t)t->pix[k]);
    pgi__env_frame_init(fr, tile_ns(t, k));
    return 1;
}

/* Direct light from the sky at the valid lanes of a tile: `n` directions a lane
 * (pgi__env_sample_direct: cosine-weighted about ns, and for a map half of them by the map),
 * the first number stratified over the n, shadow rays to infinity; adds the mean to L. Each
 * pixel has its own RNG stream (seed, pixel). The rays scatter over the hemisphere, so they
 * go to Embree as incoherent streams (pgi__rt_occluded1M: the fastest style for them,
 * photongi-bench --limits) of up to ENV_RUN samples of the 16 lanes, sample by sample; each
 * pixel still draws its numbers and sums its samples in the order j = 0, 1, ... A lane's
 * tangent frame for the cosine-weighted directions is set up once (pgi__env_frame). */
#define ENV_RUN (PGI__RT_STREAM_MAX / 16)
static void env_direct(const pgi__env *env, const pgi__rt *rt, dtile *t, const pgi_view_samples *vs, int n,
                       uint64_t seed, pgi__v3 L[16], uint64_t *rays) {
    pgi__rng rng[16];
    pgi__env_frame fr[16];
    pgi__v3 Le[16];
    env_rays R;
    R.m = 0;
    for (int k = 0; k < 16; k++) env_lane_init(t, k, seed, &rng[k], &fr[k], &Le[k]);
    for (int j0 = 0; j0 < n; j0 += ENV_RUN) {
        const int j1 = n - j0 < ENV_RUN ? n : j0 + ENV_RUN;
        for (int j = j0; j < j1; j++)
            for (int k = 0; k < 16; k++) {
                if (!t->on[k]) continue;
                float u1 = ((float)j + pgi_rng_f(&rng[k])) / (float)n, u2 = pgi_rng_f(&rng[k]), pdf;
                pgi__v3 le, d = pgi__env_sample_direct_in(env, &fr[k], u1, u2, &pdf, &le);
                float c = v3_dot(tile_ns(t, k), d);
                if (!(pdf > 0.f) || !(c > 0.f) || !(v3_dot(tile_ng(t, k), d) > 0.f)) continue;
                env_ray_add(&R, k, tile_x(t, k), d, v3_scale(le, c / pdf));
            }
        const size_t m = env_rays_cast(rt, &R, rays);
        for (size_t i = 0; i < m; i++) {
            if (R.occ[i]) continue;
            const int k = R.lane[i];
            Le[k] = v3_add(Le[k], v3_mul(tile_brdf(t, vs, k, R.wi[i]), R.w[i]));
        }
    }
    for (int k = 0; k < 16; k++)
        if (t->on[k]) L[k] = v3_add(L[k], v3_scale(Le[k], 1.f / (float)n));
}

/* Element i of a pseudo-random permutation of 0..l-1 chosen by p (Kensler 2013, "Correlated
 * Multi-Jittered Sampling": a hash that is a bijection on the next power of two, walked until it
 * lands below l). With stratum j of a sample's first number, stratum permute(j) of its second
 * makes a lane's samples a Latin hypercube. */
static inline unsigned permute(unsigned i, unsigned l, unsigned p) {
    unsigned w = l - 1;
    w |= w >> 1, w |= w >> 2, w |= w >> 4, w |= w >> 8, w |= w >> 16;
    do {
        i ^= p, i *= 0xe170893du, i ^= p >> 16, i ^= (i & w) >> 4, i ^= p >> 8, i *= 0x0929eb3fu, i ^= p >> 23;
        i ^= (i & w) >> 1, i *= 1u | p >> 27, i *= 0x6935fa69u, i ^= (i & w) >> 11, i *= 0x74dcb303u;
        i ^= (i & w) >> 2, i *= 0x9e501cc3u, i ^= (i & w) >> 2, i *= 0xc860a3dfu, i &= w, i ^= i >> 5;
    } while (i >= l);
    return (i + p) % l;
}

/* env_direct in a scene with portals (scene/portal.h): of the n directions a lane, ceil(n/4)
 * come from the sky's own sampler (the cosine; for a map its mixture) and the rest from the
 * portals (a point of a portal picked by its solid angle seen from the lane, uniform in that
 * solid angle), combined by the balance heuristic over both (each sample weighted by
 * 1 / (n_a p_a + n_b p_b)): the same expected value, with far fewer shadow rays into the walls
 * around a window. Each strategy's samples are stratified in both numbers (a Latin hypercube:
 * permute). A lane that sees no portal's inside
 * takes all n from the sky's sampler, as env_direct. */
static void env_direct_portals(const pgi__env *env, const pgi__portal *P, size_t np, const pgi__rt *rt, dtile *t,
                               const pgi_view_samples *vs, int n, uint64_t seed, pgi__v3 L[16], uint64_t *rays) {
    pgi__rng rng[16];
    pgi__env_frame fr[16];
    float pw[16][2 * PGI__MAX_PORTALS]; /* pick probabilities and solid angles (pgi__portal_direct_weights) */
    pgi__portal_sph cache[16][PGI__PORTAL_CACHE];
    int na[16], nb[16];
    unsigned perm[16][2]; /* the second numbers' permutations: the sky's sampler, the portals */
    pgi__v3 Le[16];
    env_rays R;
    R.m = 0;
    for (int k = 0; k < 16; k++) {
        if (!env_lane_init(t, k, seed, &rng[k], &fr[k], &Le[k])) continue;
        const float sum = pgi__portal_direct_weights(P, np, tile_x(t, k), tile_ns(t, k), pw[k], cache[k]);
        na[k] = sum > 0.f ? (n + 3) / 4 : n;
        nb[k] = n - na[k];
        perm[k][0] = pgi_rng_u32(&rng[k]);
        perm[k][1] = pgi_rng_u32(&rng[k]);
    }
    /* The MIS weights are needed only where the shadow ray escapes (most of the cosine samples
     * hit the walls): a ray's strategy, and for the sky's sampler its pdf and radiance, wait for
     * the occlusion test. */
    float pa_ray[PGI__RT_STREAM_MAX];
    unsigned char portal_ray[PGI__RT_STREAM_MAX];
    for (int j0 = 0; j0 < n; j0 += ENV_RUN) {
        const int j1 = n - j0 < ENV_RUN ? n : j0 + ENV_RUN;
        for (int j = j0; j < j1; j++)
            for (int k = 0; k < 16; k++) {
                if (!t->on[k]) continue;
                const pgi__v3 x = tile_x(t, k), ns = tile_ns(t, k);
                pgi__v3 le = v3(0.f, 0.f, 0.f), d;
                float pa = 0.f;
                const int portal = j >= na[k];
                if (!portal) { /* the sky's sampler */
                    const float u1 = ((float)j + pgi_rng_f(&rng[k])) / (float)na[k];
                    const float u2 =
                        ((float)permute((unsigned)j, (unsigned)na[k], perm[k][0]) + pgi_rng_f(&rng[k])) / (float)na[k];
                    d = pgi__env_sample_direct_in(env, &fr[k], u1, u2, &pa, &le);
                    if (!(pa > 0.f)) continue;
                } else { /* a portal */
                    const unsigned jb = (unsigned)(j - na[k]);
                    const float u0 = ((float)jb + pgi_rng_f(&rng[k])) / (float)nb[k];
                    const float u2 =
                        ((float)permute(jb, (unsigned)nb[k], perm[k][1]) + pgi_rng_f(&rng[k])) / (float)nb[k];
                    if (!pgi__portal_direct_sample(P, np, pw[k], cache[k], x, u0, u2, &d)) continue;
                }
                if (!(v3_dot(ns, d) > 0.f) || !(v3_dot(tile_ng(t, k), d) > 0.f)) continue;
                pa_ray[R.m] = pa;
                portal_ray[R.m] = (unsigned char)portal;
                env_ray_add(&R, k, x, d, le);
            }
        const size_t m = env_rays_cast(rt, &R, rays);
        for (size_t i = 0; i < m; i++) {
            if (R.occ[i]) continue;
            const int k = R.lane[i];
            const pgi__v3 d = R.wi[i], ns = tile_ns(t, k);
            const float pb = nb[k] ? pgi__portal_direct_pdf(P, np, pw[k], R.org[i], d) : 0.f;
            float pa = pa_ray[i];
            pgi__v3 le = R.w[i];
            if (portal_ray[i]) {
                if (!(pb > 0.f)) continue; /* lost to rounding at a portal's edge */
                pa = pgi__env_pdf_direct(env, ns, d);
                le = pgi__env_eval(env, d);
            }
            const float den = (float)na[k] * pa + (float)nb[k] * pb;
            if (!(den > 0.f) || !isfinite(den)) continue;
            Le[k] = v3_add(Le[k], v3_mul(tile_brdf(t, vs, k, d), v3_scale(le, v3_dot(ns, d) / den)));
        }
    }
    for (int k = 0; k < 16; k++)
        if (t->on[k]) L[k] = v3_add(L[k], Le[k]);
}

void pgi__area_table_free(pgi__area_table *t) {
    free(t->cdf);
    free(t->start);
    free(t->rec);
    memset(t, 0, sizeof *t);
}

pgi_status pgi__area_table_guide(pgi__area_table *t) {
    const size_t n = t->n;
    free(t->start);
    t->start = NULL;
    t->nb = n < ((size_t)1 << 20) ? n : ((size_t)1 << 20);
    int monotone = 1;
    for (size_t k = 1; k < n; k++)
        if (!(t->cdf[k] >= t->cdf[k - 1])) monotone = 0;
    if (!monotone || n < 2 || n > UINT32_MAX) return PGI_OK; /* binary search */
    t->start = malloc((t->nb + 1) * sizeof *t->start);
    if (!t->start) return pgi__fail(PGI_ERR_OOM, "out of memory for the area-light table");
    size_t i = 0;
    t->start[0] = 0;
    for (size_t b = 1; b <= t->nb; b++) {
        const double lo = ((double)b - 1.5) / (double)t->nb;
        while (i < n - 1 && !((double)t->cdf[i] > lo)) i++;
        t->start[b] = (uint32_t)i;
    }
    return PGI_OK;
}

pgi_status pgi__area_table_build(const pgi_scene *s, pgi__area_table *t) {
    memset(t, 0, sizeof *t);
    t->n = pgi__light_area_count(s);
    if (!t->n) return PGI_OK;
    const size_t n = t->n;
    t->cdf = malloc(n * sizeof *t->cdf);
    t->rec = malloc(n * sizeof *t->rec);
    size_t *idx = malloc(n * sizeof *idx); /* each area light's in s->lights */
    if (!t->cdf || !t->rec || !idx) {
        free(idx);
        pgi__area_table_free(t);
        return pgi__fail(PGI_ERR_OOM, "out of memory for the area-light table");
    }
    pgi__light_area_cdf(s, t->cdf, idx);
    for (size_t k = 0; k < n; k++) {
        const pgi__light *lt = &s->lights[idx[k]];
        const uint32_t *v = s->tri + 3 * (size_t)lt->tri;
        pgi__area_rec *r = &t->rec[k];
        r->a = pgi__scene_vertex(s, v[0]);
        r->b = pgi__scene_vertex(s, v[1]);
        r->c = pgi__scene_vertex(s, v[2]);
        r->normal = v3_load(lt->normal);
        r->color = v3_load(lt->color);
        r->area = lt->area;
    }
    free(idx);
    for (size_t k = 0; k < n; k++) t->rec[k].p = t->cdf[k] - (k ? t->cdf[k - 1] : 0.f); /* what pgi__cdf_pick returns */
    pgi_status st = pgi__area_table_guide(t);
    if (st) pgi__area_table_free(t);
    return st;
}

/* The view-sample planes of tile (tx, ty) that pgi__direct reads for every pixel, and its
 * output, into the cache: a tile reads 4 short runs of each plane, more streams than the hardware
 * prefetcher follows (the shading planes follow per lane: PREFETCH_SHADING). DIRECT_PREFETCH
 * tiles ahead. Macros, not functions: gcc finds a
 * function that only prefetches free of side effects and drops its calls. */
#ifndef DIRECT_PREFETCH
#define DIRECT_PREFETCH 2
#endif
#define PREFETCH_RUN(p, bytes)                                                                                         \
    do {                                                                                                               \
        __builtin_prefetch((const char *)(p));                                                                         \
        __builtin_prefetch((const char *)(p) + (bytes)-1);                                                             \
    } while (0)
#define PREFETCH_TILE(vs, out, one, tx, ty)                                                                            \
    do {                                                                                                               \
        const int pf_x0 = 4 * (tx), pf_n = (vs)->width - pf_x0 < 4 ? (vs)->width - pf_x0 : 4;                          \
        const size_t pf_b3 = 3 * (size_t)pf_n * sizeof(float);                                                         \
        for (int pf_r = 0; pf_r < 4 && 4 * (ty) + pf_r < (vs)->height; pf_r++) {                                       \
            const size_t pf_i = (size_t)(4 * (ty) + pf_r) * (size_t)(vs)->width + (size_t)pf_x0;                       \
            PREFETCH_RUN((vs)->flags + pf_i, (size_t)pf_n);                                                            \
            PREFETCH_RUN((vs)->pos + 3 * pf_i, pf_b3);                                                                 \
            PREFETCH_RUN((vs)->nrm + 3 * pf_i, pf_b3);                                                                 \
            PREFETCH_RUN((vs)->ngeo + 3 * pf_i, pf_b3);                                                                \
            if (!weight_one(one, 4 * (ty) + pf_r, pf_x0)) PREFETCH_RUN((vs)->weight + 3 * pf_i, pf_b3);                \
            PREFETCH_RUN((out) + 3 * pf_i, pf_b3);                                                                     \
        }                                                                                                              \
    } while (0)
/* What tile_brdf loads for lane k, requested when the lane casts a shadow ray: the ray's trace
 * then covers the misses, and pixels that face away from every light never load these planes
 * (a fifth of Sibenik's; prefetched with the tile, they cost bandwidth for nothing). */
#define PREFETCH_SHADING(vs, t, k)                                                                                     \
    do {                                                                                                               \
        if (!(t)->ready[k]) {                                                                                          \
            const size_t pf_i = (t)->pix[k];                                                                           \
            __builtin_prefetch((vs)->wo + 3 * pf_i);                                                                   \
            __builtin_prefetch((vs)->kd + 3 * pf_i);                                                                   \
            if (!((vs)->flags[pf_i] & PGI_VS_LAMBERT)) { /* pgi__vs_lobe reads no more */                              \
                __builtin_prefetch((vs)->ks + 3 * pf_i);                                                               \
                __builtin_prefetch((vs)->shininess + pf_i);                                                            \
            }                                                                                                          \
        }                                                                                                              \
    } while (0)

/* The entries of a pgi__view_fill of this image (rows NULL: none); weight_one: does it know the
 * weights of pixel (x, y) to be 1? */
typedef struct weight_rows {
    const uint8_t *rows;
    size_t cols;
} weight_rows;
static inline int weight_one(const weight_rows *one, int y, int x) {
    return one->rows && (one->rows[(size_t)y * one->cols + (size_t)(x / PGI__FILL_W)] & PGI__FILL_WEIGHT);
}

#if VIEW_AVX2
/* composite's loop over whole groups of eight floats from i0; returns where it stopped. */
__attribute__((target("avx2"))) static size_t composite_avx2(float *out, const float *w, const float *emit,
                                                             const float *indirect, size_t i0, size_t i1,
                                                             pgi_output output, int one, int zero) {
    size_t i = i0;
    for (; i + 8 <= i1; i += 8) {
        const __m256 in = _mm256_loadu_ps(indirect + i);
        const __m256 ind = one ? in : _mm256_mul_ps(_mm256_loadu_ps(w + i), in);
        const __m256 dir =
            _mm256_add_ps(zero ? _mm256_setzero_ps() : _mm256_loadu_ps(emit + i), _mm256_loadu_ps(out + i));
        _mm256_storeu_ps(out + i, output == PGI_OUTPUT_INDIRECT ? ind
                                  : output == PGI_OUTPUT_DIRECT ? dir
                                                                : _mm256_add_ps(dir, ind));
    }
    return i;
}
#endif

/* The image's floats [i0, i1) from the direct light out holds there (the weight applied): emitted +
 * direct light, plus the weight times the indirect light (output picks the parts);
 * `fill` holds the pgi__view_fill bits of these pixels: where the weights are known to be 1 or the
 * emission +0 those loads are left out (1 * x is x, and +0 + x is what adding the constant gives,
 * -0 included). */
static void composite(float *out, const float *w, const float *emit, const float *indirect, size_t i0, size_t i1,
                      pgi_output output, unsigned fill, int avx2) {
    const int one = (fill & PGI__FILL_WEIGHT) != 0, zero = (fill & PGI__FILL_EMIT) != 0;
#if VIEW_AVX2
    /* the same operations eight floats an instruction (gcc left this loop scalar) */
    if (avx2) i0 = composite_avx2(out, w, emit, indirect, i0, i1, output, one, zero);
#else
    (void)avx2;
#endif
    for (size_t i = i0; i < i1; i++) {
        float ind = one ? indirect[i] : w[i] * indirect[i];
        float dir = (zero ? 0.f : emit[i]) + out[i];
        out[i] = output == PGI_OUTPUT_INDIRECT ? ind : output == PGI_OUTPUT_DIRECT ? dir : dir + ind;
    }
}

#if VIEW_AVX2
/* The lanes of tile (tx, ty), which lies whole in the image: when all 16 samples are valid,
 * sets them up as pgi__direct's lane loop does (pixels, on, not ready, x = p + eps ng, ns, ng:
 * the same operations, each row's 12 floats of a plane turned into components by shuffles)
 * and returns 1; else 0, and t is left for that loop. */
__attribute__((target("avx2"))) static int dtile_full_avx2(const pgi_view_samples *vs, int W, int tx, int ty, float eps,
                                                           dtile *t) {
    const size_t i0 = (size_t)(4 * ty) * (size_t)W + (size_t)(4 * tx);
    uint32_t all = 0x01010101u * PGI_VS_VALID, f = all;
    for (int r = 0; r < 4; r++) {
        uint32_t b;
        memcpy(&b, vs->flags + i0 + (size_t)r * (size_t)W, 4);
        f &= b;
    }
    if ((f & all) != all) return 0;
    const __m256 e = _mm256_set1_ps(eps);
    for (int h = 0; h < 2; h++) {
        const size_t ia = i0 + (size_t)(2 * h) * (size_t)W, ib = ia + (size_t)W;
        __m256 c[3][3]; /* plane (pos, nrm, ngeo), component */
        const float *planes[3] = {vs->pos, vs->nrm, vs->ngeo};
        for (int pl = 0; pl < 3; pl++) {
            const float *a = planes[pl] + 3 * ia, *b = planes[pl] + 3 * ib;
            const __m256 o0 = _mm256_setr_m128(_mm_loadu_ps(a), _mm_loadu_ps(b));
            const __m256 o1 = _mm256_setr_m128(_mm_loadu_ps(a + 4), _mm_loadu_ps(b + 4));
            const __m256 o2 = _mm256_setr_m128(_mm_loadu_ps(a + 8), _mm_loadu_ps(b + 8));
            /* (x0 y0 z0 x1) (y1 z1 x2 y2) (z2 x3 y3 z3) -> (x0..x3) (y0..y3) (z0..z3), per half */
            const __m256 q = _mm256_shuffle_ps(o1, o2, _MM_SHUFFLE(2, 1, 3, 2)); /* x2 y2 x3 y3 */
            const __m256 u = _mm256_shuffle_ps(o0, o1, _MM_SHUFFLE(1, 0, 2, 1)); /* y0 z0 y1 z1 */
            c[pl][0] = _mm256_shuffle_ps(o0, q, _MM_SHUFFLE(2, 0, 3, 0));
            c[pl][1] = _mm256_shuffle_ps(u, q, _MM_SHUFFLE(3, 1, 2, 0));
            c[pl][2] = _mm256_shuffle_ps(u, o2, _MM_SHUFFLE(3, 0, 3, 1));
        }
        for (int k = 0; k < 3; k++) {
            _mm256_storeu_ps(t->xs[k] + 8 * h, _mm256_add_ps(c[0][k], _mm256_mul_ps(c[2][k], e)));
            _mm256_storeu_ps(t->nss[k] + 8 * h, c[1][k]);
            _mm256_storeu_ps(t->ngs[k] + 8 * h, c[2][k]);
        }
    }
    for (int k = 0; k < 16; k++) {
        t->pix[k] = i0 + (size_t)(k >> 2) * (size_t)W + (size_t)(k & 3);
        t->ready[k] = 0;
        t->on[k] = 1;
    }
    return 1;
}
#endif

pgi_status pgi__direct(const pgi_scene *s, const pgi__rt *rt, const pgi_view_samples *vs, const pgi__view_fill *fill,
                       const pgi__direct_sum *sum, int area_samples, uint64_t seed, int threads, float *out,
                       uint64_t *rays_out) {
    /* Area lights get their own CDF by power (luminance). */
    pgi__area_table at;
    pgi_status st = pgi__area_table_build(s, &at);
    if (st) return st;
    const size_t narea = at.n;
    const float eps = pgi__scene_epsilon(s);
    uint64_t rays = 0;
    const int W = vs->width, H = vs->height;
    /* rows whose weights are all 1 are not read: 1 * x is x */
    const weight_rows one = {fill && fill->rows && fill->width == W && fill->height == H ? fill->rows : NULL,
                             fill ? (size_t)fill->cols : 0};
    /* 4x4-pixel tiles (tile_lane): the shadow rays of a tile towards one light (or one area
     * sample each) go to Embree as one coherent 16-wide packet (the fastest style:
     * photongi-bench --limits). Every pixel keeps its own RNG stream and its sums run in the
     * order of the lights and samples, as a pixel-by-pixel loop would. */
    const int tiles_x = (W + 3) / 4, tiles_y = (H + 3) / 4;
#if VIEW_AVX2
    const int avx2 = pgi__cpu_avx2();
#else
    const int avx2 = 0;
#endif
    const pgi_cancel *cancel = sum ? sum->cancel : NULL;
#pragma omp parallel for schedule(dynamic, 1) reduction(+ : rays) num_threads(pgi__threads(threads))
    for (int ty = 0; ty < tiles_y; ty++) {
        dtile t;
        if (pgi__cancelled(cancel)) continue; /* the remaining rows drain at once */
        for (int tx = 0; tx < tiles_x; tx++) {
            pgi__v3 L[16];
            int any = 0;
            if (DIRECT_PREFETCH && tx + DIRECT_PREFETCH < tiles_x)
                PREFETCH_TILE(vs, out, &one, tx + DIRECT_PREFETCH, ty);
#if VIEW_AVX2
            if (avx2 && 4 * tx + 4 <= W && 4 * ty + 4 <= H && dtile_full_avx2(vs, W, tx, ty, eps, &t)) {
                for (int k = 0; k < 16; k++) L[k] = v3(0.f, 0.f, 0.f);
                any = 1;
            } else
#endif
                for (int k = 0; k < 16; k++) {
                    int px, py;
                    int on = tile_lane(tx, ty, k, W, H, &px, &py);
                    size_t i = on ? (size_t)py * (size_t)W + (size_t)px : 0;
                    t.pix[k] = i;
                    t.ready[k] = 0;
                    L[k] = v3(0.f, 0.f, 0.f);
                    if (on && !(vs->flags[i] & PGI_VS_VALID)) {
                        v3_store(out + 3 * i, L[k]);
                        on = 0;
                    }
                    t.on[k] = on;
                    /* x = p + eps ng (v3_madd) in scalars, stored to both layouts: filled as vectors and
                 * read back lane by lane, gcc reloaded each component from the stores just made */
                    float x0 = 0.f, x1 = 0.f, x2 = 0.f, n0 = 0.f, n1 = 0.f, n2 = 0.f, g0 = 0.f, g1 = 0.f, g2 = 0.f;
                    if (on) { /* off lanes reach Embree masked: zeros */
                        const float *pp = vs->pos + 3 * i, *pn = vs->nrm + 3 * i, *pg = vs->ngeo + 3 * i;
                        n0 = pn[0];
                        n1 = pn[1];
                        n2 = pn[2];
                        g0 = pg[0];
                        g1 = pg[1];
                        g2 = pg[2];
                        x0 = pp[0] + g0 * eps;
                        x1 = pp[1] + g1 * eps;
                        x2 = pp[2] + g2 * eps;
                        any = 1;
                    }
                    t.xs[0][k] = x0;
                    t.xs[1][k] = x1;
                    t.xs[2][k] = x2;
                    t.nss[0][k] = n0;
                    t.nss[1][k] = n1;
                    t.nss[2][k] = n2;
                    t.ngs[0][k] = g0;
                    t.ngs[1][k] = g1;
                    t.ngs[2][k] = g2;
                }
            if (!any) continue;
            int valid[16], occ[16];
            float cs[16], tmax[16], wis[3][16], Lis[3][16];
            const float *const xo[3] = {t.xs[0], t.xs[1], t.xs[2]}, *const wd[3] = {wis[0], wis[1], wis[2]};
            for (size_t l = 0; l < s->nlights; l++) {
                const pgi__light *lt = &s->lights[l];
                if (!pgi__light_is_delta(lt)) continue;
                int nv = 0;
                if (pgi__light_delta16_ok(lt))
                    nv = pgi__light_delta16(lt, t.on, (const float(*)[16])t.xs, (const float(*)[16])t.nss,
                                            (const float(*)[16])t.ngs, valid, wis, Lis, cs, tmax);
                else
                    for (int k = 0; k < 16; k++) {
                        pgi__v3 w, li;
                        valid[k] = t.on[k] && pgi__light_delta(lt, tile_x(&t, k), tile_ns(&t, k), tile_ng(&t, k), &w,
                                                               &li, &cs[k], &tmax[k]);
                        if (!valid[k]) continue;
                        nv++;
                        wis[0][k] = w.x;
                        wis[1][k] = w.y;
                        wis[2][k] = w.z;
                        Lis[0][k] = li.x;
                        Lis[1][k] = li.y;
                        Lis[2][k] = li.z;
                    }
                if (!nv) continue;
                rays += (uint64_t)nv;
                for (int k = 0; k < 16; k++)
                    if (valid[k]) PREFETCH_SHADING(vs, &t, k);
                pgi__rt_occluded16_soa(rt, valid, xo, wd, tmax, occ);
                for (int k = 0; k < 16; k++)
                    if (valid[k] && !occ[k]) {
                        const pgi__v3 w = v3(wis[0][k], wis[1][k], wis[2][k]), li = v3(Lis[0][k], Lis[1][k], Lis[2][k]);
                        L[k] = v3_add(L[k], v3_scale(v3_mul(tile_brdf(&t, vs, k, w), li), cs[k]));
                    }
            }
            if (narea && area_samples > 0) {
                pgi__rng rng[16];
                pgi__v3 La[16], xa[16]; /* the samples' sum; the origins as occluded16 takes them */
                pgi__v3 wi[16] = {{0}}; /* zeroed only in scenes with area lights */
                for (int k = 0; k < 16; k++) {
                    La[k] = v3(0.f, 0.f, 0.f);
                    xa[k] = tile_x(&t, k);
                    if (t.on[k]) pgi_rng_seed(&rng[k], seed ^ 0xd15ec7ULL, (uint64_t)t.pix[k]);
                }
                float g[16];
                const pgi__area_rec *lts[16];
                for (int j = 0; j < area_samples; j++) {
                    int nv = 0;
                    for (int k = 0; k < 16; k++) {
                        valid[k] = 0;
                        if (!t.on[k]) continue;
                        float u = ((float)j + pgi_rng_f(&rng[k])) / (float)area_samples; /* stratified light pick */
                        const pgi__area_rec *lt = &at.rec[pgi__area_pick(&at, u)];
                        const float pl = lt->p;
                        float u1 = pgi_rng_f(&rng[k]), u2 = pgi_rng_f(&rng[k]);
                        /* pgi__triangle_sample on the record's vertices */
                        const pgi__v3 y = pgi__tri_point(lt->a, lt->b, lt->c, u1, u2);
                        float d2, dist, cl;
                        if (!(pl > 0.f) || !pgi__light_area_toward(y, lt->normal, xa[k], &wi[k], &d2, &dist, &cl))
                            continue;
                        const float c = v3_dot(tile_ns(&t, k), wi[k]);
                        if (!(cl > 0.f) || !(c > 0.f) || !(v3_dot(tile_ng(&t, k), wi[k]) > 0.f)) continue;
                        tmax[k] = dist * (1.f - 1e-3f);
                        g[k] = c * cl / d2 * lt->area / pl;
                        lts[k] = lt;
                        valid[k] = 1;
                        nv++;
                    }
                    if (!nv) continue;
                    rays += (uint64_t)nv;
                    for (int k = 0; k < 16; k++)
                        if (valid[k]) PREFETCH_SHADING(vs, &t, k);
                    pgi__rt_occluded16(rt, valid, xa, wi, tmax, 1, occ);
                    for (int k = 0; k < 16; k++)
                        if (valid[k] && !occ[k])
                            La[k] = v3_add(La[k], v3_scale(v3_mul(tile_brdf(&t, vs, k, wi[k]), lts[k]->color), g[k]));
                }
                for (int k = 0; k < 16; k++)
                    if (t.on[k]) L[k] = v3_add(L[k], v3_scale(La[k], 1.f / (float)area_samples));
            }
            if (s->env && area_samples > 0) {
                for (int k = 0; k < 16; k++)
                    if (t.on[k]) PREFETCH_SHADING(vs, &t, k);
                if (s->nportals)
                    env_direct_portals(s->env, s->portals, s->nportals, rt, &t, vs, area_samples, seed, L, &rays);
                else env_direct(s->env, rt, &t, vs, area_samples, seed, L, &rays);
            }
            for (int k = 0; k < 16; k++)
                if (t.on[k])
                    v3_store(out + 3 * t.pix[k], weight_one(&one, 4 * ty + (k >> 2), 4 * tx)
                                                     ? L[k]
                                                     : v3_mul(L[k], v3_load(vs->weight + 3 * t.pix[k])));
        }
        /* The strip's 4 rows are one run of memory, its direct light still in the cache: the
         * composite follows it here, 32 pixels (a pgi__view_fill entry) at a time, in parallel. */
        if (sum)
            for (int y = 4 * ty; y < 4 * ty + 4 && y < H; y++)
                for (int x = 0; x < W; x += PGI__FILL_W) {
                    const size_t p0 = (size_t)y * (size_t)W + (size_t)x;
                    const size_t p1 = p0 + (size_t)(W - x < PGI__FILL_W ? W - x : PGI__FILL_W);
                    if (sum->direct) /* composite's `dir`, before it replaces out */
                        for (size_t i = 3 * p0; i < 3 * p1; i++) sum->direct[i] = sum->emit[i] + out[i];
                    composite(out, vs->weight, sum->emit, sum->indirect, 3 * p0, 3 * p1, sum->output,
                              one.rows ? one.rows[(size_t)y * one.cols + (size_t)(x / PGI__FILL_W)] : 0u, avx2);
                }
    }
    pgi__area_table_free(&at);
    *rays_out = rays;
    return pgi__cancelled(cancel) ? pgi__fail_cancelled("direct") : PGI_OK;
}

void pgi__indirect_image(const pgi_view_samples *vs, const float *indirect, int threads, float *out) {
    const long n = (long)(3 * vs->count);
#pragma omp parallel for schedule(static) num_threads(pgi__threads(threads))
    for (long i = 0; i < n; i++) out[i] = vs->weight[i] * indirect[i];
}

void pgi__view_aovs(const pgi_view_samples *vs, const float *indirect, int threads, pgi_aovs *a) {
    const long n = (long)vs->count;
#pragma omp parallel for schedule(static) num_threads(pgi__threads(threads))
    for (long i = 0; i < n; i++) {
        const int valid = (vs->flags[i] & PGI_VS_VALID) != 0;
        for (int c = 0; c < 3; c++) {
            const size_t k = 3 * (size_t)i + (size_t)c;
            if (a->albedo) a->albedo[k] = valid ? vs->kd[k] : 0.f;
            if (a->normal) a->normal[k] = valid ? vs->nrm[k] : 0.f;
            if (a->indirect) a->indirect[k] = vs->weight[k] * indirect[k];
        }
        if (a->depth) a->depth[i] = vs->depth[i];
    }
}
