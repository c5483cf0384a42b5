/* Building geometry, and an engine's scene from arrays (pgi_scene_create) with its vertices
 * moved each frame (pgi_scene_update_positions).
 *
 * A scene from arrays goes the way a mesh file goes (load_assimp.c): its geometry is appended
 * through pgi__scene_grow_geometry, its normals stored through pgi__normal_clean and
 * pgi__scene_fix_normals, its textures through pgi__scene_add_texture, and pgi__scene_finalize
 * checks it and makes its area lights, so that the same arrays render alike from either. */
#include <stdio.h>
#include <string.h>

#include "core/mem.h"
#include "scene_internal.h"

/* realloc to n elements of `size` bytes (keeps *p on failure). */
static int grow(void *pp, size_t n, size_t size) {
    void **p = (void **)pp;
    void *q = realloc(*p, (n ? n : 1) * size);
    if (!q) return 0;
    *p = q;
    return 1;
}

pgi_status pgi__scene_grow_geometry(pgi_scene *s, size_t add_v, size_t add_t, int want_nrm, int want_uv, int want_col,
                                    const char *what) {
    const size_t nv = s->nverts + add_v, nt = s->ntris + add_t;
    const int keep_nrm = want_nrm && (s->nverts == 0 || s->nrm != NULL);
    const int had_uv = s->uv != NULL, keep_uv = want_uv || had_uv;
    const int had_col = s->col != NULL, keep_col = want_col || had_col;
    if (!grow(&s->pos, nv * 3, sizeof(float)) || !grow(&s->tri, nt * 3, sizeof(uint32_t)) ||
        !grow(&s->tri_mat, nt, sizeof(uint32_t)) || (keep_nrm && !grow(&s->nrm, nv * 3, sizeof(float))) ||
        (keep_uv && !grow(&s->uv, nv * 2, sizeof(float))) || (keep_col && !grow(&s->col, nv * 3, sizeof(float))) ||
        (s->tri_dynamic && !grow(&s->tri_dynamic, nt, 1)))
        return pgi__fail(PGI_ERR_OOM, "%s: out of memory for %zu vertices and %zu triangles", what, nv, nt);
    if (keep_uv) /* earlier geometry without UVs, and the new vertices until they are written: 0, 0 */
        memset(s->uv + 2 * (had_uv ? s->nverts : 0), 0, (had_uv ? add_v : nv) * 2 * sizeof(float));
    if (keep_col) /* earlier geometry without colours, and the new vertices until they are written: white */
        for (size_t i = 3 * (had_col ? s->nverts : 0); i < 3 * nv; i++) s->col[i] = 1.f;
    if (s->tri_dynamic) memset(s->tri_dynamic + s->ntris, 0, add_t);
    return PGI_OK;
}

void pgi__scene_fix_normals(pgi_scene *s, size_t t0, size_t t1) {
    if (!s->nrm) return;
    for (size_t t = t0; t < t1; t++) {
        const uint32_t *ix = s->tri + 3 * t;
        pgi__v3 fn = v3_cross(v3_sub(pgi__scene_vertex(s, ix[1]), pgi__scene_vertex(s, ix[0])),
                              v3_sub(pgi__scene_vertex(s, ix[2]), pgi__scene_vertex(s, ix[0])));
        for (int c = 0; c < 3; c++) {
            float *n = s->nrm + 3 * (size_t)ix[c];
            if (n[0] == 0.f && n[1] == 0.f && n[2] == 0.f) v3_store(n, v3_norm(fn));
        }
    }
}

/* ------------------------------------------------------------- checks */

static int finite_in_range(const float *p, int n) {
    for (int k = 0; k < n; k++)
        if (!(fabsf(p[k]) <= PGI_MAX_COORD)) return 0; /* false for NaN */
    return 1;
}

