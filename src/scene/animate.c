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

#include "light.h"
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
    return pgi__scene_grow_geometry(s, nv, nt, s->nrm != NULL, 0, 0, "adding an object");
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
        float th = PGI__PI * (float)i / (float)st;
        for (int j = 0; j <= sl; j++) {
            float ph = 2.f * PGI__PI * (float)j / (float)sl;
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
    if (a->loop == PGI__LOOP_REPEAT) {
        u = fmod(u, D);
        if (u < 0.0) u += D;
    } else if (a->loop == PGI__LOOP_PINGPONG) {
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
    float ax = deg[0] * (PGI__PI / 180.f), ay = deg[1] * (PGI__PI / 180.f), az = deg[2] * (PGI__PI / 180.f);
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
    /* Area lights' area and normal from their moved triangles, then every light's power as
     * pgi__scene_finalize sets it. */
    for (size_t i = 0; i < s->nlights; i++) {
        pgi__light *l = &s->lights[i];
        if (l->type == PGI__LIGHT_AREA) {
            const uint32_t *t = s->tri + 3 * (size_t)l->tri;
            pgi__v3 a = pgi__scene_vertex(s, t[0]), b = pgi__scene_vertex(s, t[1]), c = pgi__scene_vertex(s, t[2]);
            pgi__v3 n = v3_cross(v3_sub(b, a), v3_sub(c, a));
            l->area = 0.5f * v3_len(n);
            v3_store(l->normal, v3_norm(n));
        }
        pgi__light_set_power(l, diag);
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
                const pgi__light_kind *k = pgi__light_kind_of(l->type);
                return pgi__fail(PGI_ERR_PARSE,
                                 "%s: light %zu (%s) has a power of %g W, beyond %g (its intensity, irradiance or "
                                 "emission %g times %s)",
                                 what, i, k->name, (double)l->power[c], (double)PGI_MAX_LIGHT_POWER,
                                 (double)l->color[c], k->power_of);
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
    for (size_t i = 0; i < s->nlights; i++) n += s->lights[i].type != PGI__LIGHT_AREA;
    return n;
}

/* Material index of area group g (0-based among emissive materials that have triangles), or SIZE_MAX. */
static size_t area_group_material(const pgi_scene *s, size_t g) {
    for (size_t m = 0; m < s->nmats; m++) {
        int used = 0;
        for (size_t i = 0; i < s->nlights && !used; i++)
            used = s->lights[i].type == PGI__LIGHT_AREA && s->tri_mat[s->lights[i].tri] == m;
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
            if (l->type == PGI__LIGHT_AREA || k++ != i) continue;
            const pgi__light_kind *kind = pgi__light_kind_of(l->type);
            out->kind = (pgi_light_kind)kind->pub;
            out->name = kind->name;
            if (kind->fields & PGI__LIGHT_HAS_POS) memcpy(out->position, l->pos, sizeof out->position);
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
        if (l->type != PGI__LIGHT_AREA || s->tri_mat[l->tri] != m) continue;
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
            if (s->lights[j].type != PGI__LIGHT_AREA && k++ == i) memcpy(s->lights[j].pos, pos, 3 * sizeof(float));
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

/* ------------------------------------------------------------ light control */

/* Index into s->lights of explicit light group i (< explicit_lights(s)). */
static size_t explicit_light_index(const pgi_scene *s, size_t i) {
    size_t k = 0;
    for (size_t j = 0; j < s->nlights; j++)
        if (s->lights[j].type != PGI__LIGHT_AREA && k++ == i) return j;
    return SIZE_MAX;
}

static int finite_vec(const float *p, float lim) {
    return fabsf(p[0]) <= lim && fabsf(p[1]) <= lim && fabsf(p[2]) <= lim; /* false for NaN */
}

/* color x intensity, all 0 colour meaning white. */
static pgi_status light_radiance(const pgi_light_desc *ld, const char *what, float out[3]) {
    const int white = ld->color[0] == 0.f && ld->color[1] == 0.f && ld->color[2] == 0.f;
    if (!finite_vec(ld->color, 3.0e38f) || ld->color[0] < 0.f || ld->color[1] < 0.f || ld->color[2] < 0.f ||
        !(ld->intensity >= 0.f))
        return pgi__fail(PGI_ERR_INVALID_ARG, "%s: colour (%g, %g, %g) and intensity %g must be finite and >= 0", what,
                         (double)ld->color[0], (double)ld->color[1], (double)ld->color[2], (double)ld->intensity);
    for (int c = 0; c < 3; c++) {
        out[c] = (white ? 1.f : ld->color[c]) * ld->intensity;
        if (!(out[c] <= PGI_MAX_RADIANCE))
            return pgi__fail(PGI_ERR_INVALID_ARG, "%s: colour x intensity %g is out of range (0..%g)", what,
                             (double)out[c], (double)PGI_MAX_RADIANCE);
    }
    return PGI_OK;
}

pgi_status pgi__light_from_desc(const pgi_light_desc *ld, const char *what, pgi__light *l) {
    memset(l, 0, sizeof *l);
    const pgi__light_kind *k = pgi__light_kind_public((int)ld->kind);
    if (!k) {
        char names[128];
        return pgi__fail(PGI_ERR_INVALID_ARG, "%s: kind %d is not a %s light (area lights are emissive materials)",
                         what, (int)ld->kind, pgi__light_kind_list(names, sizeof names, 0, 1));
    }
    l->type = k->type;
    pgi_status st = light_radiance(ld, what, l->color);
    if (st) return st;
    if (!finite_vec(ld->position, (float)PGI_MAX_COORD) || !finite_vec(ld->direction, (float)PGI_MAX_COORD))
        return pgi__fail(PGI_ERR_INVALID_ARG,
                         "%s: position (%g, %g, %g) or direction is not finite or beyond the coordinate range "
                         "(-%g..%g)",
                         what, (double)ld->position[0], (double)ld->position[1], (double)ld->position[2],
                         (double)PGI_MAX_COORD, (double)PGI_MAX_COORD);
    if (k->fields & PGI__LIGHT_HAS_POS) memcpy(l->pos, ld->position, sizeof l->pos);
    if (k->fields & PGI__LIGHT_HAS_DIR) {
        pgi__v3 d = v3_load(ld->direction);
        if (!(v3_len(d) > 0.f))
            return pgi__fail(PGI_ERR_INVALID_ARG, "%s: a %s light needs a direction", what, k->name);
        v3_store(l->dir, v3_norm(d));
    }
    if (k->fields & PGI__LIGHT_HAS_CONE) {
        if (!(ld->cone_deg > 0.f && ld->cone_deg < 180.f))
            return pgi__fail(PGI_ERR_INVALID_ARG, "%s: %s cone half-angle %g is outside (0, 180) degrees", what,
                             k->name, (double)ld->cone_deg);
        l->cos_cutoff = cosf(ld->cone_deg * (PGI__PI / 180.f));
    }
    return PGI_OK;
}

/* Material m's emission ke, and the colour of every area light on its triangles. */
static void set_area_emission(pgi_scene *s, size_t m, const float ke[3]) {
    memcpy(s->mats[m].ke, ke, 3 * sizeof(float));
    for (size_t j = 0; j < s->nlights; j++)
        if (s->lights[j].type == PGI__LIGHT_AREA && s->tri_mat[s->lights[j].tri] == m)
            memcpy(s->lights[j].color, ke, 3 * sizeof(float));
}

/* After a change of the lights: powers recomputed and checked; on failure the lights (and the
 * materials, area groups) are put back from the copies given. */
static pgi_status lights_commit(pgi_scene *s, pgi__light *old_lights, size_t old_n, size_t mat, const float *old_ke) {
    pgi__scene_refresh(s);
    pgi_status st = pgi__scene_check_numbers(s, "pgi_scene_set_light");
    if (!st) {
        free(old_lights);
        return PGI_OK;
    }
    char msg[512];
    snprintf(msg, sizeof msg, "%s", pgi_last_error());
    if (old_lights) {
        free(s->lights);
        s->lights = old_lights;
        s->nlights = old_n;
    }
    if (old_ke) set_area_emission(s, mat, old_ke);
    pgi__scene_refresh(s);
    return pgi__fail(PGI_ERR_INVALID_ARG, "%s", msg);
}

static pgi__light *lights_copy(const pgi_scene *s) {
    pgi__light *c = malloc((s->nlights ? s->nlights : 1) * sizeof *c);
    if (c && s->nlights) memcpy(c, s->lights, s->nlights * sizeof *c);
    return c;
}

/* rgb as a colour (its largest component 1) and an intensity. */
static void split_radiance(const float rgb[3], float color[3], float *intensity) {
    const float m = fmaxf(rgb[0], fmaxf(rgb[1], rgb[2]));
    *intensity = m > 0.f ? m : 0.f;
    for (int c = 0; c < 3; c++) color[c] = m > 0.f ? rgb[c] / m : 1.f;
}

pgi_status pgi_scene_get_light(const pgi_scene *s, size_t group, pgi_light_desc *out) {
    if (!out) return pgi__fail(PGI_ERR_INVALID_ARG, "pgi_scene_get_light: NULL argument");
    pgi_light_group g;
    pgi_status st = pgi_scene_get_light_group(s, group, &g);
    if (st) return st;
    memset(out, 0, sizeof *out);
    out->kind = g.kind;
    if (g.kind == PGI_LIGHT_KIND_AREA) {
        memcpy(out->position, g.position, sizeof out->position);
        split_radiance(s->mats[area_group_material(s, group - explicit_lights(s))].ke, out->color, &out->intensity);
        return PGI_OK;
    }
    const pgi__light *l = &s->lights[explicit_light_index(s, group)];
    memcpy(out->position, l->pos, sizeof out->position);
    memcpy(out->direction, l->dir, sizeof out->direction);
    split_radiance(l->color, out->color, &out->intensity);
    if (pgi__light_kind_of(l->type)->fields & PGI__LIGHT_HAS_CONE)
        out->cone_deg = acosf(l->cos_cutoff) * (180.f / PGI__PI);
    return PGI_OK;
}

pgi_status pgi_scene_set_light(pgi_scene *s, size_t group, const pgi_light_desc *ld) {
    if (!ld) return pgi__fail(PGI_ERR_INVALID_ARG, "pgi_scene_set_light: NULL light");
    pgi_light_group g;
    pgi_status st = pgi_scene_get_light_group(s, group, &g);
    if (st) return st;
    char what[64];
    snprintf(what, sizeof what, "pgi_scene_set_light: light group %zu", group);
    if (ld->kind != g.kind)
        return pgi__fail(PGI_ERR_INVALID_ARG, "%s is a %s light; its kind cannot change (remove it and add one)", what,
                         g.kind == PGI_LIGHT_KIND_AREA ? "area" : g.name);
    if (g.kind == PGI_LIGHT_KIND_AREA) {
        float ke[3], old_ke[3];
        if ((st = light_radiance(ld, what, ke))) return st;
        const size_t m = area_group_material(s, group - explicit_lights(s));
        memcpy(old_ke, s->mats[m].ke, sizeof old_ke);
        set_area_emission(s, m, ke);
        return lights_commit(s, NULL, 0, m, old_ke);
    }
    pgi__light l;
    if ((st = pgi__light_from_desc(ld, what, &l))) return st;
    pgi__light *old = lights_copy(s);
    if (!old) return pgi__fail(PGI_ERR_OOM, "%s: out of memory", what);
    s->lights[explicit_light_index(s, group)] = l;
    return lights_commit(s, old, s->nlights, 0, NULL);
}

pgi_status pgi_scene_add_light(pgi_scene *s, const pgi_light_desc *ld, size_t *group) {
    if (!s || !ld) return pgi__fail(PGI_ERR_INVALID_ARG, "pgi_scene_add_light: NULL argument");
    pgi__light l;
    pgi_status st = pgi__light_from_desc(ld, "pgi_scene_add_light", &l);
    if (st) return st;
    pgi__light *old = lights_copy(s), *nl = old ? malloc((s->nlights + 1) * sizeof *nl) : NULL;
    if (!nl) {
        free(old);
        return pgi__fail(PGI_ERR_OOM, "pgi_scene_add_light: out of memory");
    }
    const size_t ne = explicit_lights(s), n = s->nlights; /* explicit lights come first */
    memcpy(nl, s->lights, ne * sizeof *nl);
    nl[ne] = l;
    memcpy(nl + ne + 1, s->lights + ne, (n - ne) * sizeof *nl);
    free(s->lights);
    s->lights = nl;
    s->nlights = n + 1;
    if ((st = lights_commit(s, old, n, 0, NULL))) return st;
    if (group) *group = ne;
    return PGI_OK;
}

pgi_status pgi_scene_remove_light(pgi_scene *s, size_t group) {
    pgi_light_group g;
    pgi_status st = pgi_scene_get_light_group(s, group, &g);
    if (st) return st;
    if (g.kind == PGI_LIGHT_KIND_AREA)
        return pgi__fail(PGI_ERR_UNSUPPORTED,
                         "pgi_scene_remove_light: light group %zu is an emissive material ('%s'); set its intensity "
                         "to 0 instead",
                         group, g.name);
    if (s->nlights == 1 && !s->env)
        return pgi__fail(PGI_ERR_INVALID_ARG,
                         "pgi_scene_remove_light: light group %zu is the scene's only light (set its intensity to 0, "
                         "or add another first)",
                         group);
    const size_t j = explicit_light_index(s, group);
    memmove(s->lights + j, s->lights + j + 1, (s->nlights - j - 1) * sizeof *s->lights);
    s->nlights--;
    pgi__scene_refresh(s);
    return PGI_OK;
}
