/* Texture lookup: bilinear filtering, repeat (wrap) addressing, sRGB -> linear; the alpha
 * channel (cut-out masks) is linear and filtered alike.
 *
 * Texture coordinates follow the OBJ convention: v = 0 is the bottom of the
 * image, while the stored image has row 0 at the top, so rows are flipped.
 * Texel centres sit at half-integer positions (u = (x + 0.5) / width).
 * Texels are decoded with the sRGB table pgi__srgb8_texture_lut (src/core/srgb.c). */
#include "scene_internal.h"

#include <stdio.h>
#include <string.h>

#include "bsdf.h"
#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#include <immintrin.h> /* lookup_n_avx2 */
#endif

static inline const unsigned char *texel_at(const pgi__texture *t, int x, int y) {
    return t->rgba + 4 * ((size_t)y * (size_t)t->width + (size_t)x);
}

pgi__v3 pgi__texture_lookup(const pgi__texture *t, float u, float v) {
    if (!t || !t->rgba || t->width <= 0 || t->height <= 0) return v3(1.f, 1.f, 1.f);
    pgi__tex_footprint2x2 f = pgi__tex_bilinear_footprint(t, u, v);
    pgi__texel_quad q;
    pgi__tex_quad_at(t, &f, &q);
    return pgi__texture_quad_lookup(&q);
}

/* The body of pgi__texture_lookup_n, compiled once for the baseline and, on x86-64 with GCC or
 * clang, once more for SSE 4.1, where floorf is one instruction (roundss) instead of a sequence
 * of conversions and compares: floorf is exact either way, so both give the same bits. */
#define LOOKUP_N_BODY                                                                                                  \
    pgi__texel_quad q[PGI__TEXTURE_LOOKUP_N];                                                                          \
    int on[PGI__TEXTURE_LOOKUP_N];                                                                                     \
    for (int k = 0; k < n; k++) {                                                                                      \
        on[k] = t[k] && t[k]->rgba && t[k]->width > 0 && t[k]->height > 0;                                             \
        if (!on[k]) continue;                                                                                          \
        const pgi__tex_footprint2x2 f = pgi__tex_bilinear_footprint(t[k], u[k], v[k]);                                 \
        pgi__tex_quad_at(t[k], &f, &q[k]);                                                                             \
        __builtin_prefetch(q[k].p[0]);                                                                                 \
        __builtin_prefetch(q[k].p[3]);                                                                                 \
    }                                                                                                                  \
    for (int k = 0; k < n; k++) out[k] = on[k] ? pgi__texture_quad_lookup(&q[k]) : v3(1.f, 1.f, 1.f);

static void lookup_n_base(const pgi__texture *const *t, const float *u, const float *v, int n, pgi__v3 *out) {
    LOOKUP_N_BODY
}

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__)) && !defined(__SSE4_1__)
#define PGI__LOOKUP_SSE41 1
__attribute__((target("sse4.1"))) static void lookup_n_sse41(const pgi__texture *const *t, const float *u,
                                                             const float *v, int n, pgi__v3 *out) {
    LOOKUP_N_BODY
}
#endif

#if PGI__AVX2_TARGET
#define PGI__LOOKUP_AVX2 1
/* i wrapped into [0, n) as pgi__tex_wrap_index (i in [-1, n]). */
__attribute__((target("avx2"))) static inline __m256i wrap8(__m256i i, __m256i n) {
    const __m256i neg = _mm256_cmpgt_epi32(_mm256_setzero_si256(), i),
                  over = _mm256_cmpgt_epi32(i, _mm256_sub_epi32(n, _mm256_set1_epi32(1)));
    return _mm256_sub_epi32(_mm256_add_epi32(i, _mm256_and_si256(neg, n)), _mm256_and_si256(over, n));
}

/* Can the footprints of lookups on t be computed eight at a time (footprint8)? The addresses'
 * parts are 32-bit there. */