/* Positions (and normals, may be NULL) of n vertices: finite, within PGI_MAX_COORD. */
static pgi_status check_vertices(const char *what, size_t mesh, const float *pos, const float *nrm, size_t n) {
    for (size_t v = 0; v < n; v++) {
        const float *p = pos + 3 * v;
        if (!finite_in_range(p, 3))
            return pgi__fail(PGI_ERR_INVALID_ARG,
                             "%s: mesh %zu: vertex %zu at (%g, %g, %g) is not finite or beyond the coordinate range "
                             "(-%g..%g)",
                             what, mesh, v, (double)p[0], (double)p[1], (double)p[2], (double)PGI_MAX_COORD,
                             (double)PGI_MAX_COORD);
        if (nrm && !(isfinite(nrm[3 * v]) && isfinite(nrm[3 * v + 1]) && isfinite(nrm[3 * v + 2])))
            return pgi__fail(PGI_ERR_INVALID_ARG, "%s: mesh %zu: the normal of vertex %zu is not finite", what, mesh,
                             v);
    }
    return PGI_OK;
}

static pgi_status check_mesh(const pgi_scene_desc *d, size_t i) {
    const char *what = "pgi_scene_create";
    const pgi_mesh_desc *m = &d->meshes[i];
    if (m->vertex_count == 0 || m->triangle_count == 0 || !m->positions || !m->indices)
        return pgi__fail(PGI_ERR_INVALID_ARG, "%s: mesh %zu needs vertices (positions) and triangles (indices)", what,
                         i);
    if ((m->normals != NULL) != (d->meshes[0].normals != NULL))
        return pgi__fail(PGI_ERR_INVALID_ARG,
                         "%s: mesh %zu %s normals and mesh 0 %s: give them for every mesh or for none (flat shading)",
                         what, i, m->normals ? "has" : "has no", d->meshes[0].normals ? "has" : "has none");
    pgi_status st = check_vertices(what, i, m->positions, m->normals, m->vertex_count);
    if (st) return st;
    if (m->uvs)
        for (size_t v = 0; v < 2 * m->vertex_count; v++)
            if (!isfinite(m->uvs[v]))
                return pgi__fail(PGI_ERR_INVALID_ARG, "%s: mesh %zu: the uv of vertex %zu is not finite", what, i,
                                 v / 2);
    if (m->colors)
        for (size_t v = 0; v < 3 * m->vertex_count; v++)
            if (!(m->colors[v] >= 0.f && m->colors[v] <= 1.f)) /* false for NaN */
                return pgi__fail(PGI_ERR_INVALID_ARG, "%s: mesh %zu: the colour of vertex %zu is not in [0, 1] (%g)",
                                 what, i, v / 3, (double)m->colors[v]);
    for (size_t t = 0; t < m->triangle_count; t++) {
        for (int c = 0; c < 3; c++)
            if (m->indices[3 * t + c] >= m->vertex_count)
                return pgi__fail(PGI_ERR_INVALID_ARG, "%s: mesh %zu: triangle %zu refers to vertex %u of %zu", what, i,
                                 t, m->indices[3 * t + c], m->vertex_count);
        const uint32_t mat = m->materials ? m->materials[t] : m->material;
        if (mat >= d->material_count)
            return pgi__fail(PGI_ERR_INVALID_ARG, "%s: mesh %zu: triangle %zu has material %u of %zu", what, i, t, mat,
                             d->material_count);
    }
    return PGI_OK;
}

/* The arrays' bytes in the scene (geometry and decoded textures) against the budget. */
static pgi_status check_budget(const pgi_scene_desc *d, size_t nv, size_t nt) {
    const uint64_t budget = d->max_memory == PGI_MEMORY_UNLIMITED ? 0
                            : d->max_memory                       ? d->max_memory
                                                                  : pgi__mem_default_budget();
    int any_col = 0;
    for (size_t i = 0; i < d->mesh_count; i++) any_col |= d->meshes[i].colors != NULL;
    uint64_t need = (uint64_t)nv * (any_col ? 11u : 8u) * sizeof(float) + (uint64_t)nt * 5u * sizeof(uint32_t);
    for (size_t i = 0; i < d->texture_count; i++) {
        const uint64_t w = (uint64_t)d->textures[i].width, h = (uint64_t)d->textures[i].height;
        need += w * h * 4u + ((w + 3) / 4) * ((h + 3) / 4) * 64u;
    }
    if (!budget || need <= budget) return PGI_OK;
    char a[32], b[32];
    return pgi__fail(PGI_ERR_OOM,
                     "pgi_scene_create: %zu vertices, %zu triangles and %zu textures need %s, over the memory budget "
                     "of %s",
                     nv, nt, d->texture_count, pgi__mem_format(need, a, sizeof a),
                     pgi__mem_format(budget, b, sizeof b));
}

