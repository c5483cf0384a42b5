/* Checks a mesh file before Assimp reads it. Assimp 5.2 crashes, hangs or
 * runs for minutes on some malformed files (../shared/bad-inputs): an MTL
 * statement before any `newmtl` (segfault in the OBJ importer), a face line
 * with millions of indices, a PLY header that never ends, a PLY body with empty faces or
 * indices past the vertices (out-of-range reads, an abort), an OBJ whose mtllib is missing (Assimp
 * then reads <name>.mtl instead, so that is checked too). These are refused
 * here with the file and line; everything else is left to Assimp. On the
 * way it counts OBJ smoothing statements, which Assimp ignores
 * (pgi__mesh_hints). */
#include <ctype.h>
#include <errno.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#include <assimp/cimport.h>
#include <cjson/cJSON.h>

#include "scene/scene_internal.h"

#define MAX_FACE_INDICES 65536 /* per f/l/p line */
#define MAX_PLY_HEADER 65536   /* bytes */

static int has_ext(const char *path, const char *ext) {
    size_t n = strlen(path), e = strlen(ext);
    return n > e && strcasecmp(path + n - e, ext) == 0;
}

/* Streams a text file one line at a time without holding long lines: `head`
 * gets the first 1023 bytes of the line, `tokens` the number of
 * whitespace-separated tokens in the whole line. Returns 0 at the end. */
typedef struct line_reader {
    FILE *f;
    char head[1024];
    size_t tokens;
    int line; /* of the current line: 1 + the newlines before it */
    int newlines;
    int obj; /* OBJ and MTL: lines as Assimp's OBJ parser sees them */
} line_reader;

/* The next line. OBJ and MTL (r->obj) as Assimp's OBJ parser sees lines: a NUL, CR or form feed
 * ends one too (its IsLineEnd), so that "junk\0mtllib m.mtl" names a material library there and
 * here alike. A PLY header's lines end at newlines only (its binary body follows the last). */
static int next_line(line_reader *r) {
    int c, in_token = 0, any = 0;
    size_t n = 0;
    r->tokens = 0;
    r->line = r->newlines + 1;
    while ((c = fgetc(r->f)) != EOF) {
        any = 1;
        if (c == '\n') {
            r->newlines++;
            break;
        }
        if (r->obj && (c == '\0' || c == '\r' || c == '\f')) break;
        if (n + 1 < sizeof r->head) r->head[n++] = (char)c;
        int space = isspace(c) != 0;
        if (!space && !in_token) r->tokens++;
        in_token = !space;
    }
    r->head[n] = 0;
    return any;
}

/* First token of s into tok (at most n-1 bytes); returns the rest, spaces skipped. */
static const char *first_token(const char *s, char *tok, size_t n) {
    while (isspace((unsigned char)*s)) s++;
    size_t k = 0;
    while (*s && !isspace((unsigned char)*s)) {
        if (k + 1 < n) tok[k++] = *s;
        s++;
    }
    tok[k] = 0;
    while (isspace((unsigned char)*s)) s++;
    return s;
}

/* What an OBJ's material libraries add up to: the distinct files read (each once) and their
 * materials. */
typedef struct mtl_state {
    char libs[PGI__MAX_MESH_FILES][1024];
    int nlibs;
    long materials;
    uint64_t budget;
} mtl_state;

/* `*found` is set when the file exists (a missing one is Assimp's to report). A library that is
 * not a regular file, or is larger than the budget, is refused; one already read is skipped. */
static pgi_status check_mtl(const char *obj, const char *path, mtl_state *ms, int *found) {
    for (int i = 0; i < ms->nlibs; i++)
        if (strcmp(ms->libs[i], path) == 0) return *found = 1, PGI_OK;
    const char *why;
    FILE *f = pgi__fopen_input(path, ms->budget, NULL, &why);
    if (!f) {
        if (errno != EINVAL && errno != EFBIG) return PGI_OK; /* missing, unreadable: Assimp's to report */
        return pgi__fail(PGI_ERR_IO, "%s: material library %s: %s", obj, path, why);
    }
    *found = 1;
    if (ms->nlibs == PGI__MAX_MESH_FILES) {
        fclose(f);
        return pgi__fail(PGI_ERR_UNSUPPORTED, "%s: names more than %d material libraries", obj, PGI__MAX_MESH_FILES);
    }
    snprintf(ms->libs[ms->nlibs++], sizeof ms->libs[0], "%s", path);
    line_reader r = {.f = f, .obj = 1};
    pgi_status st = PGI_OK;
    int in_material = 0;
    while (!st && next_line(&r)) {
        char tok[64];
        first_token(r.head, tok, sizeof tok);
        if (!tok[0] || tok[0] == '#') continue;
        if (strcmp(tok, "newmtl") == 0) {
            in_material = 1;
            if (++ms->materials > PGI__MAX_MESH_MATERIALS)
                st = pgi__fail(PGI_ERR_UNSUPPORTED, "%s:%d: more than %d materials (with the other libraries of %s)",
                               path, r.line, PGI__MAX_MESH_MATERIALS, obj);
        } else if (!in_material)
            st = pgi__fail(PGI_ERR_PARSE, "%s:%d: '%s' before any 'newmtl' (a material statement needs a material)",
                           path, r.line, tok);
    }
    fclose(f);
    return st;
}