static inline int footprint8_ok(const pgi__texture *t) {
    return t && t->rgba && t->tiled && t->width > 0 && t->height > 0 &&
           (size_t)((t->width + 3) >> 2) * (size_t)((t->height + 3) >> 2) * 64 <= (size_t)INT32_MAX;
}

/* pgi__tex_bilinear_footprint's and pgi__tex_quad_at's operations on eight lookups (u, v) on t an instruction (floorf
 * as roundps, exact), so the same texels and weights: o[c] the byte offsets of texel c of each
 * lookup's quad in t->tiled, *tx and *ty its weights. t must pass footprint8_ok. */
__attribute__((target("avx2"))) static inline void footprint8(const pgi__texture *t, __m256 uf, __m256 vf, __m256i o[4],
                                                              __m256 *tx, __m256 *ty) {
    const __m256 inf = _mm256_set1_ps(INFINITY), absm = _mm256_castsi256_ps(_mm256_set1_epi32(0x7fffffff));
    uf = _mm256_and_ps(uf, _mm256_cmp_ps(_mm256_and_ps(uf, absm), inf, _CMP_LT_OQ)); /* !isfinite: 0 */
    vf = _mm256_and_ps(vf, _mm256_cmp_ps(_mm256_and_ps(vf, absm), inf, _CMP_LT_OQ));
    const __m256 fu = _mm256_sub_ps(uf, _mm256_floor_ps(uf)), fv = _mm256_sub_ps(vf, _mm256_floor_ps(vf));
    const __m256 half = _mm256_set1_ps(0.5f);
    const __m256 x = _mm256_sub_ps(_mm256_mul_ps(fu, _mm256_set1_ps((float)t->width)), half);
    const __m256 y =
        _mm256_sub_ps(_mm256_mul_ps(_mm256_sub_ps(_mm256_set1_ps(1.f), fv), _mm256_set1_ps((float)t->height)), half);
    const __m256 x0f = _mm256_floor_ps(x), y0f = _mm256_floor_ps(y);
    *tx = _mm256_sub_ps(x, x0f);
    *ty = _mm256_sub_ps(y, y0f);
    const __m256i W = _mm256_set1_epi32(t->width), H = _mm256_set1_epi32(t->height), one = _mm256_set1_epi32(1);
    const __m256i three = _mm256_set1_epi32(3);
    const __m256i xi = _mm256_cvttps_epi32(x0f), yi = _mm256_cvttps_epi32(y0f);
    const __m256i x0 = wrap8(xi, W), x1 = wrap8(_mm256_add_epi32(xi, one), W);
    const __m256i y0 = wrap8(yi, H), y1 = wrap8(_mm256_add_epi32(yi, one), H);
    /* pgi__tex_quad_at: rows 64 ((y >> 2) bw) + 16 (y & 3), columns 64 (x >> 2) + 4 (x & 3) */
    const __m256i bw = _mm256_set1_epi32((t->width + 3) >> 2);
#define ROW8(y)                                                                                                        \
    _mm256_add_epi32(_mm256_slli_epi32(_mm256_mullo_epi32(_mm256_srai_epi32(y, 2), bw), 6),                            \
                     _mm256_slli_epi32(_mm256_and_si256(y, three), 4))
#define COL8(x)                                                                                                        \
    _mm256_add_epi32(_mm256_slli_epi32(_mm256_srai_epi32(x, 2), 6), _mm256_slli_epi32(_mm256_and_si256(x, three), 2))
    const __m256i r0 = ROW8(y0), r1 = ROW8(y1), c0 = COL8(x0), c1 = COL8(x1);
#undef ROW8
#undef COL8
    o[0] = _mm256_add_epi32(r0, c0);
    o[1] = _mm256_add_epi32(r0, c1);
    o[2] = _mm256_add_epi32(r1, c0);
    o[3] = _mm256_add_epi32(r1, c1);
}

