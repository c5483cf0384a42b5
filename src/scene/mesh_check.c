/* Checks a mesh file before Assimp reads it. Assimp 5.2 crashes, hangs or
 * runs for minutes on some malformed files (../shared/bad-inputs): an MTL
 * statement before any `newmtl` (segfault in the OBJ importer), a face line
 * with millions of indices, a PLY header that never ends. These are refused
 * here with the file and line; everything else is left to Assimp. On the
 * way it counts OBJ smoothing statements, which Assimp ignores
 * (pgi__mesh_hints). */
#include <ctype.h>
#include <stdio.h>
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
    int line;
} line_reader;

static int next_line(line_reader *r) {
    int c, in_token = 0, any = 0;
    size_t n = 0;
    r->tokens = 0;
    while ((c = fgetc(r->f)) != EOF) {
        any = 1;
        if (c == '\n') break;
        if (n + 1 < sizeof r->head) r->head[n++] = (char)c;
        int space = isspace(c) != 0;
        if (!space && !in_token) r->tokens++;
        in_token = !space;
    }
    r->head[n] = 0;
    if (any) r->line++;
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
    line_reader r = {.f = f};
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
    line_reader r = {.f = f};
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

static int ply_type(const char *t) {
    static const char *const k[] = {"char", "uchar", "short", "ushort", "int",   "uint",   "float",   "double",
                                    "int8", "uint8", "int16", "uint16", "int32", "uint32", "float32", "float64"};
    for (size_t i = 0; i < sizeof k / sizeof k[0]; i++)
        if (strcmp(t, k[i]) == 0) return 1;
    return 0;
}

static pgi_status check_ply(const char *path) {
    FILE *f = fopen(path, "rb");
    if (!f) return PGI_OK;
    line_reader r = {.f = f};
    pgi_status st = PGI_OK;
    int done = 0;
    while (!st && !done && next_line(&r)) {
        char tok[64], a[64], b[64], c[64];
        const char *rest = first_token(r.head, tok, sizeof tok);
        if (ftell(f) > MAX_PLY_HEADER) {
            st = pgi__fail(PGI_ERR_PARSE, "%s: PLY header longer than %d bytes", path, MAX_PLY_HEADER);
        } else if (r.line == 1) {
            if (strcmp(tok, "ply") != 0) st = pgi__fail(PGI_ERR_PARSE, "%s:1: not a PLY file (no 'ply' line)", path);
        } else if (strcmp(tok, "format") == 0) {
            first_token(rest, a, sizeof a);
            if (strcmp(a, "ascii") != 0 && strcmp(a, "binary_little_endian") != 0 &&
                strcmp(a, "binary_big_endian") != 0)
                st = pgi__fail(PGI_ERR_PARSE, "%s:%d: unknown PLY format '%s'", path, r.line, a);
        } else if (strcmp(tok, "element") == 0) {
            rest = first_token(rest, a, sizeof a);
            first_token(rest, b, sizeof b);
            char *end;
            long long n = strtoll(b, &end, 10);
            if (!a[0] || !b[0] || *end || n < 0 || n > INT32_MAX)
                st = pgi__fail(PGI_ERR_PARSE, "%s:%d: malformed PLY element line", path, r.line);
        } else if (strcmp(tok, "property") == 0) {
            rest = first_token(rest, a, sizeof a);
            rest = first_token(rest, b, sizeof b);
            first_token(rest, c, sizeof c);
            int ok = strcmp(a, "list") == 0 ? ply_type(b) && ply_type(c) : ply_type(a) && b[0];
            if (!ok) st = pgi__fail(PGI_ERR_PARSE, "%s:%d: malformed PLY property '%s'", path, r.line, r.head);
        } else if (strcmp(tok, "end_header") == 0) {
            done = 1;
        } else if (strcmp(tok, "comment") != 0 && strcmp(tok, "obj_info") != 0) {
            st = pgi__fail(PGI_ERR_PARSE, "%s:%d: unexpected '%s' in the PLY header", path, r.line, tok);
        }
    }
    if (!st && !done) st = pgi__fail(PGI_ERR_PARSE, "%s: PLY header has no 'end_header'", path);
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
