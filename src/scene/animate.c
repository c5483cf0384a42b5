/* Dynamic scenes: primitive objects added by scene descriptions, rigid
 * keyframed motions (pgi_scene_set_time), and light groups the viewer moves.
 *
 * The scene keeps one merged triangle mesh. An animation owns a set of
 * vertices and their rest positions; setting the time rewrites those
 * vertices in place, refreshes what depends on positions (bounds, area-light
 * geometry, light powers) and bumps a version counter, which the renderer
 * compares with the one its ray-tracing scene was built for. */
#include <stdio.h>
#include <string.h>

#include "scene_internal.h"

void pgi__scene_free_anims(pgi_scene *s) {
    for (size_t i = 0; i < s->nanims; i++) {
        free(s->anims[i].verts);
        free(s->anims[i].rest_pos);
        free(s->anims[i].rest_nrm);
        free(s->anims[i].keys);
    }
    free(s->anims);
    free(s->tri_dynamic);
    s->anims = NULL;
    s->nanims = 0;
    s->tri_dynamic = NULL;
}

/* ------------------------------------------------------------ geometry */

static pgi_status grow_arrays(pgi_scene *s, size_t nv, size_t nt) {
    size_t v = s->nverts + nv, t = s->ntris + nt;
    float *p = realloc(s->pos, v * 3 * sizeof *p);
    if (!p) return pgi__fail(PGI_ERR_OOM, "out of memory adding an object");
    s->pos = p;
    if (s->nrm) {
        float *n = realloc(s->nrm, v * 3 * sizeof *n);
        if (!n) return pgi__fail(PGI_ERR_OOM, "out of memory adding an object");
        s->nrm = n;
    }
    if (s->uv) {
        float *u = realloc(s->uv, v * 2 * sizeof *u);
        if (!u) return pgi__fail(PGI_ERR_OOM, "out of memory adding an object");
        s->uv = u;
        memset(s->uv + 2 * s->nverts, 0, nv * 2 * sizeof *u);
    }
    uint32_t *tr = realloc(s->tri, t * 3 * sizeof *tr);
    if (!tr) return pgi__fail(PGI_ERR_OOM, "out of memory adding an object");
    s->tri = tr;
    uint32_t *m = realloc(s->tri_mat, t * sizeof *m);
    if (!m) return pgi__fail(PGI_ERR_OOM, "out of memory adding an object");
    s->tri_mat = m;
    if (s->tri_dynamic) {
        uint8_t *d = realloc(s->tri_dynamic, t);
        if (!d) return pgi__fail(PGI_ERR_OOM, "out of memory adding an object");
        s->tri_dynamic = d;
        memset(s->tri_dynamic + s->ntris, 0, nt);
    }
    return PGI_OK;
}

static uint32_t put_vertex(pgi_scene *s, pgi__v3 p, pgi__v3 n) {
    v3_store(s->pos + 3 * s->nverts, p);
    if (s->nrm) v3_store(s->nrm + 3 * s->nverts, n);
    return (uint32_t)s->nverts++;
}

static void put_tri(pgi_scene *s, uint32_t a, uint32_t b, uint32_t c, uint32_t mat) {
    s->tri[3 * s->ntris] = a;
    s->tri[3 * s->ntris + 1] = b;
    s->tri[3 * s->ntris + 2] = c;
    s->tri_mat[s->ntris++] = mat;
}

#define SPHERE_SLICES 48
#define SPHERE_STACKS 24

pgi_status pgi__scene_add_sphere(pgi_scene *s, const float c[3], float r, uint32_t mat, size_t *first) {
    const int sl = SPHERE_SLICES, st = SPHERE_STACKS;
    pgi_status e = grow_arrays(s, (size_t)(sl + 1) * (st + 1), (size_t)sl * st * 2);
    if (e) return e;
    *first = s->ntris;
    uint32_t base = (uint32_t)s->nverts;
    pgi__v3 cc = v3_load(c);
    for (int i = 0; i <= st; i++) {
        float th = PGI_PI * (float)i / (float)st;
        for (int j = 0; j <= sl; j++) {
            float ph = 2.f * PGI_PI * (float)j / (float)sl;
            pgi__v3 n = v3(sinf(th) * cosf(ph), cosf(th), sinf(th) * sinf(ph));
            put_vertex(s, v3_madd(cc, n, r), n);
        }
    }
    for (int i = 0; i < st; i++)
        for (int j = 0; j < sl; j++) {
            uint32_t a = base + (uint32_t)(i * (sl + 1) + j), d = a + (uint32_t)(sl + 1);
            if (i > 0) put_tri(s, a, a + 1, d, mat);
            if (i < st - 1) put_tri(s, a + 1, d + 1, d, mat);
        }
    return PGI_OK;
}

