/* Checks a glTF's accessors, buffer views and the objects that use them before Assimp reads it.
 * Assimp 5.2's glTF 2 importer trusts much of what the JSON says: a sparse accessor without
 * "indices" or "values" dereferences a null pointer; an accessor's range is checked by its
 * component size alone (a VEC3 may read past its view); an accessor with neither a buffer view
 * nor a sparse part, a skin without inverse bind matrices, a triangle strip of fewer than three
 * vertices, an animation whose output is shorter than its input (CUBICSPLINE: three times) and
 * indices past the vertex count all crash it or read out of bounds. These are refused here with
 * the object and the problem; what Assimp checks itself (an index past the end of an array, a
 * buffer shorter than its byteLength) is left to it. The rules are glTF 2.0's own "MUST"s, and
 * a few that glTF leaves open and Assimp needs (POSITION in every primitive, three vertices to
 * a triangle strip or fan). */
#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cjson/cJSON.h>

#include "scene/scene_internal.h"

#define GLTF_FLOAT 5126
#define SPARSE_ONLY_MAX_BYTES ((double)(1 << 28)) /* an accessor of zeros and a sparse part */
#define PGI__GLTF_MAX_READ ((size_t)1 << 30)      /* bytes of indices read to check them */

typedef struct gltf {
    const char *path;
    const cJSON *buffers, *views, *accessors, *nodes;
    int n_buffers, n_views, n_accessors, n_nodes;
    FILE *glb; /* the GLB whose BIN chunk (glb_bin_len bytes at glb_bin) is buffer 0 without a uri */
    uint64_t glb_bin, glb_bin_len;
    char msg[256];
} gltf;

/* Fills g->msg and returns PGI_ERR_PARSE. */
static pgi_status bad(gltf *g, const char *fmt, ...) {
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(g->msg, sizeof g->msg, fmt, ap);
    va_end(ap);
    return pgi__fail(PGI_ERR_PARSE, "%s: %s", g->path, g->msg);
}

static const cJSON *item(const cJSON *o, const char *key) { return cJSON_GetObjectItemCaseSensitive(o, key); }

static int array_size(const cJSON *a) { return cJSON_IsArray(a) ? cJSON_GetArraySize(a) : 0; }

/* A non-negative integer member: 1 when present (in *out), 0 when absent (*out = def), -1 when
 * present but not an integer in [0, max]. */
static int get_uint(const cJSON *o, const char *key, double max, double def, double *out) {
    const cJSON *v = item(o, key);
    *out = def;
    if (!v) return 0;
    if (!cJSON_IsNumber(v) || !(v->valuedouble >= 0 && v->valuedouble <= max) ||
        v->valuedouble != floor(v->valuedouble))
        return -1;
    *out = v->valuedouble;
    return 1;
}

/* A member naming an element of an array of n: 0 (in *out) when valid, 1 when absent and
 * optional; otherwise the refusal. */
static pgi_status get_ref(gltf *g, const cJSON *o, const char *key, int n, int required, const char *owner,
                          const char *target, int *out) {
    double v;
    const int r = get_uint(o, key, 1e15, -1, &v);
    *out = -1;
    if (r == 0 && !required) return PGI_OK;
    if (r == 0) return bad(g, "%s has no \"%s\"", owner, key);
    if (r < 0 || v >= n) return bad(g, "%s: \"%s\" is not one of its %d %s", owner, key, n, target);
    *out = (int)v;
    return PGI_OK;
}

static int component_size(double t) {
    switch ((int)t) {
    case 5120:
    case 5121: return 1;
    case 5122:
    case 5123: return 2;
    case 5125:
    case 5126: return 4;
    default: return 0;
    }
}

/* Components of an accessor type, 0 when it is none. */
static int type_components(const char *t) {
    static const struct {
        const char *name;
        int n;
    } k[] = {{"SCALAR", 1}, {"VEC2", 2}, {"VEC3", 3}, {"VEC4", 4}, {"MAT2", 4}, {"MAT3", 9}, {"MAT4", 16}};
    for (size_t i = 0; t && i < sizeof k / sizeof k[0]; i++)
        if (strcmp(t, k[i].name) == 0) return k[i].n;
    return 0;
}

