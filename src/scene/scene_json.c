/* JSON scene description (see docs/scene-format.md).
 *
 *   {
 *     "name": "sibenik",                       optional; default: file name without .json
 *     "mesh": "sibenik/sibenik.obj",           required; any file Assimp reads
 *     "cameras": [                             optional ("camera": {...} for one)
 *       {"eye": [-18, -13.5, 0], "look_at": [10, -12, 0], "up": [0, 1, 0], "fov_y": 60,
 *        "name": "nave"}                       "name" optional (--camera NAME)
 *     ],                                       the mesh file's own cameras follow these
 *     "lights": [                              optional when the mesh has emissive (Ke) materials
 *                                              or lights of its own (glTF), which are added to these
 *       {"type": "point", "position": [0, -3, 0], "intensity": [300, 300, 300]},
 *       {"type": "spot", "position": [..], "direction": [..], "angle": 30, "intensity": [..]},
 *       {"type": "sun", "direction": [0.195, -0.976, 0.098], "irradiance": [5, 5, 5]}
 *     ],
 *     "sky": {"color": [0.55, 0.7, 1], "intensity": 1.5, "ground": [..]},   optional; or
 *     "environment": {"map": "sky.exr", "scale": 1, "rotation": 0},      (env.c)
 *     "render": {"photons": 200000, "radius": 0.25, "bounces": 4,
 *                "width": 1280, "height": 720, "exposure": 1.0},    all optional
 *     "specular": "ggx"                        optional: model of the mesh's illum-2 materials,
 *                                              "ggx" (microfacet plastic, default) or "phong"
 *   }
 *
 * Units: positions in the mesh's units; intensity I in W/sr (point, spot),
 * irradiance E in W/m^2 (sun; "direction" is the way the light travels);
 * "angle" is the spot's half-angle cut-off in degrees, in (0, 180); "up"
 * defaults to [0, 1, 0] and "fov_y" (vertical, degrees) to 60.
 *
 * Mesh paths: an absolute path is used as is; a relative one is looked up
 * first in the JSON file's folder, then in $PHOTONGI_SCENES, or when that is
 * not set in the source tree's ../shared/scenes (PGI__SOURCE_DIR/../shared/scenes,
 * so a build finds them from any directory), then in ../shared/scenes
 * relative to the working directory.
 *
 * Unknown keys are errors (they are usually typos), except keys starting
 * with '_' and "comment", "description", "credit", "license", "source",
 * which are ignored. Every error message names the JSON file and the key. */
#include "scene_internal.h"
#include "light.h"
#include "portal.h"

#include <cJSON.h>
#include <errno.h>
#include <stdio.h>
#include <string.h>
#include <sys/stat.h>

#define DEFAULT_SCENES_DIR "../shared/scenes"
#ifdef PGI__SOURCE_DIR
#define SOURCE_SCENES_DIR PGI__SOURCE_DIR "/../shared/scenes"
#endif

/* A description is a few kilobytes; far beyond that it is not one (or a file that never ends). */
#define MAX_JSON_BYTES (64u << 20)
/* cJSON takes about 100 bytes a value (a 64-byte node, its key, malloc's overhead): a 64 MiB file
 * of "[0,0,0,..." would take 3 GB. 4M values (10^5 lights take 1M) bound it near 400 MB. */
#define MAX_JSON_VALUES 4000000u
/* Triangles the "objects" may add (a sphere has 2304): 16M triangles take about 560 MB. */
#define MAX_OBJECT_TRIANGLES (16u << 20)

/* Values in a JSON text, at most: one more than its commas, brackets and braces outside strings. */
static size_t count_json_values(const char *t, size_t len) {
    size_t n = 1;
    int in_str = 0;
    for (size_t i = 0; i < len; i++) {
        char c = t[i];
        if (in_str) {
            if (c == '\\') i++;
            else if (c == '"') in_str = 0;
        } else if (c == '"') in_str = 1;
        else if (c == ',' || c == '[' || c == '{') n++;
    }
    return n;
}

/* Reads a whole file, NUL-terminated. */
static pgi_status read_file(const char *path, char **out, size_t *len) {
    /* A FIFO would block the open, a device (a link to /dev/zero) never end. */
    const char *why = pgi__not_regular_file(path);
    if (why) return pgi__fail(PGI_ERR_IO, "%s: %s", path, why);
    FILE *f = fopen(path, "rb");
    if (!f) return pgi__fail(PGI_ERR_IO, "%s: cannot open: %s", path, strerror(errno));
    size_t cap = 4096, n = 0;
    char *buf = malloc(cap);
    if (!buf) {
        fclose(f);
        return pgi__fail(PGI_ERR_OOM, "%s: out of memory", path);
    }
    for (;;) {
        if (n > MAX_JSON_BYTES) {
            free(buf);
            fclose(f);
            return pgi__fail(PGI_ERR_PARSE, "%s: larger than %u MiB: not a scene description", path,
                             MAX_JSON_BYTES >> 20);
        }
        if (n + 1 >= cap) {
            char *nb = realloc(buf, cap * 2);
            if (!nb) {
                free(buf);
                fclose(f);
                return pgi__fail(PGI_ERR_OOM, "%s: out of memory", path);
            }
            buf = nb;
            cap *= 2;
        }
        size_t r = fread(buf + n, 1, cap - 1 - n, f);
        n += r;
        if (r == 0) break;
    }
    int err = ferror(f);
    fclose(f);
    if (err) {
        free(buf);
        return pgi__fail(PGI_ERR_IO, "%s: read error", path);
    }
    buf[n] = 0;
    *out = buf;
    *len = n;
    return PGI_OK;
}

/* ------------------------------------------------------------ validation */

static int ignored_key(const char *k) {
    static const char *const ok[] = {"comment", "description", "credit", "license", "source", NULL};
    if (k[0] == '_') return 1;
    for (int i = 0; ok[i]; i++)
        if (strcmp(k, ok[i]) == 0) return 1;
    return 0;
}

/* Rejects keys of `obj` not in the NULL-terminated `allowed` list. `where` is "" or "lights[2]". */
static pgi_status check_keys(const char *path, const cJSON *obj, const char *where, const char *const *allowed) {
    for (const cJSON *it = obj->child; it; it = it->next) {
        const char *k = it->string ? it->string : "";
        int found = ignored_key(k);
        for (int i = 0; !found && allowed[i]; i++) found = strcmp(k, allowed[i]) == 0;
        if (found) continue;
        char list[256] = "";
        for (int i = 0; allowed[i]; i++) {
            strncat(list, i ? ", " : "", sizeof list - strlen(list) - 1);
            strncat(list, allowed[i], sizeof list - strlen(list) - 1);
        }
        return pgi__fail(PGI_ERR_PARSE, "%s: unknown key '%s%s%s' (expected one of: %s)", path, where,
                         *where ? "." : "", k, list);
    }
    return PGI_OK;
}