/* LOOKUP_N_BODY with the footprints of eight lookups on one texture (nearly always: the lanes of
 * a view packet mostly share a material) an instruction (footprint8); other lookups one by one. */
__attribute__((target("avx2"))) static void lookup_n_avx2(const pgi__texture *const *t, const float *u, const float *v,
                                                          int n, pgi__v3 *out) {
    pgi__texel_quad q[PGI__TEXTURE_LOOKUP_N];
    int on[PGI__TEXTURE_LOOKUP_N];
    for (int k0 = 0; k0 < n; k0 += 8) {
        const int m = n - k0 < 8 ? n - k0 : 8;
        const pgi__texture *t0 = t[k0];
        int same = footprint8_ok(t0);
        for (int k = k0 + 1; same && k < k0 + m; k++) same = t[k] == t0;
        if (!same) {
            for (int k = k0; k < k0 + m; k++) {
                on[k] = t[k] && t[k]->rgba && t[k]->width > 0 && t[k]->height > 0;
                if (!on[k]) continue;
                const pgi__tex_footprint2x2 f = pgi__tex_bilinear_footprint(t[k], u[k], v[k]);
                pgi__tex_quad_at(t[k], &f, &q[k]);
                __builtin_prefetch(q[k].p[0]);
                __builtin_prefetch(q[k].p[3]);
            }
            continue;
        }
        float uu[8] = {0}, vv[8] = {0};
        memcpy(uu, u + k0, (size_t)m * sizeof(float));
        memcpy(vv, v + k0, (size_t)m * sizeof(float));
        __m256i ov[4];
        __m256 txv, tyv;
        footprint8(t0, _mm256_loadu_ps(uu), _mm256_loadu_ps(vv), ov, &txv, &tyv);
        float tx[8], ty[8];
        _mm256_storeu_ps(tx, txv);
        _mm256_storeu_ps(ty, tyv);
        int32_t o[4][8];
        for (int c = 0; c < 4; c++) _mm256_storeu_si256((__m256i *)o[c], ov[c]);
        for (int i = 0; i < m; i++) {
            pgi__texel_quad *qk = &q[k0 + i];
            on[k0 + i] = 1;
            for (int c = 0; c < 4; c++) qk->p[c] = t0->tiled + o[c][i];
            qk->tx = tx[i];
            qk->ty = ty[i];
            __builtin_prefetch(qk->p[0]);
            __builtin_prefetch(qk->p[3]);
        }
    }
    for (int k = 0; k < n; k++) out[k] = on[k] ? pgi__texture_quad_lookup(&q[k]) : v3(1.f, 1.f, 1.f);
}
#endif

#ifdef PGI__LOOKUP_AVX2
/* pgi__texture_quads16's footprints (footprint8) of 16 lookups: offsets and weights stored, two
 * texels of each quad (its corners, which lie in the lines of the other two unless the quad
 * straddles a block on both axes) requested. */
__attribute__((target("avx2"))) static void quads16_avx2(const pgi__texture *t, const float *u, const float *v,
                                                         pgi__texel_quads16 *q) {
    for (int h = 0; h < 16; h += 8) {
        __m256i o[4];
        __m256 tx, ty;
        footprint8(t, _mm256_loadu_ps(u + h), _mm256_loadu_ps(v + h), o, &tx, &ty);
        for (int c = 0; c < 4; c++) _mm256_storeu_si256((__m256i *)(void *)(q->o[c] + h), o[c]);
        _mm256_storeu_ps(q->tx + h, tx);
        _mm256_storeu_ps(q->ty + h, ty);
    }
    for (int k = 0; k < 16; k++) {
        __builtin_prefetch(t->tiled + q->o[0][k]);
        __builtin_prefetch(t->tiled + q->o[3][k]);
    }
}

/* pgi__texture_quads16_lookup eight lanes an instruction: the quads' texels and their sRGB
 * decoding by gathers, then pgi__texture_quad_lookup's operations in its order (no FMA: -ffp-contract=off),
 * so the same bits. */
