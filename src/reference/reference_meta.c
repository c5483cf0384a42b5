/* Sidecar metadata of a reference image (<image>.json), so that
 * `photongi reference --continue` adds samples with the same settings.
 * Format 2 adds "jitter" (true: samples spread over the pixel); format 1
 * files were made through pixel centres and continue that way. An optional
 * "specular" ("ggx" | "phong") records `reference --specular`. */
#include <stdio.h>
#include <string.h>

#include <cjson/cJSON.h>

#include "core/core.h"
#include "photongi/reference.h"

pgi_status pgi_reference_meta_write(const pgi_reference_meta *m, const char *path) {
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
    char *txt = ok ? cJSON_Print(o) : NULL;
    cJSON_Delete(o);
    if (!txt) return pgi__fail(PGI_ERR_OOM, "out of memory writing %s", path);
    FILE *f = fopen(path, "wb");
    if (!f) {
        free(txt);
        return pgi__fail(PGI_ERR_IO, "%s: cannot write", path);
    }
    int bad = fputs(txt, f) < 0 || fputc('\n', f) == EOF;
    bad |= fclose(f) != 0;
    free(txt);
    return bad ? pgi__fail(PGI_ERR_IO, "%s: write failed", path) : PGI_OK;
}

static int get_u64(const cJSON *o, const char *name, uint64_t *out) {
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(o, name);
    if (!cJSON_IsString(v)) return 0;
    char *end;
    unsigned long long x = strtoull(v->valuestring, &end, 10);
    if (end == v->valuestring || *end) return 0;
    *out = x;
    return 1;
}

static int get_int(const cJSON *o, const char *name, int *out) {
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(o, name);
    if (!cJSON_IsNumber(v)) return 0;
    *out = v->valueint;
    return 1;
}

pgi_status pgi_reference_meta_read(const char *path, pgi_reference_meta *m) {
    memset(m, 0, sizeof *m);
    FILE *f = fopen(path, "rb");
    if (!f) return pgi__fail(PGI_ERR_IO, "%s: cannot open (the reference's metadata file)", path);
    char buf[8192];
    size_t len = fread(buf, 1, sizeof buf - 1, f);
    fclose(f);
    buf[len] = 0;
    cJSON *o = cJSON_Parse(buf);
    if (!o) return pgi__fail(PGI_ERR_PARSE, "%s: not JSON (the reference's metadata file)", path);
    const cJSON *fmt = cJSON_GetObjectItemCaseSensitive(o, "format");
    const cJSON *sc = cJSON_GetObjectItemCaseSensitive(o, "scene");
    const int v1 = cJSON_IsString(fmt) && strcmp(fmt->valuestring, "photongi-reference-1") == 0;
    const int v2 = cJSON_IsString(fmt) && strcmp(fmt->valuestring, "photongi-reference-2") == 0;
    const cJSON *jit = cJSON_GetObjectItemCaseSensitive(o, "jitter");
    int ok = (v1 || (v2 && cJSON_IsBool(jit))) && cJSON_IsString(sc) && get_int(o, "width", &m->width) &&
             get_int(o, "height", &m->height) && get_int(o, "bounces", &m->bounces) &&
             get_int(o, "camera", &m->camera) && get_u64(o, "seed", &m->seed) && get_u64(o, "spp", &m->spp);
    m->jitter = v2 && cJSON_IsTrue(jit) ? PGI_JITTER_ON : PGI_JITTER_OFF;
    const cJSON *sp = cJSON_GetObjectItemCaseSensitive(o, "specular");
    /* A sidecar without it predates the microfacet plastic: glossy materials were Blinn-Phong. */
    m->specular = PGI_SPECULAR_PHONG;
    if (sp) {
        if (cJSON_IsString(sp) && strcmp(sp->valuestring, "phong") == 0) m->specular = PGI_SPECULAR_PHONG;
        else if (cJSON_IsString(sp) && strcmp(sp->valuestring, "ggx") == 0) m->specular = PGI_SPECULAR_GGX;
        else ok = 0;
    }
    if (ok) snprintf(m->scene, sizeof m->scene, "%s", sc->valuestring);
    cJSON_Delete(o);
    if (!ok)
        return pgi__fail(PGI_ERR_PARSE,
                         "%s: not a photongi reference metadata file (needs format, scene, width, "
                         "height, bounces, camera, seed, spp, jitter)",
                         path);
    return PGI_OK;
}
