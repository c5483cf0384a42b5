/* Rays on the GPU (gpu_rays.h): the BVH's four arrays in four storage buffers, the rays.comp
 * kernel over a ray buffer and a hit buffer. */
#include "gpu/gpu_rays.h"

#include <string.h>

#ifdef PGI__HAVE_VULKAN
#include "gpu/spirv.h"
#endif

#define GROUP 64u
#define MAX_GROUPS 65535u

typedef struct rays_push {
    uint32_t first, count, flags, pad;
} rays_push;
_Static_assert(sizeof(rays_push) == 16, "rays.comp Push");

struct pgi__gpu_rays {
    pgi__gpu *g;
    pgi__bvh *bvh;
    pgi__gpu_buffer *nodes, *tris, *masks, *alpha;
    pgi__gpu_buffer *rays, *hits; /* pgi__gpu_rays_intersect's */
    pgi__gpu_kernel *kernel;
    uint32_t max_groups; /* a dispatch's most groups (MAX_GROUPS; tests lower it) */
    pgi__tri_bvh_config cfg;
};

/* Uploads n bytes of src (NULL or n 0: one zero word, a buffer must exist) into *b. */
static pgi_status upload(pgi__gpu *g, pgi__gpu_buffer **b, const void *src, size_t n, const char *what) {
    static const uint32_t zero[12];
    if (!src || !n) src = zero, n = sizeof zero;
    pgi_status st = pgi__gpu_buffer_reserve(g, b, n, what);
    return st ? st : pgi__gpu_upload(g, *b, 0, src, n);
}

/* Builds the BVH and uploads its four arrays. */
static pgi_status build_upload(pgi__gpu_rays *r, const pgi_scene *s) {
    pgi__bvh *b = NULL;
    pgi_status st = pgi__tri_bvh_build(s, &r->cfg, &b);
    if (st) return st;
    if ((st = upload(r->g, &r->nodes, b->nodes, b->nnodes * sizeof(pgi__tri_bvh_node), "gpu_bvh_nodes")) ||
        (st = upload(r->g, &r->tris, b->tris, b->ntris * sizeof(pgi__tri_bvh_tri), "gpu_bvh_tris")) ||
        (st = upload(r->g, &r->masks, b->masks, b->nmasks * sizeof(pgi__tri_bvh_mask), "gpu_bvh_masks")) ||
        (st = upload(r->g, &r->alpha, b->alpha, b->nalpha * sizeof(uint32_t), "gpu_bvh_alpha"))) {
        pgi__tri_bvh_destroy(b);
        return st;
    }
    pgi__tri_bvh_destroy(r->bvh);
    r->bvh = b;
    return PGI_OK;
}

pgi_status pgi__gpu_rays_create(pgi__gpu *g, const pgi_scene *s, pgi__gpu_rays **out) {
    *out = NULL;
#ifndef PGI__HAVE_VULKAN
    (void)g;
    (void)s;
    return pgi__fail(PGI_ERR_UNSUPPORTED, "GPU rays: this build has no Vulkan backend (configure with PGI_VULKAN=ON)");
#else
    pgi__gpu_rays *r = calloc(1, sizeof *r);
    if (!r) return pgi__fail(PGI_ERR_OOM, "out of memory creating the GPU rays");
    r->g = g;
    r->max_groups = MAX_GROUPS;
    r->cfg = pgi__tri_bvh_default_config();
    pgi_status st = build_upload(r, s);
    if (!st)
        st = pgi__gpu_kernel_create(g, pgi__spv_rays, sizeof pgi__spv_rays, "rays", 6, sizeof(rays_push), &r->kernel);
    if (st) {
        pgi__gpu_rays_destroy(r);
        return st;
    }
    *out = r;
    return PGI_OK;
#endif
}

void pgi__gpu_rays_destroy(pgi__gpu_rays *r) {
    if (!r) return;
    pgi__gpu_kernel_destroy(r->g, r->kernel);
    pgi__gpu_buffer_destroy(r->g, r->nodes);
    pgi__gpu_buffer_destroy(r->g, r->tris);
    pgi__gpu_buffer_destroy(r->g, r->masks);
    pgi__gpu_buffer_destroy(r->g, r->alpha);
    pgi__gpu_buffer_destroy(r->g, r->rays);
    pgi__gpu_buffer_destroy(r->g, r->hits);
    pgi__tri_bvh_destroy(r->bvh);
    free(r);
}