__attribute__((target("avx2"))) static void quads16_lookup_avx2(const pgi__texture *t, const pgi__texel_quads16 *q,
                                                                float out[3][16]) {
    const __m256i byte = _mm256_set1_epi32(0xff);
    const __m256 one = _mm256_set1_ps(1.f);
    __m256i g[2][4]; /* every texel requested before any is decoded: their cache misses overlap */
    for (int h = 0; h < 2; h++)
        for (int c = 0; c < 4; c++)
            g[h][c] = _mm256_i32gather_epi32((const int *)(const void *)t->tiled,
                                             _mm256_loadu_si256((const __m256i *)(const void *)(q->o[c] + 8 * h)), 1);
    for (int h = 0; h < 2; h++) {
        const __m256 tx = _mm256_loadu_ps(q->tx + 8 * h), ty = _mm256_loadu_ps(q->ty + 8 * h);
        const __m256 sx = _mm256_sub_ps(one, tx), sy = _mm256_sub_ps(one, ty);
        for (int ch = 0; ch < 3; ch++) {
            __m256 d[4];
            for (int c = 0; c < 4; c++)
                d[c] = _mm256_i32gather_ps(pgi__srgb8_texture_lut,
                                           _mm256_and_si256(_mm256_srli_epi32(g[h][c], 8 * ch), byte), 4);
            const __m256 top = _mm256_add_ps(_mm256_mul_ps(d[0], sx), _mm256_mul_ps(d[1], tx));
            const __m256 bot = _mm256_add_ps(_mm256_mul_ps(d[2], sx), _mm256_mul_ps(d[3], tx));
            _mm256_storeu_ps(out[ch] + 8 * h, _mm256_add_ps(_mm256_mul_ps(top, sy), _mm256_mul_ps(bot, ty)));
        }
    }
}

/* The table pgi__srgb8_texture_lut at 16 indices (0..255) from registers: lut[2j], lut[2j+1] hold
 * entries 32 j .. 32 j + 31, one two-register permute picks by the index's low five bits, its top
 * three bits pick the permute. */
__attribute__((target("avx2,avx512f"))) static inline __m512 srgb_decode16(__m512i idx, const __m512 lut[16]) {
    const __m512i hi = _mm512_srli_epi32(idx, 5);
    __m512 r = _mm512_permutex2var_ps(lut[0], idx, lut[1]);
    for (int j = 1; j < 8; j++)
        r = _mm512_mask_mov_ps(r, _mm512_cmpeq_epi32_mask(hi, _mm512_set1_epi32(j)),
                               _mm512_permutex2var_ps(lut[2 * j], idx, lut[2 * j + 1]));
    return r;
}

/* quads16_lookup_avx2 with 16 lanes a register: 16-wide gathers of the texels, their decoding by
 * permutes of the table held in registers instead of gathers from it; the same bits. */
__attribute__((target("avx2,avx512f"))) static void
quads16_lookup_avx512(const pgi__texture *t, const pgi__texel_quads16 *q, float out[3][16]) {
    __m512i g[4];
    for (int c = 0; c < 4; c++)
        g[c] = _mm512_i32gather_epi32(_mm512_loadu_si512((const void *)q->o[c]), (const void *)t->tiled, 1);
    __m512 lut[16];
    for (int j = 0; j < 16; j++) lut[j] = _mm512_loadu_ps(pgi__srgb8_texture_lut + 16 * j);
    const __m512 tx = _mm512_loadu_ps(q->tx), ty = _mm512_loadu_ps(q->ty);
    const __m512 one = _mm512_set1_ps(1.f), sx = _mm512_sub_ps(one, tx), sy = _mm512_sub_ps(one, ty);
    const __m512i byte = _mm512_set1_epi32(0xff);
    for (int ch = 0; ch < 3; ch++) {
        __m512 d[4];
        for (int c = 0; c < 4; c++) d[c] = srgb_decode16(_mm512_and_si512(_mm512_srli_epi32(g[c], 8 * ch), byte), lut);
        const __m512 top = _mm512_add_ps(_mm512_mul_ps(d[0], sx), _mm512_mul_ps(d[1], tx));
        const __m512 bot = _mm512_add_ps(_mm512_mul_ps(d[2], sx), _mm512_mul_ps(d[3], tx));
        _mm512_storeu_ps(out[ch], _mm512_add_ps(_mm512_mul_ps(top, sy), _mm512_mul_ps(bot, ty)));
    }
}
#endif