static pgi_status check_obj(const char *path, FILE *f, uint64_t budget, pgi__mesh_hints *hints) {
    mtl_state *ms = calloc(1, sizeof *ms); /* 256 KiB: neither the stack nor thread-local storage */
    if (!ms) return pgi__fail(PGI_ERR_OOM, "%s: out of memory", path);
    ms->budget = budget;
    line_reader r = {.f = f, .obj = 1};
    pgi_status st = PGI_OK;
    const char *slash = strrchr(path, '/');
    const int dir_len = slash ? (int)(slash - path + 1) : 0;
    while (!st && next_line(&r)) {
        char tok[64];
        const char *rest = first_token(r.head, tok, sizeof tok);
        if ((strcmp(tok, "f") == 0 || strcmp(tok, "l") == 0 || strcmp(tok, "p") == 0) &&
            r.tokens - 1 > MAX_FACE_INDICES)
            st = pgi__fail(PGI_ERR_UNSUPPORTED, "%s:%d: a face of %zu vertices (at most %d)", path, r.line,
                           r.tokens - 1, MAX_FACE_INDICES);
        else if (strcmp(tok, "s") == 0) {
            char arg[16];
            first_token(rest, arg, sizeof arg);
            if (strcmp(arg, "off") == 0 || strcmp(arg, "0") == 0) hints->smooth_off++;
            else if (arg[0]) hints->smooth_on++;
        } else if (strcmp(tok, "mtllib") == 0 && *rest) {
            /* Importers differ on names with spaces: check the whole rest of the line and each word. */
            char lib[2048], name[1024];
            snprintf(name, sizeof name, "%s", rest);
            for (size_t n = strlen(name); n > 0 && isspace((unsigned char)name[n - 1]);) name[--n] = 0;
            int found = 0;
            if (snprintf(lib, sizeof lib, "%.*s%s", dir_len, path, name) < (int)sizeof lib)
                st = check_mtl(path, lib, ms, &found);
            for (const char *w = rest; !st && *w;) {
                w = first_token(w, name, sizeof name);
                if (snprintf(lib, sizeof lib, "%.*s%s", dir_len, path, name) < (int)sizeof lib)
                    st = check_mtl(path, lib, ms, &found);
            }
            /* No such library: Assimp then reads the OBJ's own name with "mtl" for "obj" instead. */
            size_t pl = strlen(path);
            if (!st && !found && pl >= 3 && snprintf(lib, sizeof lib, "%.*smtl", (int)(pl - 3), path) < (int)sizeof lib)
                st = check_mtl(path, lib, ms, &found);
            if (!st && !found) {
                snprintf(name, sizeof name, "%s", rest);
                for (size_t n = strlen(name); n > 0 && isspace((unsigned char)name[n - 1]);) name[--n] = 0;
                pgi__list_append(hints->missing_mtl, sizeof hints->missing_mtl, name);
            }
        }
    }
    free(ms);
    return st;
}

/* PLY scalar types: size in bytes (0: unknown) and whether signed / floating point. */
static int ply_type(const char *t, int *is_signed, int *is_float) {
    static const struct {
        const char *name;
        int size, sign, flt;
    } k[] = {{"char", 1, 1, 0},  {"uchar", 1, 0, 0},  {"short", 2, 1, 0},   {"ushort", 2, 0, 0},
             {"int", 4, 1, 0},   {"uint", 4, 0, 0},   {"float", 4, 1, 1},   {"double", 8, 1, 1},
             {"int8", 1, 1, 0},  {"uint8", 1, 0, 0},  {"int16", 2, 1, 0},   {"uint16", 2, 0, 0},
             {"int32", 4, 1, 0}, {"uint32", 4, 0, 0}, {"float32", 4, 1, 1}, {"float64", 8, 1, 1}};
    for (size_t i = 0; i < sizeof k / sizeof k[0]; i++)
        if (strcmp(t, k[i].name) == 0) {
            if (is_signed) *is_signed = k[i].sign;
            if (is_float) *is_float = k[i].flt;
            return k[i].size;
        }
    return 0;
}

#define PLY_MAX_ELEMENTS 16
#define PLY_MAX_PROPS 32

typedef struct ply_prop {
    int size, sign, flt;              /* the value, or a list's items */
    int list, count_size, count_sign; /* a list: its count's type */
    int indices;                      /* vertex_indices / vertex_index of "face" */
} ply_prop;

typedef struct ply_element {
    char name[64];
    long long count;
    int nprops;
    ply_prop props[PLY_MAX_PROPS];
} ply_element;

/* One value of the body: binary (`big`: big-endian) or one ASCII token. Returns 0 at the end. */
static int ply_value(FILE *f, int ascii, int big, int size, int sign, int flt, double *out) {
    if (ascii) {
        char tok[128];
        if (fscanf(f, "%127s", tok) != 1) return 0;
        *out = strtod(tok, NULL);
        return 1;
    }
    unsigned char b[8];
    if (fread(b, 1, (size_t)size, f) != (size_t)size) return 0;
    uint64_t u = 0;
    for (int i = 0; i < size; i++) u = u << 8 | b[big ? i : size - 1 - i];
    if (flt) {
        if (size == 4) {
            uint32_t u32 = (uint32_t)u;
            float v;
            memcpy(&v, &u32, 4);
            *out = v;
        } else {
            double v;
            memcpy(&v, &u, 8);
            *out = v;
        }
    } else if (sign && size < 8 && (u >> (8 * size - 1)) & 1) {
        *out = (double)(int64_t)(u | ~(uint64_t)0 << (8 * size));
    } else {
        *out = (double)u;
    }
    return 1;
}

/* Walks the body as the header declares it: every row there, every face of at least three
 * vertices that exist. Assimp 5.2 follows out-of-range indices and aborts on empty faces. */