enum { ANY = 0, NONNEG = 1 };

/* Reads a 3-vector of numbers of magnitude at most `hi` (PGI_MAX_COORD for positions and
 * directions, PGI_MAX_RADIANCE for radiances). Absent: returns 0 (and *present = 0) when optional,
 * error otherwise. */
static pgi_status get_vec3(const char *path, const cJSON *obj, const char *where, const char *key, int sign, double hi,
                           int required, float out[3], int *present) {
    const cJSON *a = cJSON_GetObjectItemCaseSensitive(obj, key);
    if (present) *present = a != NULL;
    const char *what = sign == NONNEG ? "non-negative numbers" : "numbers";
    if (!a) {
        if (!required) return PGI_OK;
        return pgi__fail(PGI_ERR_PARSE, "%s: %s%s%s is missing (an array of 3 %s)", path, where, *where ? "." : "", key,
                         what);
    }
    int ok = cJSON_IsArray(a) && cJSON_GetArraySize(a) == 3;
    const cJSON *e = ok ? a->child : NULL;
    for (int i = 0; ok && i < 3; i++, e = e->next) {
        if (!cJSON_IsNumber(e) || !isfinite(e->valuedouble) || (sign == NONNEG && e->valuedouble < 0.0)) ok = 0;
        else if (!(fabs(e->valuedouble) <= hi))
            return pgi__fail(PGI_ERR_PARSE, "%s: %s%s%s[%d] = %g is out of range (%s%g..%g)", path, where,
                             *where ? "." : "", key, i, e->valuedouble, sign == NONNEG ? "" : "-",
                             sign == NONNEG ? 0.0 : hi, hi);
        else out[i] = (float)e->valuedouble;
    }
    if (!ok)
        return pgi__fail(PGI_ERR_PARSE, "%s: %s%s%s must be an array of 3 %s", path, where, *where ? "." : "", key,
                         what);
    return PGI_OK;
}

/* Reads a finite number; `lo_excl`: must be > lo, else >= lo. */
static pgi_status get_number(const char *path, const cJSON *obj, const char *where, const char *key, int required,
                             double lo, int lo_excl, double hi, double *out, int *present) {
    const cJSON *n = cJSON_GetObjectItemCaseSensitive(obj, key);
    if (present) *present = n != NULL;
    if (!n) {
        if (!required) return PGI_OK;
        return pgi__fail(PGI_ERR_PARSE, "%s: %s%s%s is missing", path, where, *where ? "." : "", key);
    }
    double v = cJSON_IsNumber(n) ? n->valuedouble : NAN;
    if (!isfinite(v) || (lo_excl ? !(v > lo) : !(v >= lo)) || !(v <= hi))
        return pgi__fail(PGI_ERR_PARSE, "%s: %s%s%s must be a number %s %g and at most %g", path, where,
                         *where ? "." : "", key, lo_excl ? "greater than" : "of at least", lo, hi);
    *out = v;
    return PGI_OK;
}

static pgi_status get_count(const char *path, const cJSON *obj, const char *key, double hi, double *out) {
    const cJSON *n = cJSON_GetObjectItemCaseSensitive(obj, key);
    if (!n) return PGI_OK;
    double v = cJSON_IsNumber(n) ? n->valuedouble : NAN;
    if (!isfinite(v) || v < 0.0 || v > hi || v != floor(v))
        return pgi__fail(PGI_ERR_PARSE, "%s: render.%s must be a non-negative whole number (at most %.0f)", path, key,
                         hi);
    *out = v;
    return PGI_OK;
}

static pgi_status parse_camera(const char *path, const cJSON *c, const char *where, pgi_camera_def *cd, char *name,
                               size_t name_size) {
    static const char *const keys[] = {"eye", "look_at", "up", "fov_y", "name", NULL};
    if (!cJSON_IsObject(c))
        return pgi__fail(PGI_ERR_PARSE, "%s: %s must be an object with eye, look_at, up, fov_y", path, where);
    pgi_status st = check_keys(path, c, where, keys);
    if (st) return st;
    const cJSON *jn = cJSON_GetObjectItemCaseSensitive(c, "name");
    if (jn && (!cJSON_IsString(jn) || !jn->valuestring[0] || (jn->valuestring[0] >= '0' && jn->valuestring[0] <= '9') ||
               strlen(jn->valuestring) >= name_size))
        return pgi__fail(PGI_ERR_PARSE,
                         "%s: %s.name must be a string of 1..%zu characters that does not start with a digit (--camera "
                         "takes a number as an index)",
                         path, where, name_size - 1);
    snprintf(name, name_size, "%s", jn ? jn->valuestring : "");
    float up[3] = {0.f, 1.f, 0.f};
    double fov = 60.0;
    if ((st = get_vec3(path, c, where, "eye", ANY, (double)PGI_MAX_COORD, 1, cd->eye, NULL))) return st;
    if ((st = get_vec3(path, c, where, "look_at", ANY, (double)PGI_MAX_COORD, 1, cd->look_at, NULL))) return st;
    if ((st = get_vec3(path, c, where, "up", ANY, (double)PGI_MAX_COORD, 0, up, NULL))) return st;
    if ((st = get_number(path, c, where, "fov_y", 0, 0.0, 1, 179.9, &fov, NULL))) return st;
    memcpy(cd->up, up, sizeof up);
    cd->fov_y_deg = (float)fov;
    pgi__v3 d = v3_sub(v3_load(cd->look_at), v3_load(cd->eye));
    if (!(v3_len(d) > 0.f)) return pgi__fail(PGI_ERR_PARSE, "%s: %s: eye and look_at are the same point", path, where);
    if (!(v3_len(v3_cross(d, v3_load(cd->up))) > 0.f))
        return pgi__fail(PGI_ERR_PARSE, "%s: %s: up is zero or parallel to the view direction", path, where);
    return PGI_OK;
}