int pgi__texture_quads16(const pgi__texture *t, const float *u, const float *v, pgi__texel_quads16 *q) {
#ifdef PGI__LOOKUP_AVX2
    if (pgi__cpu_avx2() && footprint8_ok(t)) {
        quads16_avx2(t, u, v, q);
        return 1;
    }
#endif
    (void)t, (void)u, (void)v, (void)q;
    return 0;
}

void pgi__texture_quads16_lookup(const pgi__texture *t, const pgi__texel_quads16 *q, float out[3][16]) {
#ifdef PGI__LOOKUP_AVX2
    if (pgi__cpu_avx512()) quads16_lookup_avx512(t, q, out);
    else quads16_lookup_avx2(t, q, out);
#else
    (void)t, (void)q, (void)out;
#endif
}

void pgi__texture_lookup16_soa(const pgi__texture *t, const float *u, const float *v, float out[3][16]) {
    pgi__texel_quads16 q;
    if (pgi__texture_quads16(t, u, v, &q)) {
        pgi__texture_quads16_lookup(t, &q, out);
        return;
    }
    const pgi__texture *ts[16];
    pgi__v3 c[16];
    for (int k = 0; k < 16; k++) ts[k] = t;
    pgi__texture_lookup_n(ts, u, v, 16, c);
    for (int k = 0; k < 16; k++) out[0][k] = c[k].x, out[1][k] = c[k].y, out[2][k] = c[k].z;
}

void pgi__texture_lookup_n(const pgi__texture *const *t, const float *u, const float *v, int n, pgi__v3 *out) {
#ifdef PGI__LOOKUP_AVX2
    if (pgi__cpu_avx2()) {
        lookup_n_avx2(t, u, v, n, out);
        return;
    }
#endif
#ifdef PGI__LOOKUP_SSE41
    if (__builtin_cpu_supports("sse4.1")) { /* a load and a test (libgcc sets the flags at start-up) */
        lookup_n_sse41(t, u, v, n, out);
        return;
    }
#endif
    lookup_n_base(t, u, v, n, out);
}

pgi__v3 pgi__texture_lookup_level(const pgi__texture *t, float u, float v, int l) {
    if (!t || !t->rgba || t->width <= 0 || t->height <= 0) return v3(1.f, 1.f, 1.f);
    if (l <= 0 || l >= t->levels || !t->mip[l]) return pgi__texture_lookup(t, u, v);
    const int w = t->width >> l > 0 ? t->width >> l : 1, h = t->height >> l > 0 ? t->height >> l : 1;
    const pgi__tex_footprint2x2 f = pgi__tex_bilinear_footprint_wh(w, h, u, v);
    const unsigned char *px = t->mip[l];
    const size_t r0 = 4 * (size_t)f.y0 * (size_t)w, r1 = 4 * (size_t)f.y1 * (size_t)w;
    return pgi__tex_blend(pgi__tex_decode(px + r0 + 4 * (size_t)f.x0), pgi__tex_decode(px + r0 + 4 * (size_t)f.x1),
                          pgi__tex_decode(px + r1 + 4 * (size_t)f.x0), pgi__tex_decode(px + r1 + 4 * (size_t)f.x1),
                          f.tx, f.ty);
}