typedef struct accessor {
    double count, component, byte_offset;
    int components, view, sparse;
    const char *type;
} accessor;

/* Buffer view i's offset, length and stride (0: packed); checked against its buffer. */
static pgi_status view_range(gltf *g, int i, double *offset, double *length, double *stride, int *buffer) {
    const cJSON *v = cJSON_GetArrayItem(g->views, i);
    char owner[48];
    snprintf(owner, sizeof owner, "buffer view %d", i);
    pgi_status st = get_ref(g, v, "buffer", g->n_buffers, 1, owner, "buffers", buffer);
    if (st) return st;
    double blen;
    if (get_uint(cJSON_GetArrayItem(g->buffers, *buffer), "byteLength", 1e15, 0, &blen) != 1 || blen < 1)
        return bad(g, "buffer %d has no byteLength of at least 1", *buffer);
    if (get_uint(v, "byteLength", 1e15, 0, length) != 1 || *length < 1)
        return bad(g, "%s has no byteLength of at least 1", owner);
    if (get_uint(v, "byteOffset", 1e15, 0, offset) < 0) return bad(g, "%s: byteOffset is not a byte count", owner);
    if (get_uint(v, "byteStride", 252, 0, stride) < 0 || (*stride != 0 && *stride < 4))
        return bad(g, "%s: byteStride is not 4 to 252", owner);
    if (*offset + *length > blen)
        return bad(g, "%s: bytes %.0f to %.0f lie past the end of buffer %d (%.0f bytes)", owner, *offset,
                   *offset + *length, *buffer, blen);
    return PGI_OK;
}

/* Accessor i: its type, component type, and that every byte it reads lies in its views. */
static pgi_status check_accessor(gltf *g, int i, accessor *a) {
    const cJSON *o = cJSON_GetArrayItem(g->accessors, i);
    char owner[48];
    snprintf(owner, sizeof owner, "accessor %d", i);
    memset(a, 0, sizeof *a);
    if (!cJSON_IsObject(o)) return bad(g, "%s is not an object", owner);
    const cJSON *type = item(o, "type");
    a->type = cJSON_IsString(type) ? type->valuestring : NULL;
    a->components = type_components(a->type);
    if (!a->components) return bad(g, "%s: \"type\" is not SCALAR, VEC2-4 or MAT2-4", owner);
    if (get_uint(o, "componentType", 1e9, 0, &a->component) != 1 || !component_size(a->component))
        return bad(g, "%s: \"componentType\" is not 5120-5123, 5125 or 5126", owner);
    if (get_uint(o, "count", 4294967295.0, 0, &a->count) != 1 || a->count < 1)
        return bad(g, "%s: \"count\" is not a whole number of at least 1", owner);
    if (get_uint(o, "byteOffset", 1e15, 0, &a->byte_offset) < 0)
        return bad(g, "%s: byteOffset is not a byte count", owner);
    pgi_status st = get_ref(g, o, "bufferView", g->n_views, 0, owner, "buffer views", &a->view);
    if (st) return st;
    const double elem = a->components * component_size(a->component);
    const cJSON *sparse = item(o, "sparse");
    a->sparse = sparse != NULL;
    if (a->view >= 0) {
        double off, len, stride;
        int buf;
        if ((st = view_range(g, a->view, &off, &len, &stride, &buf))) return st;
        if (stride != 0 && stride < elem)
            return bad(g, "%s: elements of %.0f bytes in buffer view %d of stride %.0f", owner, elem, a->view, stride);
        const double step = stride != 0 ? stride : elem;
        const double end = fmax(a->byte_offset + (a->count - 1) * step + elem, a->byte_offset + a->count * elem);
        if (end > len)
            return bad(g, "%s: %.0f elements of %.0f bytes from byte %.0f need %.0f bytes, buffer view %d has %.0f",
                       owner, a->count, elem, a->byte_offset, end, a->view, len);
    } else if (!sparse) {
        return bad(g, "%s has neither a bufferView nor a sparse part", owner);
    } else if (a->count * elem > SPARSE_ONLY_MAX_BYTES) {
        return bad(g, "%s: %.0f elements of zeros (at most %.0f bytes)", owner, a->count, SPARSE_ONLY_MAX_BYTES);
    }
    if (!sparse) return PGI_OK;
    if (!cJSON_IsObject(sparse)) return bad(g, "%s: \"sparse\" is not an object", owner);
    double n;
    if (get_uint(sparse, "count", a->count, 0, &n) != 1 || n < 1)
        return bad(g, "%s: sparse \"count\" is not 1 to the accessor's count (%.0f)", owner, a->count);
    static const char *const parts[2] = {"indices", "values"};
    for (int p = 0; p < 2; p++) {
        const cJSON *part = item(sparse, parts[p]);
        char what[64];
        snprintf(what, sizeof what, "%s: sparse %s", owner, parts[p]);
        if (!cJSON_IsObject(part)) return bad(g, "%s: sparse has no \"%s\" object", owner, parts[p]);
        int view;
        if ((st = get_ref(g, part, "bufferView", g->n_views, 1, what, "buffer views", &view))) return st;
        double view_off, len, stride, off, ct = 0, size = elem;
        int buf;
        if ((st = view_range(g, view, &view_off, &len, &stride, &buf))) return st;
        if (get_uint(part, "byteOffset", 1e15, 0, &off) < 0) return bad(g, "%s: byteOffset is not a byte count", what);
        if (p == 0) {
            if (get_uint(part, "componentType", 1e9, 0, &ct) != 1 || (ct != 5121 && ct != 5123 && ct != 5125))
                return bad(g, "%s: \"componentType\" is not 5121, 5123 or 5125", what);
            size = component_size(ct);
        }
        if (off + n * size > len)
            return bad(g, "%s: %.0f of %.0f bytes from byte %.0f lie past buffer view %d (%.0f bytes)", what, n, size,
                       off, view, len);
    }
    return PGI_OK;
}

