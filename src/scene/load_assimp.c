/* Mesh import through Assimp's C API (OBJ/MTL, glTF, PLY, ...).
 *
 * The file is imported with Triangulate | JoinIdenticalVertices |
 * SortByPType | PreTransformVertices | GenNormals: every mesh ends up in
 * world space, point and line primitives land in meshes of their own (and
 * are skipped here), and meshes without normals get flat face normals
 * (Assimp computes them before joining vertices, so flat faces keep their
 * own vertices). Geometry, materials and textures are appended to the scene.
 *
 * Material mapping (Wavefront MTL names; Assimp 5.2 keeps the raw MTL
 * `illum` number as the integer property "$mat.illum", and a derived
 * aiShadingMode in AI_MATKEY_SHADING_MODEL):
 *   illum 4, 6, 7 or 9, or opacity d < 1     -> glass, ior = Ni (1.5 if Ni <= 1), ks = 1
 *   illum 3 or 5, max(Kd) < 0.01, max(Ks) > 0 -> mirror, ks = Ks
 *   max(Ks) > 0 and Ns > 1                    -> Phong, ks = Ks (F0), s = Ns in [1, 10000],
 *                                                kd scaled so that kd + ks <= 1
 *   otherwise                                 -> Lambert
 * kd = Kd clamped to [0, 1]; ke = Ke. map_Kd is loaded (8-bit sRGB) relative
 * to the mesh file's folder; with a texture, kd is the multiplier, or 1 when
 * Kd is black or absent. */
#include "scene_internal.h"

#include <assimp/cimport.h>
#include <assimp/material.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>
#include <stb_image.h>

#include <stdio.h>
#include <string.h>
#include <sys/stat.h>

static int regular_file(const char *p) {
    struct stat st;
    return stat(p, &st) == 0 && S_ISREG(st.st_mode);
}

/* Copies with truncation (names longer than the field are cut). */
static void copy_str(char *dst, size_t n, const char *src) {
    size_t k = strlen(src);
    if (k >= n) k = n - 1;
    memcpy(dst, src, k);
    dst[k] = 0;
}

static float clamp01(float x) { return x > 0.f ? (x < 1.f ? x : 1.f) : 0.f; } /* NaN -> 0 */
static float max3(const float *c) { return fmaxf(c[0], fmaxf(c[1], c[2])); }

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
    char dir[1024]; /* the mesh file's folder with a trailing '/', or "" */
    size_t first;   /* scene textures added by this import start here */
} tex_cache;

static pgi_status push_texture(pgi_scene *s, int w, int h, unsigned char *rgba, const char *path, int *index) {
    pgi__texture *t = realloc(s->texs, (s->ntexs + 1) * sizeof *t);
    if (!t) {
        stbi_image_free(rgba);
        return pgi__fail(PGI_ERR_OOM, "out of memory for texture '%s'", path);
    }
    s->texs = t;
    pgi__texture *nt = &s->texs[s->ntexs];
    memset(nt, 0, sizeof *nt);
    nt->width = w;
    nt->height = h;
    nt->rgba = rgba; /* stbi allocates with malloc: pgi_scene_destroy frees it with free() */
    copy_str(nt->path, sizeof nt->path, path);
    *index = (int)s->ntexs++;
    return PGI_OK;
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
            if (st) return st;
            rgba = stbi_load_from_memory((const unsigned char *)at->pcData, (int)at->mWidth, &w, &h, &n, 4);
            if (!rgba)
                return pgi__fail(PGI_ERR_IO, "%s: material '%s': cannot read texture '%s': %s", tc->mesh_path, mat_name,
                                 resolved, stbi_failure_reason());
        } else {
            pgi_status st = pgi__check_image_size(resolved, at->mWidth, at->mHeight);
            if (st) return st;
            w = (int)at->mWidth;
            h = (int)at->mHeight;
            rgba = malloc((size_t)w * (size_t)h * 4);
            if (!rgba) return pgi__fail(PGI_ERR_OOM, "%s: out of memory for texture '%s'", tc->mesh_path, resolved);
            for (size_t i = 0; i < (size_t)w * (size_t)h; i++) {
                rgba[4 * i + 0] = at->pcData[i].r;
                rgba[4 * i + 1] = at->pcData[i].g;
                rgba[4 * i + 2] = at->pcData[i].b;
                rgba[4 * i + 3] = at->pcData[i].a;
            }
        }
        return push_texture(s, w, h, rgba, resolved, index);
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
    int w, h, n;
    if (!stbi_info(resolved, &w, &h, &n))
        return pgi__fail(PGI_ERR_IO, "%s: material '%s': cannot read texture '%s': %s", tc->mesh_path, mat_name,
                         resolved, stbi_failure_reason());
    pgi_status st = pgi__check_image_size(resolved, w, h);
    if (st) return st;
    unsigned char *rgba = stbi_load(resolved, &w, &h, &n, 4);
    if (!rgba)
        return pgi__fail(PGI_ERR_IO, "%s: material '%s': cannot read texture '%s': %s", tc->mesh_path, mat_name,
                         resolved, stbi_failure_reason());
    return push_texture(s, w, h, rgba, resolved, index);
}

