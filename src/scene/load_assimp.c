/* Mesh import through Assimp's C API (OBJ/MTL, glTF, PLY, ...).
 *
 * The file is imported with Triangulate | JoinIdenticalVertices |
 * SortByPType | PreTransformVertices: every mesh ends up in world space, and
 * point and line primitives land in meshes of their own (and are skipped
 * here). Geometry, materials and textures are appended to the scene.
 *
 * Normals: a mesh's own normals are kept. A mesh without them gets normals
 * here, never from Assimp: its GenNormals and GenSmoothNormals (5.2) store
 * each triangle's normal into the triangle's vertices, so a vertex shared by
 * several triangles, as PLY and glTF files store them, keeps the normal of
 * the last one (10.8 degrees off on an icosphere), while an OBJ, whose
 * corners the importer keeps apart, comes out flat. Here, per corner:
 *   glTF (.gltf, .glb)                      -> flat: the face normal (the glTF
 *                                              spec's rule for missing normals)
 *   OBJ whose `s` statements are all off    -> flat
 *   otherwise (PLY, OBJ with `s 1` or none) -> smooth: the mean of the face
 *     normals around the vertex, weighted by the triangles' corner angles
 *     there (independent of how the surface is triangulated), over the
 *     triangles whose normal is within k_smooth_max_deg of this corner's
 *     triangle (a cube stays a cube). Vertices at the same position count as
 *     one (UV seams do not crease); corners of one vertex that end up with
 *     different normals get vertices of their own.
 * The OBJ and the PLY of one normal-less mesh therefore get the same normals.
 *
 * Material mapping (Wavefront MTL names; Assimp 5.2 keeps the raw MTL
 * `illum` number as the integer property "$mat.illum", and a derived
 * aiShadingMode in AI_MATKEY_SHADING_MODEL):
 *   illum 4, 6, 7 or 9, or opacity d < 1     -> glass, ior = Ni (1.5 if Ni <= 1), ks = 1
 *     (d < 1 without map_d; with one, d scales the cut-out's alpha)
 *   illum 3 or 5, max(Kd) < 0.01, max(Ks) > 0 -> mirror, ks = Ks
 *   max(Ks) > 0 and Ns > 1                    -> Phong, ks = Ks (F0), s = Ns in [1, 10000],
 *                                                kd scaled so that kd + ks <= 1
 *   otherwise                                 -> Lambert
 * kd = Kd clamped to [0, 1]; ke = Ke. map_Kd is loaded (8-bit sRGB) relative
 * to the mesh file's folder; with a texture, kd is the multiplier, or 1 when
 * Kd is black or absent.
 *
 * Cut-outs (pgi__material.alpha_cutoff): a map_d texture (its alpha channel, or its grey value
 * when it has none) times d, or for glTF alphaMode MASK the base colour texture's alpha times
 * the base colour factor's alpha; the surface is cut out where that is below 0.5 (MTL) or
 * alphaCutoff (glTF). glTF BLEND is not a cut-out (opacity < 1 is glass, as for MTL d).
 *
 * Vertex colours (Assimp's first colour set, mColors[0]: a glTF's COLOR_0, a PLY's red green
 * blue, an OBJ's `v x y z r g b`, ...) multiply the diffuse albedo kd at each hit (before its
 * texture), interpolated across the triangle (pgi__scene_kd). A glTF's are linear (the glTF
 * spec); every other format's are taken as sRGB-encoded, as the 8-bit colours of PLY files and
 * the tools that write OBJ colours are, and decoded to linear (vertex_colour). RGB only, clamped
 * to [0, 1]; alpha is not used. A material the file does not define (PLY has none; Assimp's
 * DefaultMaterial for OBJ faces without one) whose meshes all have colours is white rather than
 * its grey 0.6, so that the colours are the base colour; a defined one's colour multiplies them
 * (glTF's baseColorFactor x COLOR_0). Meshes without colours in a file or scene where others
 * have them are white (1, 1, 1): they render as before. */
#define _DEFAULT_SOURCE /* realpath */
#include "scene_internal.h"

#include "core/mem.h"
#include "io/io_internal.h"

#include <assimp/cfileio.h>
#include <assimp/cimport.h>
#include <assimp/material.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>
#include <stb_image.h>

#include <errno.h>
#include <limits.h>
#include <pthread.h>
#include <stdio.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>

/* Copies with truncation (names longer than the field are cut). */
static void copy_str(char *dst, size_t n, const char *src) {
    size_t k = strlen(src);
    if (k >= n) k = n - 1;
    memcpy(dst, src, k);
    dst[k] = 0;
}

static float clamp01(float x) { return x > 0.f ? (x < 1.f ? x : 1.f) : 0.f; } /* NaN -> 0 */
static float max3(const float *c) { return fmaxf(c[0], fmaxf(c[1], c[2])); }

/* A vertex colour channel as the scene stores it: clamped to [0, 1], and decoded from sRGB unless
 * `linear` (glTF). An 8-bit value c / 255 (what Assimp makes of a PLY's uchar colours) decodes to
 * exactly what an 8-bit texel of that value does (pgi__srgb8_texture_lut). */
static float vertex_colour(float c, int linear) {
    c = clamp01(c);
    if (linear) return c;
    const long i = lroundf(c * 255.f);
    return (float)i / 255.f == c ? pgi__srgb8_texture_lut[i] : (float)pgi__srgb_to_linear((double)c);
}

static int get_color(const struct aiMaterial *m, const char *key, unsigned type, unsigned idx, float out[3]) {
    struct aiColor4D c;
    if (aiGetMaterialColor(m, key, type, idx, &c) != AI_SUCCESS) return 0;
    out[0] = c.r;
    out[1] = c.g;
    out[2] = c.b;
    return 1;
}

static int get_float(const struct aiMaterial *m, const char *key, unsigned type, unsigned idx, float *out) {
    ai_real v;
    unsigned int n = 1;
    if (aiGetMaterialFloatArray(m, key, type, idx, &v, &n) != AI_SUCCESS || n < 1) return 0;
    *out = (float)v;
    return 1;
}

static int get_int(const struct aiMaterial *m, const char *key, unsigned type, unsigned idx, int *out) {
    int v;
    unsigned int n = 1;
    if (aiGetMaterialIntegerArray(m, key, type, idx, &v, &n) != AI_SUCCESS || n < 1) return 0;
    *out = v;
    return 1;
}

/* Texture bookkeeping for one import: resolved path -> scene texture index. */
typedef struct tex_cache {
    const char *mesh_path;
    char dir[1024];         /* the mesh file's folder with a trailing '/', or "" */
    size_t first;           /* scene textures added by this import start here */
    int ply;                /* a PLY file (no materials of its own) */
    pgi__mesh_hints *hints; /* missing_tex: the texture files that are not there */
} tex_cache;

