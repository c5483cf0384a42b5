/* Sidecar metadata of a reference image (<image>.json), so that
 * `photongi reference --continue` adds samples with the same settings.
 * Format 2 adds "jitter" (true: samples spread over the pixel); format 1
 * files were made through pixel centres and continue that way. An optional
 * "specular" ("ggx" | "phong") records `reference --specular`. */
#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <stdio.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cjson/cJSON.h>

#include "core/core.h"
#include "io/io_internal.h"
#include "photongi/reference.h"

/* The sidecar's text into the file wpath (messages name path). */
static pgi_status meta_write_to(const pgi_reference_meta *m, const char *path, const char *wpath) {
    cJSON *o = cJSON_CreateObject();
    if (!o) return pgi__fail(PGI_ERR_OOM, "out of memory writing %s", path);
    char seed[32], spp[32];
    snprintf(seed, sizeof seed, "%llu", (unsigned long long)m->seed);
    snprintf(spp, sizeof spp, "%llu", (unsigned long long)m->spp);
    int ok = cJSON_AddStringToObject(o, "format", "photongi-reference-2") &&
             cJSON_AddStringToObject(o, "scene", m->scene) && cJSON_AddNumberToObject(o, "width", m->width) &&
             cJSON_AddNumberToObject(o, "height", m->height) && cJSON_AddNumberToObject(o, "bounces", m->bounces) &&
             cJSON_AddNumberToObject(o, "camera", m->camera) && cJSON_AddStringToObject(o, "seed", seed) &&
             cJSON_AddStringToObject(o, "spp", spp) && cJSON_AddBoolToObject(o, "jitter", m->jitter != PGI_JITTER_OFF);
    if (ok && m->specular != PGI_SPECULAR_DEFAULT)
        ok = cJSON_AddStringToObject(o, "specular", m->specular == PGI_SPECULAR_PHONG ? "phong" : "ggx") != NULL;
    if (ok && m->has_view) {
        /* float -> double is exact and cJSON prints a double so that it reads back the same */
        const pgi_camera_def *c = &m->view;
        cJSON *v = cJSON_AddObjectToObject(o, "view");
        ok = v && cJSON_AddItemToObject(v, "eye", cJSON_CreateFloatArray(c->eye, 3)) &&
             cJSON_AddItemToObject(v, "look_at", cJSON_CreateFloatArray(c->look_at, 3)) &&
             cJSON_AddItemToObject(v, "up", cJSON_CreateFloatArray(c->up, 3)) &&
             cJSON_AddNumberToObject(v, "fov_y", c->fov_y_deg);
    }
    if (ok && m->exr_bytes) {
        char bytes[32], hash[32];
        snprintf(bytes, sizeof bytes, "%llu", (unsigned long long)m->exr_bytes);
        snprintf(hash, sizeof hash, "%016llx", (unsigned long long)m->exr_hash);
        ok = cJSON_AddStringToObject(o, "exr_bytes", bytes) && cJSON_AddStringToObject(o, "exr_fnv1a64", hash);
    }
    char *txt = ok ? cJSON_Print(o) : NULL;
    cJSON_Delete(o);
    if (!txt) return pgi__fail(PGI_ERR_OOM, "out of memory writing %s", path);
    errno = 0;
    FILE *f = fopen(wpath, "wb");
    if (!f) {
        int e = errno;
        free(txt);
        return pgi__fail(PGI_ERR_IO, "%s: cannot write: %s", path, strerror(e));
    }
    int bad = fputs(txt, f) < 0 || fputc('\n', f) == EOF || fflush(f) != 0;
    int e = bad ? errno : 0;
    if (fclose(f) != 0 && !bad) {
        bad = 1;
        e = errno;
    }
    free(txt);
    return bad ? pgi__fail(PGI_ERR_IO, "%s: cannot write: %s", path, e ? strerror(e) : "write error") : PGI_OK;
}

pgi_status pgi_reference_meta_write(const pgi_reference_meta *m, const char *path) {
    pgi__out out;
    pgi_status st = pgi__out_begin(path, &out);
    if (st) return st;
    if ((st = meta_write_to(m, path, pgi__out_path(&out, path)))) {
        pgi__out_abort(&out);
        return st;
    }
    return pgi__out_commit(&out, path);
}

pgi_status pgi_reference_file_hash(const char *path, uint64_t *bytes, uint64_t *hash) {
    int fd = open(path, O_RDONLY | O_NONBLOCK);
    if (fd < 0) {
        int e = errno;
        return pgi__fail(PGI_ERR_IO, "%s: cannot open: %s", path, strerror(e));
    }
    struct stat sb;
    if (fstat(fd, &sb) != 0 || !S_ISREG(sb.st_mode)) {
        close(fd);
        return pgi__fail(PGI_ERR_IO, "%s: not a regular file", path);
    }
    uint64_t h = 0xcbf29ce484222325ULL, n = 0;
    unsigned char buf[1 << 16];
    for (;;) {
        ssize_t r = read(fd, buf, sizeof buf);
        if (r < 0 && errno == EINTR) continue;
        if (r < 0) {
            int e = errno;
            close(fd);
            return pgi__fail(PGI_ERR_IO, "%s: cannot read: %s", path, strerror(e));
        }
        if (r == 0) break;
        for (ssize_t i = 0; i < r; i++) h = (h ^ buf[i]) * 0x100000001b3ULL;
        n += (uint64_t)r;
    }
    close(fd);
    *bytes = n;
    *hash = h;
    return PGI_OK;
}