/* A light: its type's fields (light.h pgi__light_kind), in the table's order, then its colour. */
static pgi_status parse_light(const char *path, const cJSON *l, const char *where, pgi__light *L) {
    memset(L, 0, sizeof *L);
    char names[128];
    pgi__light_kind_list(names, sizeof names, 1, 0);
    if (!cJSON_IsObject(l)) return pgi__fail(PGI_ERR_PARSE, "%s: %s must be an object", path, where);
    const cJSON *t = cJSON_GetObjectItemCaseSensitive(l, "type");
    if (!t) return pgi__fail(PGI_ERR_PARSE, "%s: %s.type is missing (%s)", path, where, names);
    if (!cJSON_IsString(t)) return pgi__fail(PGI_ERR_PARSE, "%s: %s.type must be a string (%s)", path, where, names);
    const pgi__light_kind *k = pgi__light_kind_named(t->valuestring, 0);
    if (!k)
        return pgi__fail(PGI_ERR_PARSE, "%s: %s.type '%s' is unknown (expected %s)", path, where, t->valuestring,
                         names);
    const char *keys[6] = {"type"};
    int nk = 1;
    if (k->fields & PGI__LIGHT_HAS_POS) keys[nk++] = "position";
    if (k->fields & PGI__LIGHT_HAS_DIR) keys[nk++] = "direction";
    if (k->fields & PGI__LIGHT_HAS_CONE) keys[nk++] = "angle";
    keys[nk++] = k->colour;
    L->type = k->type;
    pgi_status st = check_keys(path, l, where, keys);
    if (st) return st;
    double angle = 0.0;
    if ((k->fields & PGI__LIGHT_HAS_POS) &&
        (st = get_vec3(path, l, where, "position", ANY, (double)PGI_MAX_COORD, 1, L->pos, NULL)))
        return st;
    if ((k->fields & PGI__LIGHT_HAS_DIR) &&
        (st = get_vec3(path, l, where, "direction", ANY, (double)PGI_MAX_COORD, 1, L->dir, NULL)))
        return st;
    if ((k->fields & PGI__LIGHT_HAS_CONE) && (st = get_number(path, l, where, "angle", 1, 0.0, 1, 179.9, &angle, NULL)))
        return st;
    if ((st = get_vec3(path, l, where, k->colour, NONNEG, (double)PGI_MAX_RADIANCE, 1, L->color, NULL))) return st;
    if ((k->fields & PGI__LIGHT_HAS_DIR) && !(v3_len(v3_load(L->dir)) > 0.f))
        return pgi__fail(PGI_ERR_PARSE, "%s: %s.direction must not be zero", path, where);
    if (k->fields & PGI__LIGHT_HAS_CONE) L->cos_cutoff = (float)cos(angle * (3.14159265358979323846 / 180.0));
    return PGI_OK;
}

static pgi_status parse_render(const char *path, const cJSON *r, pgi_scene_defaults *d) {
    static const char *const keys[] = {"photons", "radius", "bounces", "width", "height", "exposure", NULL};
    if (!cJSON_IsObject(r)) return pgi__fail(PGI_ERR_PARSE, "%s: render must be an object", path);
    pgi_status st = check_keys(path, r, "render", keys);
    if (st) return st;
    double photons = 0, bounces = 0, width = 0, height = 0, radius = 0, exposure = 0;
    /* The renderer's own limits: a value it would refuse is the file's fault, said here (exit 1),
     * not a usage error at render time. */
    if ((st = get_count(path, r, "photons", (double)PGI_MAX_PHOTONS, &photons))) return st;
    if ((st = get_count(path, r, "bounces", 64.0, &bounces))) return st;
    if ((st = get_count(path, r, "width", (double)PGI_MAX_IMAGE_SIDE, &width))) return st;
    if ((st = get_count(path, r, "height", (double)PGI_MAX_IMAGE_SIDE, &height))) return st;
    if (width * height > (double)PGI_MAX_IMAGE_PIXELS)
        return pgi__fail(PGI_ERR_PARSE, "%s: render.width x height = %.0f x %.0f is more than %u pixels", path, width,
                         height, PGI_MAX_IMAGE_PIXELS);
    if ((st = get_number(path, r, "render", "radius", 0, 0.0, 0, (double)PGI_MAX_RADIUS, &radius, NULL))) return st;
    if (radius != 0.0 && !((float)radius >= (float)PGI_MIN_RADIUS))
        return pgi__fail(PGI_ERR_PARSE, "%s: render.radius %g is out of range (%g..%g, or 0: automatic)", path, radius,
                         (double)PGI_MIN_RADIUS, (double)PGI_MAX_RADIUS);
    if ((st = get_number(path, r, "render", "exposure", 0, 0.0, 0, 3.0e38, &exposure, NULL))) return st;
    d->photons = (uint32_t)photons;
    d->bounces = (int)bounces;
    d->width = (int)width;
    d->height = (int)height;
    d->radius = (float)radius;
    d->exposure = (float)exposure;
    return PGI_OK;
}

/* ------------------------------------------------------------ mesh path */

/* `kind` names the key in messages: "mesh", "environment.map". */
static pgi_status resolve_mesh(const char *path, const char *kind, const char *mesh, char *out, size_t n) {
    if (mesh[0] == '/') {
        const char *why = pgi__not_regular_file(mesh);
        if (why && strcmp(why, "no such file") == 0)
            return pgi__fail(PGI_ERR_IO, "%s: %s '%s' not found", path, kind, mesh);
        if (why) return pgi__fail(PGI_ERR_IO, "%s: %s '%s' %s", path, kind, mesh, why);
        snprintf(out, n, "%s", mesh);
        return PGI_OK;
    }
    char dir1[1024];
    const char *slash = strrchr(path, '/');
    if (slash) snprintf(dir1, sizeof dir1, "%.*s", (int)(slash - path) > 0 ? (int)(slash - path) : 1, path);
    else snprintf(dir1, sizeof dir1, ".");
    const char *env = getenv("PHOTONGI_SCENES");
    const char *dirs[4] = {dir1};
    int nd = 1;
    if (env && *env) dirs[nd++] = env;
    else {
#ifdef SOURCE_SCENES_DIR
        dirs[nd++] = SOURCE_SCENES_DIR;
#endif
        dirs[nd++] = DEFAULT_SCENES_DIR;
    }
    char looked[2048] = "", other[1024] = "";
    const char *other_why = NULL;
    for (int i = 0; i < nd; i++) {
        size_t dl = strlen(dirs[i]);
        int len = snprintf(out, n, "%s%s%s", dirs[i], dl && dirs[i][dl - 1] == '/' ? "" : "/", mesh);
        if (len <= 0 || (size_t)len >= n) continue;
        const char *why = pgi__not_regular_file(out);
        if (!why) return PGI_OK;
        if (!other_why && strcmp(why, "no such file") != 0) { /* there, but a directory, a FIFO, ... */
            other_why = why;
            snprintf(other, sizeof other, "%s", out);
        }
        pgi__list_append(looked, sizeof looked, dirs[i]);
    }
    if (other_why) return pgi__fail(PGI_ERR_IO, "%s: %s '%s': %s %s", path, kind, mesh, other, other_why);
    return pgi__fail(PGI_ERR_IO,
                     "%s: %s '%s' not found (looked in %s; set PHOTONGI_SCENES to the folder that holds "
                     "the scenes; docs/scenes.md says where to get the papers' scenes and how to lay them out)",
                     path, kind, mesh, looked);
}


/* ------------------------------------------------------------ dynamic objects */