/* A texture's error (which names the texture) prefixed with the mesh and the material. */
static pgi_status texture_fail(pgi_status st, const tex_cache *tc, const char *mat_name) {
    char why[512];
    snprintf(why, sizeof why, "%s", pgi_last_error());
    return pgi__fail(st, "%s: material '%s': %s", tc->mesh_path, mat_name, why);
}

/* A texture of w x h is counted against the load's memory budget before it is decoded: its
 * RGBA8 texels and their copy in 4x4 blocks (docs/memory.md), on top of the scene's textures. */
static pgi_status texture_budget(const pgi_scene *s, const tex_cache *tc, const char *mat_name, const char *file, int w,
                                 int h, uint64_t budget) {
    if (!budget) return PGI_OK;
    size_t scene_bytes, tex_bytes;
    pgi__scene_memory(s, &scene_bytes, &tex_bytes);
    const uint64_t need = (uint64_t)w * (uint64_t)h * 4u + (uint64_t)((w + 3) / 4) * (uint64_t)((h + 3) / 4) * 64u;
    if ((uint64_t)scene_bytes + tex_bytes + need <= budget) return PGI_OK;
    char a[32], b[32], c[32];
    return pgi__fail(PGI_ERR_OOM,
                     "%s: material '%s': texture '%s' (%dx%d) needs %s, with the scene's %s over the memory budget "
                     "of %s",
                     tc->mesh_path, mat_name, file, w, h, pgi__mem_format(need, a, sizeof a),
                     pgi__mem_format((uint64_t)scene_bytes + tex_bytes, b, sizeof b),
                     pgi__mem_format(budget, c, sizeof c));
}

static pgi_status load_texture(pgi_scene *s, tex_cache *tc, const struct aiScene *sc, const char *mat_name,
                               const char *file, int *index) {
    char resolved[sizeof((pgi__texture *)0)
                      ->path]; /* same size as the stored path, so deduplication compares whole paths */
    /* Embedded texture ("*N", glTF/GLB): decode from memory. */
    if (file[0] == '*') {
        char *end;
        long k = strtol(file + 1, &end, 10);
        if (*end || k < 0 || (unsigned long)k >= sc->mNumTextures)
            return pgi__fail(PGI_ERR_PARSE, "%s: material '%s': bad embedded texture reference '%s'", tc->mesh_path,
                             mat_name, file);
        int rl = snprintf(resolved, sizeof resolved, "%s%s", tc->mesh_path, file);
        if (rl < 0 || (size_t)rl >= sizeof resolved)
            return pgi__fail(PGI_ERR_IO, "%s: material '%s': path too long", tc->mesh_path, mat_name);
        for (size_t i = tc->first; i < s->ntexs; i++)
            if (strcmp(s->texs[i].path, resolved) == 0) return *index = (int)i, PGI_OK;
        const struct aiTexture *at = sc->mTextures[k];
        int w, h, n;
        unsigned char *rgba;
        if (at->mHeight == 0) {
            /* The header's size first: a few bytes can declare gigabytes of pixels. */
            if (!stbi_info_from_memory((const unsigned char *)at->pcData, (int)at->mWidth, &w, &h, &n))
                return pgi__fail(PGI_ERR_IO, "%s: material '%s': cannot read texture '%s': %s", tc->mesh_path, mat_name,
                                 resolved, stbi_failure_reason());
            pgi_status st = pgi__check_image_size(resolved, w, h);
            if (!st) st = texture_budget(s, tc, mat_name, resolved, w, h, pgi__scene_load_budget());
            if (st) return st;
            if ((st = pgi__hdr_check(resolved, NULL, at->pcData, at->mWidth))) return texture_fail(st, tc, mat_name);
            rgba = stbi_load_from_memory((const unsigned char *)at->pcData, (int)at->mWidth, &w, &h, &n, 4);
            if (!rgba)
                return pgi__fail(PGI_ERR_IO, "%s: material '%s': cannot read texture '%s': %s", tc->mesh_path, mat_name,
                                 resolved, stbi_failure_reason());
        } else {
            pgi_status st = pgi__check_image_size(resolved, at->mWidth, at->mHeight);
            if (!st)
                st = texture_budget(s, tc, mat_name, resolved, (int)at->mWidth, (int)at->mHeight,
                                    pgi__scene_load_budget());
            if (st) return st;
            w = (int)at->mWidth;
            h = (int)at->mHeight;
            n = 4; /* raw aiTexel ARGB8888 */
            rgba = malloc((size_t)w * (size_t)h * 4);
            if (!rgba) return pgi__fail(PGI_ERR_OOM, "%s: out of memory for texture '%s'", tc->mesh_path, resolved);
            for (size_t i = 0; i < (size_t)w * (size_t)h; i++) {
                rgba[4 * i + 0] = at->pcData[i].r;
                rgba[4 * i + 1] = at->pcData[i].g;
                rgba[4 * i + 2] = at->pcData[i].b;
                rgba[4 * i + 3] = at->pcData[i].a;
            }
        }
        return pgi__scene_add_texture(s, w, h, n, rgba, resolved, index);
    }

    char norm[1024];
    snprintf(norm, sizeof norm, "%s", file);
    /* Backslashes (Windows exporters) become '/', and repeated separators collapse. */
    size_t nw = 0;
    for (size_t r = 0; norm[r]; r++) {
        char c = norm[r] == '\\' ? '/' : norm[r];
        if (c == '/' && nw > 0 && norm[nw - 1] == '/') continue;
        norm[nw++] = c;
    }
    norm[nw] = 0;
    const char *rel = norm;
    while (rel[0] == '.' && rel[1] == '/') rel += 2;
    int len = rel[0] == '/' ? snprintf(resolved, sizeof resolved, "%s", rel)
                            : snprintf(resolved, sizeof resolved, "%s%s", tc->dir, rel);
    if (len < 0 || (size_t)len >= sizeof resolved)
        return pgi__fail(PGI_ERR_IO, "%s: material '%s': texture path '%s' is too long", tc->mesh_path, mat_name, file);
    for (size_t i = tc->first; i < s->ntexs; i++)
        if (strcmp(s->texs[i].path, resolved) == 0) return *index = (int)i, PGI_OK;
    /* One decode a file, however it is named ("a/../t.png", links): by its canonical path. */
    char canon[PATH_MAX];
    if (realpath(resolved, canon) && strlen(canon) < sizeof s->texs[0].canon)
        for (size_t i = tc->first; i < s->ntexs; i++)
            if (strcmp(s->texs[i].canon, canon) == 0) return *index = (int)i, PGI_OK;
    /* A texture file that is not there is named in the load's warning, and its material keeps its
       colour (a scene from elsewhere often misses one); one that is there and cannot be read fails. */
    struct stat sb;
    if (stat(resolved, &sb) != 0 && errno == ENOENT) {
        if (!strstr(tc->hints->missing_tex, resolved))
            pgi__list_append(tc->hints->missing_tex, sizeof tc->hints->missing_tex, resolved);
        *index = -1;
        return PGI_OK;
    }
    int w, h, n;
    const char *why;
    const uint64_t budget = pgi__scene_load_budget();
    FILE *f = pgi__fopen_input(resolved, budget, NULL, &why);
    if (!f)
        return pgi__fail(PGI_ERR_IO, "%s: material '%s': cannot read texture '%s': %s", tc->mesh_path, mat_name,
                         resolved, why);
    if (!stbi_info_from_file(f, &w, &h, &n)) {
        fclose(f);
        return pgi__fail(PGI_ERR_IO, "%s: material '%s': cannot read texture '%s': %s", tc->mesh_path, mat_name,
                         resolved, stbi_failure_reason());
    }
    pgi_status st = pgi__check_image_size(resolved, w, h);
    if (!st) st = texture_budget(s, tc, mat_name, resolved, w, h, budget);
    if (!st) st = pgi__hdr_check(resolved, f, NULL, 0);
    unsigned char *rgba = st ? NULL : stbi_load_from_file(f, &w, &h, &n, 4);
    fclose(f);
    if (st) return st == PGI_ERR_OOM ? st : texture_fail(st, tc, mat_name);
    if (!rgba)
        return pgi__fail(PGI_ERR_IO, "%s: material '%s': cannot read texture '%s': %s", tc->mesh_path, mat_name,
                         resolved, stbi_failure_reason());
    st = pgi__scene_add_texture(s, w, h, n, rgba, resolved, index);
    if (!st && strlen(canon) < sizeof s->texs[0].canon)
        snprintf(s->texs[*index].canon, sizeof s->texs[0].canon, "%s", canon);
    return st;
}

