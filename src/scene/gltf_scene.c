/* What a glTF file holds beyond its meshes, read from its JSON (docs/scene-format.md, "Cameras
 * and lights from mesh files"):
 *
 *   camera nodes        -> cameras, in node order, named by the node (else by the camera):
 *                          eye = the node's global transform applied to the origin, looking down
 *                          its -Z with +Y up; fov_y = yfov (radians, vertical) in degrees.
 *                          Assimp 5.2 is not used for these: it adds the node's translation
 *                          twice (once in the importer, again in PreTransformVertices) and
 *                          renames the cameras "cam_N".
 *   KHR_lights_punctual -> lights placed by their nodes, units taken one to one:
 *                          point: intensity I = color x intensity (candela read as W/sr);
 *                          spot: the same I inside a hard cone; glTF's smooth falloff from
 *                          innerConeAngle to outerConeAngle (((cos - cos_o) / (cos_i - cos_o))^2)
 *                          becomes the cone cos(cut-off) = (2 cos_i + cos_o) / 3, which keeps
 *                          the light's on-axis intensity and its power;
 *                          directional: irradiance E = color x intensity (lux read as W/m^2),
 *                          travelling down the node's -Z.
 *   KHR_materials_emissive_strength -> a factor per material on its emission (emissiveFactor).
 *
 * Everything else the file holds that photongi does not use is named in `unused` (animations,
 * skins, morph targets, orthographic cameras, light ranges, texture kinds other than base colour,
 * vertex colour sets past COLOR_0 (COLOR_0 is used: load_assimp.c), metallic or transmissive
 * materials, extensions). */
#include "scene_internal.h"
#include "light.h"

#include <cJSON.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>

static const cJSON *item(const cJSON *o, const char *key) { return cJSON_GetObjectItemCaseSensitive(o, key); }
static int array_size(const cJSON *a) { return cJSON_IsArray(a) ? cJSON_GetArraySize(a) : 0; }

static double num(const cJSON *o, const char *key, double def) {
    const cJSON *n = item(o, key);
    return cJSON_IsNumber(n) && isfinite(n->valuedouble) ? n->valuedouble : def;
}

/* Reads n numbers of array `a` into out (left as they are where `a` is not such an array). */
static void nums(const cJSON *a, int n, double *out) {
    if (array_size(a) != n) return;
    double v[16];
    int i = 0;
    for (const cJSON *e = a->child; e; e = e->next, i++) {
        if (!cJSON_IsNumber(e) || !isfinite(e->valuedouble)) return;
        v[i] = e->valuedouble;
    }
    memcpy(out, v, (size_t)n * sizeof *out);
}

/* 4x4 matrices, column-major as glTF stores them: m[4 * col + row]. */
static void mat_mul(const double *a, const double *b, double *out) {
    double r[16];
    for (int c = 0; c < 4; c++)
        for (int rr = 0; rr < 4; rr++) {
            double s = 0.0;
            for (int k = 0; k < 4; k++) s += a[4 * k + rr] * b[4 * c + k];
            r[4 * c + rr] = s;
        }
    memcpy(out, r, sizeof r);
}

