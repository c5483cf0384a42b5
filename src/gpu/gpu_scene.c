/* The scene on the GPU (gpu_scene.h): packing the scene's internals into the std430 arrays
 * scene.glsl reads, and keeping them in step with the scene's versions. */
#include "gpu/gpu_scene.h"
#include "gpu/gpu_estimator.h" /* pgi__gpu_lobe */

#include <math.h>
#include <string.h>

#include "scene/bsdf.h"
#include "scene/light.h"

struct pgi__gpu_scene {
    pgi__gpu *g;
    pgi__gpu_rays *rays;
    pgi__gpu_buffer *verts, *tris, *mats, *lobes, *lights, *area, *tex;
    pgi__gpu_buffer *emit; /* (gpu-trace) photon emission */
    uint32_t nemit;
    pgi__gpu_buffer *portals; /* the sky's direct light through the portals */
    uint32_t nportals;
    pgi__gpu_scene_push info;
    uint64_t static_version, dynamic_version, lights_hash;
};

/* FNV-1a over the lights, as progressive.c's picture_of: point and spot lights move
 * (pgi_scene_set_light_position) without touching the geometry's versions. */
static uint64_t lights_hash(const pgi_scene *s) {
    uint64_t h = 1469598103934665603ULL;
    const unsigned char *p = (const unsigned char *)s->lights;
    for (size_t i = 0; i < s->nlights * sizeof *s->lights; i++) h = (h ^ p[i]) * 1099511628211ULL;
    return h;
}

#define LUT_WORDS 256

/* Uploads n bytes of src (n 0: one zero entry of 16 words, a buffer must exist) into *b. */
static pgi_status upload(pgi__gpu *g, pgi__gpu_buffer **b, const void *src, size_t n, const char *what) {
    static const uint32_t zero[16];
    if (!src || !n) src = zero, n = sizeof zero;
    pgi_status st = pgi__gpu_buffer_reserve(g, b, n, what);
    return st ? st : pgi__gpu_upload(g, *b, 0, src, n);
}

static pgi_status check_scene(const pgi_scene *s) {
    if (s->env && s->env->rgb)
        return pgi__fail(PGI_ERR_UNSUPPORTED,
                         "the GPU frame does not support an environment map ('%s'): a constant sky only (use "
                         "--device cpu)",
                         s->env->path);
    if (s->ntris > UINT32_MAX / 4 || s->nverts > UINT32_MAX / 4 || s->nlights > UINT32_MAX / 4)
        return pgi__fail(PGI_ERR_UNSUPPORTED, "the GPU frame: the scene is too large (%zu triangles)", s->ntris);
    return PGI_OK;
}

/* (addition, gpu-trace) Photon emission: the lights' power and the light CDF of
 * src/photon/trace.c (the sky its last entry), the bounding sphere, the sky's frame. */
static pgi_status upload_emit(pgi__gpu_scene *gs, const pgi_scene *s) {
    const size_t nl = s->nlights + (s->env ? 1 : 0);
    pgi__gpu_emit *e = calloc(nl + 3, sizeof *e);
    if (!e) return pgi__fail(PGI_ERR_OOM, "%s", "out of memory packing the scene for the GPU");
    double total = 0.0;
    for (size_t i = 0; i < nl; i++) {
        const pgi__light *L = i < s->nlights ? &s->lights[i] : &s->env->light;
        memcpy(e[i].power, L->power, sizeof e[i].power);
        total += fmax(0.0, (double)v3_lum(v3_load(L->power)));
        e[i].cdf = (float)total; /* trace.c keeps the running sum as a float */
    }
    gs->nemit = 0;
    if (total > 0.0) {
        for (size_t i = 0; i < nl; i++) e[i].cdf = (float)(e[i].cdf / total);
        e[nl - 1].cdf = 1.f;
        gs->nemit = (uint32_t)nl;
    }
    for (int a = 0; a < 3; a++) e[nl].power[a] = 0.5f * (s->bmin[a] + s->bmax[a]);
    e[nl].cdf = 0.5f * pgi__scene_diagonal(s);
    if (s->env) {
        memcpy(e[nl + 1].power, s->env->fx, sizeof e[nl + 1].power);
        e[nl + 1].cdf = s->env->p_sky;
        memcpy(e[nl + 2].power, s->env->fz, sizeof e[nl + 2].power);
    }
    pgi_status st = upload(gs->g, &gs->emit, e, (nl + 3) * sizeof *e, "gpu_scene");
    free(e);
    return st;
}