static pgi_status check_ply_body(const char *path, FILE *f, int ascii, int big, const ply_element *el, int nel) {
    long long nverts = 0;
    for (int e = 0; e < nel; e++)
        if (strcmp(el[e].name, "vertex") == 0) nverts = el[e].count;
    for (int e = 0; e < nel; e++) {
        const ply_element *E = &el[e];
        long long row = 0;
        for (; row < E->count; row++) {
            for (int p = 0; p < E->nprops; p++) {
                const ply_prop *P = &E->props[p];
                double v;
                if (!P->list) {
                    if (!ply_value(f, ascii, big, P->size, P->sign, P->flt, &v)) goto short_body;
                    continue;
                }
                if (!ply_value(f, ascii, big, P->count_size, P->count_sign, 0, &v)) goto short_body;
                if (!(v >= 0.0 && v <= (double)MAX_FACE_INDICES))
                    return pgi__fail(PGI_ERR_PARSE, "%s: PLY %s %lld has a list of %g values", path, E->name, row, v);
                long long n = (long long)v;
                if (P->indices && n < 3)
                    return pgi__fail(PGI_ERR_PARSE, "%s: PLY face %lld has %lld vertices (at least 3)", path, row, n);
                for (long long i = 0; i < n; i++) {
                    if (!ply_value(f, ascii, big, P->size, P->sign, P->flt, &v)) goto short_body;
                    if (P->indices && !(v >= 0.0 && v < (double)nverts))
                        return pgi__fail(PGI_ERR_PARSE, "%s: PLY face %lld refers to vertex %g of %lld", path, row, v,
                                         nverts);
                }
            }
        }
        continue;
    short_body:
        return pgi__fail(PGI_ERR_PARSE, "%s: PLY data ends in %s %lld of %lld", path, E->name, row, E->count);
    }
    return PGI_OK;
}

static pgi_status check_ply(const char *path, FILE *f) {
    line_reader r = {.f = f};
    pgi_status st = PGI_OK;
    int done = 0, ascii = 0, big = 0, nel = 0, walk = 1;
    static _Thread_local ply_element el[PLY_MAX_ELEMENTS];
    while (!st && !done && next_line(&r)) {
        char tok[64], a[64], b[64], c[64];
        const char *rest = first_token(r.head, tok, sizeof tok);
        if (ftell(f) > MAX_PLY_HEADER) {
            st = pgi__fail(PGI_ERR_PARSE, "%s: PLY header longer than %d bytes", path, MAX_PLY_HEADER);
        } else if (r.line == 1) {
            if (strcmp(tok, "ply") != 0) st = pgi__fail(PGI_ERR_PARSE, "%s:1: not a PLY file (no 'ply' line)", path);
        } else if (strcmp(tok, "format") == 0) {
            first_token(rest, a, sizeof a);
            ascii = strcmp(a, "ascii") == 0;
            big = strcmp(a, "binary_big_endian") == 0;
            if (!ascii && !big && strcmp(a, "binary_little_endian") != 0)
                st = pgi__fail(PGI_ERR_PARSE, "%s:%d: unknown PLY format '%s'", path, r.line, a);
        } else if (strcmp(tok, "element") == 0) {
            rest = first_token(rest, a, sizeof a);
            first_token(rest, b, sizeof b);
            char *end;
            long long n = strtoll(b, &end, 10);
            if (!a[0] || !b[0] || *end || n < 0 || n > INT32_MAX)
                st = pgi__fail(PGI_ERR_PARSE, "%s:%d: malformed PLY element line", path, r.line);
            else if (nel == PLY_MAX_ELEMENTS) walk = 0; /* unusual: left to Assimp */
            else {
                memset(&el[nel], 0, sizeof el[nel]);
                snprintf(el[nel].name, sizeof el[nel].name, "%s", a);
                el[nel++].count = n;
            }
        } else if (strcmp(tok, "property") == 0) {
            rest = first_token(rest, a, sizeof a);
            rest = first_token(rest, b, sizeof b);
            rest = first_token(rest, c, sizeof c);
            ply_prop P = {0};
            int ok;
            if (strcmp(a, "list") == 0) {
                P.list = 1;
                int count_flt = 0;
                P.count_size = ply_type(b, &P.count_sign, &count_flt);
                P.size = ply_type(c, &P.sign, &P.flt);
                first_token(rest, a, sizeof a); /* the name */
                ok = P.count_size && !count_flt && P.size;
                P.indices = strcmp(a, "vertex_indices") == 0 || strcmp(a, "vertex_index") == 0;
            } else {
                P.size = ply_type(a, &P.sign, &P.flt);
                ok = P.size && b[0];
            }
            if (!ok) st = pgi__fail(PGI_ERR_PARSE, "%s:%d: malformed PLY property '%s'", path, r.line, r.head);
            else if (nel == 0) st = pgi__fail(PGI_ERR_PARSE, "%s:%d: PLY property before any element", path, r.line);
            else if (el[nel - 1].nprops == PLY_MAX_PROPS) walk = 0;
            else {
                ply_element *E = &el[nel - 1];
                P.indices = P.indices && strcmp(E->name, "face") == 0;
                E->props[E->nprops++] = P;
            }
        } else if (strcmp(tok, "end_header") == 0) {
            done = 1;
        } else if (strcmp(tok, "comment") != 0 && strcmp(tok, "obj_info") != 0) {
            st = pgi__fail(PGI_ERR_PARSE, "%s:%d: unexpected '%s' in the PLY header", path, r.line, tok);
        }
    }
    if (!st && !done) st = pgi__fail(PGI_ERR_PARSE, "%s: PLY header has no 'end_header'", path);
    if (!st && walk) st = check_ply_body(path, f, ascii, big, el, nel);
    return st;
}