static pgi_status add_texture(pgi_scene *s, const pgi_texture_desc *t, size_t i) {
    char name[64];
    snprintf(name, sizeof name, "texture %zu", i);
    if (t->channels < 1 || t->channels > 4 || !t->pixels)
        return pgi__fail(PGI_ERR_INVALID_ARG, "pgi_scene_create: %s needs pixels of 1 to 4 channels (has %d)", name,
                         t->channels);
    pgi_status st = pgi__check_image_size(name, t->width, t->height);
    if (st) return st;
    const size_t n = (size_t)t->width * (size_t)t->height;
    unsigned char *rgba = malloc(n * 4);
    if (!rgba) return pgi__fail(PGI_ERR_OOM, "pgi_scene_create: out of memory for %s", name);
    const int c = t->channels;
    for (size_t k = 0; k < n; k++) {
        const unsigned char *p = t->pixels + (size_t)c * k;
        unsigned char *q = rgba + 4 * k;
        q[0] = p[0];
        q[1] = c >= 3 ? p[1] : p[0];
        q[2] = c >= 3 ? p[2] : p[0];
        q[3] = c == 2 ? p[1] : c == 4 ? p[3] : 255;
    }
    int index;
    return pgi__scene_add_texture(s, t->width, t->height, c, rgba, name, &index);
}

static float clamp01(float x) { return x > 0.f ? (x < 1.f ? x : 1.f) : 0.f; }

static pgi_status convert_material(const pgi_scene_desc *d, size_t i, pgi__material *m) {
    const pgi_material_desc *md = &d->materials[i];
    const char *what = "pgi_scene_create";
    memset(m, 0, sizeof *m);
    if (md->name) snprintf(m->name, sizeof m->name, "%s", md->name);
    else snprintf(m->name, sizeof m->name, "material %zu", i);
    const float *vals[] = {md->diffuse, md->specular, md->emission};
    for (int k = 0; k < 3; k++)
        for (int c = 0; c < 3; c++)
            if (!(vals[k][c] >= 0.f) || (k < 2 && vals[k][c] > 1.f) || (k == 2 && !(vals[k][c] <= PGI_MAX_RADIANCE)))
                return pgi__fail(PGI_ERR_INVALID_ARG, "%s: material %zu ('%s'): %s must be %s, got %g", what, i,
                                 m->name,
                                 k == 0   ? "diffuse"
                                 : k == 1 ? "specular"
                                          : "emission",
                                 k < 2 ? "in [0, 1] (a reflectance)" : "in [0, 1e12] (a radiance)", (double)vals[k][c]);
    if (!(md->shininess >= 0.f && md->shininess <= 10000.f))
        return pgi__fail(PGI_ERR_INVALID_ARG, "%s: material %zu ('%s'): shininess %g is outside 0..10000", what, i,
                         m->name, (double)md->shininess);
    if (!(md->ior == 0.f || (md->ior >= 1.f && md->ior <= 10.f)))
        return pgi__fail(PGI_ERR_INVALID_ARG, "%s: material %zu ('%s'): ior %g is outside 1..10 (0: default)", what, i,
                         m->name, (double)md->ior);
    if (md->diffuse_texture < 0 || (size_t)md->diffuse_texture > d->texture_count || md->alpha_texture < 0 ||
        (size_t)md->alpha_texture > d->texture_count)
        return pgi__fail(PGI_ERR_INVALID_ARG,
                         "%s: material %zu ('%s'): texture %d or %d of %zu (0: none, i + 1: "
                         "texture i)",
                         what, i, m->name, md->diffuse_texture, md->alpha_texture, d->texture_count);
    if (!(md->alpha_cutoff >= 0.f && md->alpha_cutoff <= 2.f))
        return pgi__fail(PGI_ERR_INVALID_ARG, "%s: material %zu ('%s'): alpha_cutoff %g is outside 0..2", what, i,
                         m->name, (double)md->alpha_cutoff);
    memcpy(m->kd, md->diffuse, sizeof m->kd);
    memcpy(m->ke, md->emission, sizeof m->ke);
    m->tex_kd = md->diffuse_texture - 1;
    m->tex_alpha = md->alpha_texture - 1;
    if (m->tex_kd >= 0 && !(m->kd[0] > 0.f || m->kd[1] > 0.f || m->kd[2] > 0.f))
        m->kd[0] = m->kd[1] = m->kd[2] = 1.f; /* a texture and no colour: the texture's */
    const int ks_zero = !(md->specular[0] > 0.f || md->specular[1] > 0.f || md->specular[2] > 0.f);
    for (int c = 0; c < 3; c++) m->ks[c] = clamp01(md->specular[c]);
    m->shininess = md->shininess;
    switch (md->type) {
    case PGI_MATERIAL_LAMBERT: m->type = PGI__MAT_LAMBERT; break;
    case PGI_MATERIAL_GLOSSY:
        m->type = PGI__MAT_PLASTIC;
        m->auto_glossy = 1;
        break;
    case PGI_MATERIAL_PLASTIC: m->type = PGI__MAT_PLASTIC; break;
    case PGI_MATERIAL_PHONG:
        m->type = PGI__MAT_PHONG;
        for (int c = 0; c < 3; c++)
            if (m->kd[c] + m->ks[c] > 1.f) m->kd[c] = 1.f - m->ks[c]; /* energy conservation, as for MTL */
        break;
    case PGI_MATERIAL_MIRROR: m->type = PGI__MAT_MIRROR; break;
    case PGI_MATERIAL_GLASS: m->type = PGI__MAT_GLASS; break;
    default:
        return pgi__fail(PGI_ERR_INVALID_ARG, "%s: material %zu ('%s'): unknown type %d", what, i, m->name,
                         (int)md->type);
    }
    if ((m->type == PGI__MAT_MIRROR || m->type == PGI__MAT_GLASS) && ks_zero) m->ks[0] = m->ks[1] = m->ks[2] = 1.f;
    /* the mesh loader's: glass and plastic 1.5 by default, the others 1 */
    m->ior = md->ior > 0.f ? md->ior : (m->type == PGI__MAT_GLASS || m->type == PGI__MAT_PLASTIC) ? 1.5f : 1.f;
    if (m->tex_alpha >= 0) m->alpha_cutoff = md->alpha_cutoff > 0.f ? md->alpha_cutoff : 0.5f;
    memcpy(m->kd_mesh, m->kd, sizeof m->kd_mesh);
    return PGI_OK;
}

