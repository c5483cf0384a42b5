/* Scene model: creation, validation, light set-up, loading dispatch. */
#include "scene_internal.h"
#include "core/mem.h"

#include "bsdf.h"
#include "light.h"

#include <dirent.h>
#include <errno.h>
#include <stdio.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>

pgi_status pgi__scene_new(const char *name, pgi_scene **out) {
    pgi_scene *s = calloc(1, sizeof *s);
    if (!s) return pgi__fail(PGI_ERR_OOM, "out of memory allocating a scene");
    snprintf(s->name, sizeof s->name, "%s", name ? name : "scene");
    snprintf(s->source, sizeof s->source, "built-in");
    *out = s;
    return PGI_OK;
}

void pgi_scene_destroy(pgi_scene *s) {
    if (!s) return;
    free(s->pos);
    free(s->nrm);
    free(s->uv);
    free(s->col);
    free(s->tri);
    free(s->tri_mat);
    free(s->mats);
    for (size_t i = 0; i < s->ntexs; i++) pgi__texture_free(&s->texs[i]);
    free(s->texs);
    free(s->lights);
    pgi__env_destroy(s->env);
    free(s->portals);
    free(s->cams);
    free(s->cam_names);
    free(s->meshes);
    free(s->update_backup);
    pgi__scene_free_anims(s);
    free(s);
}

pgi_status pgi__scene_add_camera(pgi_scene *s, const pgi_camera_def *def, const char *name) {
    pgi_camera_def *c = realloc(s->cams, (s->ncams + 1) * sizeof *c);
    if (!c) return pgi__fail(PGI_ERR_OOM, "out of memory for a camera");
    s->cams = c;
    if (name && *name && !s->cam_names) s->cam_names = calloc(s->ncams + 1, sizeof *s->cam_names);
    else if (s->cam_names) {
        char(*n)[64] = realloc(s->cam_names, (s->ncams + 1) * sizeof *n);
        if (n) s->cam_names = n;
        else {
            free(s->cam_names);
            s->cam_names = NULL;
        }
    }
    if (name && *name && !s->cam_names) return pgi__fail(PGI_ERR_OOM, "out of memory for a camera");
    if (s->cam_names) snprintf(s->cam_names[s->ncams], sizeof s->cam_names[0], "%s", name ? name : "");
    s->cams[s->ncams++] = *def;
    return PGI_OK;
}

void pgi__scene_warn(pgi_scene *s, const char *text) {
    if (!text || !*text) return;
    size_t n = strlen(s->warning);
    snprintf(s->warning + n, sizeof s->warning - n, "%s%s", n ? "; " : "", text);
}

static int finite3(const float *p) { return isfinite(p[0]) && isfinite(p[1]) && isfinite(p[2]); }

/* Within the coordinate range (PGI_MAX_COORD; false for NaN). */
static int in_range3(const float *p) {
    return fabsf(p[0]) <= PGI_MAX_COORD && fabsf(p[1]) <= PGI_MAX_COORD && fabsf(p[2]) <= PGI_MAX_COORD;
}