/* ------------------------------------------------ declared counts and nesting */

/* The whole file in memory (NUL-terminated), at most `budget` bytes. */
static pgi_status read_whole(const char *path, FILE *f, uint64_t size, uint64_t budget, char **out) {
    *out = NULL;
    if (budget && size > budget)
        return pgi__fail(PGI_ERR_OOM, "%s: %llu bytes, over the memory budget of %llu bytes", path,
                         (unsigned long long)size, (unsigned long long)budget);
    char *buf = malloc((size_t)size + 1);
    if (!buf) return pgi__fail(PGI_ERR_OOM, "%s: out of memory for %llu bytes", path, (unsigned long long)size);
    size_t got = fread(buf, 1, (size_t)size, f);
    buf[got] = 0;
    *out = buf;
    return PGI_OK;
}

/* A count the file declares is plausible only when the file can hold that many items of at
 * least `min_bytes` each (Assimp allocates by the declared count before it reads them). */
static pgi_status check_count(const char *path, long line, const char *what, double count, double min_bytes,
                              uint64_t size) {
    if (count >= 0 && count * min_bytes <= (double)size + 16.0) return PGI_OK;
    return pgi__fail(PGI_ERR_PARSE, "%s:%ld: declares %.0f %s, more than its %llu bytes can hold", path, line, count,
                     what, (unsigned long long)size);
}

static pgi_status too_deep(const char *path, const char *what, long line) {
    if (line > 0)
        return pgi__fail(PGI_ERR_UNSUPPORTED, "%s:%ld: %s nested deeper than %d levels", path, line, what,
                         PGI__MAX_MESH_DEPTH);
    return pgi__fail(PGI_ERR_UNSUPPORTED, "%s: %s nested deeper than %d levels", path, what, PGI__MAX_MESH_DEPTH);
}

/* Nesting of {} and [] (strings in double quotes skipped when `quotes`): JSON, DirectX .x, BVH,
 * OpenGEX. */
static pgi_status check_braces(const char *path, const char *b, size_t n, int quotes, const char *what) {
    long depth = 0, line = 1;
    for (size_t i = 0; i < n; i++) {
        const char c = b[i];
        if (c == '\n') line++;
        else if (quotes && c == '"') {
            for (i++; i < n && b[i] != '"'; i++)
                if (b[i] == '\\') i++;
        } else if (c == '{' || c == '[') {
            if (++depth > PGI__MAX_MESH_DEPTH) return too_deep(path, what, line);
        } else if ((c == '}' || c == ']') && depth > 0) depth--;
    }
    return PGI_OK;
}

/* Element nesting of an XML file (COLLADA, X3D, AMF, Irrlicht...), and the attributes whose name
 * has "count" in it (COLLADA's count, Irrlicht's vertexCount...): items of at least 2 bytes. */
static pgi_status check_xml(const char *path, const char *b, size_t n, uint64_t size) {
    long depth = 0, line = 1;
    for (size_t i = 0; i < n; i++) {
        if (b[i] == '\n') line++;
        if (b[i] != '<') continue;
        if (i + 3 < n && memcmp(b + i, "<!--", 4) == 0) {
            const char *e = strstr(b + i, "-->");
            if (!e) break;
            for (; b + i < e; i++) line += b[i] == '\n';
            continue;
        }
        if (i + 1 < n && (b[i + 1] == '?' || b[i + 1] == '!')) continue;
        const int closing = i + 1 < n && b[i + 1] == '/';
        /* To the end of the tag, quoted attribute values skipped. */
        char prev = 0;
        for (i++; i < n && b[i] != '>'; i++) {
            if (b[i] == '\n') line++;
            if (b[i] == '"' || b[i] == '\'') {
                const char q = b[i];
                size_t e = i; /* the attribute's name: before '=' */
                while (e > 0 && isspace((unsigned char)b[e - 1])) e--;
                if (e > 0 && b[e - 1] == '=') {
                    e--;
                    while (e > 0 && isspace((unsigned char)b[e - 1])) e--;
                    size_t a = e;
                    while (a > 0 && (isalnum((unsigned char)b[a - 1]) || b[a - 1] == '_' || b[a - 1] == ':')) a--;
                    char name[64];
                    if (e - a < sizeof name) {
                        for (size_t k = a; k < e; k++) name[k - a] = (char)tolower((unsigned char)b[k]);
                        name[e - a] = 0;
                        if (strstr(name, "count")) {
                            char *end;
                            const double v = strtod(b + i + 1, &end);
                            pgi_status st = end > b + i + 1 ? check_count(path, line, "items", v, 2, size) : PGI_OK;
                            if (st) return st;
                        }
                    }
                }
                for (i++; i < n && b[i] != q; i++) line += b[i] == '\n';
            }
            prev = b[i];
        }
        if (closing) depth -= depth > 0;
        else if (prev != '/' && ++depth > PGI__MAX_MESH_DEPTH) return too_deep(path, "XML elements", line);
    }
    return PGI_OK;
}

/* Keyword counts: `keyword N` declares N items of at least min_bytes each. */
typedef struct count_key {
    const char *key, *what;
    double min_bytes;
} count_key;

static const count_key k_md5_keys[] = {{"numJoints", "joints", 8},
                                       {"numMeshes", "meshes", 8},
                                       {"numverts", "vertices", 8},
                                       {"numtris", "triangles", 8},
                                       {"numweights", "weights", 8},
                                       {"numFrames", "frames", 8},
                                       {"numAnimatedComponents", "animated components", 2},
                                       {"numCuts", "cuts", 2},
                                       {NULL, NULL, 0}};