int pgi__gpu_rays_needs_update(const pgi__gpu_rays *r, const pgi_scene *s) {
    return pgi__tri_bvh_needs_update(r->bvh, s);
}

pgi_status pgi__gpu_rays_update(pgi__gpu_rays *r, const pgi_scene *s) {
    if (!pgi__gpu_rays_needs_update(r, s)) return PGI_OK;
    return build_upload(r, s);
}

const pgi__bvh *pgi__gpu_rays_bvh(const pgi__gpu_rays *r) { return r->bvh; }

pgi_status pgi__gpu_rays_set_config(pgi__gpu_rays *r, const pgi_scene *s, const pgi__tri_bvh_config *cfg) {
    pgi__tri_bvh_config old = r->cfg;
    r->cfg = cfg ? *cfg : pgi__tri_bvh_default_config();
    pgi_status st = build_upload(r, s);
    if (st) r->cfg = old;
    return st;
}

void pgi__gpu_rays_set_max_groups(pgi__gpu_rays *r, uint32_t groups) {
    r->max_groups = groups < 1 ? 1 : groups > MAX_GROUPS ? MAX_GROUPS : groups;
}

pgi_status pgi__gpu_rays_dispatch(pgi__gpu_rays *r, pgi__gpu_buffer *rays, pgi__gpu_buffer *hits, size_t first,
                                  size_t n, int any_hit) {
    if (!rays || !hits) return pgi__fail(PGI_ERR_INTERNAL, "GPU rays: no ray or hit buffer");
    if (first + n > pgi__gpu_buffer_size(rays) / sizeof(pgi__tri_bvh_ray) ||
        first + n > pgi__gpu_buffer_size(hits) / sizeof(pgi__hit) || first + n > UINT32_MAX)
        return pgi__fail(PGI_ERR_INTERNAL, "GPU rays: rays %zu..%zu outside the ray or hit buffer", first, first + n);
    pgi__gpu_buffer *bufs[6] = {r->nodes, r->tris, r->masks, r->alpha, rays, hits};
    const size_t chunk = (size_t)r->max_groups * GROUP;
    for (size_t done = 0; done < n; done += chunk) {
        size_t m = n - done < chunk ? n - done : chunk;
        rays_push p = {(uint32_t)(first + done), (uint32_t)m, any_hit ? 1u : 0u, 0u};
        pgi_status st = pgi__gpu_dispatch(r->g, r->kernel, bufs, &p, (uint32_t)((m + GROUP - 1) / GROUP), 1, 1);
        if (st) return st;
    }
    return PGI_OK;
}

pgi_status pgi__gpu_rays_intersect(pgi__gpu_rays *r, const pgi__tri_bvh_ray *rays, size_t n, int any_hit,
                                   pgi__hit *hits) {
    if (n == 0) return PGI_OK;
    pgi_status st;
    if ((st = pgi__gpu_buffer_reserve(r->g, &r->rays, n * sizeof *rays, "gpu_rays")) ||
        (st = pgi__gpu_buffer_reserve(r->g, &r->hits, n * sizeof *hits, "gpu_hits")) ||
        (st = pgi__gpu_upload(r->g, r->rays, 0, rays, n * sizeof *rays)) || (st = pgi__gpu_begin(r->g)))
        return st;
    pgi__gpu_timestamp(r->g, "start");
    st = pgi__gpu_rays_dispatch(r, r->rays, r->hits, 0, n, any_hit);
    pgi__gpu_timestamp(r->g, "rays");
    pgi_status st2 = pgi__gpu_submit_wait(r->g); /* ends the sequence even when recording failed */
    if (st || (st = st2)) return st;
    return pgi__gpu_download(r->g, r->hits, 0, hits, n * sizeof *hits);
}

void pgi__gpu_rays_buffers(const pgi__gpu_rays *r, pgi__gpu_buffer **out) {
    out[0] = r->nodes;
    out[1] = r->tris;
    out[2] = r->masks;
    out[3] = r->alpha;
}