/* The portals, as scene_internal.h keeps them (the direct pass, portal.glsl). */
static pgi_status upload_portals(pgi__gpu_scene *gs, const pgi_scene *s) {
    pgi__gpu_portal *q = calloc(s->nportals + 1, sizeof *q);
    if (!q) return pgi__fail(PGI_ERR_OOM, "%s", "out of memory packing the scene for the GPU");
    for (size_t i = 0; i < s->nportals; i++) {
        const pgi__portal *P = &s->portals[i];
        memcpy(q[i].o, P->o, sizeof q[i].o);
        memcpy(q[i].e1, P->e1, sizeof q[i].e1);
        memcpy(q[i].e2, P->e2, sizeof q[i].e2);
        memcpy(q[i].n, P->n, sizeof q[i].n);
        memcpy(q[i].centre, P->centre, sizeof q[i].centre);
        memcpy(q[i].d1, P->d1, sizeof q[i].d1);
        memcpy(q[i].d2, P->d2, sizeof q[i].d2);
        q[i].area = P->area;
        q[i].rect = P->rect ? 1u : 0u;
    }
    gs->nportals = (uint32_t)s->nportals;
    pgi_status st = upload(gs->g, &gs->portals, q, s->nportals * sizeof *q, "gpu_scene");
    free(q);
    return st;
}

/* Vertices, lights and the area CDF: what moves with the scene's geometry. */
static pgi_status upload_dynamic(pgi__gpu_scene *gs, const pgi_scene *s) {
    pgi__gpu *g = gs->g;
    pgi_status st = PGI_OK;
    pgi__gpu_vert *v = calloc(s->nverts + 1, sizeof *v);
    pgi__gpu_light *l = calloc(s->nlights + 1, sizeof *l);
    pgi__gpu_area *a = calloc(s->nlights + 1, sizeof *a);
    if (!v || !l || !a) {
        st = pgi__fail(PGI_ERR_OOM, "%s", "out of memory packing the scene for the GPU");
        goto done;
    }
    for (size_t i = 0; i < s->nverts; i++) {
        memcpy(v[i].pos, s->pos + 3 * i, 3 * sizeof(float));
        if (s->nrm) memcpy(v[i].nrm, s->nrm + 3 * i, 3 * sizeof(float));
        if (s->uv) {
            v[i].u = s->uv[2 * i];
            v[i].v = s->uv[2 * i + 1];
        }
        if (s->col) memcpy(v[i].col, s->col + 3 * i, 3 * sizeof(float));
        else v[i].col[0] = v[i].col[1] = v[i].col[2] = 1.f;
    }
    /* the area lights' pick table, pgi__direct's (pgi__light_area_cdf) */
    float *cdf = malloc((s->nlights + 1) * sizeof *cdf);
    size_t *idx = malloc((s->nlights + 1) * sizeof *idx);
    if (!cdf || !idx) {
        free(cdf);
        free(idx);
        st = pgi__fail(PGI_ERR_OOM, "%s", "out of memory packing the scene for the GPU");
        goto done;
    }
    for (size_t i = 0; i < s->nlights; i++) {
        const pgi__light *L = &s->lights[i];
        pgi__gpu_light *o = &l[i];
        memcpy(o->pos, L->pos, sizeof o->pos);
        memcpy(o->dir, L->dir, sizeof o->dir);
        memcpy(o->color, L->color, sizeof o->color);
        memcpy(o->normal, L->normal, sizeof o->normal);
        o->type = (uint32_t)L->type;
        o->cos_cutoff = L->cos_cutoff;
        o->area = L->area;
        o->tri = L->tri;
    }
    const size_t narea = pgi__light_area_cdf(s, cdf, idx);
    for (size_t k = 0; k < narea; k++) {
        a[k].cdf = cdf[k];
        a[k].light = (uint32_t)idx[k];
    }
    free(cdf);
    free(idx);
    if ((st = upload(g, &gs->verts, v, s->nverts * sizeof *v, "gpu_scene")) ||
        (st = upload(g, &gs->lights, l, s->nlights * sizeof *l, "gpu_scene")) ||
        (st = upload(g, &gs->area, a, narea * sizeof *a, "gpu_scene")))
        goto done;
    gs->info.nlights = (uint32_t)s->nlights;
    gs->info.narea = (uint32_t)narea;
    gs->info.eps = pgi__scene_epsilon(s);
    gs->static_version = s->static_version;
    gs->dynamic_version = s->dynamic_version;
    gs->lights_hash = lights_hash(s);
    if ((st = upload_emit(gs, s))) goto done;
    st = upload_portals(gs, s);
done:
    free(v);
    free(l);
    free(a);
    return st;
}