static pgi_status convert_material(pgi_scene *s, tex_cache *tc, const struct aiScene *sc, const struct aiMaterial *am,
                                   pgi__material *m) {
    memset(m, 0, sizeof *m);
    m->tex_kd = -1;
    struct aiString name;
    if (aiGetMaterialString(am, AI_MATKEY_NAME, &name) == AI_SUCCESS) copy_str(m->name, sizeof m->name, name.data);
    else snprintf(m->name, sizeof m->name, "unnamed");

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

    if (illum == 4 || illum == 6 || illum == 7 || illum == 9 || opacity < 1.f) {
        m->type = PGI_MAT_GLASS;
        m->ior = (isfinite(ni) && ni > 1.f) ? ni : 1.5f;
        m->ks[0] = m->ks[1] = m->ks[2] = 1.f;
    } else if ((illum == 3 || illum == 5) && max3(m->kd) < 0.01f && max3(ks) > 0.f) {
        m->type = PGI_MAT_MIRROR;
        for (int c = 0; c < 3; c++) m->ks[c] = clamp01(ks[c]);
    } else if (max3(ks) > 0.f && ns > 1.f) {
        m->type = PGI_MAT_PHONG;
        m->shininess = ns > 10000.f ? 10000.f : ns;
        for (int c = 0; c < 3; c++) {
            m->ks[c] = clamp01(ks[c]);
            if (m->kd[c] + m->ks[c] > 1.f) m->kd[c] = 1.f - m->ks[c];
        }
    } else {
        m->type = PGI_MAT_LAMBERT;
    }
    if (m->type != PGI_MAT_GLASS) m->ior = isfinite(ni) && ni > 0.f ? ni : 1.f;

    struct aiString tpath;
    if (aiGetMaterialTextureCount(am, aiTextureType_DIFFUSE) > 0 &&
        aiGetMaterialTexture(am, aiTextureType_DIFFUSE, 0, &tpath, NULL, NULL, NULL, NULL, NULL, NULL) == AI_SUCCESS &&
        tpath.length > 0) {
        pgi_status st = load_texture(s, tc, sc, m->name, tpath.data, &m->tex_kd);
        if (st) return st;
        if (!has_kd || max3(m->kd) <= 0.f) {
            for (int c = 0; c < 3; c++) {
                m->kd[c] = 1.f;
                if (m->type == PGI_MAT_PHONG && m->kd[c] + m->ks[c] > 1.f) m->kd[c] = 1.f - m->ks[c];
            }
        }
    }
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

pgi_status pgi__scene_import_mesh(pgi_scene *s, const char *path) {
    if (!s || !path) return pgi__fail(PGI_ERR_INVALID_ARG, "pgi__scene_import_mesh: NULL argument");
    if (!regular_file(path)) return pgi__fail(PGI_ERR_IO, "%s: no such file", path);
    pgi_status pre = pgi__mesh_precheck(path);
    if (pre) return pre;

    const unsigned int flags = aiProcess_Triangulate | aiProcess_JoinIdenticalVertices | aiProcess_SortByPType |
                               aiProcess_PreTransformVertices | aiProcess_GenNormals;
    const struct aiScene *sc = aiImportFile(path, flags);
    if (!sc) {
        const char *e = aiGetErrorString();
        return pgi__fail(PGI_ERR_PARSE, "%s: %s", path, e && *e ? e : "Assimp could not import the file");
    }

    pgi_status st = PGI_OK;
    /* Count what will be appended. */
    size_t add_v = 0, add_t = 0;
    int any_uv = 0, all_nrm = 1;
    for (unsigned i = 0; i < sc->mNumMeshes; i++) {
        const struct aiMesh *me = sc->mMeshes[i];
        if (!(me->mPrimitiveTypes & aiPrimitiveType_TRIANGLE) || me->mNumVertices == 0) continue;
        size_t nt = 0;
        for (unsigned f = 0; f < me->mNumFaces; f++) nt += me->mFaces[f].mNumIndices == 3;
        if (!nt) continue;
        add_v += me->mNumVertices;
        add_t += nt;
        if (me->mTextureCoords[0]) any_uv = 1;
        if (!me->mNormals) all_nrm = 0;
    }
    if (add_t == 0 || sc->mNumMaterials == 0) {
        aiReleaseImport(sc);
        return pgi__fail(PGI_ERR_PARSE, "%s: no triangles found (not a mesh file, or a malformed one)", path);
    }
    const size_t v0 = s->nverts, t0 = s->ntris, m0 = s->nmats;
    if (v0 + add_v > (size_t)UINT32_MAX || t0 + add_t > (size_t)UINT32_MAX / 3) {
        aiReleaseImport(sc);
        return pgi__fail(PGI_ERR_UNSUPPORTED, "%s: too many vertices or triangles (%zu, %zu)", path, v0 + add_v,
                         t0 + add_t);
    }
    const size_t nv = v0 + add_v, nt = t0 + add_t, nm = m0 + sc->mNumMaterials;
    /* Normals: per-vertex if the scene so far has them (or is empty) and every new mesh has them. */
    int keep_nrm = all_nrm && (v0 == 0 || s->nrm != NULL);
    int had_uv = s->uv != NULL;
    int want_uv = any_uv || had_uv;

    if (!grow(&s->pos, nv * 3, sizeof(float)) || !grow(&s->tri, nt * 3, sizeof(uint32_t)) ||
        !grow(&s->tri_mat, nt, sizeof(uint32_t)) || !grow(&s->mats, nm, sizeof(pgi__material)) ||
        (keep_nrm && !grow(&s->nrm, nv * 3, sizeof(float))) || (want_uv && !grow(&s->uv, nv * 2, sizeof(float)))) {
        aiReleaseImport(sc);
        return pgi__fail(PGI_ERR_OOM, "%s: out of memory for %zu vertices and %zu triangles", path, nv, nt);
    }
    if (!keep_nrm && s->nrm) {
        free(s->nrm); /* mixing smooth and flat-shaded inputs: shade everything flat */
        s->nrm = NULL;
    }
    if (want_uv && !had_uv && v0 > 0) memset(s->uv, 0, v0 * 2 * sizeof(float)); /* earlier geometry had no UVs */

    /* Materials (appended first so that textures and indices are known). */
    tex_cache tc;
    tc.mesh_path = path;
    tc.first = s->ntexs;
    tc.dir[0] = 0;
    const char *slash = strrchr(path, '/');
    if (slash) snprintf(tc.dir, sizeof tc.dir, "%.*s/", (int)(slash - path), path);
    for (unsigned i = 0; i < sc->mNumMaterials && !st; i++) {
        st = convert_material(s, &tc, sc, sc->mMaterials[i], &s->mats[m0 + i]);
        if (!st) s->nmats = m0 + i + 1;
    }
    if (st) {
        aiReleaseImport(sc);
        return st;
    }

    /* Geometry. */
    size_t vb = v0, tb = t0;
    for (unsigned i = 0; i < sc->mNumMeshes; i++) {
        const struct aiMesh *me = sc->mMeshes[i];
        if (!(me->mPrimitiveTypes & aiPrimitiveType_TRIANGLE) || me->mNumVertices == 0) continue;
        size_t ntm = 0;
        for (unsigned f = 0; f < me->mNumFaces; f++) ntm += me->mFaces[f].mNumIndices == 3;
        if (!ntm) continue;
        for (unsigned k = 0; k < me->mNumVertices; k++) {
            float *p = s->pos + 3 * (vb + k);
            p[0] = (float)me->mVertices[k].x;
            p[1] = (float)me->mVertices[k].y;
            p[2] = (float)me->mVertices[k].z;
            if (keep_nrm) {
                float *n = s->nrm + 3 * (vb + k);
                pgi__v3 nn = v3((float)me->mNormals[k].x, (float)me->mNormals[k].y, (float)me->mNormals[k].z);
                /* Degenerate faces give zero or NaN normals: keep them finite (finalize rejects NaN). */
                if (!v3_finite(nn) || !(v3_len(nn) > 0.f)) nn = v3(0.f, 0.f, 0.f);
                else nn = v3_norm(nn);
                v3_store(n, nn);
            }
            if (want_uv) {
                float *t = s->uv + 2 * (vb + k);
                if (me->mTextureCoords[0]) {
                    t[0] = (float)me->mTextureCoords[0][k].x;
                    t[1] = (float)me->mTextureCoords[0][k].y;
                } else {
                    t[0] = t[1] = 0.f;
                }
            }
        }
        uint32_t mat = (uint32_t)(m0 + (me->mMaterialIndex < sc->mNumMaterials ? me->mMaterialIndex : 0));
        for (unsigned f = 0; f < me->mNumFaces; f++) {
            const struct aiFace *fc = &me->mFaces[f];
            if (fc->mNumIndices != 3) continue;
            for (int c = 0; c < 3; c++) {
                unsigned idx = fc->mIndices[c];
                if (idx >= me->mNumVertices) {
                    aiReleaseImport(sc);
                    return pgi__fail(PGI_ERR_PARSE, "%s: mesh %u face %u refers to vertex %u of %u", path, i, f, idx,
                                     me->mNumVertices);
                }
                s->tri[3 * tb + c] = (uint32_t)(vb + idx);
            }
            s->tri_mat[tb] = mat;
            tb++;
        }
        vb += me->mNumVertices;
    }
    aiReleaseImport(sc);
    if (keep_nrm) {
        /* Vertices whose normal Assimp left zero (degenerate input) take the face normal of a triangle using them. */
        for (size_t t = t0; t < tb; t++) {
            const uint32_t *ix = s->tri + 3 * t;
            pgi__v3 fn = v3_cross(v3_sub(pgi__scene_vertex(s, ix[1]), pgi__scene_vertex(s, ix[0])),
                                  v3_sub(pgi__scene_vertex(s, ix[2]), pgi__scene_vertex(s, ix[0])));
            for (int c = 0; c < 3; c++) {
                float *n = s->nrm + 3 * (size_t)ix[c];
                if (n[0] == 0.f && n[1] == 0.f && n[2] == 0.f) v3_store(n, v3_norm(fn));
            }
        }
    }
    s->nverts = vb;
    s->ntris = tb;
    return PGI_OK;
}