static pgi_status convert_material(pgi_scene *s, tex_cache *tc, const struct aiScene *sc, const struct aiMaterial *am,
                                   pgi__material *m) {
    memset(m, 0, sizeof *m);
    m->tex_kd = -1;
    m->tex_alpha = -1;
    struct aiString name;
    if (aiGetMaterialString(am, AI_MATKEY_NAME, &name) == AI_SUCCESS) {
        copy_str(m->name, sizeof m->name, name.data);
    } else if (tc->ply) {
        /* PLY has no materials; Assimp makes one up (kd = ks = 1). Give it what OBJ faces
         * without `usemtl` get (Assimp's DefaultMaterial, Lambert kd 0.6), so that one mesh
         * renders alike from both formats. */
        snprintf(m->name, sizeof m->name, "DefaultMaterial");
        m->type = PGI__MAT_LAMBERT;
        m->kd[0] = m->kd[1] = m->kd[2] = 0.6f;
        m->ior = 1.f;
        return PGI_OK;
    } else {
        snprintf(m->name, sizeof m->name, "unnamed");
    }

    float kd[3] = {0.f, 0.f, 0.f}, ks[3] = {0.f, 0.f, 0.f}, ke[3] = {0.f, 0.f, 0.f};
    int has_kd = get_color(am, AI_MATKEY_COLOR_DIFFUSE, kd);
    get_color(am, AI_MATKEY_COLOR_SPECULAR, ks);
    get_color(am, AI_MATKEY_COLOR_EMISSIVE, ke);
    float ns = 0.f, ni = 1.f, opacity = 1.f;
    get_float(am, AI_MATKEY_SHININESS, &ns);
    get_float(am, AI_MATKEY_REFRACTI, &ni);
    get_float(am, AI_MATKEY_OPACITY, &opacity);
    int illum = -1;
    if (!get_int(am, "$mat.illum", 0, 0, &illum)) {
        /* Not an OBJ material: approximate from the shading model. */
        int sm;
        if (get_int(am, AI_MATKEY_SHADING_MODEL, &sm))
            illum = (sm == aiShadingMode_Phong || sm == aiShadingMode_Blinn) ? 2 : 1;
    }

    for (int c = 0; c < 3; c++) {
        m->kd[c] = clamp01(kd[c]);
        ks[c] = isnan(ks[c]) ? 0.f : ks[c];
        m->ke[c] = ke[c] > 0.f ? ke[c] : (isfinite(ke[c]) ? 0.f : ke[c]); /* Inf stays, finalize rejects it */
    }

    /* Cut-outs: glTF alphaMode MASK (the base colour texture's alpha), or an MTL map_d (Assimp's
     * opacity texture). Either way `d` / the base colour factor's alpha (Assimp's opacity)
     * scales the texture's alpha instead of making the material glass. */
    struct aiString amode, dpath;
    const int gltf_mask =
        aiGetMaterialString(am, "$mat.gltf.alphaMode", 0, 0, &amode) == AI_SUCCESS && strcmp(amode.data, "MASK") == 0;
    const int map_d =
        !gltf_mask && aiGetMaterialTextureCount(am, aiTextureType_OPACITY) > 0 &&
        aiGetMaterialTexture(am, aiTextureType_OPACITY, 0, &dpath, NULL, NULL, NULL, NULL, NULL, NULL) == AI_SUCCESS &&
        dpath.length > 0;
    const int cut_out = gltf_mask || map_d;

    if (illum == 4 || illum == 6 || illum == 7 || illum == 9 || (opacity < 1.f && !cut_out)) {
        m->type = PGI__MAT_GLASS;
        m->ior = (isfinite(ni) && ni > 1.f) ? ni : 1.5f;
        m->ks[0] = m->ks[1] = m->ks[2] = 1.f;
    } else if ((illum == 3 || illum == 5) && max3(m->kd) < 0.01f && max3(ks) > 0.f) {
        m->type = PGI__MAT_MIRROR;
        for (int c = 0; c < 3; c++) m->ks[c] = clamp01(ks[c]);
    } else if (max3(ks) > 0.f && ns > 1.f) {
        /* A specular colour (illum 2): the model follows the scene's "specular" (plastic by
         * default, or Blinn-Phong, pgi_scene_set_specular sets it once the textures are in). */
        m->type = PGI__MAT_PLASTIC;
        m->auto_glossy = 1;
        m->shininess = ns > 10000.f ? 10000.f : ns;
        for (int c = 0; c < 3; c++) m->ks[c] = clamp01(ks[c]);
    } else {
        m->type = PGI__MAT_LAMBERT;
    }
    if (m->type == PGI__MAT_PLASTIC) m->ior = (isfinite(ni) && ni > 1.f) ? ni : 1.5f;
    else if (m->type != PGI__MAT_GLASS) m->ior = isfinite(ni) && ni > 0.f ? ni : 1.f;

    struct aiString tpath;
    if (aiGetMaterialTextureCount(am, aiTextureType_DIFFUSE) > 0 &&
        aiGetMaterialTexture(am, aiTextureType_DIFFUSE, 0, &tpath, NULL, NULL, NULL, NULL, NULL, NULL) == AI_SUCCESS &&
        tpath.length > 0) {
        pgi_status st = load_texture(s, tc, sc, m->name, tpath.data, &m->tex_kd);
        if (st) return st;
        if (!has_kd || max3(m->kd) <= 0.f) {
            for (int c = 0; c < 3; c++) m->kd[c] = 1.f;
        }
    }
    if (cut_out) {
        float cutoff = 0.5f; /* MTL has no cut-off of its own; glTF's default */
        if (gltf_mask) {
            float c;
            if (get_float(am, "$mat.gltf.alphaCutoff", 0, 0, &c) && isfinite(c) && c >= 0.f) cutoff = c;
            m->tex_alpha = m->tex_kd; /* the base colour texture */
        } else {
            pgi_status st = load_texture(s, tc, sc, m->name, dpath.data, &m->tex_alpha);
            if (st) return st;
            pgi__texture_grey_alpha(&s->texs[m->tex_alpha]); /* a map_d without alpha is a grey mask */
        }
        /* alpha * scale < cutoff  <=>  alpha < cutoff / scale; above 1 the whole surface is cut. */
        float scale = isfinite(opacity) ? clamp01(opacity) : 1.f;
        m->alpha_cutoff = !(cutoff > 0.f) ? 0.f : scale > 0.f ? fminf(cutoff / scale, 2.f) : 2.f;
    }
    memcpy(m->kd_mesh, m->kd, sizeof m->kd_mesh);
    return PGI_OK;
}