pgi__v3 pgi__texture_lookup_lod(const pgi__texture *t, float u, float v, float lod) {
    if (!t || !t->rgba || t->width <= 0 || t->height <= 0) return v3(1.f, 1.f, 1.f);
    if (!(lod > 0.f) || t->levels <= 1) return pgi__texture_lookup(t, u, v);
    const float top = (float)(t->levels - 1);
    if (lod >= top) return pgi__texture_lookup_level(t, u, v, t->levels - 1);
    const int l = (int)lod;
    const float f = lod - (float)l;
    const pgi__v3 a = pgi__texture_lookup_level(t, u, v, l), b = pgi__texture_lookup_level(t, u, v, l + 1);
    return v3_add(v3_scale(a, 1.f - f), v3_scale(b, f));
}

/* The 8-bit sRGB code whose decoding is nearest linear value x (the table is increasing). */
static unsigned char srgb8_nearest(float x) {
    int lo = 0, hi = 255;
    while (lo < hi) { /* the first code decoding to x or more */
        const int mid = (lo + hi) / 2;
        if (pgi__srgb8_texture_lut[mid] < x) lo = mid + 1;
        else hi = mid;
    }
    if (lo > 0 && x - pgi__srgb8_texture_lut[lo - 1] <= pgi__srgb8_texture_lut[lo] - x) lo--;
    return (unsigned char)lo;
}

/* t's mip levels (pgi__texture.mip) from its level 0; levels stays 1 without memory for them. */
static void build_mips(pgi__texture *t) {
    t->levels = 1;
    t->lod_bias = 0.5f * log2f((float)t->width * (float)t->height);
    if (t->width <= 0 || t->height <= 0 || !t->rgba) return;
    int n = 1;
    while ((t->width >> n) > 0 || (t->height >> n) > 0) n++;
    if (n > PGI__MIP_LEVELS) n = PGI__MIP_LEVELS;
    int sw = t->width, sh = t->height;
    const unsigned char *src = t->rgba;
    for (int l = 1; l < n; l++) {
        const int w = sw / 2 > 0 ? sw / 2 : 1, h = sh / 2 > 0 ? sh / 2 : 1;
        unsigned char *dst = malloc((size_t)w * (size_t)h * 4);
        if (!dst) { /* no levels at all: the lookups read level 0 */
            for (int k = 1; k < l; k++) free(t->mip[k]), t->mip[k] = NULL;
            return;
        }
        for (int y = 0; y < h; y++) {
            const int ya = 2 * y < sh ? 2 * y : sh - 1, yb = 2 * y + 1 < sh ? 2 * y + 1 : sh - 1;
            for (int x = 0; x < w; x++) {
                const int xa = 2 * x < sw ? 2 * x : sw - 1, xb = 2 * x + 1 < sw ? 2 * x + 1 : sw - 1;
                const unsigned char *p[4] = {src + 4 * ((size_t)ya * (size_t)sw + (size_t)xa),
                                             src + 4 * ((size_t)ya * (size_t)sw + (size_t)xb),
                                             src + 4 * ((size_t)yb * (size_t)sw + (size_t)xa),
                                             src + 4 * ((size_t)yb * (size_t)sw + (size_t)xb)};
                unsigned char *o = dst + 4 * ((size_t)y * (size_t)w + (size_t)x);
                for (int c = 0; c < 3; c++)
                    o[c] = srgb8_nearest(0.25f * (pgi__srgb8_texture_lut[p[0][c]] + pgi__srgb8_texture_lut[p[1][c]] +
                                                  pgi__srgb8_texture_lut[p[2][c]] + pgi__srgb8_texture_lut[p[3][c]]));
                o[3] = (unsigned char)(((unsigned)p[0][3] + p[1][3] + p[2][3] + p[3][3] + 2) / 4);
            }
        }
        t->mip[l] = dst;
        src = dst;
        sw = w;
        sh = h;
    }
    t->levels = n;
}