pgi_status pgi__scene_finalize(pgi_scene *s, const char *what) {
    if (s->ntris == 0) return pgi__fail(PGI_ERR_PARSE, "%s: the scene has no triangles", what);
    pgi_status sst = pgi_scene_set_specular(s, PGI_SPECULAR_DEFAULT); /* the description's "specular" */
    if (sst) return sst;
    pgi__sanitize(s->name); /* names come from files and are printed (info, messages, stats) */
    for (size_t m = 0; m < s->nmats; m++) pgi__sanitize(s->mats[m].name);
    for (size_t a = 0; a < s->nanims; a++) pgi__sanitize(s->anims[a].name);
    for (size_t c = 0; s->cam_names && c < s->ncams; c++) pgi__sanitize(s->cam_names[c]);
    pgi__sanitize(s->warning);
    float bmin[3] = {INFINITY, INFINITY, INFINITY}, bmax[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (size_t v = 0; v < s->nverts; v++) {
        const float *p = s->pos + 3 * v;
        if (!finite3(p))
            return pgi__fail(PGI_ERR_PARSE, "%s: vertex %zu has a non-finite coordinate (NaN or Inf)", what, v);
        if (!in_range3(p))
            return pgi__fail(PGI_ERR_PARSE, "%s: vertex %zu at (%g, %g, %g) is beyond the coordinate range (-%g..%g)",
                             what, v, (double)p[0], (double)p[1], (double)p[2], (double)PGI_MAX_COORD,
                             (double)PGI_MAX_COORD);
        if (s->nrm && !finite3(s->nrm + 3 * v))
            return pgi__fail(PGI_ERR_PARSE, "%s: normal of vertex %zu is not finite", what, v);
        for (int k = 0; k < 3; k++) {
            bmin[k] = fminf(bmin[k], p[k]);
            bmax[k] = fmaxf(bmax[k], p[k]);
        }
    }
    memcpy(s->bmin, bmin, sizeof bmin);
    memcpy(s->bmax, bmax, sizeof bmax);
    for (size_t t = 0; t < s->ntris; t++) {
        for (int k = 0; k < 3; k++)
            if (s->tri[3 * t + k] >= s->nverts)
                return pgi__fail(PGI_ERR_PARSE, "%s: triangle %zu refers to vertex %u of %zu", what, t,
                                 s->tri[3 * t + k], s->nverts);
        if (s->tri_mat[t] >= s->nmats)
            return pgi__fail(PGI_ERR_PARSE, "%s: triangle %zu has material %u of %zu", what, t, s->tri_mat[t],
                             s->nmats);
    }
    for (size_t m = 0; m < s->nmats; m++) {
        pgi__material *mt = &s->mats[m];
        if (!finite3(mt->kd) || !finite3(mt->ks) || !finite3(mt->ke) || !isfinite(mt->shininess) || !isfinite(mt->ior))
            return pgi__fail(PGI_ERR_PARSE, "%s: material '%s' has a non-finite value", what, mt->name);
        for (int c = 0; c < 3; c++)
            if (!(mt->ke[c] <= PGI_MAX_RADIANCE))
                return pgi__fail(PGI_ERR_PARSE,
                                 "%s: material '%s' has an emission of %g, out of range (0..%g, a radiance)", what,
                                 mt->name, (double)mt->ke[c], (double)PGI_MAX_RADIANCE);
        if (mt->tex_kd >= (int)s->ntexs)
            return pgi__fail(PGI_ERR_PARSE, "%s: material '%s' refers to a missing texture", what, mt->name);
        if (pgi__mat_masked(mt)) {
            if (!isfinite(mt->alpha_cutoff) || mt->tex_alpha < -1 || mt->tex_alpha >= (int)s->ntexs)
                return pgi__fail(PGI_ERR_PARSE, "%s: material '%s' has a bad cut-out mask", what, mt->name);
            /* Area lights emit from their whole triangles: an emitter is never cut out. */
            if (mt->ke[0] > 0.f || mt->ke[1] > 0.f || mt->ke[2] > 0.f) mt->alpha_cutoff = 0.f;
        }
        if (mt->type == PGI__MAT_PLASTIC) pgi__ggx_prepare(mt->ior); /* its albedo table, now rather than mid-render */
    }

    /* One area light per emissive triangle. */
    size_t narea = 0;
    for (size_t t = 0; t < s->ntris; t++) {
        const float *ke = s->mats[s->tri_mat[t]].ke;
        if (ke[0] > 0.f || ke[1] > 0.f || ke[2] > 0.f) narea++;
    }
    size_t nexplicit = 0;
    for (size_t i = 0; i < s->nlights; i++)
        if (s->lights[i].type != PGI__LIGHT_AREA) s->lights[nexplicit++] = s->lights[i];
    if (narea) {
        pgi__light *L = realloc(s->lights, (nexplicit + narea) * sizeof *L);
        if (!L) return pgi__fail(PGI_ERR_OOM, "%s: out of memory for %zu area lights", what, narea);
        s->lights = L;
    }
    s->nlights = nexplicit;
    for (size_t t = 0; t < s->ntris && narea; t++) {
        const float *ke = s->mats[s->tri_mat[t]].ke;
        if (!(ke[0] > 0.f || ke[1] > 0.f || ke[2] > 0.f)) continue;
        pgi__v3 a = pgi__scene_vertex(s, s->tri[3 * t]), b = pgi__scene_vertex(s, s->tri[3 * t + 1]),
                c = pgi__scene_vertex(s, s->tri[3 * t + 2]);
        pgi__v3 n = v3_cross(v3_sub(b, a), v3_sub(c, a));
        float area = 0.5f * v3_len(n);
        if (!(area > 0.f)) continue; /* degenerate triangles emit nothing */
        pgi__light *l = &s->lights[s->nlights++];
        memset(l, 0, sizeof *l);
        l->type = PGI__LIGHT_AREA;
        l->tri = (uint32_t)t;
        l->area = area;
        v3_store(l->normal, v3_norm(n));
        memcpy(l->color, ke, sizeof l->color);
    }

    float diag = v3_len(v3_sub(v3_load(bmax), v3_load(bmin)));
    for (size_t i = 0; i < s->nlights; i++) {
        pgi__light *l = &s->lights[i];
        if (!finite3(l->color) || l->color[0] < 0.f || l->color[1] < 0.f || l->color[2] < 0.f)
            return pgi__fail(PGI_ERR_PARSE, "%s: light %zu has a negative or non-finite colour", what, i);
        if (!finite3(l->pos) || !finite3(l->dir))
            return pgi__fail(PGI_ERR_PARSE, "%s: light %zu has a non-finite position or direction", what, i);
        if (!in_range3(l->pos) || !in_range3(l->dir))
            return pgi__fail(PGI_ERR_PARSE,
                             "%s: light %zu has a position (%g, %g, %g) or direction beyond the coordinate range "
                             "(-%g..%g)",
                             what, i, (double)l->pos[0], (double)l->pos[1], (double)l->pos[2], (double)PGI_MAX_COORD,
                             (double)PGI_MAX_COORD);
        for (int c = 0; c < 3; c++)
            if (!(l->color[c] <= PGI_MAX_RADIANCE))
                return pgi__fail(PGI_ERR_PARSE,
                                 "%s: light %zu has an intensity or irradiance of %g, out of range (0..%g)", what, i,
                                 (double)l->color[c], (double)PGI_MAX_RADIANCE);
        if (l->type == PGI__LIGHT_ENV)
            return pgi__fail(PGI_ERR_PARSE, "%s: light %zu: the environment is not a light", what, i);
        const pgi__light_kind *k = pgi__light_kind_of(l->type);
        if ((k->fields & PGI__LIGHT_HAS_CONE) && !(l->cos_cutoff > -1.f && l->cos_cutoff < 1.f))
            return pgi__fail(PGI_ERR_PARSE, "%s: %s light %zu needs a cut-off angle in (0, 180) degrees", what, k->name,
                             i);
        if (k->fields & PGI__LIGHT_HAS_DIR) {
            if (!(v3_len(v3_load(l->dir)) > 0.f))
                return pgi__fail(PGI_ERR_PARSE, "%s: %s light %zu has a zero direction", what, k->name, i);
            v3_store(l->dir, v3_norm(v3_load(l->dir)));
        }
        pgi__light_set_power(l, diag);
    }
    if (s->env) pgi__env_set_radius(s->env, 0.5f * diag); /* photons leave a disk covering the bounding sphere */

    if (s->ncams == 0) {
        /* Default view: from +z outside the bounds towards the centre. */
        s->cams = calloc(1, sizeof *s->cams);
        if (!s->cams) return pgi__fail(PGI_ERR_OOM, "%s: out of memory", what);
        s->ncams = 1;
        pgi__v3 c = v3_scale(v3_add(v3_load(bmin), v3_load(bmax)), 0.5f);
        pgi__v3 e = v3(c.x, c.y, bmax[2] + 1.2f * fmaxf(bmax[0] - bmin[0], bmax[1] - bmin[1]));
        v3_store(s->cams[0].eye, e);
        v3_store(s->cams[0].look_at, c);
        v3_store(s->cams[0].up, v3(0.f, 1.f, 0.f));
        s->cams[0].fov_y_deg = 50.f;
        s->cams_auto = 1;
    }
    for (size_t i = 0; i < s->ncams; i++) {
        pgi_camera_def *cd = &s->cams[i];
        if (!finite3(cd->eye) || !finite3(cd->look_at) || !finite3(cd->up) ||
            !(v3_len(v3_sub(v3_load(cd->look_at), v3_load(cd->eye))) > 0.f) ||
            !(v3_len(v3_cross(v3_sub(v3_load(cd->look_at), v3_load(cd->eye)), v3_load(cd->up))) > 0.f))
            return pgi__fail(PGI_ERR_PARSE, "%s: camera %zu is degenerate (eye = look-at, or up parallel to the view)",
                             what, i);
        if (!in_range3(cd->eye) || !in_range3(cd->look_at) || !in_range3(cd->up))
            return pgi__fail(PGI_ERR_PARSE,
                             "%s: camera %zu: eye (%g, %g, %g), look-at or up is beyond the coordinate range (-%g..%g)",
                             what, i, (double)cd->eye[0], (double)cd->eye[1], (double)cd->eye[2], (double)PGI_MAX_COORD,
                             (double)PGI_MAX_COORD);
        if (!(cd->fov_y_deg > 0.f && cd->fov_y_deg < 180.f))
            return pgi__fail(PGI_ERR_PARSE, "%s: camera %zu field of view %g is outside (0, 180) degrees", what, i,
                             cd->fov_y_deg);
    }
    return pgi__scene_check_numbers(s, what);
}

size_t pgi__scene_emissive_triangles(const pgi_scene *s) {
    size_t n = 0;
    for (size_t t = 0; t < s->ntris; t++) {
        const float *ke = s->mats[s->tri_mat[t]].ke;
        n += ke[0] > 0.f || ke[1] > 0.f || ke[2] > 0.f;
    }
    return n;
}

float pgi__scene_diagonal(const pgi_scene *s) { return v3_len(v3_sub(v3_load(s->bmax), v3_load(s->bmin))); }

float pgi__scene_epsilon(const pgi_scene *s) { return fmaxf(1e-5f, 1e-5f * pgi__scene_diagonal(s)); }

static int file_exists(const char *p) {
    struct stat st;
    return stat(p, &st) == 0 && S_ISREG(st.st_mode);
}

static int ends_with(const char *s, const char *suffix) {
    size_t n = strlen(s), m = strlen(suffix);
    return n >= m && strcasecmp(s + n - m, suffix) == 0;
}

/* Folders a bare scene name is looked up in, as <folder>/<name>.json: the working directory's
 * scenes/ (a local description wins), the source tree's (PGI__SOURCE_DIR: a build run from
 * anywhere), the installed one (PGI__DATADIR, e.g. /usr/local/share/photongi). */
static const char *const k_scene_dirs[] = {"scenes",
#ifdef PGI__SOURCE_DIR
                                           PGI__SOURCE_DIR "/scenes",
#endif
#ifdef PGI__DATADIR
                                           PGI__DATADIR "/scenes",
#endif
                                           NULL};

/* The named scenes of the scene folders (x.json -> x), sorted, each once, after the built-ins. */
typedef char scene_name[64];
static int cmp_names(const void *a, const void *b) { return strcmp(a, b); }
static void list_scene_names(char *names, size_t cap) {
    scene_name found[64];
    size_t n = 0;
    for (int i = 0; k_scene_dirs[i]; i++) {
        DIR *d = opendir(k_scene_dirs[i]);
        if (!d) continue;
        for (struct dirent *e; n < 64 && (e = readdir(d));) {
            size_t l = strlen(e->d_name);
            if (l > 5 && l - 5 < sizeof found[0] && strcmp(e->d_name + l - 5, ".json") == 0)
                snprintf(found[n++], sizeof found[0], "%.*s", (int)(l - 5), e->d_name);
        }
        closedir(d);
    }
    qsort(found, n, sizeof found[0], cmp_names);
    for (int i = 0; pgi__builtin_names[i]; i++) pgi__list_append(names, cap, pgi__builtin_names[i]);
    for (size_t i = 0; i < n; i++)
        if (i == 0 || strcmp(found[i], found[i - 1]) != 0) pgi__list_append(names, cap, found[i]);
}

static _Thread_local uint64_t g_load_budget; /* 0: the default budget */

uint64_t pgi__scene_load_budget(void) {
    if (g_load_budget == PGI_MEMORY_UNLIMITED) return 0;
    return g_load_budget ? g_load_budget : pgi__mem_default_budget();
}

static pgi_status scene_load(const char *spec, pgi_scene **out);

pgi_status pgi_scene_load_budget(const char *spec, uint64_t max_memory, pgi_scene **out) {
    const uint64_t saved = g_load_budget;
    g_load_budget = max_memory ? max_memory : pgi__mem_default_budget(); /* read once a load */
    pgi_status st = scene_load(spec, out);
    g_load_budget = saved;
    return st;
}

pgi_status pgi_scene_load(const char *spec, pgi_scene **out) { return pgi_scene_load_budget(spec, 0, out); }

static pgi_status scene_load(const char *spec, pgi_scene **out) {
    if (!out) return pgi__fail(PGI_ERR_INVALID_ARG, "pgi_scene_load: out is NULL");
    *out = NULL;
    if (!spec || !*spec) return pgi__fail(PGI_ERR_INVALID_ARG, "no scene given");
    pgi__clear_error();
    for (int i = 0; pgi__builtin_names[i]; i++)
        if (strcmp(spec, pgi__builtin_names[i]) == 0) return pgi__scene_builtin(spec, out);
    if (ends_with(spec, ".json")) return pgi__scene_load_json(spec, out);
    if (!strchr(spec, '/') && !strchr(spec, '.')) {
        /* A bare name: a description <dir>/<name>.json of a scene folder (k_scene_dirs). */
        char path[4096], dirs[1024] = "", names[512] = "";
        for (int i = 0; k_scene_dirs[i]; i++) {
            snprintf(path, sizeof path, "%s/%s.json", k_scene_dirs[i], spec);
            if (file_exists(path)) return pgi__scene_load_json(path, out);
            pgi__list_append(dirs, sizeof dirs, k_scene_dirs[i]);
        }
        list_scene_names(names, sizeof names);
        return pgi__fail(PGI_ERR_INVALID_ARG,
                         "unknown scene '%s': not a built-in scene and no %s.json in %s (scenes: %s; or give a path "
                         "to a .json description or a mesh)",
                         spec, spec, dirs, names);
    }
    const char *why = pgi__not_regular_file(spec);
    if (why) return pgi__fail(PGI_ERR_IO, "%s: %s", spec, why);
    const char *base = strrchr(spec, '/');
    pgi_scene *s = NULL;
    pgi_status st = pgi__scene_new(base ? base + 1 : spec, &s);
    if (st) return st;
    snprintf(s->source, sizeof s->source, "%s", spec);
    st = pgi__scene_import_mesh(s, spec);
    if (!st) st = pgi__scene_finalize(s, spec);
    if (!st && s->nlights == 0 && pgi__scene_emissive_triangles(s) > 0)
        st = pgi__fail(PGI_ERR_PARSE,
                       "%s: the emissive triangles (%zu, MTL Ke) all have zero area, so nothing emits; a bare mesh "
                       "cannot name other lights: write a .json scene description with a \"lights\" list",
                       spec, pgi__scene_emissive_triangles(s));
    else if (!st && s->nlights == 0)
        st = pgi__fail(PGI_ERR_PARSE,
                       "%s: the file has no lights: no emissive material%s and no light of its own%s; write a .json "
                       "scene description with a \"lights\" list (docs/scene-format.md)",
                       spec,
                       ends_with(spec, ".obj")                               ? " (MTL Ke)"
                       : ends_with(spec, ".gltf") || ends_with(spec, ".glb") ? " (emissiveFactor)"
                                                                             : "",
                       ends_with(spec, ".gltf") || ends_with(spec, ".glb")  ? " (KHR_lights_punctual)"
                       : ends_with(spec, ".obj") || ends_with(spec, ".ply") ? " (the format has none)"
                                                                            : "");
    if (st) {
        pgi_scene_destroy(s);
        return st;
    }
    *out = s;
    return PGI_OK;
}

void pgi_scene_get_info(const pgi_scene *s, pgi_scene_info *o) {
    memset(o, 0, sizeof *o);
    o->name = s->name;
    o->source = s->source;
    o->triangles = s->ntris;
    o->vertices = s->nverts;
    o->materials = s->nmats;
    o->textures = s->ntexs;
    for (size_t m = 0; m < s->nmats; m++) o->cutout_materials += pgi__mat_masked(&s->mats[m]);
    o->lights = s->nlights;
    for (size_t i = 0; i < s->nlights; i++) { /* each type's count (light.c's table) */
        const size_t at = pgi__light_kind_of(s->lights[i].type)->count_at;
        if (at) ++*(size_t *)((char *)o + at);
    }
    o->sky_lights = s->env ? 1 : 0;
    o->portals = s->nportals;
    o->lights += o->sky_lights;
    memcpy(o->bounds_min, s->bmin, sizeof o->bounds_min);
    memcpy(o->bounds_max, s->bmax, sizeof o->bounds_max);
    o->cameras = s->ncams;
    o->warnings = s->warning;
    if (s->ncams) o->camera = s->cams[0];
    o->camera_auto = s->cams_auto;
    o->defaults = s->defaults;
    o->surface_area = pgi__scene_area(s);
    o->specular = PGI_SPECULAR_GGX;
    for (size_t m = 0; m < s->nmats; m++) {
        if (!s->mats[m].auto_glossy) continue;
        o->glossy_materials++;
        if (s->mats[m].type == PGI__MAT_PHONG) o->specular = PGI_SPECULAR_PHONG;
    }
    o->animated_objects = s->nanims;
    for (size_t i = 0; i < s->nanims; i++) {
        const pgi__anim *a = &s->anims[i];
        if (a->nkeys && a->keys[a->nkeys - 1].t > o->anim_duration) o->anim_duration = a->keys[a->nkeys - 1].t;
    }
}

pgi_status pgi_scene_set_specular(pgi_scene *s, pgi_specular model) {
    if (!s) return pgi__fail(PGI_ERR_INVALID_ARG, "pgi_scene_set_specular: NULL scene");
    if (model == PGI_SPECULAR_DEFAULT) model = s->specular != PGI_SPECULAR_DEFAULT ? s->specular : PGI_SPECULAR_GGX;
    if (model != PGI_SPECULAR_GGX && model != PGI_SPECULAR_PHONG)
        return pgi__fail(PGI_ERR_INVALID_ARG, "pgi_scene_set_specular: unknown model %d", (int)model);
    for (size_t m = 0; m < s->nmats; m++) {
        pgi__material *mt = &s->mats[m];
        if (!mt->auto_glossy) continue;
        memcpy(mt->kd, mt->kd_mesh, sizeof mt->kd);
        if (model == PGI_SPECULAR_PHONG) {
            mt->type = PGI__MAT_PHONG;
            for (int c = 0; c < 3; c++)
                if (mt->kd[c] + mt->ks[c] > 1.f) mt->kd[c] = 1.f - mt->ks[c]; /* energy conservation */
        } else {
            mt->type = PGI__MAT_PLASTIC;
            pgi__ggx_prepare(mt->ior);
        }
    }
    return PGI_OK;
}

size_t pgi_builtin_scene_count(void) {
    size_t n = 0;
    while (pgi__builtin_names[n]) n++;
    return n;
}

const char *pgi_builtin_scene_name(size_t i) { return i < pgi_builtin_scene_count() ? pgi__builtin_names[i] : NULL; }

pgi_status pgi_scene_get_camera(const pgi_scene *s, size_t i, pgi_camera_def *out) {
    if (!s || !out) return pgi__fail(PGI_ERR_INVALID_ARG, "pgi_scene_get_camera: NULL argument");
    if (i >= s->ncams)
        return pgi__fail(PGI_ERR_INVALID_ARG, "camera %zu does not exist (the scene has %zu)", i, s->ncams);
    *out = s->cams[i];
    return PGI_OK;
}

const char *pgi_scene_camera_name(const pgi_scene *s, size_t i) {
    return s && s->cam_names && i < s->ncams ? s->cam_names[i] : "";
}

pgi_status pgi_scene_find_camera(const pgi_scene *s, const char *name, size_t *index) {
    if (!s || !name || !index) return pgi__fail(PGI_ERR_INVALID_ARG, "pgi_scene_find_camera: NULL argument");
    char *end;
    errno = 0;
    unsigned long long k = *name >= '0' && *name <= '9' ? strtoull(name, &end, 10) : 0;
    if (*name >= '0' && *name <= '9' && !*end && errno == 0) {
        if (k >= s->ncams)
            return pgi__fail(PGI_ERR_INVALID_ARG, "camera %s does not exist (the scene has %zu, 0..%zu)", name,
                             s->ncams, s->ncams - 1);
        *index = (size_t)k;
        return PGI_OK;
    }
    for (size_t i = 0; s->cam_names && i < s->ncams; i++)
        if (strcmp(s->cam_names[i], name) == 0) return *index = i, PGI_OK;
    char list[1024] = "";
    for (size_t i = 0; i < s->ncams; i++) {
        char one[96];
        const char *n = pgi_scene_camera_name(s, i);
        if (*n) snprintf(one, sizeof one, "%zu '%.64s'", i, n);
        else snprintf(one, sizeof one, "%zu (unnamed)", i);
        pgi__list_append(list, sizeof list, one);
    }
    return pgi__fail(PGI_ERR_INVALID_ARG, "no camera named '%s' in scene %s; its cameras: %s", name, s->name, list);
}

double pgi__scene_area(const pgi_scene *s) {
    double a = 0.0;
    for (size_t t = 0; t < s->ntris; t++) {
        const uint32_t *v = s->tri + 3 * t;
        pgi__v3 p0 = pgi__scene_vertex(s, v[0]), p1 = pgi__scene_vertex(s, v[1]), p2 = pgi__scene_vertex(s, v[2]);
        a += 0.5 * (double)v3_len(v3_cross(v3_sub(p1, p0), v3_sub(p2, p0)));
    }
    return a;
}

void pgi__scene_memory(const pgi_scene *s, size_t *scene_bytes, size_t *texture_bytes) {
    size_t b = sizeof *s + s->nverts * 3 * sizeof(float) * (1 + (s->nrm != NULL)) +
               (s->uv ? s->nverts * 2 * sizeof(float) : 0) + (s->col ? s->nverts * 3 * sizeof(float) : 0) +
               s->ntris * 4 * sizeof(uint32_t) + (s->tri_dynamic ? s->ntris : 0) + s->nmats * sizeof *s->mats +
               s->ntexs * sizeof *s->texs + s->nlights * sizeof *s->lights + s->ncams * sizeof *s->cams +
               s->nmeshes * sizeof *s->meshes + s->update_backup_cap * sizeof(float);
    if (s->env) {
        const pgi__env *e = s->env;
        b += sizeof *e + (e->rgb ? (size_t)e->w * (size_t)e->h * 4 * sizeof(float) + (size_t)e->h * sizeof(float) : 0);
    }
    for (size_t i = 0; i < s->nanims; i++) {
        const pgi__anim *a = &s->anims[i];
        b += sizeof *a + a->nverts * (sizeof(uint32_t) + 3 * sizeof(float) * (1 + (a->rest_nrm != NULL))) +
             a->nkeys * sizeof *a->keys;
    }
    size_t t = 0;
    for (size_t i = 0; i < s->ntexs; i++) {
        const pgi__texture *x = &s->texs[i];
        t += (size_t)x->width * (size_t)x->height * 4;
        if (x->tiled) t += (size_t)((x->width + 3) / 4) * (size_t)((x->height + 3) / 4) * 64;
        t += pgi__texture_mip_bytes(x);
    }
    *scene_bytes = b;
    *texture_bytes = t;
}