/* Grows *p to hold n elements of `size` bytes (keeps it on failure). */
static int grow(void *pp, size_t n, size_t size) {
    void **p = (void **)pp;
    void *q = realloc(*p, (n ? n : 1) * size);
    if (!q) return 0;
    *p = q;
    return 1;
}

/* Creases: neighbouring triangles whose normals differ by less than this are
 * smoothed together. Above the 45 degrees between the sides of an octagonal
 * prism and the 41.8 of an icosahedron, below the 60 of a hexagonal prism and
 * the 90 of a box; not a divisor of 360, so that regular prisms are not
 * decided by rounding. */
static const float k_smooth_max_deg = 50.f;

typedef enum normal_mode { NORMALS_SMOOTH = 0, NORMALS_FLAT = 1 } normal_mode;

/* One mesh as appended to the scene: output vertex i copies aiMesh vertex
 * src[i] (position, UV) with normal nrm[i]; src and nrm are NULL when the
 * mesh has its own normals (the vertices are then copied as they are). */
typedef struct mesh_out {
    size_t nv, nt;
    uint32_t *idx; /* 3 output vertices per triangle */
    uint32_t *src;
    float *nrm; /* 3 per output vertex */
} mesh_out;

static void mesh_out_free(mesh_out *o) {
    free(o->idx);
    free(o->src);
    free(o->nrm);
    memset(o, 0, sizeof *o);
}

/* Position key for welding: the bits of x, y, z (-0 made +0), sorted as integers, so
 * that equal positions are adjacent whatever the floats (NaN included) hold. */
typedef struct weld_key {
    uint32_t k[3], v;
} weld_key;

static int cmp_weld(const void *pa, const void *pb) {
    const weld_key *a = pa, *b = pb;
    for (int c = 0; c < 3; c++)
        if (a->k[c] != b->k[c]) return a->k[c] < b->k[c] ? -1 : 1;
    return a->v < b->v ? -1 : a->v > b->v;
}

/* Normals for a mesh without them (see the top of the file); fills o->src, o->nrm,
 * o->nv and rewrites o->idx to the output vertices. */