/* "motion": {"keyframes": [{"t", "translate", "rotate", "scale"}, ...], "loop": "clamp"|"repeat"|"pingpong"} */
static pgi_status parse_motion(const char *path, const cJSON *m, const char *where, pgi__keyframe **keys_out,
                               size_t *nkeys, pgi__loop *loop) {
    static const char *const keys[] = {"keyframes", "loop", NULL};
    static const char *const kkeys[] = {"t", "translate", "rotate", "scale", NULL};
    char w[128];
    snprintf(w, sizeof w, "%s.motion", where);
    if (!cJSON_IsObject(m)) return pgi__fail(PGI_ERR_PARSE, "%s: %s must be an object with keyframes", path, w);
    pgi_status st = check_keys(path, m, w, keys);
    if (st) return st;
    *loop = PGI__LOOP_CLAMP;
    const cJSON *jl = cJSON_GetObjectItemCaseSensitive(m, "loop");
    if (jl) {
        if (cJSON_IsString(jl) && strcmp(jl->valuestring, "clamp") == 0) *loop = PGI__LOOP_CLAMP;
        else if (cJSON_IsString(jl) && strcmp(jl->valuestring, "repeat") == 0) *loop = PGI__LOOP_REPEAT;
        else if (cJSON_IsString(jl) && strcmp(jl->valuestring, "pingpong") == 0) *loop = PGI__LOOP_PINGPONG;
        else return pgi__fail(PGI_ERR_PARSE, "%s: %s.loop must be \"clamp\", \"repeat\" or \"pingpong\"", path, w);
    }
    const cJSON *jk = cJSON_GetObjectItemCaseSensitive(m, "keyframes");
    if (!cJSON_IsArray(jk) || cJSON_GetArraySize(jk) < 1 || cJSON_GetArraySize(jk) > 100000)
        return pgi__fail(PGI_ERR_PARSE, "%s: %s.keyframes must be a non-empty array of keyframes", path, w);
    size_t n = (size_t)cJSON_GetArraySize(jk);
    pgi__keyframe *k = calloc(n, sizeof *k);
    if (!k) return pgi__fail(PGI_ERR_OOM, "%s: out of memory", path);
    const cJSON *e = jk->child; /* linked walk: cJSON_GetArrayItem in a loop is quadratic */
    for (size_t i = 0; i < n && !st; i++, e = e->next) {
        char wk[160];
        snprintf(wk, sizeof wk, "%s.keyframes[%zu]", w, i);
        if (!cJSON_IsObject(e)) {
            st = pgi__fail(PGI_ERR_PARSE, "%s: %s must be an object", path, wk);
            break;
        }
        double t = 0.0, sc = 1.0;
        k[i].scale = 1.f;
        if (!st) st = check_keys(path, e, wk, kkeys);
        if (!st) st = get_number(path, e, wk, "t", 1, -1e9, 0, 1e9, &t, NULL);
        if (!st) st = get_vec3(path, e, wk, "translate", ANY, (double)PGI_MAX_COORD, 0, k[i].translate, NULL);
        if (!st) st = get_vec3(path, e, wk, "rotate", ANY, (double)PGI_MAX_COORD, 0, k[i].rotate, NULL);
        if (!st) st = get_number(path, e, wk, "scale", 0, 0.0, 1, 1e6, &sc, NULL);
        k[i].t = (float)t;
        k[i].scale = (float)sc;
        if (!st && i > 0 && !(k[i].t > k[i - 1].t))
            st = pgi__fail(PGI_ERR_PARSE, "%s: %s.t must be greater than the previous keyframe's t", path, wk);
    }
    if (st) {
        free(k);
        return st;
    }
    *keys_out = k;
    *nkeys = n;
    return PGI_OK;
}

/* "material": {"name", "type": lambert|plastic|phong|mirror|glass, "kd", "ks", "shininess", "ior", "emission"};
 * appends it to the scene and returns its index. */
static pgi_status parse_material(const char *path, pgi_scene *s, const cJSON *j, const char *where, const char *defname,
                                 uint32_t *out) {
    static const char *const keys[] = {"name", "type", "kd", "ks", "shininess", "ior", "emission", NULL};
    char w[128];
    snprintf(w, sizeof w, "%s.material", where);
    pgi__material m;
    memset(&m, 0, sizeof m);
    snprintf(m.name, sizeof m.name, "%s", defname);
    m.type = PGI__MAT_LAMBERT;
    m.kd[0] = m.kd[1] = m.kd[2] = 0.8f;
    m.ior = 1.5f;
    m.tex_kd = -1;
    m.tex_alpha = -1;
    pgi_status st = PGI_OK;
    if (j) {
        if (!cJSON_IsObject(j)) return pgi__fail(PGI_ERR_PARSE, "%s: %s must be an object", path, w);
        if ((st = check_keys(path, j, w, keys))) return st;
        const cJSON *jn = cJSON_GetObjectItemCaseSensitive(j, "name");
        if (jn) {
            if (!cJSON_IsString(jn) || !jn->valuestring[0])
                return pgi__fail(PGI_ERR_PARSE, "%s: %s.name must be a non-empty string", path, w);
            snprintf(m.name, sizeof m.name, "%s", jn->valuestring);
        }
        const cJSON *jt = cJSON_GetObjectItemCaseSensitive(j, "type");
        if (jt) {
            const char *t = cJSON_IsString(jt) ? jt->valuestring : "";
            if (strcmp(t, "lambert") == 0) m.type = PGI__MAT_LAMBERT;
            else if (strcmp(t, "phong") == 0) m.type = PGI__MAT_PHONG;
            else if (strcmp(t, "plastic") == 0) m.type = PGI__MAT_PLASTIC;
            else if (strcmp(t, "mirror") == 0) m.type = PGI__MAT_MIRROR;
            else if (strcmp(t, "glass") == 0) m.type = PGI__MAT_GLASS;
            else
                return pgi__fail(PGI_ERR_PARSE,
                                 "%s: %s.type must be \"lambert\", \"plastic\", \"phong\", \"mirror\" or \"glass\"",
                                 path, w);
        }
        if (m.type == PGI__MAT_MIRROR || m.type == PGI__MAT_GLASS) {
            m.kd[0] = m.kd[1] = m.kd[2] = 0.f;
            m.ks[0] = m.ks[1] = m.ks[2] = 1.f;
        } else if (m.type == PGI__MAT_PHONG || m.type == PGI__MAT_PLASTIC) {
            m.ks[0] = m.ks[1] = m.ks[2] = 0.04f;
            m.shininess = 64.f;
        }
        double sh = m.shininess, ior = m.ior;
        if ((st = get_vec3(path, j, w, "kd", NONNEG, 3.0e38, 0, m.kd, NULL))) return st;
        if ((st = get_vec3(path, j, w, "ks", NONNEG, 3.0e38, 0, m.ks, NULL))) return st;
        if ((st = get_vec3(path, j, w, "emission", NONNEG, (double)PGI_MAX_RADIANCE, 0, m.ke, NULL))) return st;
        if ((st = get_number(path, j, w, "shininess", 0, 1.0, 0, 10000.0, &sh, NULL))) return st;
        if ((st = get_number(path, j, w, "ior", 0, 1.0, 1, 10.0, &ior, NULL))) return st;
        m.shininess = (float)sh;
        m.ior = (float)ior;
        for (int c = 0; c < 3; c++) {
            if (m.kd[c] > 1.f || m.ks[c] > 1.f)
                return pgi__fail(PGI_ERR_PARSE, "%s: %s.kd and ks must be at most 1 (they are reflectances)", path, w);
        }
        if (m.type == PGI__MAT_PHONG)
            for (int c = 0; c < 3; c++)
                if (m.kd[c] + m.ks[c] > 1.f) m.kd[c] = 1.f - m.ks[c]; /* energy conservation, as for MTL */
    }
    pgi__material *nm = realloc(s->mats, (s->nmats + 1) * sizeof *nm);
    if (!nm) return pgi__fail(PGI_ERR_OOM, "%s: out of memory", path);
    s->mats = nm;
    s->mats[s->nmats] = m;
    *out = (uint32_t)s->nmats++;
    return PGI_OK;
}