/* A node's local transform: its "matrix", else T * R * S. */
static void node_local(const cJSON *node, double *m) {
    static const double id[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
    memcpy(m, id, sizeof id);
    if (array_size(item(node, "matrix")) == 16) {
        nums(item(node, "matrix"), 16, m);
        return;
    }
    double t[3] = {0, 0, 0}, q[4] = {0, 0, 0, 1}, s[3] = {1, 1, 1};
    nums(item(node, "translation"), 3, t);
    nums(item(node, "rotation"), 4, q);
    nums(item(node, "scale"), 3, s);
    const double ql = sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    if (ql > 0.0)
        for (int i = 0; i < 4; i++) q[i] /= ql;
    const double x = q[0], y = q[1], z = q[2], w = q[3];
    const double r[9] = {/* columns */
                         1 - 2 * (y * y + z * z), 2 * (x * y + z * w),     2 * (x * z - y * w),
                         2 * (x * y - z * w),     1 - 2 * (x * x + z * z), 2 * (y * z + x * w),
                         2 * (x * z + y * w),     2 * (y * z - x * w),     1 - 2 * (x * x + y * y)};
    for (int c = 0; c < 3; c++)
        for (int rr = 0; rr < 3; rr++) m[4 * c + rr] = r[3 * c + rr] * s[c];
    m[12] = t[0];
    m[13] = t[1];
    m[14] = t[2];
}

static void xform_point(const double *m, const double *p, float out[3]) {
    for (int r = 0; r < 3; r++) out[r] = (float)(m[r] * p[0] + m[4 + r] * p[1] + m[8 + r] * p[2] + m[12 + r]);
}

/* The direction m maps d to, unit length (0 when m collapses it). */
static void xform_dir(const double *m, const double *d, float out[3]) {
    double v[3];
    for (int r = 0; r < 3; r++) v[r] = m[r] * d[0] + m[4 + r] * d[1] + m[8 + r] * d[2];
    const double l = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    for (int r = 0; r < 3; r++) out[r] = l > 0.0 ? (float)(v[r] / l) : 0.f;
}

static void note(char *buf, size_t cap, const char *fmt, ...) {
    char item_[256];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(item_, sizeof item_, fmt, ap);
    va_end(ap);
    pgi__list_append(buf, cap, item_);
}

/* "N things" / "1 thing" into the list when n > 0. */
static void note_count(char *buf, size_t cap, size_t n, const char *one, const char *many) {
    if (n) note(buf, cap, "%zu %s", n, n == 1 ? one : many);
}

/* Extensions photongi reads (or whose absence changes nothing it draws). */
static int known_extension(const char *e) {
    static const char *const k[] = {"KHR_lights_punctual", "KHR_materials_emissive_strength", "KHR_mesh_quantization",
                                    NULL};
    for (int i = 0; k[i]; i++)
        if (strcmp(e, k[i]) == 0) return 1;
    return 0;
}

static void free_extras(pgi__gltf_extras *x) {
    free(x->cams);
    free(x->lights);
    free(x->emissive_strength);
    memset(x, 0, sizeof *x);
}

pgi_status pgi__gltf_read_extras(const char *path, const cJSON *root, pgi__gltf_extras *x) {
    memset(x, 0, sizeof *x);
    const cJSON *nodes = item(root, "nodes"), *cams = item(root, "cameras");
    const cJSON *mats = item(root, "materials"), *meshes = item(root, "meshes");
    const cJSON *ext = item(root, "extensions");
    const cJSON *lights = item(item(ext, "KHR_lights_punctual"), "lights");
    const int nn = array_size(nodes), nc = array_size(cams), nl = array_size(lights), nm = array_size(mats);
    char *un = x->unused;
    const size_t ucap = sizeof x->unused;
    pgi_status st = PGI_OK;

    /* Materials: emissive strength; what the material model leaves out. */
    size_t metallic = 0, normal_maps = 0, mr_maps = 0, emissive_maps = 0, occlusion_maps = 0;
    if (nm > 0) {
        x->emissive_strength = malloc((size_t)nm * sizeof *x->emissive_strength);
        if (!x->emissive_strength) return pgi__fail(PGI_ERR_OOM, "%s: out of memory for %d materials", path, nm);
        x->nmats = (size_t)nm;
        int i = 0;
        for (const cJSON *m = mats->child; m; m = m->next, i++) {
            const double k =
                num(item(item(m, "extensions"), "KHR_materials_emissive_strength"), "emissiveStrength", 1.0);
            x->emissive_strength[i] = k >= 0.0 && k <= (double)PGI_MAX_RADIANCE ? (float)k : 1.f;
            const cJSON *pbr = item(m, "pbrMetallicRoughness");
            metallic += num(pbr, "metallicFactor", 0.0) > 0.0; /* given: exporters write it */
            mr_maps += item(pbr, "metallicRoughnessTexture") != NULL;
            normal_maps += item(m, "normalTexture") != NULL;
            emissive_maps += item(m, "emissiveTexture") != NULL;
            occlusion_maps += item(m, "occlusionTexture") != NULL;
        }
    }

    /* Parents, and the nodes of the scene Assimp imports ("scene", else the first). */
    int *parent = nn > 0 ? malloc((size_t)nn * sizeof *parent) : NULL;
    char *in_scene = nn > 0 ? calloc((size_t)nn, 1) : NULL;
    const cJSON **nodev = nn > 0 ? malloc((size_t)nn * sizeof *nodev) : NULL;
    /* the cameras and lights by index (nodes refer to them: no walk down a list per node) */
    const cJSON **camv = nc > 0 ? malloc((size_t)nc * sizeof *camv) : NULL;
    const cJSON **lightv = nl > 0 ? malloc((size_t)nl * sizeof *lightv) : NULL;
    if ((nn > 0 && (!parent || !in_scene || !nodev)) || (nc > 0 && !camv) || (nl > 0 && !lightv)) {
        free(parent);
        free(in_scene);
        free(nodev);
        free(camv);
        free(lightv);
        free_extras(x);
        return pgi__fail(PGI_ERR_OOM, "%s: out of memory for %d nodes", path, nn);
    }
    for (int i = 0; i < nn; i++) parent[i] = -1;
    int i = 0;
    for (const cJSON *c = nc ? cams->child : NULL; c; c = c->next) camv[i++] = c;
    i = 0;
    for (const cJSON *l = nl ? lights->child : NULL; l; l = l->next) lightv[i++] = l;
    i = 0;
    for (const cJSON *node = nn ? nodes->child : NULL; node; node = node->next, i++) {
        nodev[i] = node;
        for (const cJSON *c = item(node, "children") ? item(node, "children")->child : NULL; c; c = c->next)
            if (cJSON_IsNumber(c) && c->valuedouble >= 0 && c->valuedouble < nn) parent[(int)c->valuedouble] = i;
    }
    const cJSON *scenes = item(root, "scenes");
    const double sv = num(root, "scene", 0.0);
    const cJSON *scene = sv >= 0.0 && sv < array_size(scenes) ? cJSON_GetArrayItem(scenes, (int)sv) : NULL;
    if (scene) {
        for (const cJSON *r = item(scene, "nodes") ? item(scene, "nodes")->child : NULL; r; r = r->next)
            if (cJSON_IsNumber(r) && r->valuedouble >= 0 && r->valuedouble < nn) in_scene[(int)r->valuedouble] = 1;
    } else {
        for (int k = 0; k < nn; k++) in_scene[k] = parent[k] < 0;
    }

    /* Camera and light nodes (the node check has refused cycles and trees deeper than
     * PGI__MAX_MESH_DEPTH, so the walks up end). */
    size_t want_c = 0, want_l = 0, ortho = 0, ranges = 0;
    for (const cJSON *node = nn ? nodes->child : NULL; node; node = node->next) {
        want_c += item(node, "camera") != NULL;
        want_l += item(item(item(node, "extensions"), "KHR_lights_punctual"), "light") != NULL;
    }
    if (want_c) x->cams = calloc(want_c, sizeof *x->cams);
    if (want_l) x->lights = calloc(want_l, sizeof *x->lights);
    if ((want_c && !x->cams) || (want_l && !x->lights))
        st = pgi__fail(PGI_ERR_OOM, "%s: out of memory for %zu cameras and %zu lights", path, want_c, want_l);
    i = 0;
    for (const cJSON *node = nn ? nodes->child : NULL; node && !st; node = node->next, i++) {
        const cJSON *jc = item(node, "camera");
        const cJSON *jl = item(item(item(node, "extensions"), "KHR_lights_punctual"), "light");
        if (!jc && !jl) continue;
        int top = i;
        while (parent[top] >= 0) top = parent[top];
        if (!in_scene[top]) continue;
        double m[16], l[16];
        node_local(node, m);
        for (int p = parent[i]; p >= 0; p = parent[p]) {
            node_local(nodev[p], l);
            mat_mul(l, m, m);
        }
        static const double origin[3] = {0, 0, 0}, fwd[3] = {0, 0, -1}, upv[3] = {0, 1, 0};
        const cJSON *nname = item(node, "name");
        if (jc && cJSON_IsNumber(jc) && jc->valuedouble >= 0 && jc->valuedouble < nc) {
            const cJSON *cam = camv[(int)jc->valuedouble];
            const cJSON *type = item(cam, "type");
            const cJSON *persp = item(cam, "perspective");
            const double yfov = num(persp, "yfov", 0.0);
            if (!cJSON_IsString(type) || strcmp(type->valuestring, "perspective") != 0 || !(yfov > 0.0)) {
                ortho++;
            } else {
                pgi__file_camera *fc = &x->cams[x->ncams];
                const cJSON *cname = cJSON_IsString(nname) ? nname : item(cam, "name");
                if (cJSON_IsString(cname)) snprintf(fc->name, sizeof fc->name, "%s", cname->valuestring);
                float f[3];
                xform_point(m, origin, fc->def.eye);
                xform_dir(m, fwd, f);
                for (int k = 0; k < 3; k++) fc->def.look_at[k] = fc->def.eye[k] + f[k];
                xform_dir(m, upv, fc->def.up);
                fc->def.fov_y_deg = (float)(yfov * (180.0 / 3.14159265358979323846));
                /* a camera the scene's checks would refuse (a singular node transform) is left out */
                if (fabsf(f[0]) + fabsf(f[1]) + fabsf(f[2]) > 0.f && fc->def.fov_y_deg < 180.f) x->ncams++;
                else ortho++;
            }
        }
        if (jl && cJSON_IsNumber(jl) && jl->valuedouble >= 0 && jl->valuedouble < nl) {
            const cJSON *jlight = lightv[(int)jl->valuedouble];
            const cJSON *type = item(jlight, "type");
            const char *t = cJSON_IsString(type) ? type->valuestring : "";
            double col[3] = {1, 1, 1};
            nums(item(jlight, "color"), 3, col);
            const double inten = num(jlight, "intensity", 1.0);
            ranges += item(jlight, "range") != NULL;
            pgi__light *L = &x->lights[x->nlights];
            memset(L, 0, sizeof *L);
            for (int k = 0; k < 3; k++) L->color[k] = (float)(col[k] * inten);
            xform_point(m, origin, L->pos);
            xform_dir(m, fwd, L->dir);
            const pgi__light_kind *kind = pgi__light_kind_named(t, 1);
            if (!kind) {
                note(un, ucap, "light %d of type '%s'", (int)jl->valuedouble, t);
                continue;
            }
            L->type = kind->type;
            if (!(kind->fields & PGI__LIGHT_HAS_POS)) memset(L->pos, 0, sizeof L->pos);
            if (!(kind->fields & PGI__LIGHT_HAS_DIR)) memset(L->dir, 0, sizeof L->dir);
            if (kind->fields & PGI__LIGHT_HAS_CONE) {
                const cJSON *spot = item(jlight, "spot");
                double outer = num(spot, "outerConeAngle", 3.14159265358979323846 / 4.0);
                double inner = num(spot, "innerConeAngle", 0.0);
                if (!(outer > 0.0)) outer = 1e-4;
                if (outer > 3.14159265358979323846 / 2.0) outer = 3.14159265358979323846 / 2.0;
                if (!(inner >= 0.0) || inner > outer) inner = outer;
                L->cos_cutoff = (float)((2.0 * cos(inner) + cos(outer)) / 3.0);
                if (!(L->cos_cutoff < 1.f)) L->cos_cutoff = nextafterf(1.f, 0.f);
            }
            x->nlights++;
        }
    }
    free(parent);
    free(in_scene);
    free(nodev);
    free(camv);
    free(lightv);
    if (st) {
        free_extras(x);
        return st;
    }

    /* What else the file holds. */
    size_t colors = 0, targets = 0;
    for (const cJSON *me = array_size(meshes) ? meshes->child : NULL; me; me = me->next)
        for (const cJSON *p = array_size(item(me, "primitives")) ? item(me, "primitives")->child : NULL; p;
             p = p->next) {
            colors += item(item(p, "attributes"), "COLOR_1") != NULL;
            targets += array_size(item(p, "targets")) > 0;
        }
    note_count(un, ucap, (size_t)array_size(item(root, "animations")), "animation", "animations");
    note_count(un, ucap, (size_t)array_size(item(root, "skins")), "skin", "skins");
    note_count(un, ucap, targets, "primitive with morph targets", "primitives with morph targets");
    note_count(un, ucap, colors, "primitive with a second vertex colour set (COLOR_1; COLOR_0 is used)",
               "primitives with a second vertex colour set (COLOR_1; COLOR_0 is used)");
    note_count(un, ucap, ortho, "orthographic or degenerate camera", "orthographic or degenerate cameras");
    note_count(un, ucap, ranges, "light range (lights fall off as 1/d^2 without end)",
               "light ranges (lights fall off as 1/d^2 without end)");
    note_count(un, ucap, metallic, "metallic material (drawn as diffuse)", "metallic materials (drawn as diffuse)");
    note_count(un, ucap, normal_maps, "normal map", "normal maps");
    note_count(un, ucap, mr_maps, "metallic-roughness map", "metallic-roughness maps");
    note_count(un, ucap, emissive_maps, "emissive map (the emissive factor is used)",
               "emissive maps (the emissive factor is used)");
    note_count(un, ucap, occlusion_maps, "occlusion map", "occlusion maps");
    const cJSON *used = item(root, "extensionsUsed");
    for (const cJSON *e = array_size(used) ? used->child : NULL; e; e = e->next)
        if (cJSON_IsString(e) && !known_extension(e->valuestring)) note(un, ucap, "%s", e->valuestring);
    return PGI_OK;
}