static const count_key k_ac_keys[] = {{"numvert", "vertices", 6},
                                      {"numsurf", "surfaces", 8},
                                      {"refs", "references", 6},
                                      {"kids", "children", 8},
                                      {NULL, NULL, 0}};
static const count_key k_nff_keys[] = {{"p", "polygon vertices", 6},
                                       {"pp", "polygon vertices", 12},
                                       {"tpp", "polygon vertices", 16},
                                       {NULL, NULL, 0}};

static pgi_status check_keyword_counts(const char *path, const char *b, size_t n, uint64_t size, const count_key *keys,
                                       int ac) {
    long line = 1;
    long kids[PGI__MAX_MESH_DEPTH + 1];
    int nk = 0; /* AC3D: children still to come at each open level */
    int line_start = 1, sense8 = 0;
    for (size_t i = 0; i < n;) {
        if (b[i] == '\n') {
            line++;
            line_start = 1;
            i++;
            continue;
        }
        if (isspace((unsigned char)b[i])) {
            i++;
            continue;
        }
        size_t t0 = i;
        while (i < n && !isspace((unsigned char)b[i])) i++;
        const size_t len = i - t0;
        const int first = line_start;
        line_start = 0;
        if (keys == k_nff_keys && t0 == 0 && len == 3 && memcmp(b, "nff", 3) == 0) sense8 = 1;
        if (sense8 && first && isdigit((unsigned char)b[t0])) {
            /* Sense8 NFF: a line's first number is a count (vertices, polygons, a polygon's
             * vertices) of items of at least 2 bytes. */
            pgi_status st = check_count(path, line, "items", strtod(b + t0, NULL), 2, size);
            if (st) return st;
            continue;
        }
        if (ac && first && len == 6 && memcmp(b + t0, "OBJECT", 6) == 0) {
            while (nk > 0 && kids[nk - 1] == 0) nk--;
            if (nk > 0) kids[nk - 1]--;
            continue;
        }
        for (const count_key *k = keys; k->key; k++) {
            if (strlen(k->key) != len || memcmp(b + t0, k->key, len) != 0) continue;
            if (!ac && keys == k_nff_keys && !first) break; /* NFF: commands start lines */
            const double v = strtod(b + i, NULL);
            pgi_status st = check_count(path, line, k->what, v, k->min_bytes, size);
            if (st) return st;
            if (ac && strcmp(k->key, "kids") == 0 && v > 0) {
                if (nk == PGI__MAX_MESH_DEPTH) return too_deep(path, "AC3D objects", line);
                kids[nk++] = (long)v;
            }
            break;
        }
        if (!ac && keys == k_nff_keys && first && len == 4 && memcmp(b + t0, "tess", 4) == 0) {
            const double v = strtod(b + i, NULL);
            if (!(v >= 0 && v <= 8))
                return pgi__fail(PGI_ERR_UNSUPPORTED, "%s:%ld: tessellation %g (at most 8)", path, line, v);
        }
    }
    return PGI_OK;
}

/* DirectX .x (text): a whole number followed by ';' starts a list (vertices, faces, indices,
 * weights) of that many items of at least 2 bytes ("0,"); floats and GUIDs are skipped. */
static pgi_status check_x_counts(const char *path, const char *b, size_t n, uint64_t size) {
    if (n < 16 || memcmp(b, "xof ", 4) != 0 || memcmp(b + 8, "txt", 3) != 0) return PGI_OK; /* binary: Assimp's */
    long line = 1;
    for (size_t i = 0; i < n; i++) {
        if (b[i] == '\n') line++;
        if (!isdigit((unsigned char)b[i]) ||
            (i > 0 && (isalnum((unsigned char)b[i - 1]) || b[i - 1] == '.' || b[i - 1] == '-' || b[i - 1] == '_')))
            continue;
        size_t j = i;
        while (j < n && isdigit((unsigned char)b[j])) j++;
        size_t k = j;
        while (k < n && (b[k] == ' ' || b[k] == '\t')) k++;
        if (k < n && b[k] == ';') {
            pgi_status st = check_count(path, line, "items", strtod(b + i, NULL), 2, size);
            if (st) return st;
        }
        i = j - 1;
    }
    return PGI_OK;
}

/* ASE: a "*...NUM..." or "*...COUNT" keyword (*MESH_NUMVERTEX, *MATERIAL_COUNT...) and BVH's
 * "Frames:" declare that many items of at least 2 bytes. */
static pgi_status check_star_counts(const char *path, const char *b, size_t n, uint64_t size, int bvh) {
    long line = 1;
    for (size_t i = 0; i < n; i++) {
        if (b[i] == '\n') line++;
        if (bvh ? (b[i] != 'F' || (i > 0 && !isspace((unsigned char)b[i - 1]))) : b[i] != '*') continue;
        size_t j = i;
        while (j < n && !isspace((unsigned char)b[j])) j++;
        char tok[64];
        const size_t len = j - i < sizeof tok - 1 ? j - i : sizeof tok - 1;
        memcpy(tok, b + i, len);
        tok[len] = 0;
        const int counts = bvh ? strcmp(tok, "Frames:") == 0 : strstr(tok, "NUM") || strstr(tok, "COUNT");
        if (counts) {
            char *end;
            const double v = strtod(b + j, &end);
            pgi_status st = end > b + j ? check_count(path, line, "items", v, 2, size) : PGI_OK;
            if (st) return st;
        }
        i = j > i ? j - 1 : i;
    }
    return PGI_OK;
}