static pgi_status add_motion(const char *path, pgi_scene *s, const cJSON *jm, const char *where, const char *name,
                             const uint32_t *tris, size_t ntris, const float *pivot) {
    pgi__keyframe *keys = NULL;
    size_t nk = 0;
    pgi__loop loop;
    pgi_status st = parse_motion(path, jm, where, &keys, &nk, &loop);
    if (st) return st;
    st = pgi__scene_add_anim(s, name, tris, ntris, pivot, keys, nk, loop);
    if (st == PGI_ERR_PARSE) { /* name the file */
        char msg[512];
        snprintf(msg, sizeof msg, "%s", pgi_last_error());
        return pgi__fail(st, "%s: %s", path, msg);
    }
    return st;
}

/* "objects": [{"name", "shape": "sphere"|"box", "center", "radius" | "size", "material", "motion"}] */
static pgi_status parse_object(const char *path, pgi_scene *s, const cJSON *o, const char *where) {
    static const char *const keys[] = {"name", "shape", "center", "radius", "size", "material", "motion", NULL};
    if (!cJSON_IsObject(o)) return pgi__fail(PGI_ERR_PARSE, "%s: %s must be an object", path, where);
    pgi_status st = check_keys(path, o, where, keys);
    if (st) return st;
    char name[64];
    snprintf(name, sizeof name, "%s", where);
    const cJSON *jn = cJSON_GetObjectItemCaseSensitive(o, "name");
    if (jn) {
        if (!cJSON_IsString(jn) || !jn->valuestring[0])
            return pgi__fail(PGI_ERR_PARSE, "%s: %s.name must be a non-empty string", path, where);
        snprintf(name, sizeof name, "%s", jn->valuestring);
    }
    const cJSON *js = cJSON_GetObjectItemCaseSensitive(o, "shape");
    const char *shape = cJSON_IsString(js) ? js->valuestring : "";
    if (strcmp(shape, "sphere") != 0 && strcmp(shape, "box") != 0)
        return pgi__fail(PGI_ERR_PARSE, "%s: %s.shape must be \"sphere\" or \"box\"", path, where);
    float c[3], size[3] = {1.f, 1.f, 1.f};
    double radius = 0.0;
    if ((st = get_vec3(path, o, where, "center", ANY, (double)PGI_MAX_COORD, 1, c, NULL))) return st;
    if (shape[0] == 's') {
        if (cJSON_GetObjectItemCaseSensitive(o, "size"))
            return pgi__fail(PGI_ERR_PARSE, "%s: %s: a sphere has a radius, not a size", path, where);
        if ((st = get_number(path, o, where, "radius", 1, 0.0, 1, (double)PGI_MAX_COORD, &radius, NULL))) return st;
    } else {
        if (cJSON_GetObjectItemCaseSensitive(o, "radius"))
            return pgi__fail(PGI_ERR_PARSE, "%s: %s: a box has a size, not a radius", path, where);
        if ((st = get_vec3(path, o, where, "size", NONNEG, (double)PGI_MAX_COORD, 1, size, NULL))) return st;
        if (!(size[0] > 0.f && size[1] > 0.f && size[2] > 0.f))
            return pgi__fail(PGI_ERR_PARSE, "%s: %s.size must be 3 positive numbers", path, where);
    }
    uint32_t mat = 0;
    if ((st = parse_material(path, s, cJSON_GetObjectItemCaseSensitive(o, "material"), where, name, &mat))) return st;
    size_t first;
    if (shape[0] == 's') st = pgi__scene_add_sphere(s, c, (float)radius, mat, &first);
    else st = pgi__scene_add_box(s, c, size, mat, &first);
    if (st) return st;
    const cJSON *jm = cJSON_GetObjectItemCaseSensitive(o, "motion");
    if (!jm) return PGI_OK;
    size_t nt = s->ntris - first;
    uint32_t *tris = malloc(nt * sizeof *tris);
    if (!tris) return pgi__fail(PGI_ERR_OOM, "%s: out of memory", path);
    for (size_t i = 0; i < nt; i++) tris[i] = (uint32_t)(first + i);
    st = add_motion(path, s, jm, where, name, tris, nt, c);
    free(tris);
    return st;
}

/* "animate": [{"material": "name", "motion": {...}}]: moves the mesh triangles of a material. */
static pgi_status parse_animate(const char *path, pgi_scene *s, const cJSON *a, const char *where) {
    static const char *const keys[] = {"material", "motion", NULL};
    if (!cJSON_IsObject(a)) return pgi__fail(PGI_ERR_PARSE, "%s: %s must be an object", path, where);
    pgi_status st = check_keys(path, a, where, keys);
    if (st) return st;
    const cJSON *jm = cJSON_GetObjectItemCaseSensitive(a, "material");
    if (!cJSON_IsString(jm))
        return pgi__fail(PGI_ERR_PARSE, "%s: %s.material must be the name of a mesh material", path, where);
    if (!cJSON_GetObjectItemCaseSensitive(a, "motion"))
        return pgi__fail(PGI_ERR_PARSE, "%s: %s.motion is missing", path, where);
    size_t m = 0;
    while (m < s->nmats && strcmp(s->mats[m].name, jm->valuestring) != 0) m++;
    if (m == s->nmats)
        return pgi__fail(PGI_ERR_PARSE, "%s: %s.material '%s' is not a material of the mesh", path, where,
                         jm->valuestring);
    uint32_t *tris = malloc((s->ntris ? s->ntris : 1) * sizeof *tris);
    if (!tris) return pgi__fail(PGI_ERR_OOM, "%s: out of memory", path);
    size_t nt = 0;
    for (size_t t = 0; t < s->ntris; t++)
        if (s->tri_mat[t] == m) tris[nt++] = (uint32_t)t;
    st = add_motion(path, s, cJSON_GetObjectItemCaseSensitive(a, "motion"), where, jm->valuestring, tris, nt, NULL);
    free(tris);
    return st;
}