pgi_status pgi__scene_add_box(pgi_scene *s, const float c[3], const float size[3], uint32_t mat, size_t *first) {
    pgi_status e = grow_arrays(s, 24, 12);
    if (e) return e;
    *first = s->ntris;
    pgi__v3 h = v3_scale(v3_load(size), 0.5f), cc = v3_load(c);
    /* Each face: normal axis a, sign sg; corners counter-clockwise seen from outside. */
    for (int a = 0; a < 3; a++)
        for (int sg = -1; sg <= 1; sg += 2) {
            int b = (a + 1) % 3, d = (a + 2) % 3;
            float n[3] = {0, 0, 0};
            n[a] = (float)sg;
            uint32_t idx[4];
            static const float cu[4] = {-1, 1, 1, -1}, cv[4] = {-1, -1, 1, 1};
            for (int k = 0; k < 4; k++) {
                float p[3];
                p[a] = sg * (&h.x)[a];
                p[b] = cu[k] * (&h.x)[b] * (float)sg;
                p[d] = cv[k] * (&h.x)[d];
                idx[k] = put_vertex(s, v3_add(cc, v3_load(p)), v3_load(n));
            }
            put_tri(s, idx[0], idx[1], idx[2], mat);
            put_tri(s, idx[0], idx[2], idx[3], mat);
        }
    return PGI_OK;
}

/* ------------------------------------------------------------ motions */

pgi_status pgi__scene_add_anim(pgi_scene *s, const char *name, const uint32_t *tris, size_t ntris, const float *pivot,
                               pgi__keyframe *keys, size_t nkeys, pgi__loop loop) {
    if (!s->tri_dynamic) {
        s->tri_dynamic = calloc(s->ntris ? s->ntris : 1, 1);
        if (!s->tri_dynamic) {
            free(keys);
            return pgi__fail(PGI_ERR_OOM, "out of memory for an animation");
        }
    }
    pgi__anim *na = realloc(s->anims, (s->nanims + 1) * sizeof *na);
    if (!na) {
        free(keys);
        return pgi__fail(PGI_ERR_OOM, "out of memory for an animation");
    }
    s->anims = na;
    pgi__anim *a = &s->anims[s->nanims];
    memset(a, 0, sizeof *a);
    snprintf(a->name, sizeof a->name, "%s", name ? name : "object");
    a->keys = keys;
    a->nkeys = nkeys;
    a->loop = loop;
    s->nanims++;
    /* Unique vertices of the triangles, in first-use order. */
    uint8_t *mark = calloc(s->nverts ? s->nverts : 1, 1);
    a->verts = malloc((ntris ? 3 * ntris : 1) * sizeof *a->verts);
    if (!mark || !a->verts) {
        free(mark);
        return pgi__fail(PGI_ERR_OOM, "out of memory for an animation");
    }
    for (size_t i = 0; i < ntris; i++) {
        uint32_t t = tris[i];
        if (s->tri_dynamic[t])
            return free(mark), pgi__fail(PGI_ERR_PARSE, "animation '%s': triangle %u already has a motion", a->name, t);
        s->tri_dynamic[t] = 1;
        for (int k = 0; k < 3; k++) {
            uint32_t v = s->tri[3 * (size_t)t + k];
            if (!mark[v]) {
                mark[v] = 1;
                a->verts[a->nverts++] = v;
            }
        }
    }
    free(mark);
    a->rest_pos = malloc((a->nverts ? a->nverts : 1) * 3 * sizeof(float));
    if (s->nrm) a->rest_nrm = malloc((a->nverts ? a->nverts : 1) * 3 * sizeof(float));
    if (!a->rest_pos || (s->nrm && !a->rest_nrm)) return pgi__fail(PGI_ERR_OOM, "out of memory for an animation");
    pgi__v3 lo = v3(INFINITY, INFINITY, INFINITY), hi = v3(-INFINITY, -INFINITY, -INFINITY);
    for (size_t i = 0; i < a->nverts; i++) {
        pgi__v3 p = pgi__scene_vertex(s, a->verts[i]);
        v3_store(a->rest_pos + 3 * i, p);
        if (a->rest_nrm) memcpy(a->rest_nrm + 3 * i, s->nrm + 3 * (size_t)a->verts[i], 3 * sizeof(float));
        lo = v3_min(lo, p);
        hi = v3_max(hi, p);
    }
    if (pivot) memcpy(a->pivot, pivot, sizeof a->pivot);
    else v3_store(a->pivot, a->nverts ? v3_scale(v3_add(lo, hi), 0.5f) : v3(0.f, 0.f, 0.f));
    /* Bounds at every time: a vertex lies within |pivot| + |translate| + scale * (its rest distance
     * from the pivot) of the origin, whatever the rotation; translate and scale are interpolated
     * linearly, so the largest reach is at a keyframe. */
    double reach0 = 0.0, far = 0.0;
    for (int c = 0; c < 3; c++) reach0 += (double)a->pivot[c] * a->pivot[c];
    reach0 = sqrt(reach0);
    for (size_t i = 0; i < a->nverts; i++) {
        double d2 = 0.0;
        for (int c = 0; c < 3; c++) {
            double d = (double)a->rest_pos[3 * i + c] - a->pivot[c];
            d2 += d * d;
        }
        if (d2 > far) far = d2;
    }
    far = sqrt(far);
    for (size_t i = 0; i < nkeys; i++) {
        double tr = 0.0;
        for (int c = 0; c < 3; c++) tr += (double)keys[i].translate[c] * keys[i].translate[c];
        double reach = reach0 + sqrt(tr) + (double)keys[i].scale * far;
        if (!(reach <= (double)PGI_MAX_COORD))
            return pgi__fail(PGI_ERR_PARSE,
                             "animation '%s': keyframe %zu (translate, scale %g) moves the object to %g from the "
                             "origin, beyond the coordinate range (-%g..%g)",
                             a->name, i, (double)keys[i].scale, reach, (double)PGI_MAX_COORD, (double)PGI_MAX_COORD);
    }
    return PGI_OK;
}