/* OFF: "[ST][C][N][4][n]OFF", then the vertex, face and edge counts. */
static pgi_status check_off(const char *path, const char *b, size_t n, uint64_t size) {
    const char *p = b, *end = b + n;
    double v[3];
    int k = 0;
    long line = 1;
    /* Skip the keyword, then read three numbers, skipping comments. */
    while (p < end && !isspace((unsigned char)*p)) p++;
    while (p < end && k < 3) {
        if (*p == '\n') line++;
        if (*p == '#') {
            while (p < end && *p != '\n') p++;
            continue;
        }
        if (isspace((unsigned char)*p)) {
            p++;
            continue;
        }
        char *e;
        v[k] = strtod(p, &e);
        if (e == p) return PGI_OK; /* not an ASCII OFF count: Assimp's to judge */
        p = e;
        k++;
    }
    if (k < 2) return PGI_OK;
    pgi_status st = check_count(path, line, "vertices", v[0], 6, size);
    if (!st) st = check_count(path, line, "faces", v[1], 2, size);
    if (!st && v[0] * 6 + v[1] * 2 > (double)size + 16.0)
        st =
            pgi__fail(PGI_ERR_PARSE, "%s:%ld: declares %.0f vertices and %.0f faces, more than its %llu bytes can hold",
                      path, line, v[0], v[1], (unsigned long long)size);
    return st;
}

/* ---------------------------------------------------------------- glTF */

#define PGI__GLTF_BUFFER_SLACK (64 << 20) /* bytes a buffer may hold past what its views use */

/* A glTF's JSON: nesting, then (parsed) its node tree's depth, cycles and its material count,
 * then its accessors and what uses them (pgi__gltf_check; a GLB's BIN chunk: glb at bin). */
static pgi_status check_gltf_json(const char *path, const char *json, size_t n, FILE *glb, uint64_t bin,
                                  uint64_t bin_len, pgi__mesh_hints *hints) {
    pgi_status st = check_braces(path, json, n, 1, "JSON");
    if (st) return st;
    /* Not glTF 2.0 JSON: refused here, for Assimp would then hand the file to whichever of its
     * importers claims its bytes (a fuzzed .gltf reached one that reads past its buffer). */
    const char *json_end = NULL;
    cJSON *root = cJSON_ParseWithLengthOpts(json, n, &json_end, 0);
    if (!root) {
        const char *at = cJSON_GetErrorPtr();
        return pgi__fail(PGI_ERR_PARSE, "%s: not glTF: its JSON does not parse (byte %ld)", path,
                         at && at >= json && at <= json + n ? (long)(at - json) : 0L);
    }
    while (json_end && json_end < json + n && isspace((unsigned char)*json_end)) json_end++;
    const cJSON *asset = cJSON_GetObjectItemCaseSensitive(root, "asset");
    const cJSON *version = cJSON_GetObjectItemCaseSensitive(asset, "version");
    if (json_end && json_end < json + n) {
        cJSON_Delete(root);
        return pgi__fail(PGI_ERR_PARSE, "%s: not glTF: more follows its JSON (byte %ld)", path,
                         (long)(json_end - json));
    }
    if (!cJSON_IsObject(root) || !cJSON_IsString(version) || version->valuestring[0] != '2') {
        cJSON_Delete(root);
        return pgi__fail(PGI_ERR_UNSUPPORTED, "%s: not a glTF 2.0 file (its asset.version is not \"2.x\")", path);
    }
    const cJSON *nodes = cJSON_GetObjectItemCaseSensitive(root, "nodes");
    const cJSON *mats = cJSON_GetObjectItemCaseSensitive(root, "materials");
    if (cJSON_IsArray(mats) && cJSON_GetArraySize(mats) > PGI__MAX_MESH_MATERIALS)
        st = pgi__fail(PGI_ERR_UNSUPPORTED, "%s: %d materials (at most %d)", path, cJSON_GetArraySize(mats),
                       PGI__MAX_MESH_MATERIALS);
    /* A buffer is read whole (its byteLength): one far larger than its views use is refused. */
    const cJSON *bufs = cJSON_GetObjectItemCaseSensitive(root, "buffers");
    const cJSON *views = cJSON_GetObjectItemCaseSensitive(root, "bufferViews");
    const int nb = cJSON_IsArray(bufs) ? cJSON_GetArraySize(bufs) : 0;
    double *used = nb > 0 ? calloc((size_t)nb, sizeof *used) : NULL;
    if (!st && nb > 0 && !used) st = pgi__fail(PGI_ERR_OOM, "%s: out of memory for %d buffers", path, nb);
    for (const cJSON *v = cJSON_IsArray(views) && used ? views->child : NULL; v; v = v->next) {
        const cJSON *vb = cJSON_GetObjectItemCaseSensitive(v, "buffer");
        const cJSON *vo = cJSON_GetObjectItemCaseSensitive(v, "byteOffset");
        const cJSON *vl = cJSON_GetObjectItemCaseSensitive(v, "byteLength");
        if (!cJSON_IsNumber(vb) || !(vb->valuedouble >= 0 && vb->valuedouble < nb) || !cJSON_IsNumber(vl)) continue;
        const double end = (cJSON_IsNumber(vo) ? vo->valuedouble : 0) + vl->valuedouble;
        if (end > used[(int)vb->valuedouble]) used[(int)vb->valuedouble] = end;
    }
    int bi = 0;
    for (const cJSON *b = used ? bufs->child : NULL; b && !st; b = b->next, bi++) {
        const cJSON *len = cJSON_GetObjectItemCaseSensitive(b, "byteLength");
        if (cJSON_IsNumber(len) && len->valuedouble > used[bi] + PGI__GLTF_BUFFER_SLACK)
            st = pgi__fail(PGI_ERR_PARSE,
                           "%s: buffer %d declares %.0f bytes, its buffer views use %.0f (at most %d MiB more is read)",
                           path, bi, len->valuedouble, used[bi], PGI__GLTF_BUFFER_SLACK >> 20);
    }
    free(used);
    const int nn = cJSON_IsArray(nodes) ? cJSON_GetArraySize(nodes) : 0;
    int *parent = nn > 0 ? malloc((size_t)nn * sizeof *parent) : NULL;
    int *depth = nn > 0 ? malloc((size_t)nn * sizeof *depth) : NULL;
    if (!st && nn > 0 && (!parent || !depth)) st = pgi__fail(PGI_ERR_OOM, "%s: out of memory for %d nodes", path, nn);
    if (!st && nn > 0) {
        for (int i = 0; i < nn; i++) parent[i] = -1, depth[i] = 0;
        int i = 0;
        for (const cJSON *node = nodes->child; node && !st; node = node->next, i++) {
            const cJSON *ch = cJSON_GetObjectItemCaseSensitive(node, "children");
            if (!cJSON_IsArray(ch)) continue;
            for (const cJSON *c = ch->child; c && !st; c = c->next) {
                if (!cJSON_IsNumber(c) || c->valuedouble < 0 || c->valuedouble >= nn) continue; /* Assimp's */
                const int k = (int)c->valuedouble;
                if (parent[k] >= 0 || k == i)
                    st = pgi__fail(PGI_ERR_PARSE, "%s: node %d is a child of more than one node (or of itself)", path,
                                   k);
                parent[k] = i;
            }
        }
        /* Depth of each node: up its parents to one whose depth is known (a loop never gets there). */
        for (int k = 0; k < nn && !st; k++) {
            int d = 0, p = k;
            while (p >= 0 && depth[p] == 0 && d <= nn) p = parent[p], d++;
            if (d > nn) {
                st = pgi__fail(PGI_ERR_PARSE, "%s: node %d is its own ancestor", path, k);
                break;
            }
            const int base = p >= 0 ? depth[p] : 0;
            for (int q = k, e = base + d; q != p; q = parent[q], e--) depth[q] = e;
            if (depth[k] > PGI__MAX_MESH_DEPTH)
                st = pgi__fail(PGI_ERR_UNSUPPORTED, "%s: node %d is %d levels deep in the node tree (at most %d)", path,
                               k, depth[k], PGI__MAX_MESH_DEPTH);
        }
    }
    free(parent);
    free(depth);
    if (!st) st = pgi__gltf_check(path, root, glb, bin, bin_len);
    if (!st) {
        hints->gltf = 1;
        st = pgi__gltf_read_extras(path, root, &hints->extras);
    }
    cJSON_Delete(root);
    return st;
}