/* ------------------------------------------------------------ sky */

/* "sky": {"color", "intensity", "ground", "up"} or "environment": {"map", "scale", "rotation", "up"}
 * (docs/scene-format.md, Sky); replaces the environment of a built-in base. */
static pgi_status parse_sky(const char *path, const cJSON *jsky, const cJSON *jenv, pgi_scene *s) {
    if (jsky && jenv) return pgi__fail(PGI_ERR_PARSE, "%s: give either sky or environment, not both", path);
    const char *where = jsky ? "sky" : "environment";
    const cJSON *j = jsky ? jsky : jenv;
    if (!cJSON_IsObject(j)) return pgi__fail(PGI_ERR_PARSE, "%s: %s must be an object", path, where);
    float up[3] = {0.f, 1.f, 0.f};
    pgi_status st;
    pgi__env *e = NULL;
    if (jsky) {
        static const char *const keys[] = {"color", "intensity", "ground", "up", NULL};
        float color[3] = {1.f, 1.f, 1.f}, ground[3];
        double k = 1.0;
        int has_ground = 0;
        if ((st = check_keys(path, j, where, keys))) return st;
        if ((st = get_vec3(path, j, where, "color", NONNEG, (double)PGI_MAX_RADIANCE, 0, color, NULL))) return st;
        if ((st = get_number(path, j, where, "intensity", 0, 0.0, 0, 3.0e38, &k, NULL))) return st;
        if ((st = get_vec3(path, j, where, "ground", NONNEG, (double)PGI_MAX_RADIANCE, 0, ground, &has_ground)))
            return st;
        if ((st = get_vec3(path, j, where, "up", ANY, (double)PGI_MAX_COORD, 0, up, NULL))) return st;
        if (!has_ground) memcpy(ground, color, sizeof ground);
        for (int c = 0; c < 3; c++) {
            color[c] = (float)(color[c] * k);
            ground[c] = (float)(ground[c] * k);
        }
        for (int c = 0; c < 3; c++)
            if (!(color[c] <= PGI_MAX_RADIANCE) || !(ground[c] <= PGI_MAX_RADIANCE))
                return pgi__fail(PGI_ERR_PARSE,
                                 "%s: sky: color x intensity (and ground x intensity) = %g is out of range "
                                 "(0..%g, a radiance)",
                                 path, (double)fmaxf(color[c], ground[c]), (double)PGI_MAX_RADIANCE);
        if (!(v3_len(v3_load(up)) > 0.f)) return pgi__fail(PGI_ERR_PARSE, "%s: sky.up must not be zero", path);
        if ((st = pgi__env_create_constant(path, color, ground, up, &e))) return st;
    } else {
        static const char *const keys[] = {"map", "scale", "rotation", "up", NULL};
        double scale = 1.0, rot = 0.0;
        if ((st = check_keys(path, j, where, keys))) return st;
        const cJSON *jm = cJSON_GetObjectItemCaseSensitive(j, "map");
        if (!jm)
            return pgi__fail(PGI_ERR_PARSE, "%s: environment.map is missing (an equirectangular EXR or HDR image)",
                             path);
        if (!cJSON_IsString(jm) || !jm->valuestring[0])
            return pgi__fail(PGI_ERR_PARSE, "%s: environment.map must be a non-empty string (an image path)", path);
        if ((st = get_number(path, j, where, "scale", 0, 0.0, 0, 3.0e38, &scale, NULL))) return st;
        if ((st = get_number(path, j, where, "rotation", 0, -36000.0, 0, 36000.0, &rot, NULL))) return st;
        if ((st = get_vec3(path, j, where, "up", ANY, (double)PGI_MAX_COORD, 0, up, NULL))) return st;
        if (!(v3_len(v3_load(up)) > 0.f)) return pgi__fail(PGI_ERR_PARSE, "%s: environment.up must not be zero", path);
        char map[1024];
        if ((st = resolve_mesh(path, "environment.map", jm->valuestring, map, sizeof map))) return st;
        if ((st = pgi__env_create_map(path, map, (float)scale, (float)rot, up, &e))) return st;
    }
    pgi__env_destroy(s->env);
    s->env = e;
    return PGI_OK;
}

/* "portals": [{"quad": [[x, y, z] x 4]}, ...]: parallelograms through which the sun and the sky
 * come in (portal.h). */
static pgi_status parse_portals(const char *path, const cJSON *j, pgi_scene *s) {
    if (!cJSON_IsArray(j))
        return pgi__fail(PGI_ERR_PARSE, "%s: portals must be an array of {\"quad\": [4 corners]}", path);
    const int n = cJSON_GetArraySize(j);
    if (n > PGI__MAX_PORTALS)
        return pgi__fail(PGI_ERR_PARSE, "%s: portals has %d entries, more than %d", path, n, PGI__MAX_PORTALS);
    if (!n) return PGI_OK;
    pgi__portal *P = calloc((size_t)n, sizeof *P);
    if (!P) return pgi__fail(PGI_ERR_OOM, "%s: out of memory", path);
    static const char *const keys[] = {"quad", NULL};
    pgi_status st = PGI_OK;
    char where[64];
    int i = 0;
    for (const cJSON *it = j->child; !st && it; it = it->next, i++) {
        snprintf(where, sizeof where, "portals[%d]", i);
        if (!cJSON_IsObject(it)) {
            st = pgi__fail(PGI_ERR_PARSE, "%s: %s must be an object {\"quad\": [4 corners]}", path, where);
            break;
        }
        if ((st = check_keys(path, it, where, keys))) break;
        const cJSON *q = cJSON_GetObjectItemCaseSensitive(it, "quad");
        float v[4][3];
        int ok = cJSON_IsArray(q) && cJSON_GetArraySize(q) == 4;
        const cJSON *c = ok ? q->child : NULL;
        for (int k = 0; ok && k < 4; k++, c = c->next) {
            ok = cJSON_IsArray(c) && cJSON_GetArraySize(c) == 3;
            const cJSON *e = ok ? c->child : NULL;
            for (int a = 0; ok && a < 3; a++, e = e->next) {
                ok = cJSON_IsNumber(e) && isfinite(e->valuedouble) && fabs(e->valuedouble) <= (double)PGI_MAX_COORD;
                if (ok) v[k][a] = (float)e->valuedouble;
            }
        }
        if (!ok) {
            st = pgi__fail(PGI_ERR_PARSE,
                           "%s: %s.quad %s (an array of 4 corners [x, y, z] of finite numbers of magnitude at most "
                           "%g)",
                           path, where, q ? "is malformed" : "is missing", (double)PGI_MAX_COORD);
            break;
        }
        const char *why = pgi__portal_from_quad(&P[i], (const float(*)[3])v);
        if (why) st = pgi__fail(PGI_ERR_PARSE, "%s: %s.quad %s", path, where, why);
    }
    if (st) {
        free(P);
        return st;
    }
    free(s->portals);
    s->portals = P;
    s->nportals = (size_t)n;
    return PGI_OK;
}