/* Keyframe values at time t (piecewise linear; loop mode outside the range). */
static void anim_eval(const pgi__anim *a, double t, pgi__keyframe *out) {
    const pgi__keyframe *k = a->keys;
    size_t n = a->nkeys;
    double t0 = k[0].t, t1 = k[n - 1].t, D = t1 - t0;
    if (n == 1 || !(D > 0.0)) {
        *out = k[0];
        return;
    }
    double u = t - t0;
    if (a->loop == PGI_LOOP_REPEAT) {
        u = fmod(u, D);
        if (u < 0.0) u += D;
    } else if (a->loop == PGI_LOOP_PINGPONG) {
        u = fmod(u, 2.0 * D);
        if (u < 0.0) u += 2.0 * D;
        if (u > D) u = 2.0 * D - u;
    } else {
        u = u < 0.0 ? 0.0 : u > D ? D : u;
    }
    double tt = t0 + u;
    size_t i = 0;
    while (i + 2 < n && tt >= k[i + 1].t) i++;
    double span = (double)k[i + 1].t - k[i].t;
    float w = span > 0.0 ? (float)((tt - k[i].t) / span) : 1.f;
    if (w < 0.f) w = 0.f;
    if (w > 1.f) w = 1.f;
    out->t = (float)tt;
    for (int c = 0; c < 3; c++) {
        out->translate[c] = k[i].translate[c] + w * (k[i + 1].translate[c] - k[i].translate[c]);
        out->rotate[c] = k[i].rotate[c] + w * (k[i + 1].rotate[c] - k[i].rotate[c]);
    }
    out->scale = k[i].scale + w * (k[i + 1].scale - k[i].scale);
}