pgi_status pgi_reference_save(const pgi_image *img, const char *exr, pgi_reference_meta *m, const char *meta_path) {
    if (!img || !img->rgb || img->width <= 0 || img->height <= 0 || !exr || !m || !meta_path)
        return pgi__fail(PGI_ERR_INVALID_ARG, "pgi_reference_save: no image or no path");
    pgi__out oe, om;
    pgi_status st = pgi__out_begin(exr, &oe);
    if (st) return st;
    const char *we = pgi__out_path(&oe, exr);
    if ((st = pgi__image_write_to(img, exr, we, 1.f))) {
        pgi__out_abort(&oe);
        return st;
    }
    m->exr_bytes = m->exr_hash = 0;
    if (!oe.direct && (st = pgi_reference_file_hash(we, &m->exr_bytes, &m->exr_hash))) {
        pgi__out_abort(&oe);
        return st;
    }
    if ((st = pgi__out_begin(meta_path, &om))) {
        pgi__out_abort(&oe);
        return st;
    }
    if ((st = meta_write_to(m, meta_path, pgi__out_path(&om, meta_path))) || (st = pgi__out_sync(&oe, exr)) ||
        (st = pgi__out_sync(&om, meta_path))) {
        pgi__out_abort(&oe);
        pgi__out_abort(&om);
        return st;
    }
    /* Both complete on the disk: the two renames, the only moment the pair can disagree. */
    if ((st = pgi__out_rename(&oe, exr))) {
        pgi__out_abort(&om);
        return st;
    }
    if ((st = pgi__out_rename(&om, meta_path))) {
        char why[512];
        snprintf(why, sizeof why, "%s", pgi_last_error());
        return pgi__fail(st, "%s is saved but %s could not be replaced (it describes the previous image): %s", exr,
                         meta_path, why);
    }
    return PGI_OK;
}

/* A whole number written as a string of decimal digits (hexadecimal with hex), in lo..hi; 0 if it is
 * not one (a sign, a fraction, more than 64 bits). */
static int get_u64(const cJSON *o, const char *name, uint64_t lo, uint64_t hi, int hex, uint64_t *out) {
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(o, name);
    if (!cJSON_IsString(v) || !v->valuestring[0]) return 0;
    uint64_t x = 0;
    const unsigned base = hex ? 16 : 10;
    for (const char *p = v->valuestring; *p; p++) {
        unsigned d;
        if (*p >= '0' && *p <= '9') d = (unsigned)(*p - '0');
        else if (hex && *p >= 'a' && *p <= 'f') d = (unsigned)(*p - 'a' + 10);
        else return 0;
        if (x > (UINT64_MAX - d) / base) return 0;
        x = x * base + d;
    }
    if (x < lo || x > hi) return 0;
    *out = x;
    return 1;
}

/* n finite floats within the coordinate range. */
static int get_floats(const cJSON *o, const char *name, int n, float *out) {
    const cJSON *a = cJSON_GetObjectItemCaseSensitive(o, name);
    if (!cJSON_IsArray(a) || cJSON_GetArraySize(a) != n) return 0;
    int i = 0;
    for (const cJSON *it = a->child; it; it = it->next, i++) {
        if (!cJSON_IsNumber(it) || !(fabs(it->valuedouble) <= PGI_MAX_COORD)) return 0;
        out[i] = (float)it->valuedouble;
    }
    return 1;
}

/* The sidecar's "view": the camera the samples were rendered from. */
static int get_view(const cJSON *v, pgi_camera_def *c) {
    const cJSON *f = cJSON_GetObjectItemCaseSensitive(v, "fov_y");
    if (!cJSON_IsObject(v) || !get_floats(v, "eye", 3, c->eye) || !get_floats(v, "look_at", 3, c->look_at) ||
        !get_floats(v, "up", 3, c->up) || !cJSON_IsNumber(f) || !(f->valuedouble > 0.0 && f->valuedouble < 180.0))
        return 0;
    c->fov_y_deg = (float)f->valuedouble;
    return 1;
}

/* A whole JSON number in lo..hi. */
static int get_int(const cJSON *o, const char *name, int lo, int hi, int *out) {
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(o, name);
    if (!cJSON_IsNumber(v)) return 0;
    const double x = v->valuedouble;
    if (!(x >= lo && x <= hi) || x != floor(x)) return 0;
    *out = (int)x;
    return 1;
}