/* ------------------------------------------------------------ loading */

static pgi_status load(const char *path, const cJSON *root, pgi_scene **out) {
    static const char *const keys[] = {"name",    "mesh",    "camera",   "cameras", "lights",      "render",  "builtin",
                                       "objects", "animate", "specular", "sky",     "environment", "portals", NULL};
    if (!cJSON_IsObject(root)) return pgi__fail(PGI_ERR_PARSE, "%s: the top level must be a JSON object", path);
    pgi_status st = check_keys(path, root, "", keys);
    if (st) return st;

    const cJSON *jname = cJSON_GetObjectItemCaseSensitive(root, "name");
    char name[128];
    if (jname) {
        if (!cJSON_IsString(jname) || !jname->valuestring[0])
            return pgi__fail(PGI_ERR_PARSE, "%s: name must be a non-empty string", path);
        snprintf(name, sizeof name, "%.127s", jname->valuestring);
    } else {
        const char *b = strrchr(path, '/');
        b = b ? b + 1 : path;
        size_t l = strlen(b);
        if (l > 5 && strcmp(b + l - 5, ".json") == 0) l -= 5;
        if (l > sizeof name - 1) l = sizeof name - 1;
        memcpy(name, b, l);
        name[l] = 0;
    }

    const cJSON *jmesh = cJSON_GetObjectItemCaseSensitive(root, "mesh");
    const cJSON *jbuiltin = cJSON_GetObjectItemCaseSensitive(root, "builtin");
    if (jmesh && jbuiltin) return pgi__fail(PGI_ERR_PARSE, "%s: give either mesh or builtin, not both", path);
    if (jbuiltin) {
        int known = 0;
        for (int i = 0; cJSON_IsString(jbuiltin) && pgi__builtin_names[i]; i++)
            known |= strcmp(jbuiltin->valuestring, pgi__builtin_names[i]) == 0;
        if (!known) {
            char names[256] = "";
            for (int i = 0; pgi__builtin_names[i]; i++) pgi__list_append(names, sizeof names, pgi__builtin_names[i]);
            return pgi__fail(PGI_ERR_PARSE, "%s: builtin must name a built-in scene (%s)", path, names);
        }
    } else {
        if (!jmesh)
            return pgi__fail(PGI_ERR_PARSE, "%s: mesh is missing (the path of an OBJ/glTF/PLY file; or builtin)", path);
        if (!cJSON_IsString(jmesh) || !jmesh->valuestring[0])
            return pgi__fail(PGI_ERR_PARSE, "%s: mesh must be a non-empty string (a file path)", path);
    }
    const cJSON *jobjs = cJSON_GetObjectItemCaseSensitive(root, "objects");
    if (jobjs && !cJSON_IsArray(jobjs)) return pgi__fail(PGI_ERR_PARSE, "%s: objects must be an array", path);
    const cJSON *janim = cJSON_GetObjectItemCaseSensitive(root, "animate");
    if (janim && !cJSON_IsArray(janim)) return pgi__fail(PGI_ERR_PARSE, "%s: animate must be an array", path);

    /* Cameras and lights are parsed before the (slow) mesh import so that errors come fast. */
    const cJSON *jcam = cJSON_GetObjectItemCaseSensitive(root, "camera");
    const cJSON *jcams = cJSON_GetObjectItemCaseSensitive(root, "cameras");
    if (jcam && jcams) return pgi__fail(PGI_ERR_PARSE, "%s: give either camera or cameras, not both", path);
    if (jcams && !cJSON_IsArray(jcams)) return pgi__fail(PGI_ERR_PARSE, "%s: cameras must be an array", path);
    const cJSON *jlights = cJSON_GetObjectItemCaseSensitive(root, "lights");
    if (jlights && !cJSON_IsArray(jlights)) return pgi__fail(PGI_ERR_PARSE, "%s: lights must be an array", path);
    const cJSON *jrender = cJSON_GetObjectItemCaseSensitive(root, "render");
    const cJSON *jspec = cJSON_GetObjectItemCaseSensitive(root, "specular");
    pgi_specular specular = PGI_SPECULAR_DEFAULT;
    if (jspec) {
        const char *v = cJSON_IsString(jspec) ? jspec->valuestring : "";
        if (strcmp(v, "ggx") == 0) specular = PGI_SPECULAR_GGX;
        else if (strcmp(v, "phong") == 0) specular = PGI_SPECULAR_PHONG;
        else return pgi__fail(PGI_ERR_PARSE, "%s: specular must be \"ggx\" or \"phong\"", path);
    }

    char mesh[1024];
    if (jmesh && (st = resolve_mesh(path, "mesh", jmesh->valuestring, mesh, sizeof mesh))) return st;

    pgi_scene *s;
    size_t nbase = 0; /* lights of the built-in base scene kept before the description's */
    pgi_scene_defaults base_defaults = {0};
    if (jbuiltin) {
        if ((st = pgi__scene_builtin(jbuiltin->valuestring, &s))) return st;
        snprintf(s->name, sizeof s->name, "%s", name);
        base_defaults = s->defaults;
    } else if ((st = pgi__scene_new(name, &s))) {
        return st;
    }
    snprintf(s->source, sizeof s->source, "%s", path);
    s->specular = specular;

    size_t ncam = jcam ? 1 : (jcams ? (size_t)cJSON_GetArraySize(jcams) : 0);
    size_t nl = jlights ? (size_t)cJSON_GetArraySize(jlights) : 0;
    if (jbuiltin) {
        /* Keep the base's explicit lights (area lights are re-derived by finalize). */
        for (size_t i = 0; i < s->nlights; i++)
            if (s->lights[i].type != PGI__LIGHT_AREA) s->lights[nbase++] = s->lights[i];
        s->nlights = nbase;
        if (ncam) {
            free(s->cams);
            free(s->cam_names);
            s->cams = NULL;
            s->cam_names = NULL;
            s->ncams = 0;
            s->cams_auto = 0;
        }
    }
    if (ncam) {
        s->cams = calloc(ncam, sizeof *s->cams);
        s->cam_names = calloc(ncam, sizeof *s->cam_names);
        if (!s->cams || !s->cam_names) st = pgi__fail(PGI_ERR_OOM, "%s: out of memory", path);
    }
    if (!st && nl) {
        pgi__light *L = realloc(s->lights, (nbase + nl) * sizeof *L);
        if (!L) st = pgi__fail(PGI_ERR_OOM, "%s: out of memory", path);
        else s->lights = L;
    }
    char where[64];
    if (!st && jcam) {
        st = parse_camera(path, jcam, "camera", &s->cams[0], s->cam_names[0], sizeof s->cam_names[0]);
        if (!st) s->ncams = 1;
    }
    /* Arrays are walked by their links (cJSON_GetArrayItem in a loop is quadratic: 10^5 lights took 30 s). */
    const cJSON *it = jcams ? jcams->child : NULL;
    for (size_t i = 0; !st && jcams && i < ncam; i++, it = it->next) {
        snprintf(where, sizeof where, "cameras[%zu]", i);
        st = parse_camera(path, it, where, &s->cams[i], s->cam_names[i], sizeof s->cam_names[i]);
        if (!st) s->ncams = i + 1;
    }
    it = jlights ? jlights->child : NULL;
    for (size_t i = 0; !st && i < nl; i++, it = it->next) {
        snprintf(where, sizeof where, "lights[%zu]", i);
        st = parse_light(path, it, where, &s->lights[nbase + i]);
        if (!st) s->nlights = nbase + i + 1;
    }
    if (!st && jrender) st = parse_render(path, jrender, &s->defaults);
    const cJSON *jsky = cJSON_GetObjectItemCaseSensitive(root, "sky");
    const cJSON *jenv = cJSON_GetObjectItemCaseSensitive(root, "environment");
    if (!st && (jsky || jenv)) st = parse_sky(path, jsky, jenv, s);
    const cJSON *jportals = cJSON_GetObjectItemCaseSensitive(root, "portals");
    if (!st && jportals) st = parse_portals(path, jportals, s);
    if (!st && jbuiltin) {
        /* Settings the description leaves out come from the built-in scene. */
        pgi_scene_defaults *d = &s->defaults;
        if (!d->photons) d->photons = base_defaults.photons;
        if (!(d->radius > 0.f)) d->radius = base_defaults.radius;
        if (!d->bounces) d->bounces = base_defaults.bounces;
        if (!d->width && !d->height) d->width = base_defaults.width, d->height = base_defaults.height;
        if (!(d->exposure > 0.f)) d->exposure = base_defaults.exposure;
    }
    if (!st && jmesh) st = pgi__scene_import_mesh(s, mesh);
    /* The objects' triangles counted before any is made (a sphere has 48 x 23 x 2, a box 12). */
    size_t planned = 0, k = 0;
    for (it = jobjs ? jobjs->child : NULL; !st && it; it = it->next, k++) {
        const cJSON *js = cJSON_GetObjectItemCaseSensitive(it, "shape");
        const char *shape = cJSON_IsString(js) ? js->valuestring : "";
        planned += strcmp(shape, "sphere") == 0 ? 48u * 23u * 2u : strcmp(shape, "box") == 0 ? 12u : 0u;
        if (planned > MAX_OBJECT_TRIANGLES)
            st = pgi__fail(PGI_ERR_PARSE,
                           "%s: objects[%zu]: the objects make more than %u triangles (a sphere has %u, a box 12): %zu "
                           "objects of %d would take gigabytes",
                           path, k, MAX_OBJECT_TRIANGLES, 48u * 23u * 2u, k + 1, cJSON_GetArraySize(jobjs));
    }
    it = jobjs ? jobjs->child : NULL;
    const size_t mesh_tris = s->ntris;
    for (size_t i = 0; !st && it; i++, it = it->next) {
        snprintf(where, sizeof where, "objects[%zu]", i);
        st = parse_object(path, s, it, where);
        if (!st && s->ntris - mesh_tris > MAX_OBJECT_TRIANGLES)
            st = pgi__fail(PGI_ERR_PARSE,
                           "%s: %s: the objects make more than %u triangles (a sphere has %u, a box 12): %zu objects "
                           "of %d would take gigabytes",
                           path, where, MAX_OBJECT_TRIANGLES, 48u * 23u * 2u, i + 1, cJSON_GetArraySize(jobjs));
    }
    it = janim ? janim->child : NULL;
    for (size_t i = 0; !st && it; i++, it = it->next) {
        snprintf(where, sizeof where, "animate[%zu]", i);
        st = parse_animate(path, s, it, where);
    }
    if (!st) st = pgi__scene_finalize(s, path);
    if (!st && s->nanims) {
        s->time = NAN; /* force: keyframe 0 need not be the rest pose */
        st = pgi_scene_set_time(s, 0.0);
        s->dynamic_version = 0;
    }
    if (!st && s->nlights == 0 && !s->env && pgi__scene_emissive_triangles(s) > 0)
        st = pgi__fail(PGI_ERR_PARSE,
                       "%s: the scene has no lights: its emissive triangles (%zu) all have zero area; add a "
                       "\"lights\" list or a \"sky\"",
                       path, pgi__scene_emissive_triangles(s));
    else if (!st && s->nlights == 0 && !s->env)
        st = pgi__fail(PGI_ERR_PARSE,
                       "%s: the scene has no lights: add a \"lights\" list or a \"sky\", or use a mesh with "
                       "emissive (Ke) materials",
                       path);
    if (st) {
        pgi_scene_destroy(s);
        return st;
    }
    *out = s;
    return PGI_OK;
}

