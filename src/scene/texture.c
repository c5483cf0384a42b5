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

/* Wraps a texel index of [-1, n] into [0, n) (coordinates are reduced to [0, 1] first, so
 * nothing farther out occurs; no division on this hot path). */
static inline int wrap_index(long i, int n) { return i < 0 ? (int)(i + n) : i >= n ? (int)(i - n) : (int)i; }

static inline const unsigned char *texel_at(const pgi__texture *t, int x, int y) {
    return t->rgba + 4 * ((size_t)y * (size_t)t->width + (size_t)x);
}

static inline pgi__v3 texel(const pgi__texture *t, int x, int y) {
    const unsigned char *p = texel_at(t, x, y);
    return v3(pgi__srgb8_texture_lut[p[0]], pgi__srgb8_texture_lut[p[1]], pgi__srgb8_texture_lut[p[2]]);
}

/* The 2x2 texels of a bilinear lookup at (u, v): columns x0, x1, rows y0, y1, and the weights
 * (tx, ty) of x1 and y1. NaN / Inf coordinates (degenerate UVs) read texel (0, 0)'s
 * neighbourhood instead of crashing. */
typedef struct footprint2x2 {
    int x0, x1, y0, y1;
    float tx, ty;
} footprint2x2;

static inline footprint2x2 bilinear_footprint(const pgi__texture *t, float u, float v) {
    if (!isfinite(u)) u = 0.f;
    if (!isfinite(v)) v = 0.f;
    /* Reduce to [0, 1) first so that huge tiling factors keep their precision in the fraction. */
    float fu = u - floorf(u);
    float fv = v - floorf(v);
    float x = fu * (float)t->width - 0.5f;
    float y = (1.f - fv) * (float)t->height - 0.5f; /* v = 0 is the bottom row */
    float x0f = floorf(x), y0f = floorf(y);
    footprint2x2 f;
    f.tx = x - x0f;
    f.ty = y - y0f;
    f.x0 = wrap_index((long)x0f, t->width);
    f.x1 = wrap_index((long)x0f + 1, t->width);
    f.y0 = wrap_index((long)y0f, t->height);
    f.y1 = wrap_index((long)y0f + 1, t->height);
    return f;
}

int pgi__texture_quad(const pgi__texture *t, float u, float v, pgi__texel_quad *q) {
    if (!t || !t->rgba || t->width <= 0 || t->height <= 0) return 0;
    footprint2x2 f = bilinear_footprint(t, u, v);
    q->row0 = texel_at(t, 0, f.y0);
    q->row1 = texel_at(t, 0, f.y1);
    q->x0 = 4 * f.x0;
    q->x1 = 4 * f.x1;
    q->tx = f.tx;
    q->ty = f.ty;
    __builtin_prefetch(q->row0 + q->x0);
    __builtin_prefetch(q->row1 + q->x0);
    return 1;
}

static inline pgi__v3 decode(const unsigned char *p) {
    return v3(pgi__srgb8_texture_lut[p[0]], pgi__srgb8_texture_lut[p[1]], pgi__srgb8_texture_lut[p[2]]);
}

/* The bilinear blend of pgi__texture_lookup (the same operations in the same order). */
static inline pgi__v3 blend(pgi__v3 a, pgi__v3 b, pgi__v3 c, pgi__v3 d, float tx, float ty) {
    pgi__v3 top = v3_add(v3_scale(a, 1.f - tx), v3_scale(b, tx));
    pgi__v3 bot = v3_add(v3_scale(c, 1.f - tx), v3_scale(d, tx));
    return v3_add(v3_scale(top, 1.f - ty), v3_scale(bot, ty));
}

pgi__v3 pgi__texture_quad_lookup(const pgi__texel_quad *q) {
    return blend(decode(q->row0 + q->x0), decode(q->row0 + q->x1), decode(q->row1 + q->x0), decode(q->row1 + q->x1),
                 q->tx, q->ty);
}

pgi__v3 pgi__texture_lookup(const pgi__texture *t, float u, float v) {
    if (!t || !t->rgba || t->width <= 0 || t->height <= 0) return v3(1.f, 1.f, 1.f);
    footprint2x2 f = bilinear_footprint(t, u, v);
    pgi__v3 a = texel(t, f.x0, f.y0), b = texel(t, f.x1, f.y0), c = texel(t, f.x0, f.y1), d = texel(t, f.x1, f.y1);
    return blend(a, b, c, d, f.tx, f.ty);
}

float pgi__texture_alpha(const pgi__texture *t, float u, float v) {
    if (!t || !t->rgba || t->width <= 0 || t->height <= 0) return 1.f;
    footprint2x2 f = bilinear_footprint(t, u, v);
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
    snprintf(nt->path, sizeof nt->path, "%s", path);
    *index = (int)s->ntexs++;
    return PGI_OK;
}