/* Triangles, materials, lobes, textures: fixed for the scene's life. */
static pgi_status upload_static(pgi__gpu_scene *gs, const pgi_scene *s) {
    pgi__gpu *g = gs->g;
    pgi_status st = PGI_OK;
    uint32_t *t = calloc(4 * (s->ntris + 1), sizeof *t);
    pgi__gpu_mat *m = calloc(s->nmats + 1, sizeof *m);
    pgi__gpu_lobe *lb = calloc(s->nmats + 1, sizeof *lb);
    size_t words = LUT_WORDS + 4 * s->ntexs;
    for (size_t i = 0; i < s->ntexs; i++)
        words += (size_t)s->texs[i].width * (size_t)s->texs[i].height + pgi__texture_mip_bytes(&s->texs[i]) / 4;
    uint32_t *tx = calloc(words + 1, sizeof *tx);
    if (!t || !m || !lb || !tx) {
        st = pgi__fail(PGI_ERR_OOM, "%s", "out of memory packing the scene for the GPU");
        goto done;
    }
    for (size_t i = 0; i < s->ntris; i++) {
        memcpy(t + 4 * i, s->tri + 3 * i, 3 * sizeof(uint32_t));
        t[4 * i + 3] = s->tri_mat[i];
    }
    for (size_t i = 0; i < s->nmats; i++) {
        const pgi__material *M = &s->mats[i];
        memcpy(m[i].kd, M->kd, sizeof m[i].kd);
        memcpy(m[i].ks, M->ks, sizeof m[i].ks);
        memcpy(m[i].ke, M->ke, sizeof m[i].ke);
        m[i].type = (uint32_t)M->type;
        m[i].ior = M->ior;
        /* without texture coordinates pgi__surface_texture reads at (0, 0), as scene.glsl */
        m[i].tex_kd = M->tex_kd >= 0 && (size_t)M->tex_kd < s->ntexs ? M->tex_kd : -1;
        if (pgi__mat_specular(M)) continue;
        pgi__lobe lo;
        pgi__lobe_of_material(M, &lo);
        pgi__gpu_lobe_pack(&lo, &lb[i]);
    }
    memcpy(tx, pgi__srgb8_texture_lut, LUT_WORDS * sizeof(float));
    size_t at = LUT_WORDS + 4 * s->ntexs;
    for (size_t i = 0; i < s->ntexs; i++) {
        const pgi__texture *T = &s->texs[i];
        uint32_t *d = tx + LUT_WORDS + 4 * i;
        const size_t n = T->rgba && T->width > 0 && T->height > 0 ? (size_t)T->width * (size_t)T->height : 0;
        d[0] = (uint32_t)at;
        d[1] = n ? (uint32_t)T->width : 0u; /* width 0: no texels, the lookup gives 1 (pgi__texture_lookup) */
        d[2] = n ? (uint32_t)T->height : 0u;
        /* the mip levels follow level 0, each max(1, w >> l) x max(1, h >> l) (scene.glsl tex_level) */
        int levels = 1;
        while (levels < T->levels && T->mip[levels]) levels++;
        d[3] = n ? (uint32_t)levels : 1u;
        for (size_t k = 0; k < n; k++) {
            const unsigned char *p = T->rgba + 4 * k;
            tx[at + k] = (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
        }
        at += n;
        for (int l = 1; n && l < levels; l++) {
            const size_t ln =
                (size_t)(T->width >> l > 0 ? T->width >> l : 1) * (size_t)(T->height >> l > 0 ? T->height >> l : 1);
            for (size_t k = 0; k < ln; k++) {
                const unsigned char *p = T->mip[l] + 4 * k;
                tx[at + k] = (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
            }
            at += ln;
        }
    }
    if ((st = upload(g, &gs->tris, t, 4 * s->ntris * sizeof *t, "gpu_scene")) ||
        (st = upload(g, &gs->mats, m, s->nmats * sizeof *m, "gpu_scene")) ||
        (st = upload(g, &gs->lobes, lb, s->nmats * sizeof *lb, "gpu_scene")) ||
        (st = upload(g, &gs->tex, tx, words * sizeof *tx, "gpu_textures")))
        goto done;
    gs->info.ntris = (uint32_t)s->ntris;
    gs->info.flags = (s->nrm ? PGI__GPU_SCENE_NORMALS : 0u) | (s->uv ? PGI__GPU_SCENE_UVS : 0u) |
                     (s->env ? PGI__GPU_SCENE_SKY : 0u) | (s->col ? PGI__GPU_SCENE_COLORS : 0u);
    if (s->env) {
        memcpy(gs->info.up, s->env->fy, sizeof gs->info.up);
        memcpy(gs->info.sky, s->env->sky, sizeof gs->info.sky);
        memcpy(gs->info.ground, s->env->ground, sizeof gs->info.ground);
    }
done:
    free(t);
    free(m);
    free(lb);
    free(tx);
    return st;
}

pgi_status pgi__gpu_scene_create(pgi__gpu *g, const pgi_scene *s, pgi__gpu_scene **out) {
    *out = NULL;
    pgi_status st = check_scene(s);
    if (st) return st;
    pgi__gpu_scene *gs = calloc(1, sizeof *gs);
    if (!gs) return pgi__fail(PGI_ERR_OOM, "%s", "out of memory for the GPU scene");
    gs->g = g;
    if ((st = pgi__gpu_rays_create(g, s, &gs->rays)) || (st = upload_static(gs, s)) || (st = upload_dynamic(gs, s))) {
        pgi__gpu_scene_destroy(gs);
        return st;
    }
    *out = gs;
    return PGI_OK;
}

void pgi__gpu_scene_destroy(pgi__gpu_scene *gs) {
    if (!gs) return;
    pgi__gpu_rays_destroy(gs->rays);
    pgi__gpu_buffer *b[] = {gs->verts, gs->tris, gs->mats, gs->lobes,  gs->lights,
                            gs->area,  gs->tex,  gs->emit, gs->portals};
    for (size_t i = 0; i < sizeof b / sizeof b[0]; i++) pgi__gpu_buffer_destroy(gs->g, b[i]);
    free(gs);
}

int pgi__gpu_scene_needs_update(const pgi__gpu_scene *gs, const pgi_scene *s) {
    return gs->static_version != s->static_version || gs->dynamic_version != s->dynamic_version ||
           gs->lights_hash != lights_hash(s) || pgi__gpu_rays_needs_update(gs->rays, s);
}

pgi_status pgi__gpu_scene_update(pgi__gpu_scene *gs, const pgi_scene *s) {
    pgi_status st;
    if (pgi__gpu_rays_needs_update(gs->rays, s) && (st = pgi__gpu_rays_update(gs->rays, s))) return st;
    return upload_dynamic(gs, s);
}

void pgi__gpu_scene_buffers(const pgi__gpu_scene *gs, pgi__gpu_buffer **out) {
    pgi__gpu_buffer *bvh[4];
    pgi__gpu_rays_buffers(gs->rays, bvh);
    pgi__gpu_buffer *b[PGI__GPU_SCENE_NBUF] = {bvh[0],   bvh[1],    bvh[2],     bvh[3],   gs->verts, gs->tris,
                                               gs->mats, gs->lobes, gs->lights, gs->area, gs->tex};
    memcpy(out, b, sizeof b);
}

void pgi__gpu_scene_info(const pgi__gpu_scene *gs, pgi__gpu_scene_push *out) { *out = gs->info; }

pgi__gpu_buffer *pgi__gpu_scene_lobes(const pgi__gpu_scene *gs) { return gs->lobes; }

pgi__gpu_rays *pgi__gpu_scene_rays(const pgi__gpu_scene *gs) { return gs->rays; }

pgi__gpu_buffer *pgi__gpu_scene_emit(const pgi__gpu_scene *gs, uint32_t *nemit) {
    *nemit = gs->nemit;
    return gs->emit;
}

pgi__gpu_buffer *pgi__gpu_scene_portals(const pgi__gpu_scene *gs, uint32_t *nportals) {
    *nportals = gs->nportals;
    return gs->portals;
}