pgi_status pgi__scene_load_json(const char *path, pgi_scene **out) {
    if (!path || !out) return pgi__fail(PGI_ERR_INVALID_ARG, "pgi__scene_load_json: NULL argument");
    *out = NULL;
    char *text = NULL;
    size_t len = 0;
    pgi_status st = read_file(path, &text, &len);
    if (st) return st;
    if (memchr(text, 0, len)) {
        free(text);
        return pgi__fail(PGI_ERR_PARSE, "%s: not a JSON text (contains NUL bytes)", path);
    }
    size_t nvalues = count_json_values(text, len);
    if (nvalues > MAX_JSON_VALUES) {
        free(text);
        return pgi__fail(PGI_ERR_PARSE,
                         "%s: about %zu JSON values, more than %u: not a scene description (10^5 lights take about "
                         "10^6 values)",
                         path, nvalues, MAX_JSON_VALUES);
    }
    const char *end = NULL;
    /* The length includes the terminating NUL, as cJSON_ParseWithOpts does: with
     * require_null_terminated, cJSON checks that the parse stops at a NUL inside the buffer. */
    cJSON *root = cJSON_ParseWithLengthOpts(text, len + 1, &end, 1);
    if (!root) {
        /* cJSON reports where it stopped; count the lines up to there (thread-safe, unlike cJSON_GetErrorPtr). */
        size_t off = end && end >= text && end <= text + len ? (size_t)(end - text) : len;
        size_t line = 1, col = 1;
        for (size_t i = 0; i < off; i++) {
            if (text[i] == '\n') line++, col = 1;
            else col++;
        }
        free(text);
        return pgi__fail(PGI_ERR_PARSE, "%s: invalid JSON near line %zu, column %zu", path, line, col);
    }
    free(text);
    st = load(path, root, out);
    cJSON_Delete(root);
    return st;
}