static const char k_base64[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";

/* The path of a file a buffer's uri names beside the glTF (as Assimp opens it: the uri as
 * written); malloc'd, NULL when out of memory. */
static char *beside(const gltf *g, const char *uri) {
    const char *slash = strrchr(g->path, '/');
    const size_t dir = slash ? (size_t)(slash - g->path) + 1 : 0;
    char *full = malloc(dir + strlen(uri) + 1);
    if (full) {
        memcpy(full, g->path, dir);
        strcpy(full + dir, uri);
    }
    return full;
}

/* Reads `n` bytes of buffer `b` from `offset`: from a base64 data: URI, a file beside the glTF
 * or the GLB's BIN chunk. 1 when read; 0 when the bytes are not there (Assimp then refuses the
 * buffer itself: a missing file, data shorter than its byteLength). */
static int read_buffer(gltf *g, int b, double offset, size_t n, unsigned char *out) {
    const cJSON *uri = item(cJSON_GetArrayItem(g->buffers, b), "uri");
    if (!uri) {
        if (!g->glb || b != 0 || offset + (double)n > (double)g->glb_bin_len) return 0;
        return fseek(g->glb, (long)(g->glb_bin + (uint64_t)offset), SEEK_SET) == 0 && fread(out, 1, n, g->glb) == n;
    }
    if (!cJSON_IsString(uri)) return 0;
    const char *s = uri->valuestring;
    if (strncmp(s, "data:", 5) == 0) {
        const char *comma = strchr(s, ',');
        if (!comma || !strstr(s, ";base64,")) return 0;
        /* 4 characters to 3 bytes: decode the quartets that hold the bytes wanted */
        const char *d = comma + 1;
        const size_t len = strlen(d);
        size_t at = (size_t)offset / 3 * 4, skip = (size_t)offset % 3, got = 0;
        while (got < n && at + 4 <= len) {
            uint32_t q = 0;
            int pad = 0;
            for (int k = 0; k < 4; k++) {
                const char c = d[at + k], *p = c ? strchr(k_base64, c) : NULL;
                if (c == '=') pad++;
                else if (!p || pad) return 0;
                q = q << 6 | (uint32_t)(p ? p - k_base64 : 0);
            }
            const unsigned char three[3] = {(unsigned char)(q >> 16), (unsigned char)(q >> 8), (unsigned char)q};
            for (int k = (int)skip; k < 3 - pad && got < n; k++) out[got++] = three[k];
            skip = 0;
            at += 4;
        }
        return got == n;
    }
    char *full = beside(g, s);
    uint64_t size;
    const char *why;
    FILE *f = full ? pgi__fopen_input(full, 0, &size, &why) : NULL;
    free(full);
    if (!f) return 0;
    const int ok =
        offset + (double)n <= (double)size && fseek(f, (long)offset, SEEK_SET) == 0 && fread(out, 1, n, f) == n;
    fclose(f);
    return ok;
}

/* The largest value of an index accessor (SCALAR, unsigned, in a buffer view); -1 when its bytes
 * are not at hand. */
static double max_index(gltf *g, const accessor *a) {
    double off, len, stride;
    int buf;
    if (view_range(g, a->view, &off, &len, &stride, &buf)) return -1;
    const int size = component_size(a->component);
    const double step = stride != 0 ? stride : size;
    const size_t span = (size_t)((a->count - 1) * step + size);
    /* no more than the buffer's declared length (Assimp checks that it holds that much) */
    double blen;
    get_uint(cJSON_GetArrayItem(g->buffers, buf), "byteLength", 1e15, 0, &blen);
    if ((double)span > blen || (double)span > (double)PGI__GLTF_MAX_READ) return -1;
    unsigned char *bytes = malloc(span);
    double max = -1;
    if (bytes && read_buffer(g, buf, off + a->byte_offset, span, bytes)) {
        max = 0;
        for (size_t i = 0; i < (size_t)a->count; i++) {
            const unsigned char *p = bytes + (size_t)(i * step);
            const double v =
                size == 1 ? p[0]
                : size == 2
                    ? (double)(p[0] | p[1] << 8)
                    : (double)((uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24);
            if (v > max) max = v;
        }
    }
    free(bytes);
    return max;
}

/* Attribute semantics as Assimp matches them (by prefix, in this order), with the types and
 * component types glTF allows for each; types 0: any. */
static const struct semantic {
    const char *prefix;
    const char *types[2];
    double components[3];
} k_semantics[] = {
    {"POSITION", {"VEC3"}, {GLTF_FLOAT}},
    {"NORMAL", {"VEC3"}, {GLTF_FLOAT}},
    {"TANGENT", {"VEC4"}, {GLTF_FLOAT}},
    {"TEXCOORD", {"VEC2"}, {GLTF_FLOAT, 5121, 5123}},
    {"COLOR", {"VEC3", "VEC4"}, {GLTF_FLOAT, 5121, 5123}},
    {"JOINTS", {"VEC4"}, {5121, 5123}},
    {"JOINTMATRIX", {NULL}, {0}},
    {"WEIGHTS", {"VEC4"}, {GLTF_FLOAT, 5121, 5123}},
};

static int semantic_of(const char *name, int targets) {
    for (int i = 0; i < (targets ? 3 : (int)(sizeof k_semantics / sizeof k_semantics[0])); i++)
        if (strncmp(name, k_semantics[i].prefix, strlen(k_semantics[i].prefix)) == 0) return i;
    return -1;
}

/* The attributes of a primitive (or one morph target): each a valid accessor of its semantic's
 * type and of the primitive's vertex count (*vertices; set from POSITION when < 0). */
static pgi_status check_attributes(gltf *g, const cJSON *attrs, const char *owner, int targets, double *vertices,
                                   int *sets) {
    pgi_status st;
    const cJSON *pos = item(attrs, "POSITION");
    for (int pass = 0; pass < 2; pass++) /* POSITION first: the others must match its count */
        for (const cJSON *at = attrs->child; at; at = at->next) {
            if ((pass == 0) != (at == pos)) continue;
            const int s = semantic_of(at->string, targets);
            if (s < 0) continue; /* Assimp skips what it does not know */
            char what[192];
            snprintf(what, sizeof what, "%s: attribute %.40s", owner, at->string);
            double v;
            if (get_uint(attrs, at->string, 1e15, 0, &v) != 1 || v >= g->n_accessors)
                return bad(g, "%s is not one of its %d accessors", what, g->n_accessors);
            accessor a;
            if ((st = check_accessor(g, (int)v, &a))) return st;
            const struct semantic *sem = &k_semantics[s];
            int type_ok = !sem->types[0], comp_ok = !sem->components[0];
            for (int k = 0; k < 2 && sem->types[k]; k++) type_ok |= strcmp(a.type, sem->types[k]) == 0;
            for (int k = 0; k < 3 && sem->components[k]; k++) comp_ok |= a.component == sem->components[k];
            if (!type_ok || !comp_ok)
                return bad(g, "%s: accessor %.0f (%s of %.0f) is not a %s of the types glTF allows", what, v, a.type,
                           a.component, sem->types[0] ? sem->types[0] : "?");
            if (*vertices < 0) *vertices = a.count;
            else if (a.count != *vertices)
                return bad(g, "%s: %.0f elements, POSITION has %.0f", what, a.count, *vertices);
            if (sets) sets[s]++;
        }
    return PGI_OK;
}

static pgi_status check_mesh(gltf *g, int m, const cJSON *mesh) {
    const cJSON *prims = item(mesh, "primitives");
    char owner[64];
    snprintf(owner, sizeof owner, "mesh %d", m);
    if (array_size(prims) < 1) return bad(g, "%s has no primitives", owner);
    int p = 0;
    pgi_status st;
    for (const cJSON *prim = prims->child; prim; prim = prim->next, p++) {
        snprintf(owner, sizeof owner, "mesh %d primitive %d", m, p);
        const cJSON *attrs = item(prim, "attributes");
        if (!cJSON_IsObject(attrs)) return bad(g, "%s has no \"attributes\" object", owner);
        if (!item(attrs, "POSITION")) return bad(g, "%s has no POSITION attribute", owner);
        double vertices = -1, mode;
        int sets[sizeof k_semantics / sizeof k_semantics[0]] = {0};
        if ((st = check_attributes(g, attrs, owner, 0, &vertices, sets))) return st;
        if (sets[5] && sets[7] && sets[5] != sets[7])
            return bad(g, "%s: %d JOINTS sets and %d WEIGHTS sets", owner, sets[5], sets[7]);
        if (get_uint(prim, "mode", 6, 4, &mode) < 0) return bad(g, "%s: \"mode\" is not 0 to 6", owner);
        int idx;
        if ((st = get_ref(g, prim, "indices", g->n_accessors, 0, owner, "accessors", &idx))) return st;
        double n = vertices;
        if (idx >= 0) {
            accessor a;
            if ((st = check_accessor(g, idx, &a))) return st;
            if (strcmp(a.type, "SCALAR") != 0 || (a.component != 5121 && a.component != 5123 && a.component != 5125) ||
                a.view < 0 || a.sparse)
                return bad(g, "%s: indices (accessor %d) are not unsigned SCALARs in a buffer view", owner, idx);
            const double max = max_index(g, &a);
            if (max >= vertices)
                return bad(g, "%s: index %.0f of accessor %d is past its %.0f vertices", owner, max, idx, vertices);
            n = a.count;
        }
        static const double need[7] = {1, 2, 2, 2, 3, 3, 3};
        if (n < need[(int)mode])
            return bad(g, "%s: %.0f vertices, mode %.0f needs at least %.0f", owner, n, mode, need[(int)mode]);
        const cJSON *targets = item(prim, "targets");
        if (targets && !cJSON_IsArray(targets)) return bad(g, "%s: \"targets\" is not an array", owner);
        int t = 0;
        for (const cJSON *tg = targets ? targets->child : NULL; tg; tg = tg->next, t++) {
            char what[96];
            snprintf(what, sizeof what, "%s target %d", owner, t);
            if (!cJSON_IsObject(tg)) return bad(g, "%s is not an object", what);
            if ((st = check_attributes(g, tg, what, 1, &vertices, NULL))) return st;
        }
    }
    return PGI_OK;
}

static pgi_status check_skin(gltf *g, int s, const cJSON *skin) {
    char owner[48];
    snprintf(owner, sizeof owner, "skin %d", s);
    const cJSON *joints = item(skin, "joints");
    if (array_size(joints) < 1) return bad(g, "%s has no joints", owner);
    for (const cJSON *j = joints->child; j; j = j->next)
        if (!cJSON_IsNumber(j) || !(j->valuedouble >= 0 && j->valuedouble < g->n_nodes))
            return bad(g, "%s: a joint is not one of its %d nodes", owner, g->n_nodes);
    int m;
    pgi_status st = get_ref(g, skin, "inverseBindMatrices", g->n_accessors, 1, owner, "accessors", &m);
    accessor a;
    if (!st) st = check_accessor(g, m, &a);
    if (!st && (strcmp(a.type, "MAT4") != 0 || a.component != GLTF_FLOAT || a.count < array_size(joints)))
        st = bad(g, "%s: inverseBindMatrices (accessor %d) are not %d float MAT4s", owner, m, array_size(joints));
    return st;
}

static pgi_status check_animation(gltf *g, int an, const cJSON *anim) {
    char owner[64];
    const cJSON *samplers = item(anim, "samplers"), *channels = item(anim, "channels");
    const int ns = array_size(samplers);
    pgi_status st;
    int i = 0;
    for (const cJSON *s = ns ? samplers->child : NULL; s; s = s->next, i++) {
        snprintf(owner, sizeof owner, "animation %d sampler %d", an, i);
        int in, out;
        accessor a, b;
        if ((st = get_ref(g, s, "input", g->n_accessors, 1, owner, "accessors", &in))) return st;
        if ((st = get_ref(g, s, "output", g->n_accessors, 1, owner, "accessors", &out))) return st;
        if ((st = check_accessor(g, in, &a)) || (st = check_accessor(g, out, &b))) return st;
        if (strcmp(a.type, "SCALAR") != 0 || a.component != GLTF_FLOAT)
            return bad(g, "%s: input (accessor %d) is not float SCALARs", owner, in);
        const cJSON *interp = item(s, "interpolation");
        const int cubic = cJSON_IsString(interp) && strcmp(interp->valuestring, "CUBICSPLINE") == 0;
        if (b.count < a.count * (cubic ? 3 : 1))
            return bad(g, "%s: %.0f outputs for %.0f inputs%s", owner, b.count, a.count,
                       cubic ? " (CUBICSPLINE: three each)" : "");
    }
    i = 0;
    for (const cJSON *c = cJSON_IsArray(channels) ? channels->child : NULL; c; c = c->next, i++) {
        snprintf(owner, sizeof owner, "animation %d channel %d", an, i);
        int s, node;
        if ((st = get_ref(g, c, "sampler", ns, 1, owner, "samplers", &s))) return st;
        const cJSON *target = item(c, "target");
        if (!cJSON_IsObject(target)) return bad(g, "%s has no \"target\" object", owner);
        if ((st = get_ref(g, target, "node", g->n_nodes, 1, owner, "nodes", &node))) return st;
    }
    return PGI_OK;
}

pgi_status pgi__gltf_check(const char *path, const cJSON *root, FILE *glb, uint64_t glb_bin, uint64_t glb_bin_len) {
    gltf g = {.path = path, .glb = glb, .glb_bin = glb_bin, .glb_bin_len = glb_bin_len};
    g.buffers = item(root, "buffers");
    g.views = item(root, "bufferViews");
    g.accessors = item(root, "accessors");
    g.nodes = item(root, "nodes");
    g.n_buffers = array_size(g.buffers);
    g.n_views = array_size(g.views);
    g.n_accessors = array_size(g.accessors);
    g.n_nodes = array_size(g.nodes);
    pgi_status st = PGI_OK;
    accessor a;
    for (int i = 0; i < g.n_accessors && !st; i++) st = check_accessor(&g, i, &a);
    const cJSON *meshes = item(root, "meshes"), *skins = item(root, "skins"), *anims = item(root, "animations");
    int i = 0;
    for (const cJSON *m = cJSON_IsArray(meshes) ? meshes->child : NULL; m && !st; m = m->next, i++)
        st = check_mesh(&g, i, m);
    i = 0;
    for (const cJSON *s = cJSON_IsArray(skins) ? skins->child : NULL; s && !st; s = s->next, i++)
        st = check_skin(&g, i, s);
    i = 0;
    for (const cJSON *an = cJSON_IsArray(anims) ? anims->child : NULL; an && !st; an = an->next, i++)
        st = check_animation(&g, i, an);
    return st;
}