/* Row-major R = Rz * Ry * Rx from degrees. */
static void euler_matrix(const float deg[3], float m[9]) {
    float ax = deg[0] * (PGI_PI / 180.f), ay = deg[1] * (PGI_PI / 180.f), az = deg[2] * (PGI_PI / 180.f);
    float cx = cosf(ax), sx = sinf(ax), cy = cosf(ay), sy = sinf(ay), cz = cosf(az), sz = sinf(az);
    m[0] = cz * cy;
    m[1] = cz * sy * sx - sz * cx;
    m[2] = cz * sy * cx + sz * sx;
    m[3] = sz * cy;
    m[4] = sz * sy * sx + cz * cx;
    m[5] = sz * sy * cx - cz * sx;
    m[6] = -sy;
    m[7] = cy * sx;
    m[8] = cy * cx;
}

static pgi__v3 mat_mul(const float m[9], pgi__v3 v) {
    return v3(m[0] * v.x + m[1] * v.y + m[2] * v.z, m[3] * v.x + m[4] * v.y + m[5] * v.z,
              m[6] * v.x + m[7] * v.y + m[8] * v.z);
}

static void anim_apply(pgi_scene *s, const pgi__anim *a, double t) {
    pgi__keyframe k;
    anim_eval(a, t, &k);
    float m[9];
    euler_matrix(k.rotate, m);
    pgi__v3 pv = v3_load(a->pivot), tr = v3_load(k.translate);
    for (size_t i = 0; i < a->nverts; i++) {
        pgi__v3 p = v3_scale(v3_sub(v3_load(a->rest_pos + 3 * i), pv), k.scale);
        v3_store(s->pos + 3 * (size_t)a->verts[i], v3_add(v3_add(pv, tr), mat_mul(m, p)));
        if (a->rest_nrm) v3_store(s->nrm + 3 * (size_t)a->verts[i], mat_mul(m, v3_load(a->rest_nrm + 3 * i)));
    }
}

void pgi__scene_refresh(pgi_scene *s) {
    pgi__v3 lo = v3(INFINITY, INFINITY, INFINITY), hi = v3(-INFINITY, -INFINITY, -INFINITY);
    for (size_t v = 0; v < s->nverts; v++) {
        pgi__v3 p = pgi__scene_vertex(s, (uint32_t)v);
        lo = v3_min(lo, p);
        hi = v3_max(hi, p);
    }
    v3_store(s->bmin, lo);
    v3_store(s->bmax, hi);
    float diag = v3_len(v3_sub(hi, lo));
    /* Same formulas as pgi__scene_finalize. */
    for (size_t i = 0; i < s->nlights; i++) {
        pgi__light *l = &s->lights[i];
        float k = 0.f;
        switch (l->type) {
        case PGI_LIGHT_POINT: k = 4.f * PGI_PI; break;
        case PGI_LIGHT_SPOT: k = 2.f * PGI_PI * (1.f - l->cos_cutoff); break;
        case PGI_LIGHT_SUN: {
            float R = 0.5f * diag;
            k = PGI_PI * R * R;
            break;
        }
        case PGI_LIGHT_AREA: {
            const uint32_t *t = s->tri + 3 * (size_t)l->tri;
            pgi__v3 a = pgi__scene_vertex(s, t[0]), b = pgi__scene_vertex(s, t[1]), c = pgi__scene_vertex(s, t[2]);
            pgi__v3 n = v3_cross(v3_sub(b, a), v3_sub(c, a));
            l->area = 0.5f * v3_len(n);
            v3_store(l->normal, v3_norm(n));
            k = PGI_PI * l->area;
            break;
        }
        case PGI_LIGHT_ENV: break;
        }
        for (int c = 0; c < 3; c++) l->power[c] = l->color[c] * k;
    }
    if (s->env) pgi__env_set_radius(s->env, 0.5f * diag);
}

pgi_status pgi_scene_set_time(pgi_scene *s, double t) {
    if (!s) return pgi__fail(PGI_ERR_INVALID_ARG, "pgi_scene_set_time: no scene");
    if (!isfinite(t)) return pgi__fail(PGI_ERR_INVALID_ARG, "scene time must be finite, got %g", t);
    if (s->nanims == 0 || t == s->time) {
        s->time = t;
        return PGI_OK;
    }
    s->time = t;
    for (size_t i = 0; i < s->nanims; i++) anim_apply(s, &s->anims[i], t);
    pgi__scene_refresh(s);
    s->dynamic_version++;
    return pgi__scene_check_numbers(s, s->source[0] ? s->source : s->name);
}