pgi_status pgi_scene_create(const pgi_scene_desc *d, pgi_scene **out) {
    if (!out) return pgi__fail(PGI_ERR_INVALID_ARG, "pgi_scene_create: out is NULL");
    *out = NULL;
    pgi__clear_error();
    const char *what = "pgi_scene_create";
    if (!d || !d->meshes || d->mesh_count == 0)
        return pgi__fail(PGI_ERR_INVALID_ARG, "%s: the scene needs at least one mesh", what);
    if (!d->materials || d->material_count == 0)
        return pgi__fail(PGI_ERR_INVALID_ARG, "%s: the scene needs at least one material", what);
    if ((d->texture_count && !d->textures) || (d->light_count && !d->lights) || (d->camera_count && !d->cameras))
        return pgi__fail(PGI_ERR_INVALID_ARG, "%s: a count of textures, lights or cameras without its array", what);
    if (d->specular != PGI_SPECULAR_DEFAULT && d->specular != PGI_SPECULAR_GGX && d->specular != PGI_SPECULAR_PHONG)
        return pgi__fail(PGI_ERR_INVALID_ARG, "%s: unknown specular model %d", what, (int)d->specular);
    size_t nv = 0, nt = 0;
    pgi_status st;
    for (size_t i = 0; i < d->mesh_count; i++) {
        if ((st = check_mesh(d, i))) return st;
        nv += d->meshes[i].vertex_count;
        nt += d->meshes[i].triangle_count;
        if (nv > (size_t)UINT32_MAX || nt > (size_t)UINT32_MAX / 3)
            return pgi__fail(PGI_ERR_UNSUPPORTED, "%s: too many vertices or triangles (%zu, %zu; at most %u, %u)", what,
                             nv, nt, UINT32_MAX, UINT32_MAX / 3);
    }
    if ((st = check_budget(d, nv, nt))) return st;

    pgi_scene *s;
    if ((st = pgi__scene_new(d->name ? d->name : "memory", &s))) return st;
    snprintf(s->source, sizeof s->source, "memory");
    s->specular = d->specular;
    for (size_t i = 0; i < d->texture_count && !st; i++) st = add_texture(s, &d->textures[i], i);
    if (!st && !(s->mats = calloc(d->material_count, sizeof *s->mats)))
        st = pgi__fail(PGI_ERR_OOM, "%s: out of memory for %zu materials", what, d->material_count);
    for (size_t i = 0; i < d->material_count && !st; i++)
        if (!(st = convert_material(d, i, &s->mats[i]))) s->nmats = i + 1;
    for (size_t i = 0; i < d->material_count && !st; i++)
        if (s->mats[i].tex_alpha >= 0) pgi__texture_grey_alpha(&s->texs[s->mats[i].tex_alpha]);
    if (!st && !(s->meshes = calloc(d->mesh_count, sizeof *s->meshes)))
        st = pgi__fail(PGI_ERR_OOM, "%s: out of memory", what);
    int any_uv = 0, any_col = 0, any_dynamic = 0;
    for (size_t i = 0; i < d->mesh_count; i++) {
        any_uv |= d->meshes[i].uvs != NULL;
        any_col |= d->meshes[i].colors != NULL;
        any_dynamic |= d->meshes[i].dynamic != 0;
    }
    if (!st && any_dynamic && !(s->tri_dynamic = calloc(nt ? nt : 1, 1)))
        st = pgi__fail(PGI_ERR_OOM, "%s: out of memory", what);
    if (!st) st = pgi__scene_grow_geometry(s, nv, nt, d->meshes[0].normals != NULL, any_uv, any_col, what);
    for (size_t i = 0; i < d->mesh_count && !st; i++) {
        const pgi_mesh_desc *m = &d->meshes[i];
        pgi__mesh_range *r = &s->meshes[s->nmeshes++];
        *r = (pgi__mesh_range){s->nverts, m->vertex_count, s->ntris, m->triangle_count, m->dynamic != 0};
        memcpy(s->pos + 3 * r->v0, m->positions, 3 * r->nv * sizeof(float));
        if (s->nrm)
            for (size_t v = 0; v < r->nv; v++)
                v3_store(s->nrm + 3 * (r->v0 + v), pgi__normal_clean(v3_load(m->normals + 3 * v)));
        if (m->uvs) memcpy(s->uv + 2 * r->v0, m->uvs, 2 * r->nv * sizeof(float));
        if (m->colors) memcpy(s->col + 3 * r->v0, m->colors, 3 * r->nv * sizeof(float)); /* else white */
        for (size_t t = 0; t < r->nt; t++) {
            for (int c = 0; c < 3; c++) s->tri[3 * (r->t0 + t) + c] = (uint32_t)(r->v0 + m->indices[3 * t + c]);
            s->tri_mat[r->t0 + t] = m->materials ? m->materials[t] : m->material;
            if (r->dynamic) s->tri_dynamic[r->t0 + t] = 1;
        }
        s->nverts += r->nv;
        s->ntris += r->nt;
        pgi__scene_fix_normals(s, r->t0, s->ntris);
    }
    if (!st && d->light_count && !(s->lights = calloc(d->light_count, sizeof *s->lights)))
        st = pgi__fail(PGI_ERR_OOM, "%s: out of memory", what);
    for (size_t i = 0; i < d->light_count && !st; i++) {
        char w[64];
        snprintf(w, sizeof w, "%s: light %zu", what, i);
        if (!(st = pgi__light_from_desc(&d->lights[i], w, &s->lights[i]))) s->nlights = i + 1;
    }
    if (!st && d->camera_count) {
        if (!(s->cams = malloc(d->camera_count * sizeof *s->cams)))
            st = pgi__fail(PGI_ERR_OOM, "%s: out of memory", what);
        else {
            memcpy(s->cams, d->cameras, d->camera_count * sizeof *s->cams);
            s->ncams = d->camera_count;
        }
    }
    if (!st) st = pgi__scene_finalize(s, what);
    if (!st && s->nlights == 0)
        st = pgi__fail(PGI_ERR_INVALID_ARG,
                       "%s: the scene has no light: give an emissive material (with triangles of non-zero area) or "
                       "a point, spot or sun light",
                       what);
    if (st) {
        if (st == PGI_ERR_PARSE) st = PGI_ERR_INVALID_ARG; /* finalize's: the caller's arrays, not a file */
        pgi_scene_destroy(s);
        return st;
    }
    *out = s;
    return PGI_OK;
}