pgi_status pgi_reference_meta_read(const char *path, pgi_reference_meta *m) {
    memset(m, 0, sizeof *m);
    /* Not blocking on a FIFO, and only a regular file of a sidecar's size. */
    int fd = open(path, O_RDONLY | O_NONBLOCK);
    if (fd < 0) {
        int e = errno;
        return pgi__fail(PGI_ERR_IO, "%s: cannot open (the reference's metadata file): %s", path, strerror(e));
    }
    struct stat sb;
    char buf[8192];
    if (fstat(fd, &sb) != 0 || !S_ISREG(sb.st_mode) || sb.st_size >= (off_t)sizeof buf) {
        close(fd);
        return pgi__fail(PGI_ERR_PARSE, "%s: not a reference's metadata file (%s)", path,
                         !S_ISREG(sb.st_mode) ? "not a regular file" : "over 8 KB");
    }
    size_t len = 0;
    for (;;) {
        ssize_t r = read(fd, buf + len, sizeof buf - 1 - len);
        if (r < 0 && errno == EINTR) continue;
        if (r < 0) {
            int e = errno;
            close(fd);
            return pgi__fail(PGI_ERR_IO, "%s: cannot read: %s", path, strerror(e));
        }
        if (r == 0 || (len += (size_t)r) == sizeof buf - 1) break;
    }
    close(fd);
    buf[len] = 0;
    cJSON *o = cJSON_Parse(buf);
    if (!o) return pgi__fail(PGI_ERR_PARSE, "%s: not JSON (the reference's metadata file)", path);
    const cJSON *fmt = cJSON_GetObjectItemCaseSensitive(o, "format");
    const cJSON *sc = cJSON_GetObjectItemCaseSensitive(o, "scene");
    const int v1 = cJSON_IsString(fmt) && strcmp(fmt->valuestring, "photongi-reference-1") == 0;
    const int v2 = cJSON_IsString(fmt) && strcmp(fmt->valuestring, "photongi-reference-2") == 0;
    const cJSON *jit = cJSON_GetObjectItemCaseSensitive(o, "jitter");
    int ok = (v1 || (v2 && cJSON_IsBool(jit))) && cJSON_IsString(sc) && sc->valuestring[0] &&
             strlen(sc->valuestring) < sizeof m->scene && get_int(o, "width", 1, PGI_MAX_IMAGE_SIDE, &m->width) &&
             get_int(o, "height", 1, PGI_MAX_IMAGE_SIDE, &m->height) &&
             (uint64_t)m->width * (uint64_t)m->height <= PGI_MAX_IMAGE_PIXELS &&
             get_int(o, "bounces", 1, 64, &m->bounces) && get_int(o, "camera", 0, 1000000, &m->camera) &&
             get_u64(o, "seed", 0, UINT64_MAX, 0, &m->seed) && get_u64(o, "spp", 1, PGI_REFERENCE_MAX_SPP, 0, &m->spp);
    if (ok && cJSON_GetObjectItemCaseSensitive(o, "exr_bytes"))
        ok = get_u64(o, "exr_bytes", 1, UINT64_MAX, 0, &m->exr_bytes) &&
             get_u64(o, "exr_fnv1a64", 0, UINT64_MAX, 1, &m->exr_hash);
    m->jitter = v2 && cJSON_IsTrue(jit) ? PGI_JITTER_ON : PGI_JITTER_OFF;
    const cJSON *sp = cJSON_GetObjectItemCaseSensitive(o, "specular");
    /* A sidecar without it predates the microfacet plastic: glossy materials were Blinn-Phong. */
    m->specular = PGI_SPECULAR_PHONG;
    if (sp) {
        if (cJSON_IsString(sp) && strcmp(sp->valuestring, "phong") == 0) m->specular = PGI_SPECULAR_PHONG;
        else if (cJSON_IsString(sp) && strcmp(sp->valuestring, "ggx") == 0) m->specular = PGI_SPECULAR_GGX;
        else ok = 0;
    }
    const cJSON *view = cJSON_GetObjectItemCaseSensitive(o, "view");
    if (ok && view) ok = get_view(view, &m->view) && (m->has_view = 1);
    if (ok) snprintf(m->scene, sizeof m->scene, "%s", sc->valuestring);
    cJSON_Delete(o);
    if (!ok)
        return pgi__fail(PGI_ERR_PARSE,
                         "%s: not a photongi reference metadata file (needs format, scene, width and height "
                         "1..%d, bounces 1..64, camera 0..1000000, seed 0..2^64-1, spp 1..2^53 as a string of "
                         "digits, jitter; a view camera, if any, as eye, look_at and up of three numbers and fov_y in "
                         "(0, 180))",
                         path, PGI_MAX_IMAGE_SIDE);
    /* A relative scene path is the sidecar's folder's (where the reference was made), not the current
     * folder's: a different file of the same name here must not be mixed in. */
    const char *slash = strrchr(path, '/');
    if (m->scene[0] != '/' && slash) {
        char cand[4096];
        struct stat ss;
        int n = snprintf(cand, sizeof cand, "%.*s/%s", (int)(slash - path), path, m->scene);
        if (n > 0 && n < (int)sizeof m->scene && stat(cand, &ss) == 0 && S_ISREG(ss.st_mode))
            memcpy(m->scene, cand, (size_t)n + 1);
    }
    return PGI_OK;
}