/* What every change of the geometry or the lights keeps (PGI_MAX_COORD, PGI_MAX_LIGHT_POWER): the
 * bounds within the coordinate range and each light's power a float below the limit (a sun's power
 * grows with the scene's cross-section). */
pgi_status pgi__scene_check_numbers(const pgi_scene *s, const char *what) {
    for (int c = 0; c < 3; c++)
        if (!(fabsf(s->bmin[c]) <= PGI_MAX_COORD) || !(fabsf(s->bmax[c]) <= PGI_MAX_COORD))
            return pgi__fail(PGI_ERR_PARSE,
                             "%s: the scene's bounds (%g, %g, %g) - (%g, %g, %g) reach beyond the coordinate range "
                             "(-%g..%g)",
                             what, (double)s->bmin[0], (double)s->bmin[1], (double)s->bmin[2], (double)s->bmax[0],
                             (double)s->bmax[1], (double)s->bmax[2], (double)PGI_MAX_COORD, (double)PGI_MAX_COORD);
    for (size_t i = 0; i < s->nlights; i++) {
        const pgi__light *l = &s->lights[i];
        for (int c = 0; c < 3; c++)
            if (!(l->power[c] <= PGI_MAX_LIGHT_POWER)) {
                static const char *const kinds[] = {"point", "spot", "sun", "area", "environment"};
                return pgi__fail(PGI_ERR_PARSE,
                                 "%s: light %zu (%s) has a power of %g W, beyond %g (its intensity, irradiance or "
                                 "emission %g times %s)",
                                 what, i, l->type <= PGI_LIGHT_ENV ? kinds[l->type] : "?", (double)l->power[c],
                                 (double)PGI_MAX_LIGHT_POWER, (double)l->color[c],
                                 l->type == PGI_LIGHT_SUN ? "the scene's cross-section" : "its solid angle or area");
            }
    }
    if (s->env)
        for (int c = 0; c < 3; c++)
            if (!(s->env->light.power[c] <= PGI_MAX_LIGHT_POWER))
                return pgi__fail(PGI_ERR_PARSE,
                                 "%s: the sky's power (its radiance times the scene's cross-section) is %g W, beyond "
                                 "%g",
                                 what, (double)s->env->light.power[c], (double)PGI_MAX_LIGHT_POWER);
    return PGI_OK;
}

/* ------------------------------------------------------------ light groups */

static size_t explicit_lights(const pgi_scene *s) {
    size_t n = 0;
    for (size_t i = 0; i < s->nlights; i++) n += s->lights[i].type != PGI_LIGHT_AREA;
    return n;
}

/* Material index of area group g (0-based among emissive materials that have triangles), or SIZE_MAX. */
static size_t area_group_material(const pgi_scene *s, size_t g) {
    for (size_t m = 0; m < s->nmats; m++) {
        int used = 0;
        for (size_t i = 0; i < s->nlights && !used; i++)
            used = s->lights[i].type == PGI_LIGHT_AREA && s->tri_mat[s->lights[i].tri] == m;
        if (used && g-- == 0) return m;
    }
    return SIZE_MAX;
}

size_t pgi_scene_light_group_count(const pgi_scene *s) {
    if (!s) return 0;
    size_t n = explicit_lights(s);
    while (area_group_material(s, n - explicit_lights(s)) != SIZE_MAX) n++;
    return n;
}