size_t pgi_scene_mesh_count(const pgi_scene *s) { return s ? s->nmeshes : 0; }

pgi_status pgi_scene_update_positions(pgi_scene *s, size_t mesh, const float *positions, const float *normals,
                                      size_t vertex_count) {
    const char *what = "pgi_scene_update_positions";
    if (!s || !positions) return pgi__fail(PGI_ERR_INVALID_ARG, "%s: NULL scene or positions", what);
    if (s->nmeshes == 0)
        return pgi__fail(PGI_ERR_UNSUPPORTED, "%s: the scene has no meshes (only pgi_scene_create's scenes have)",
                         what);
    if (mesh != PGI_ALL_MESHES && mesh >= s->nmeshes)
        return pgi__fail(PGI_ERR_INVALID_ARG, "%s: mesh %zu does not exist (the scene has %zu)", what, mesh,
                         s->nmeshes);
    if (normals && !s->nrm)
        return pgi__fail(PGI_ERR_INVALID_ARG, "%s: the scene was made without normals (flat-shaded)", what);
    const size_t m0 = mesh == PGI_ALL_MESHES ? 0 : mesh, m1 = mesh == PGI_ALL_MESHES ? s->nmeshes : mesh + 1;
    const pgi__mesh_range *first = &s->meshes[m0], *last = &s->meshes[m1 - 1];
    const size_t v0 = first->v0, nv = last->v0 + last->nv - v0;
    if (vertex_count != nv)
        return pgi__fail(PGI_ERR_INVALID_ARG, "%s: %zu vertices given, mesh%s %zu%s has %zu", what, vertex_count,
                         mesh == PGI_ALL_MESHES ? "es" : "", mesh == PGI_ALL_MESHES ? (size_t)0 : mesh,
                         mesh == PGI_ALL_MESHES ? " and on" : "", nv);
    pgi_status st = check_vertices(what, m0, positions, normals, nv);
    if (st) return st;
    int dynamic = 0, fixed = 0;
    for (size_t m = m0; m < m1; m++) {
        dynamic |= s->meshes[m].dynamic;
        fixed |= !s->meshes[m].dynamic;
    }
    /* The previous positions, kept in a buffer reused from frame to frame, so that a failed check
       (a light's power, the bounds) leaves the scene as it was. */
    if (s->update_backup_cap < 3 * nv) {
        if (!grow(&s->update_backup, 3 * nv, sizeof(float)))
            return pgi__fail(PGI_ERR_OOM, "%s: out of memory for %zu vertices", what, nv);
        s->update_backup_cap = 3 * nv;
    }
    memcpy(s->update_backup, s->pos + 3 * v0, 3 * nv * sizeof(float));
    memcpy(s->pos + 3 * v0, positions, 3 * nv * sizeof(float));
    pgi__scene_refresh(s);
    if ((st = pgi__scene_check_numbers(s, what))) {
        char msg[512];
        snprintf(msg, sizeof msg, "%s", pgi_last_error());
        memcpy(s->pos + 3 * v0, s->update_backup, 3 * nv * sizeof(float));
        pgi__scene_refresh(s);
        return pgi__fail(PGI_ERR_INVALID_ARG, "%s", msg);
    }
    if (normals) {
        for (size_t v = 0; v < nv; v++) v3_store(s->nrm + 3 * (v0 + v), pgi__normal_clean(v3_load(normals + 3 * v)));
        pgi__scene_fix_normals(s, first->t0, last->t0 + last->nt);
    }
    if (dynamic) s->dynamic_version++;
    if (fixed) s->static_version++;
    return PGI_OK;
}
