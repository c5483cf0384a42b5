/* View samples, direct light and the frame's sum on the GPU (gpu_view.h). */
#include "gpu/gpu_view.h"

#include <string.h>

#include "scene/bsdf.h"

#ifdef PGI__HAVE_VULKAN
#include "gpu/spirv.h"
#endif

struct pgi__gpu_view {
    pgi__gpu *g;
    pgi__gpu_kernel *view, *direct;
    pgi__gpu_buffer *samples, *extra, *params, *counters, *image, *dummy;
    pgi__gpu_frame_params fp;
};

/* direct.comp Push */
typedef struct {
    pgi__gpu_scene_push scene;
    uint32_t width, height, seed_lo, seed_hi;
    uint32_t direct_samples, output_mode, has_indirect, nportals;
} direct_push;
_Static_assert(sizeof(direct_push) == 96 && offsetof(direct_push, direct_samples) == 80, "direct.comp Push");

pgi_status pgi__gpu_view_create(pgi__gpu *g, pgi__gpu_view **out) {
    *out = NULL;
#ifndef PGI__HAVE_VULKAN
    (void)g;
    return pgi__fail(PGI_ERR_UNSUPPORTED, "%s", "GPU view samples: this build has no Vulkan backend");
#else
    pgi__gpu_view *v = calloc(1, sizeof *v);
    if (!v) return pgi__fail(PGI_ERR_OOM, "%s", "out of memory");
    v->g = g;
    pgi_status st;
    if ((st = pgi__gpu_kernel_create(g, pgi__spv_view, sizeof pgi__spv_view, "view", PGI__GPU_SCENE_NBUF + 4,
                                     sizeof(pgi__gpu_scene_push), &v->view)) ||
        (st = pgi__gpu_kernel_create(g, pgi__spv_direct, sizeof pgi__spv_direct, "direct", PGI__GPU_SCENE_NBUF + 6,
                                     sizeof(direct_push), &v->direct)) ||
        (st = pgi__gpu_buffer_reserve(g, &v->counters, 4 * sizeof(uint32_t), "gpu_view_samples")) ||
        (st = pgi__gpu_buffer_reserve(g, &v->params, sizeof(pgi__gpu_frame_params), "gpu_view_samples")) ||
        (st = pgi__gpu_buffer_reserve(g, &v->dummy, 16, "gpu_view_samples"))) {
        pgi__gpu_view_destroy(v);
        return st;
    }
    *out = v;
    return PGI_OK;
#endif
}

void pgi__gpu_view_destroy(pgi__gpu_view *v) {
    if (!v) return;
    pgi__gpu_kernel_destroy(v->g, v->view);
    pgi__gpu_kernel_destroy(v->g, v->direct);
    pgi__gpu_buffer *b[] = {v->samples, v->extra, v->params, v->counters, v->image, v->dummy};
    for (size_t i = 0; i < sizeof b / sizeof b[0]; i++) pgi__gpu_buffer_destroy(v->g, b[i]);
    free(v);
}

pgi_status pgi__gpu_view_prepare(pgi__gpu_view *v, const pgi_camera *cam, uint64_t seed, const pgi__subpixel *sp) {
    const size_t n = (size_t)cam->width * (size_t)cam->height;
    if (n > UINT32_MAX / 4)
        return pgi__fail(PGI_ERR_UNSUPPORTED, "GPU view samples: %dx%d pixels is too many", cam->width, cam->height);
    pgi_status st;
    if ((st = pgi__gpu_buffer_reserve(v->g, &v->samples, n * sizeof(pgi__gpu_view_sample), "gpu_view_samples")) ||
        (st = pgi__gpu_buffer_reserve(v->g, &v->extra, n * sizeof(pgi__gpu_pixel_extra), "gpu_view_samples")) ||
        (st = pgi__gpu_buffer_reserve(v->g, &v->image, 3 * n * sizeof(float), "gpu_image")))
        return st;
    pgi__gpu_frame_params *p = &v->fp;
    memset(p, 0, sizeof *p);
    memcpy(p->eye, cam->eye, sizeof p->eye);
    memcpy(p->forward, cam->forward, sizeof p->forward);
    memcpy(p->right, cam->right, sizeof p->right);
    memcpy(p->up, cam->up, sizeof p->up);
    p->tan_half_fov = cam->tan_half_fov_y;
    p->aspect = cam->aspect;
    p->width = (uint32_t)cam->width;
    p->height = (uint32_t)cam->height;
    p->jitter = sp->jitter ? 1u : 0u;
    p->index = sp->index;
    p->seed_lo = (uint32_t)seed;
    p->seed_hi = (uint32_t)(seed >> 32);
    const uint64_t key = pgi__mix64(sp->seed ^ 0x6a6974746572ULL); /* pgi__pixel_jitter's per-seed key */
    p->key_lo = (uint32_t)key;
    p->key_hi = (uint32_t)(key >> 32);
    p->tex_filter = sp->tex_filter ? 1u : 0u;
    p->spread = 2.f * cam->tan_half_fov_y / (float)cam->height; /* view.c tex_cone */
    return pgi__gpu_upload(v->g, v->params, 0, p, sizeof *p);
}

static void scene_bufs(const pgi__gpu_scene *gs, pgi__gpu_buffer **b) { pgi__gpu_scene_buffers(gs, b); }