static pgi_status generate_normals(const struct aiMesh *me, normal_mode mode, mesh_out *o) {
    const size_t nv = me->mNumVertices, nt = o->nt, nc = 3 * nt;
    const float cos_max = cosf(k_smooth_max_deg * 3.14159265f / 180.f);
    weld_key *wk = malloc((nv ? nv : 1) * sizeof *wk);
    uint32_t *weld = malloc((nv ? nv : 1) * sizeof *weld), *head = malloc((nv ? nv : 1) * sizeof *head);
    pgi__v3 *fn = malloc((nt ? nt : 1) * sizeof *fn);
    float *angle = malloc((nc ? nc : 1) * sizeof *angle);
    uint32_t *start = calloc(nv + 1, sizeof *start), *list = malloc((nc ? nc : 1) * sizeof *list);
    uint32_t *next = malloc((nc ? nc : 1) * sizeof *next);
    o->src = malloc((nc ? nc : 1) * sizeof *o->src);
    o->nrm = malloc((nc ? nc : 1) * 3 * sizeof *o->nrm);
    pgi_status st = PGI_OK;
    if (!wk || !weld || !head || !fn || !angle || !start || !list || !next || !o->src || !o->nrm) {
        st = PGI_ERR_OOM;
        goto done;
    }
    /* Weld: vertices at the same position share one group. */
    for (size_t v = 0; v < nv; v++) {
        float p[3] = {(float)me->mVertices[v].x + 0.f, (float)me->mVertices[v].y + 0.f,
                      (float)me->mVertices[v].z + 0.f};
        memcpy(wk[v].k, p, sizeof p);
        wk[v].v = (uint32_t)v;
    }
    qsort(wk, nv, sizeof *wk, cmp_weld);
    uint32_t groups = 0;
    for (size_t i = 0; i < nv; i++) {
        if (i > 0 && memcmp(wk[i].k, wk[i - 1].k, sizeof wk[i].k) != 0) groups++;
        weld[wk[i].v] = groups;
    }
    /* Unit face normals (zero for degenerate triangles) and corner angles. */
    for (size_t t = 0; t < nt; t++) {
        pgi__v3 p[3];
        for (int c = 0; c < 3; c++) {
            const struct aiVector3D *a = &me->mVertices[o->idx[3 * t + c]];
            p[c] = v3((float)a->x, (float)a->y, (float)a->z);
        }
        pgi__v3 n = v3_cross(v3_sub(p[1], p[0]), v3_sub(p[2], p[0]));
        float l = v3_len(n);
        fn[t] = isfinite(l) && l > 0.f ? v3_scale(n, 1.f / l) : v3(0.f, 0.f, 0.f);
        for (int c = 0; c < 3; c++) {
            pgi__v3 e1 = v3_sub(p[(c + 1) % 3], p[c]), e2 = v3_sub(p[(c + 2) % 3], p[c]);
            float a = atan2f(v3_len(v3_cross(e1, e2)), v3_dot(e1, e2));
            angle[3 * t + c] = isfinite(a) ? a : 0.f;
        }
    }
    /* Corners around each welded position, in triangle order. */
    for (size_t c = 0; c < nc; c++) start[weld[o->idx[c]] + 1]++;
    for (size_t g = 0; g < nv; g++) start[g + 1] += start[g];
    for (size_t c = 0; c < nc; c++) list[start[weld[o->idx[c]]]++] = (uint32_t)c;
    for (size_t g = nv; g > 0; g--) start[g] = start[g - 1];
    start[0] = 0;
    /* Per corner: its normal, then an output vertex (one per aiMesh vertex and normal). */
    for (size_t v = 0; v < nv; v++) head[v] = UINT32_MAX;
    o->nv = 0;
    for (size_t c = 0; c < nc; c++) {
        const size_t t = c / 3;
        const uint32_t v = o->idx[c], g = weld[v];
        const int degenerate = fn[t].x == 0.f && fn[t].y == 0.f && fn[t].z == 0.f;
        pgi__v3 n = fn[t];
        if (mode == NORMALS_SMOOTH || degenerate) {
            n = v3(0.f, 0.f, 0.f);
            for (uint32_t k = start[g]; k < start[g + 1]; k++) {
                const uint32_t c2 = list[k];
                if (degenerate || v3_dot(fn[t], fn[c2 / 3]) >= cos_max) n = v3_madd(n, fn[c2 / 3], angle[c2]);
            }
            float l = v3_len(n);
            n = l > 0.f ? v3_scale(n, 1.f / l) : fn[t];
        }
        uint32_t out = head[v];
        while (out != UINT32_MAX && memcmp(o->nrm + 3 * (size_t)out, &n, 3 * sizeof(float)) != 0) out = next[out];
        if (out == UINT32_MAX) {
            out = (uint32_t)o->nv++;
            o->src[out] = v;
            v3_store(o->nrm + 3 * (size_t)out, n);
            next[out] = head[v];
            head[v] = out;
        }
        o->idx[c] = out;
    }
done:
    free(wk);
    free(weld);
    free(head);
    free(fn);
    free(angle);
    free(start);
    free(list);
    free(next);
    return st;
}

/* The triangles of mesh `mi` (indices checked), with generated normals when it has none. */
static pgi_status prepare_mesh(const char *path, unsigned mi, const struct aiMesh *me, normal_mode mode, mesh_out *o) {
    memset(o, 0, sizeof *o);
    for (unsigned f = 0; f < me->mNumFaces; f++) o->nt += me->mFaces[f].mNumIndices == 3;
    if (!o->nt) return PGI_OK;
    if (o->nt > UINT32_MAX / 3)
        return pgi__fail(PGI_ERR_UNSUPPORTED, "%s: mesh %u has too many triangles (%zu)", path, mi, o->nt);
    o->idx = malloc(3 * o->nt * sizeof *o->idx);
    if (!o->idx) return pgi__fail(PGI_ERR_OOM, "%s: out of memory for mesh %u", path, mi);
    size_t t = 0;
    for (unsigned f = 0; f < me->mNumFaces; f++) {
        const struct aiFace *fc = &me->mFaces[f];
        if (fc->mNumIndices != 3) continue;
        for (int c = 0; c < 3; c++) {
            unsigned idx = fc->mIndices[c];
            if (idx >= me->mNumVertices)
                return pgi__fail(PGI_ERR_PARSE, "%s: mesh %u face %u refers to vertex %u of %u", path, mi, f, idx,
                                 me->mNumVertices);
            o->idx[3 * t + c] = idx;
        }
        t++;
    }
    if (me->mNormals) {
        o->nv = me->mNumVertices;
        return PGI_OK;
    }
    if (generate_normals(me, mode, o))
        return pgi__fail(PGI_ERR_OOM, "%s: out of memory for the normals of mesh %u (%u vertices)", path, mi,
                         me->mNumVertices);
    return PGI_OK;
}

static int has_ext(const char *path, const char *ext) {
    size_t n = strlen(path), e = strlen(ext);
    return n > e && strcasecmp(path + n - e, ext) == 0;
}

/* ------------------------------------------------- the files Assimp opens */

/* Every file Assimp opens for an import (the mesh, its material libraries, a glTF's buffers)
 * goes through pgi__fopen_input: a regular file no larger than the budget (never a FIFO, which
 * would hang, nor a device such as /dev/zero, which never ends). Each file's bytes are counted
 * against the budget once however often it is opened, and no file may be opened more than
 * PGI__MAX_FILE_OPENS times. The first refusal is kept and fails the import even where Assimp
 * would go on without the file (a material library). */
#define PGI__STR_(x) #x
#define PGI__STR(x) PGI__STR_(x)

typedef struct io_file {
    dev_t dev;
    ino_t ino;
    int opens;
} io_file;

typedef struct io_ctx {
    const char *mesh_path;
    uint64_t budget, total;
    io_file files[PGI__MAX_MESH_FILES];
    int nfiles;
    pgi_status st;
    char err[1024];
} io_ctx;

static void io_refuse(io_ctx *c, pgi_status st, const char *fmt, const char *a, const char *b) {
    if (c->st) return;
    c->st = st;
    snprintf(c->err, sizeof c->err, fmt, c->mesh_path, a, b);
}

static size_t io_read(struct aiFile *f, char *buf, size_t size, size_t count) {
    return fread(buf, size, count, (FILE *)f->UserData);
}
static size_t io_write(struct aiFile *f, const char *buf, size_t size, size_t count) {
    (void)f, (void)buf, (void)size, (void)count;
    return 0;
}
static size_t io_tell(struct aiFile *f) {
    long t = ftell((FILE *)f->UserData);
    return t < 0 ? 0 : (size_t)t;
}
static size_t io_size(struct aiFile *f) {
    struct stat st;
    return fstat(fileno((FILE *)f->UserData), &st) == 0 ? (size_t)st.st_size : 0;
}
static enum aiReturn io_seek(struct aiFile *f, size_t off, enum aiOrigin origin) {
    const int whence = origin == aiOrigin_SET ? SEEK_SET : origin == aiOrigin_CUR ? SEEK_CUR : SEEK_END;
    return fseeko((FILE *)f->UserData, (off_t)off, whence) == 0 ? aiReturn_SUCCESS : aiReturn_FAILURE;
}
static void io_flush(struct aiFile *f) { (void)f; }