pgi_status pgi_scene_get_light_group(const pgi_scene *s, size_t i, pgi_light_group *out) {
    if (!s || !out) return pgi__fail(PGI_ERR_INVALID_ARG, "pgi_scene_get_light_group: NULL argument");
    memset(out, 0, sizeof *out);
    size_t ne = explicit_lights(s);
    if (i < ne) {
        size_t k = 0;
        for (size_t j = 0; j < s->nlights; j++) {
            const pgi__light *l = &s->lights[j];
            if (l->type == PGI_LIGHT_AREA || k++ != i) continue;
            static const char *const names[] = {"point", "spot", "sun"};
            out->kind = (pgi_light_kind)l->type;
            out->name = names[l->type];
            if (l->type != PGI_LIGHT_SUN) memcpy(out->position, l->pos, sizeof out->position);
            return PGI_OK;
        }
    }
    size_t m = i >= ne ? area_group_material(s, i - ne) : SIZE_MAX;
    if (m == SIZE_MAX)
        return pgi__fail(PGI_ERR_INVALID_ARG, "light group %zu does not exist (the scene has %zu)", i,
                         pgi_scene_light_group_count(s));
    out->kind = PGI_LIGHT_KIND_AREA;
    out->name = s->mats[m].name;
    pgi__v3 c = v3(0.f, 0.f, 0.f);
    double area = 0.0;
    for (size_t j = 0; j < s->nlights; j++) {
        const pgi__light *l = &s->lights[j];
        if (l->type != PGI_LIGHT_AREA || s->tri_mat[l->tri] != m) continue;
        const uint32_t *t = s->tri + 3 * (size_t)l->tri;
        pgi__v3 ctr =
            v3_scale(v3_add(v3_add(pgi__scene_vertex(s, t[0]), pgi__scene_vertex(s, t[1])), pgi__scene_vertex(s, t[2])),
                     1.f / 3.f);
        c = v3_madd(c, ctr, l->area);
        area += l->area;
        out->triangles++;
    }
    if (area > 0.0) c = v3_scale(c, (float)(1.0 / area));
    v3_store(out->position, c);
    return PGI_OK;
}

pgi_status pgi_scene_set_light_position(pgi_scene *s, size_t i, const float pos[3]) {
    pgi_light_group g;
    pgi_status st = pgi_scene_get_light_group(s, i, &g);
    if (st) return st;
    if (!pos || !(fabsf(pos[0]) <= PGI_MAX_COORD) || !(fabsf(pos[1]) <= PGI_MAX_COORD) ||
        !(fabsf(pos[2]) <= PGI_MAX_COORD))
        return pgi__fail(PGI_ERR_INVALID_ARG, "light position must be 3 numbers in -%g..%g, got (%g, %g, %g)",
                         (double)PGI_MAX_COORD, (double)PGI_MAX_COORD, pos ? (double)pos[0] : 0.0,
                         pos ? (double)pos[1] : 0.0, pos ? (double)pos[2] : 0.0);
    if (g.kind == PGI_LIGHT_KIND_SUN)
        return pgi__fail(PGI_ERR_UNSUPPORTED, "light group %zu is a sun (a direction, no position)", i);
    size_t ne = explicit_lights(s);
    if (i < ne) {
        size_t k = 0;
        for (size_t j = 0; j < s->nlights; j++)
            if (s->lights[j].type != PGI_LIGHT_AREA && k++ == i) memcpy(s->lights[j].pos, pos, 3 * sizeof(float));
        return PGI_OK;
    }
    size_t m = area_group_material(s, i - ne);
    pgi__v3 delta = v3_sub(v3_load(pos), v3_load(g.position));
    uint8_t *mark = calloc(s->nverts ? s->nverts : 1, 1);
    if (!mark) return pgi__fail(PGI_ERR_OOM, "out of memory moving a light");
    for (size_t t = 0; t < s->ntris; t++) {
        if (s->tri_mat[t] != m) continue;
        if (s->tri_dynamic && s->tri_dynamic[t]) {
            free(mark);
            return pgi__fail(PGI_ERR_UNSUPPORTED, "light '%s' is animated; it cannot also be moved by hand", g.name);
        }
        for (int k = 0; k < 3; k++) mark[s->tri[3 * t + k]] = 1;
    }
    for (size_t v = 0; v < s->nverts; v++)
        if (mark[v]) v3_store(s->pos + 3 * v, v3_add(pgi__scene_vertex(s, (uint32_t)v), delta));
    pgi__scene_refresh(s);
    if ((st = pgi__scene_check_numbers(s, "moving a light"))) { /* put it back */
        char msg[512];
        snprintf(msg, sizeof msg, "%s", pgi_last_error());
        for (size_t v = 0; v < s->nverts; v++)
            if (mark[v]) v3_store(s->pos + 3 * v, v3_sub(pgi__scene_vertex(s, (uint32_t)v), delta));
        pgi__scene_refresh(s);
        free(mark);
        return pgi__fail(PGI_ERR_INVALID_ARG, "%s", msg);
    }
    free(mark);
    s->static_version++;
    return PGI_OK;
}
