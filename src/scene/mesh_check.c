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
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

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

/* `*found` is set when the file could be opened. */
static pgi_status check_mtl(const char *path, int *found) {
    FILE *f = fopen(path, "rb");
    if (!f) return PGI_OK; /* a missing material library is Assimp's to report */
    *found = 1;
    line_reader r = {.f = f, .obj = 1};
    pgi_status st = PGI_OK;
    int in_material = 0;
    while (!st && next_line(&r)) {
        char tok[64];
        first_token(r.head, tok, sizeof tok);
        if (!tok[0] || tok[0] == '#') continue;
        if (strcmp(tok, "newmtl") == 0) in_material = 1;
        else if (!in_material)
            st = pgi__fail(PGI_ERR_PARSE, "%s:%d: '%s' before any 'newmtl' (a material statement needs a material)",
                           path, r.line, tok);
    }
    fclose(f);
    return st;
}

static pgi_status check_obj(const char *path, pgi__mesh_hints *hints) {
    FILE *f = fopen(path, "rb");
    if (!f) return PGI_OK;
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
            if (snprintf(lib, sizeof lib, "%.*s%s", dir_len, path, name) < (int)sizeof lib) st = check_mtl(lib, &found);
            for (const char *w = rest; !st && *w;) {
                w = first_token(w, name, sizeof name);
                if (snprintf(lib, sizeof lib, "%.*s%s", dir_len, path, name) < (int)sizeof lib)
                    st = check_mtl(lib, &found);
            }
            /* No such library: Assimp then reads the OBJ's own name with "mtl" for "obj" instead. */
            size_t pl = strlen(path);
            if (!st && !found && pl >= 3 && snprintf(lib, sizeof lib, "%.*smtl", (int)(pl - 3), path) < (int)sizeof lib)
                st = check_mtl(lib, &found);
        }
    }
    fclose(f);
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

static pgi_status check_ply(const char *path) {
    FILE *f = fopen(path, "rb");
    if (!f) return PGI_OK;
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
    fclose(f);
    return st;
}

pgi_status pgi__mesh_precheck(const char *path, pgi__mesh_hints *hints) {
    pgi__mesh_hints unused;
    if (!hints) hints = &unused;
    memset(hints, 0, sizeof *hints);
    if (has_ext(path, ".obj")) return check_obj(path, hints);
    if (has_ext(path, ".ply")) return check_ply(path);
    return PGI_OK;
}