static struct aiFile *io_open(struct aiFileIO *io, const char *path, const char *mode) {
    io_ctx *c = (io_ctx *)io->UserData;
    if (!path || !mode || strchr(mode, 'w') || strchr(mode, 'a') || strchr(mode, '+')) return NULL;
    const char *why;
    uint64_t size;
    FILE *fp = pgi__fopen_input(path, c->budget, &size, &why);
    if (!fp) {
        /* A missing file is for Assimp to judge (it probes names); one that is not a regular file, or
         * too large, is refused. */
        if (errno == EINVAL || errno == EFBIG) io_refuse(c, PGI_ERR_IO, "%s: %s: %s", path, why);
        return NULL;
    }
    struct stat st;
    fstat(fileno(fp), &st);
    io_file *slot = NULL;
    for (int i = 0; i < c->nfiles && !slot; i++)
        if (c->files[i].dev == st.st_dev && c->files[i].ino == st.st_ino) slot = &c->files[i];
    if (!slot) {
        if (c->nfiles == (int)(sizeof c->files / sizeof c->files[0])) {
            io_refuse(c, PGI_ERR_UNSUPPORTED, "%s: %s: %s", path,
                      "one file too many (at most " PGI__STR(PGI__MAX_MESH_FILES) " for one mesh)");
            fclose(fp);
            return NULL;
        }
        if (c->budget && c->total + size > c->budget) {
            char b[32];
            io_refuse(c, PGI_ERR_OOM, "%s: %s: with the files read before it, over the memory budget of %s", path,
                      pgi__mem_format(c->budget, b, sizeof b));
            fclose(fp);
            return NULL;
        }
        c->total += size;
        slot = &c->files[c->nfiles++];
        slot->dev = st.st_dev;
        slot->ino = st.st_ino;
        slot->opens = 0;
    }
    if (++slot->opens > PGI__MAX_FILE_OPENS) {
        char n[16];
        snprintf(n, sizeof n, "%d", PGI__MAX_FILE_OPENS);
        io_refuse(c, PGI_ERR_UNSUPPORTED, "%s: %s: opened more than %s times in one import", path, n);
        fclose(fp);
        return NULL;
    }
    struct aiFile *f = calloc(1, sizeof *f);
    if (!f) {
        fclose(fp);
        return NULL;
    }
    f->ReadProc = io_read;
    f->WriteProc = io_write;
    f->TellProc = io_tell;
    f->FileSizeProc = io_size;
    f->SeekProc = io_seek;
    f->FlushProc = io_flush;
    f->UserData = (aiUserData)fp;
    return f;
}

static void io_close(struct aiFileIO *io, struct aiFile *f) {
    (void)io;
    if (!f) return;
    fclose((FILE *)f->UserData);
    free(f);
}

/* Assimp runs on a thread of its own with a large stack (PGI__IMPORT_STACK): its importers and
 * post-processing recurse once a level of a hierarchy, and a format the pre-check does not scan
 * must not overflow the caller's stack. Only touched pages of the stack are ever committed. */
#define PGI__IMPORT_STACK ((size_t)256 << 20)

typedef struct import_job {
    const char *path;
    unsigned flags;
    struct aiFileIO *io;
    const struct aiScene *sc; /* in: to release; out: imported */
    char err[1024];
} import_job;

static void *import_main(void *arg) {
    import_job *j = arg;
    if (j->sc) {
        aiReleaseImport(j->sc);
        j->sc = NULL;
        return NULL;
    }
    j->sc = aiImportFileEx(j->path, j->flags, j->io);
    if (!j->sc) {
        const char *e = aiGetErrorString();
        snprintf(j->err, sizeof j->err, "%s", e && *e ? e : "Assimp could not import the file");
    }
    return NULL;
}

/* Runs import_main on a thread with a large stack (on this one if no thread can be made). */
static void run_import(import_job *j) {
    pthread_attr_t attr;
    pthread_t t;
    int ok = pthread_attr_init(&attr) == 0;
    if (ok && pthread_attr_setstacksize(&attr, PGI__IMPORT_STACK) == 0 &&
        pthread_create(&t, &attr, import_main, j) == 0)
        pthread_join(t, NULL);
    else import_main(j);
    if (ok) pthread_attr_destroy(&attr);
}

static void release_import(const struct aiScene *sc) {
    import_job j = {.sc = sc};
    run_import(&j);
}

/* ------------------------------------------- cameras, lights, what is not used */

/* A camera of Assimp's (after PreTransformVertices: in world space). Assimp's importers store the
 * whole horizontal angle in mHorizontalFOV (Collada's xfov; its header calls it the half angle),
 * and the aspect ratio in mAspect (0: not given, taken as 4:3, photongi's default image). */
static int convert_camera(const struct aiCamera *c, pgi_camera_def *d) {
    if (c->mOrthographicWidth > 0.f || !(c->mHorizontalFOV > 0.f) || !(c->mHorizontalFOV < 3.14159f)) return 0;
    pgi__v3 f = v3((float)c->mLookAt.x, (float)c->mLookAt.y, (float)c->mLookAt.z);
    if (!(v3_len(f) > 0.f)) return 0;
    f = v3_norm(f);
    const double aspect = c->mAspect > 0.f ? (double)c->mAspect : 4.0 / 3.0;
    const pgi__v3 eye = v3((float)c->mPosition.x, (float)c->mPosition.y, (float)c->mPosition.z);
    v3_store(d->eye, eye);
    v3_store(d->look_at, v3_add(eye, f));
    d->up[0] = (float)c->mUp.x;
    d->up[1] = (float)c->mUp.y;
    d->up[2] = (float)c->mUp.z;
    d->fov_y_deg =
        (float)(2.0 * atan(tan(0.5 * (double)c->mHorizontalFOV) / aspect) * (180.0 / 3.14159265358979323846));
    return 1;
}

/* The file's cameras and lights, its glTF emissive strengths, and one warning line naming what
 * it holds that is not used or could not be found. The materials of this import start at m0. */