size_t pgi__texture_mip_bytes(const pgi__texture *t) {
    size_t b = 0;
    for (int l = 1; l < t->levels; l++) {
        const int w = t->width >> l > 0 ? t->width >> l : 1, h = t->height >> l > 0 ? t->height >> l : 1;
        if (t->mip[l]) b += (size_t)w * (size_t)h * 4;
    }
    return b;
}

void pgi__texture_free(pgi__texture *t) {
    free(t->rgba);
    pgi__afree(t->tiled);
    for (int l = 1; l < PGI__MIP_LEVELS; l++) free(t->mip[l]);
}

float pgi__texture_alpha(const pgi__texture *t, float u, float v) {
    if (!t || !t->rgba || t->width <= 0 || t->height <= 0) return 1.f;
    pgi__tex_footprint2x2 f = pgi__tex_bilinear_footprint(t, u, v);
    float a = texel_at(t, f.x0, f.y0)[3], b = texel_at(t, f.x1, f.y0)[3];
    float c = texel_at(t, f.x0, f.y1)[3], d = texel_at(t, f.x1, f.y1)[3];
    float top = a + (b - a) * f.tx, bot = c + (d - c) * f.tx;
    return (top + (bot - top) * f.ty) * (1.f / 255.f);
}

int pgi__scene_cut_out(const pgi_scene *s, uint32_t tri, float b1, float b2) {
    const pgi__material *m = &s->mats[s->tri_mat[tri]];
    if (!pgi__mat_masked(m)) return 0;
    float alpha = 1.f;
    if (m->tex_alpha >= 0) {
        float u = 0.f, v = 0.f;
        if (s->uv) pgi__scene_uv(s, tri, b1, b2, &u, &v);
        alpha = pgi__texture_alpha(&s->texs[m->tex_alpha], u, v);
    }
    return alpha < m->alpha_cutoff;
}

pgi_status pgi__scene_add_texture(pgi_scene *s, int w, int h, int channels, unsigned char *rgba, const char *path,
                                  int *index) {
    pgi__texture *t = realloc(s->texs, (s->ntexs + 1) * sizeof *t);
    if (!t) {
        free(rgba);
        return pgi__fail(PGI_ERR_OOM, "out of memory for texture '%s'", path);
    }
    s->texs = t;
    pgi__texture *nt = &s->texs[s->ntexs];
    memset(nt, 0, sizeof *nt);
    nt->width = w;
    nt->height = h;
    nt->channels = channels;
    nt->rgba = rgba; /* stbi allocates with malloc: pgi_scene_destroy frees it with free() */
    const int bw = (w + 3) / 4, bh = (h + 3) / 4;
    nt->tiled = w > 0 && h > 0 ? pgi__aalloc((size_t)bw * (size_t)bh * 64) : NULL;
    if (nt->tiled) { /* the lookups fall back on rgba without it */
        memset(nt->tiled, 0, (size_t)bw * (size_t)bh * 64);
        for (int y = 0; y < h; y++)
            for (int x = 0; x < w; x++)
                memcpy(nt->tiled + 64 * ((size_t)(y >> 2) * (size_t)bw + (size_t)(x >> 2)) +
                           4 * (4 * (y & 3) + (x & 3)),
                       rgba + 4 * ((size_t)y * (size_t)w + (size_t)x), 4);
    }
    build_mips(nt);
    snprintf(nt->path, sizeof nt->path, "%s", path);
    *index = (int)s->ntexs++;
    return PGI_OK;
}

void pgi__texture_grey_alpha(pgi__texture *t) {
    if (t->channels != 1 && t->channels != 3) return;
    size_t n = (size_t)t->width * (size_t)t->height;
    for (size_t i = 0; i < n; i++) {
        unsigned char *p = t->rgba + 4 * i;
        p[3] = (unsigned char)(((unsigned)p[0] + p[1] + p[2] + 1) / 3);
    }
}