static uint32_t le32(const unsigned char *p) {
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

/* GLB: the lengths its header and JSON chunk declare fit in the file; then the JSON's checks. */
static pgi_status check_glb(const char *path, FILE *f, uint64_t size, uint64_t budget, pgi__mesh_hints *hints) {
    unsigned char h[20];
    if (fread(h, 1, sizeof h, f) != sizeof h || memcmp(h, "glTF", 4) != 0 || le32(h + 4) != 2 ||
        memcmp(h + 16, "JSON", 4) != 0)
        return pgi__fail(PGI_ERR_PARSE,
                         "%s: not a GLB of glTF 2.0 (its header is not \"glTF\", 2, length, a JSON chunk)", path);
    const uint32_t total = le32(h + 8), chunk = le32(h + 12);
    if (total > size)
        return pgi__fail(PGI_ERR_PARSE, "%s: GLB header declares %u bytes, the file has %llu", path, total,
                         (unsigned long long)size);
    if ((uint64_t)chunk + 20 > size)
        return pgi__fail(PGI_ERR_PARSE, "%s: GLB JSON chunk declares %u bytes, the file has %llu", path, chunk,
                         (unsigned long long)size);
    char *json;
    pgi_status st = read_whole(path, f, chunk, budget, &json);
    if (st) return st;
    /* the BIN chunk after the JSON: its length, "BIN\0", its bytes */
    unsigned char b[8];
    const uint64_t bin = 28 + (uint64_t)chunk;
    uint64_t bin_len = 0;
    if (bin <= size && fseek(f, (long)(bin - 8), SEEK_SET) == 0 && fread(b, 1, 8, f) == 8 &&
        memcmp(b + 4, "BIN", 4) == 0)
        bin_len = le32(b) < size - bin ? le32(b) : size - bin;
    st = check_gltf_json(path, json, chunk, f, bin, bin_len, hints);
    free(json);
    return st;
}

/* What a file is, for the checks: by its extension, or (an extension Assimp does not know, or
 * none) by its first bytes, since Assimp then picks an importer by content and a file named
 * `model.dat` must not get round the checks its format gets. 0: not a format checked here. */
enum {
    KIND_NONE,
    KIND_JSON,
    KIND_BRACES,
    KIND_XML,
    KIND_OFF,
    KIND_MD5,
    KIND_AC3D,
    KIND_NFF,
    KIND_X,
    KIND_ASE,
    KIND_BVH,
    KIND_OBJ,
    KIND_PLY,
    KIND_GLB
};

static int starts_with_word(const char *h, const char *w) {
    size_t n = strlen(w);
    return strncmp(h, w, n) == 0 && (!h[n] || isspace((unsigned char)h[n]));
}

/* Assimp's own tests (lower-case tokens near the start) for the formats checked here. */
static int kind_by_content(FILE *f) {
    char h[513];
    size_t n = fread(h, 1, sizeof h - 1, f);
    rewind(f);
    if (n >= 4 && memcmp(h, "glTF", 4) == 0) return KIND_GLB;
    for (size_t i = 0; i < n; i++) h[i] = h[i] ? (char)tolower((unsigned char)h[i]) : ' ';
    h[n] = 0;
    const char *t = h;
    while (isspace((unsigned char)*t)) t++;
    if (starts_with_word(h, "ply")) return KIND_PLY;
    if (strncmp(h, "xof ", 4) == 0) return KIND_X;
    if (*t == '{' || *t == '[') return KIND_JSON;
    if (*t == '<') return KIND_XML;
    if (strstr(h, "*3dsmax_asciiexport")) return KIND_ASE;
    if (starts_with_word(t, "hierarchy")) return KIND_BVH;
    if (strstr(h, "md5version")) return KIND_MD5;
    if (strncmp(t, "ac3d", 4) == 0) return KIND_AC3D;
    size_t w = strcspn(t, " \t\r\n");
    if (w >= 3 && w <= 8 && strncmp(t + w - 3, "off", 3) == 0) return KIND_OFF;
    if (strstr(h, "geometrynode") || strstr(h, "metric {")) return KIND_BRACES;
    static const char *const obj[] = {"\nv ", "\nf ", "\nvn ", "\nvt ", "mtllib", "usemtl", "\no ", "\ng "};
    char line[515]; /* a newline before the first line: the tokens at a line's start */
    snprintf(line, sizeof line, "\n%s", h);
    for (size_t i = 0; i < sizeof obj / sizeof obj[0]; i++)
        if (strstr(line, obj[i])) return KIND_OBJ;
    return KIND_NONE;
}

static int kind_of(const char *path, FILE *f) {
    static const struct {
        const char *ext;
        int kind;
    } k[] = {{".obj", KIND_OBJ},       {".ply", KIND_PLY},  {".glb", KIND_GLB},     {".gltf", KIND_JSON},
             {".x", KIND_X},           {".bvh", KIND_BVH},  {".ogex", KIND_BRACES}, {".dae", KIND_XML},
             {".xml", KIND_XML},       {".x3d", KIND_XML},  {".amf", KIND_XML},     {".irr", KIND_XML},
             {".irrmesh", KIND_XML},   {".off", KIND_OFF},  {".md5mesh", KIND_MD5}, {".md5anim", KIND_MD5},
             {".md5camera", KIND_MD5}, {".ac", KIND_AC3D},  {".acc", KIND_AC3D},    {".ac3d", KIND_AC3D},
             {".nff", KIND_NFF},       {".enff", KIND_NFF}, {".ase", KIND_ASE},     {".ask", KIND_ASE}};
    for (size_t i = 0; i < sizeof k / sizeof k[0]; i++)
        if (has_ext(path, k[i].ext)) return k[i].kind;
    const char *base = strrchr(path, '/'), *dot = strrchr(base ? base + 1 : path, '.');
    if (dot && dot[1] && aiIsExtensionSupported(dot)) return KIND_NONE; /* Assimp's importer for it */
    return kind_by_content(f);
}

pgi_status pgi__mesh_precheck(const char *path, uint64_t budget, pgi__mesh_hints *hints) {
    pgi__mesh_hints unused;
    if (!hints) hints = &unused;
    memset(hints, 0, sizeof *hints);
    const char *why;
    uint64_t size;
    FILE *f = pgi__fopen_input(path, budget, &size, &why);
    if (!f) return pgi__fail(PGI_ERR_IO, "%s: %s", path, why);
    pgi_status st = PGI_OK;
    const int kind = kind_of(path, f);
    if (kind == KIND_OBJ) st = check_obj(path, f, budget, hints);
    else if (kind == KIND_PLY) st = check_ply(path, f);
    else if (kind == KIND_GLB) st = check_glb(path, f, size, budget, hints);
    else if (kind != KIND_NONE) {
        char *b = NULL;
        st = read_whole(path, f, size, budget, &b);
        const size_t n = b ? strlen(b) : 0; /* text formats: a NUL ends what the checks see */
        if (!st && kind == KIND_JSON) st = check_gltf_json(path, b, n, NULL, 0, 0, hints);
        else if (!st && kind == KIND_BRACES) st = check_braces(path, b, n, 0, "braces");
        else if (!st && kind == KIND_XML) st = check_xml(path, b, n, size);
        else if (!st && kind == KIND_OFF) st = check_off(path, b, n, size);
        else if (!st && kind == KIND_MD5) st = check_keyword_counts(path, b, n, size, k_md5_keys, 0);
        else if (!st && kind == KIND_AC3D) st = check_keyword_counts(path, b, n, size, k_ac_keys, 1);
        else if (!st && kind == KIND_NFF) st = check_keyword_counts(path, b, n, size, k_nff_keys, 0);
        else if (!st && kind == KIND_X) st = check_x_counts(path, b, n, size);
        else if (!st && (kind == KIND_ASE || kind == KIND_BVH))
            st = check_star_counts(path, b, n, size, kind == KIND_BVH);
        if (!st && (kind == KIND_MD5 || kind == KIND_X || kind == KIND_ASE || kind == KIND_BVH))
            st = check_braces(path, b, n, kind != KIND_X && kind != KIND_BVH, "braces");
        free(b);
    }
    fclose(f);
    if (st || hints == &unused) pgi__mesh_hints_free(hints); /* the caller frees them after a success */
    return st;
}

void pgi__mesh_hints_free(pgi__mesh_hints *h) {
    if (!h) return;
    free(h->extras.cams);
    free(h->extras.lights);
    free(h->extras.emissive_strength);
    memset(&h->extras, 0, sizeof h->extras);
}