static pgi_status import_extras(pgi_scene *s, const char *path, const struct aiScene *sc, pgi__mesh_hints *h, size_t m0,
                                struct aiFileIO *io) {
    char unused[1536] = "";
    pgi_status st = PGI_OK;
    if (h->gltf) {
        const pgi__gltf_extras *x = &h->extras;
        /* Assimp's glTF materials are the file's, in order (then its default material). */
        for (size_t i = 0; i < x->nmats && i < sc->mNumMaterials; i++)
            for (int c = 0; c < 3; c++) s->mats[m0 + i].ke[c] *= x->emissive_strength[i];
        for (size_t i = 0; i < x->ncams && !st; i++) st = pgi__scene_add_camera(s, &x->cams[i].def, x->cams[i].name);
        if (!st && x->nlights) {
            pgi__light *L = realloc(s->lights, (s->nlights + x->nlights) * sizeof *L);
            if (!L) return pgi__fail(PGI_ERR_OOM, "%s: out of memory for %zu lights", path, x->nlights);
            memcpy(L + s->nlights, x->lights, x->nlights * sizeof *L);
            s->lights = L;
            s->nlights += x->nlights;
        }
        snprintf(unused, sizeof unused, "%s", x->unused);
    } else {
        /* Other formats: Assimp's cameras, named as the file names them (PreTransformVertices
         * renames them "cam_N": the names come from an import without it, same order). */
        char(*names)[64] = NULL;
        if (sc->mNumCameras) {
            import_job job = {.path = path, .flags = aiProcess_ValidateDataStructure, .io = io};
            run_import(&job);
            if (job.sc && job.sc->mNumCameras == sc->mNumCameras && (names = calloc(sc->mNumCameras, 64)))
                for (unsigned i = 0; i < sc->mNumCameras; i++)
                    snprintf(names[i], 64, "%.63s", job.sc->mCameras[i]->mName.data);
            if (job.sc) release_import(job.sc);
        }
        size_t ortho = 0;
        for (unsigned i = 0; i < sc->mNumCameras && !st; i++) {
            pgi_camera_def d;
            if (convert_camera(sc->mCameras[i], &d)) st = pgi__scene_add_camera(s, &d, names ? names[i] : NULL);
            else ortho++;
        }
        free(names);
        if (st) return st;
        char item[160];
        if (ortho) {
            snprintf(item, sizeof item, "%zu orthographic camera%s", ortho, ortho == 1 ? "" : "s");
            pgi__list_append(unused, sizeof unused, item);
        }
        if (sc->mNumLights) {
            snprintf(item, sizeof item, "%u light%s (units the format leaves open: give lights in a .json description)",
                     sc->mNumLights, sc->mNumLights == 1 ? "" : "s");
            pgi__list_append(unused, sizeof unused, item);
        }
        if (sc->mNumAnimations) {
            snprintf(item, sizeof item, "%u animation%s", sc->mNumAnimations, sc->mNumAnimations == 1 ? "" : "s");
            pgi__list_append(unused, sizeof unused, item);
        }
        unsigned more = 0; /* colour sets past the first */
        for (unsigned i = 0; i < sc->mNumMeshes; i++) more += sc->mMeshes[i]->mColors[1] != NULL;
        if (more) {
            snprintf(item, sizeof item, "second vertex colour sets (%u mesh%s; the first set is used)", more,
                     more == 1 ? "" : "es");
            pgi__list_append(unused, sizeof unused, item);
        }
    }
    char line[2048], missing[1400] = "";
    if (h->missing_mtl[0])
        snprintf(missing, sizeof missing, "not found: material librar%s %s (its materials are default grey)",
                 strchr(h->missing_mtl, ',') ? "ies" : "y", h->missing_mtl);
    if (h->missing_tex[0]) {
        const size_t n = strlen(missing);
        snprintf(missing + n, sizeof missing - n, "%snot found: texture%s %s (drawn in their materials' colours)",
                 n ? "; " : "", strchr(h->missing_tex, ',') ? "s" : "", h->missing_tex);
    }
    snprintf(line, sizeof line, "%s: %s%s%s%s", path, unused[0] ? "not used: " : "", unused,
             unused[0] && missing[0] ? "; " : "", missing);
    if (unused[0] || missing[0]) pgi__scene_warn(s, line);
    return PGI_OK;
}

