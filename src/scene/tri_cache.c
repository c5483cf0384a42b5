/* The triangle cache (tri_cache.h). */
#define _DEFAULT_SOURCE /* madvise's MADV_HUGEPAGE */
#include "tri_cache.h"

#include <omp.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>

/* Memory for the triangle records. Each hit reads one of them at random: from 1 MiB on they go to
 * 2 MiB-aligned memory the kernel may back with huge pages, so that a hit costs a cache miss but
 * no TLB miss (a scene's records span thousands of 4 KiB pages). */
static void *tris_alloc(size_t bytes, size_t *total) {
    const size_t huge = (size_t)2 << 20;
    if (bytes < huge / 2) {
        *total += bytes;
        return aligned_alloc(64, bytes);
    }
    bytes = (bytes + huge - 1) / huge * huge;
    *total += bytes;
    void *p = aligned_alloc(huge, bytes);
#ifdef MADV_HUGEPAGE
    if (p) madvise(p, bytes, MADV_HUGEPAGE); /* a hint: without huge pages all still works */
#endif
    return p;
}

pgi_status pgi__tri_cache_update(pgi__tri_cache *tc, const pgi_scene *s, int threads) {
    const int nt = pgi__threads(threads);
    const void *key[6] = {s, s->tri, s->pos, s->nrm, s->uv, s->tri_mat};
    if (tc->tris && tc->n == s->ntris && !memcmp(key, tc->key, sizeof key) && tc->version[0] == s->static_version &&
        tc->version[1] == s->dynamic_version)
        return PGI_OK;
    free(tc->tris);
    free(tc->tri_uv);
    tc->tri_uv = NULL;
    tc->n = tc->bytes = 0;
    const size_t n = s->ntris ? s->ntris : 1;
    size_t bytes = 0;
    tc->tris = tris_alloc(n * sizeof *tc->tris, &bytes);
    if (s->uv) tc->tri_uv = tris_alloc(n * PGI__TRI_UV * sizeof(float), &bytes);
    if (!tc->tris || (s->uv && !tc->tri_uv)) {
        free(tc->tris);
        free(tc->tri_uv);
        tc->tris = NULL;
        tc->tri_uv = NULL;
        return pgi__fail(PGI_ERR_OOM, "out of memory for %zu triangle records", s->ntris);
    }
    pgi__tri_rec *tr = tc->tris;
    float *tuv = tc->tri_uv;
#pragma omp parallel for schedule(static) num_threads(nt)
    for (long long i = 0; i < (long long)s->ntris; i++) {
        const uint32_t *t = s->tri + 3 * (size_t)i;
        pgi__tri_rec *r = &tr[i];
        memset(r, 0, sizeof *r);
        /* as pgi__scene_surface_untextured computes it */
        pgi__v3 a = pgi__scene_vertex(s, t[0]), b = pgi__scene_vertex(s, t[1]), c = pgi__scene_vertex(s, t[2]);
        v3_store(r->ng, v3_norm(v3_cross(v3_sub(b, a), v3_sub(c, a))));
        r->mat = s->tri_mat[i];
        if (s->nrm)
            for (int j = 0; j < 3; j++) memcpy(r->n + 3 * j, s->nrm + 3 * (size_t)t[j], 3 * sizeof(float));
        if (tuv) {
            float *q = tuv + PGI__TRI_UV * (size_t)i;
            for (int j = 0; j < 3; j++) memcpy(q + 2 * j, s->uv + 2 * (size_t)t[j], 2 * sizeof(float));
            q[6] = pgi__tri_uv_lod(a, b, c, q);
            q[7] = 0.f;
        }
    }
    tc->n = s->ntris;
    tc->bytes = bytes;
    memcpy(tc->key, key, sizeof key);
    tc->version[0] = s->static_version;
    tc->version[1] = s->dynamic_version;
    return PGI_OK;
}

void pgi__tri_cache_free(pgi__tri_cache *tc) {
    free(tc->tris);
    free(tc->tri_uv);
    *tc = (pgi__tri_cache){0};
}