pgi_status pgi__gpu_view_record(pgi__gpu_view *v, const pgi__gpu_scene *gs) {
    pgi__gpu_buffer *b[PGI__GPU_SCENE_NBUF + 4];
    scene_bufs(gs, b);
    b[11] = v->params;
    b[12] = v->samples;
    b[13] = v->extra;
    b[14] = v->counters;
    pgi__gpu_scene_push push;
    pgi__gpu_scene_info(gs, &push);
    pgi_status st;
    if ((st = pgi__gpu_fill(v->g, v->counters, 0, 4 * sizeof(uint32_t), 0)) ||
        (st = pgi__gpu_dispatch(v->g, v->view, b, &push, (v->fp.width + 7) / 8, (v->fp.height + 7) / 8, 1)))
        return st;
    pgi__gpu_timestamp(v->g, "gpu_view");
    return PGI_OK;
}

pgi_status pgi__gpu_direct_record(pgi__gpu_view *v, const pgi__gpu_scene *gs, pgi__gpu_buffer *indirect,
                                  int direct_samples, uint64_t seed, pgi_output output) {
    if (output != PGI_OUTPUT_ALL && output != PGI_OUTPUT_INDIRECT && output != PGI_OUTPUT_DIRECT)
        return pgi__fail(PGI_ERR_UNSUPPORTED, "%s",
                         "the GPU frame has the outputs all, indirect and direct (not the photon counts)");
    pgi__gpu_buffer *b[PGI__GPU_SCENE_NBUF + 6];
    scene_bufs(gs, b);
    uint32_t nportals;
    b[11] = indirect ? indirect : v->dummy;
    b[12] = v->samples;
    b[13] = v->extra;
    b[14] = v->counters;
    b[15] = v->image;
    b[16] = pgi__gpu_scene_portals(gs, &nportals);
    direct_push p = {.width = v->fp.width,
                     .height = v->fp.height,
                     .seed_lo = (uint32_t)seed,
                     .seed_hi = (uint32_t)(seed >> 32),
                     .direct_samples = (uint32_t)(direct_samples > 0 ? direct_samples : 0),
                     .output_mode = (uint32_t)output,
                     .has_indirect = indirect != NULL,
                     .nportals = nportals};
    pgi__gpu_scene_info(gs, &p.scene);
    pgi_status st = pgi__gpu_dispatch(v->g, v->direct, b, &p, (v->fp.width + 7) / 8, (v->fp.height + 7) / 8, 1);
    if (st) return st;
    pgi__gpu_timestamp(v->g, "gpu_direct");
    return PGI_OK;
}

pgi__gpu_buffer *pgi__gpu_view_samples(const pgi__gpu_view *v) { return v->samples; }
pgi__gpu_buffer *pgi__gpu_view_image(const pgi__gpu_view *v) { return v->image; }
pgi__gpu_buffer *pgi__gpu_view_extra(const pgi__gpu_view *v) { return v->extra; }

pgi_status pgi__gpu_view_counters(pgi__gpu_view *v, uint64_t *primary, uint64_t *shadow) {
    uint32_t c[4];
    pgi_status st = pgi__gpu_download(v->g, v->counters, 0, c, sizeof c);
    if (st) return st;
    *primary = (uint64_t)c[0] | (uint64_t)c[1] << 32;
    *shadow = (uint64_t)c[2] | (uint64_t)c[3] << 32;
    return PGI_OK;
}

pgi_status pgi__gpu_view_download(pgi__gpu_view *v, const pgi_scene *s, pgi_view_samples *vs, float *emit) {
    const size_t n = (size_t)v->fp.width * v->fp.height;
    if (vs->width != (int)v->fp.width || vs->height != (int)v->fp.height)
        return pgi__fail(PGI_ERR_INVALID_ARG, "view-sample buffer is %dx%d, the GPU frame %ux%u", vs->width, vs->height,
                         v->fp.width, v->fp.height);
    pgi__gpu_view_sample *a = malloc(n * sizeof *a);
    pgi__gpu_pixel_extra *x = malloc(n * sizeof *x);
    pgi_status st = PGI_OK;
    if (!a || !x) {
        st = pgi__fail(PGI_ERR_OOM, "%s", "out of memory downloading the GPU view samples");
        goto done;
    }
    if ((st = pgi__gpu_download(v->g, v->samples, 0, a, n * sizeof *a)) ||
        (st = pgi__gpu_download(v->g, v->extra, 0, x, n * sizeof *x)))
        goto done;
    vs->jitter = v->fp.jitter ? 0.5f : 0.f;
    for (size_t i = 0; i < n; i++) {
        memcpy(vs->pos + 3 * i, a[i].pos, 12);
        memcpy(vs->nrm + 3 * i, a[i].nrm, 12);
        memcpy(vs->wo + 3 * i, a[i].wo, 12);
        memcpy(vs->kd + 3 * i, a[i].kd, 12);
        memcpy(vs->ngeo + 3 * i, x[i].ngeo, 12);
        memcpy(vs->weight + 3 * i, x[i].weight, 12);
        vs->depth[i] = x[i].depth;
        vs->flags[i] = (uint8_t)a[i].flags;
        if (emit) memcpy(emit + 3 * i, x[i].emit, 12);
        pgi__v3 ks = v3(0.f, 0.f, 0.f);
        float sh = 0.f, eta = 0.f;
        if ((a[i].flags & PGI_VS_VALID) && a[i].lobe < s->nmats) pgi__lobe_params(&s->mats[a[i].lobe], &ks, &sh, &eta);
        v3_store(vs->ks + 3 * i, ks);
        vs->shininess[i] = sh;
        vs->ior[i] = eta;
    }
done:
    free(a);
    free(x);
    return st;
}