pgi_status pgi__scene_import_mesh(pgi_scene *s, const char *path) {
    if (!s || !path) return pgi__fail(PGI_ERR_INVALID_ARG, "pgi__scene_import_mesh: NULL argument");
    const char *why = pgi__not_regular_file(path);
    if (why) return pgi__fail(PGI_ERR_IO, "%s: %s", path, why);
    pgi__mesh_hints hints;
    const uint64_t budget = pgi__scene_load_budget();
    pgi_status pre = pgi__mesh_precheck(path, budget, &hints);
    if (pre) return pre;
    const normal_mode mode =
        has_ext(path, ".gltf") || has_ext(path, ".glb") || (hints.smooth_off > 0 && hints.smooth_on == 0)
            ? NORMALS_FLAT
            : NORMALS_SMOOTH;

    /* ValidateDataStructure runs first: Assimp's importers leave out-of-range indices in some
     * malformed files (a PLY face list longer than the file), which the later steps follow. */
    const unsigned int flags = aiProcess_ValidateDataStructure | aiProcess_Triangulate |
                               aiProcess_JoinIdenticalVertices | aiProcess_SortByPType | aiProcess_PreTransformVertices;
    io_ctx ctx; /* 7 KiB */
    memset(&ctx, 0, sizeof ctx);
    ctx.mesh_path = path;
    ctx.budget = budget;
    struct aiFileIO io = {.OpenProc = io_open, .CloseProc = io_close, .UserData = (aiUserData)&ctx};
    import_job job = {.path = path, .flags = flags, .io = &io};
    const struct aiScene *sc = NULL;
    for (int pass = 0; pass < 2; pass++) {
        run_import(&job);
        sc = job.sc;
        if (ctx.st) {
            if (sc) release_import(sc);
            pgi__mesh_hints_free(&hints);
            return pgi__fail(ctx.st, "%s", ctx.err);
        }
        if (!sc) {
            pgi__mesh_hints_free(&hints);
            return pgi__fail(PGI_ERR_PARSE, "%s: %s", path, job.err);
        }
        /* Assimp 5.2's JoinIdenticalVertices joins vertices that differ in their colour alone (a
         * red floor's corner and a white wall's at one place, both without normals): a file with
         * vertex colours is imported again without it, its vertices as the file indexes them (an
         * OBJ's then come three a triangle). Its files are not counted again, nor their opens. */
        int coloured = 0;
        for (unsigned i = 0; i < sc->mNumMeshes; i++) coloured |= sc->mMeshes[i]->mColors[0] != NULL;
        if (pass || !coloured) break;
        release_import(sc);
        sc = NULL;
        job = (import_job){.path = path, .flags = flags & ~(unsigned)aiProcess_JoinIdenticalVertices, .io = &io};
        for (int i = 0; i < ctx.nfiles; i++) ctx.files[i].opens = 0;
    }

    pgi_status st = PGI_OK;
    /* Triangles and output vertices of each mesh, then what will be appended. */
    mesh_out *outs = calloc(sc->mNumMeshes ? sc->mNumMeshes : 1, sizeof *outs);
    if (!outs) {
        release_import(sc);
        pgi__mesh_hints_free(&hints);
        return pgi__fail(PGI_ERR_OOM, "%s: out of memory", path);
    }
    size_t add_v = 0, add_t = 0;
    int any_uv = 0, any_col = 0;
    for (unsigned i = 0; i < sc->mNumMeshes && !st; i++) {
        const struct aiMesh *me = sc->mMeshes[i];
        if (!(me->mPrimitiveTypes & aiPrimitiveType_TRIANGLE) || me->mNumVertices == 0) continue;
        st = prepare_mesh(path, i, me, mode, &outs[i]);
        if (st || !outs[i].nt) continue;
        add_v += outs[i].nv;
        add_t += outs[i].nt;
        if (me->mTextureCoords[0]) any_uv = 1;
        if (me->mColors[0]) any_col = 1;
    }
    if (!st && (add_t == 0 || sc->mNumMaterials == 0))
        st = pgi__fail(PGI_ERR_PARSE, "%s: no triangles found (not a mesh file, or a malformed one)", path);
    const size_t v0 = s->nverts, t0 = s->ntris, m0 = s->nmats;
    if (!st && (v0 + add_v > (size_t)UINT32_MAX || t0 + add_t > (size_t)UINT32_MAX / 3))
        st = pgi__fail(PGI_ERR_UNSUPPORTED, "%s: too many vertices or triangles (%zu, %zu)", path, v0 + add_v,
                       t0 + add_t);
    const size_t nm = m0 + sc->mNumMaterials;
    /* Every mesh now has normals; they are dropped only when earlier geometry is flat-shaded (no nrm). */
    if (!st) st = pgi__scene_grow_geometry(s, add_v, add_t, 1, any_uv, any_col, path);
    if (!st && !grow(&s->mats, nm, sizeof(pgi__material))) st = pgi__fail(PGI_ERR_OOM, "%s: out of memory", path);
    if (st) goto done;
    const int keep_nrm = s->nrm != NULL, want_uv = s->uv != NULL;
    const int linear_col = has_ext(path, ".gltf") || has_ext(path, ".glb");

    /* Materials (appended first so that textures and indices are known). */
    tex_cache tc;
    tc.mesh_path = path;
    tc.first = s->ntexs;
    tc.dir[0] = 0;
    tc.ply = has_ext(path, ".ply");
    tc.hints = &hints;
    const char *slash = strrchr(path, '/');
    if (slash) snprintf(tc.dir, sizeof tc.dir, "%.*s/", (int)(slash - path), path);
    for (unsigned i = 0; i < sc->mNumMaterials && !st; i++) {
        st = convert_material(s, &tc, sc, sc->mMaterials[i], &s->mats[m0 + i]);
        if (!st) s->nmats = m0 + i + 1;
    }
    if (st) goto done;
    /* A material the file does not define, used only by meshes with vertex colours: white (the
     * colours are the base colour), not the made-up grey. */
    for (unsigned i = 0; any_col && i < sc->mNumMaterials; i++) {
        pgi__material *m = &s->mats[m0 + i];
        if (strcmp(m->name, AI_DEFAULT_MATERIAL_NAME) != 0 || m->type != PGI__MAT_LAMBERT || m->tex_kd >= 0) continue;
        int used = 0, all = 1;
        for (unsigned k = 0; k < sc->mNumMeshes; k++)
            if (outs[k].nt && sc->mMeshes[k]->mMaterialIndex == i) {
                used = 1;
                all &= sc->mMeshes[k]->mColors[0] != NULL;
            }
        if (used && all)
            for (int c = 0; c < 3; c++) m->kd[c] = m->kd_mesh[c] = 1.f;
    }

    /* Geometry. */
    size_t vb = v0, tb = t0;
    for (unsigned i = 0; i < sc->mNumMeshes; i++) {
        const struct aiMesh *me = sc->mMeshes[i];
        const mesh_out *o = &outs[i];
        if (!o->nt) continue;
        for (size_t k = 0; k < o->nv; k++) {
            const size_t from = o->src ? o->src[k] : k;
            float *p = s->pos + 3 * (vb + k);
            p[0] = (float)me->mVertices[from].x;
            p[1] = (float)me->mVertices[from].y;
            p[2] = (float)me->mVertices[from].z;
            if (keep_nrm) {
                float *n = s->nrm + 3 * (vb + k);
                pgi__v3 nn =
                    o->nrm ? v3_load(o->nrm + 3 * k)
                           : v3((float)me->mNormals[from].x, (float)me->mNormals[from].y, (float)me->mNormals[from].z);
                /* Degenerate faces give zero or NaN normals: keep them finite (finalize rejects NaN). */
                v3_store(n, pgi__normal_clean(nn));
            }
            if (want_uv) {
                float *t = s->uv + 2 * (vb + k);
                if (me->mTextureCoords[0]) {
                    t[0] = (float)me->mTextureCoords[0][from].x;
                    t[1] = (float)me->mTextureCoords[0][from].y;
                } else {
                    t[0] = t[1] = 0.f;
                }
            }
            if (me->mColors[0]) { /* else white, as pgi__scene_grow_geometry left it */
                float *c = s->col + 3 * (vb + k);
                c[0] = vertex_colour((float)me->mColors[0][from].r, linear_col);
                c[1] = vertex_colour((float)me->mColors[0][from].g, linear_col);
                c[2] = vertex_colour((float)me->mColors[0][from].b, linear_col);
            }
        }
        uint32_t mat = (uint32_t)(m0 + (me->mMaterialIndex < sc->mNumMaterials ? me->mMaterialIndex : 0));
        for (size_t f = 0; f < o->nt; f++) {
            for (int c = 0; c < 3; c++) s->tri[3 * tb + c] = (uint32_t)(vb + o->idx[3 * f + c]);
            s->tri_mat[tb] = mat;
            tb++;
        }
        vb += o->nv;
    }
    pgi__scene_fix_normals(s, t0, tb);
    s->nverts = vb;
    s->ntris = tb;
    st = import_extras(s, path, sc, &hints, m0, &io);
done:
    for (unsigned i = 0; i < sc->mNumMeshes; i++) mesh_out_free(&outs[i]);
    free(outs);
    release_import(sc);
    pgi__mesh_hints_free(&hints);
    return st;
}
