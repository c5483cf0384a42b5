/* Rays on the GPU (src/gpu/gpu_rays.h, src/gpu/shaders/rays.comp) on whatever Vulkan device the
 * loader finds (CI: lavapipe). The kernel gives the same hits as the CPU traversal of the same
 * layout (rt/tri_bvh.c): the same triangle for every ray, t, u, v within 1e-6 relative (the kernel
 * keeps the CPU's operation order and no fused multiply-adds; a device's division may round
 * differently, hence not bit for bit), the same occlusion answers; and it agrees with Embree as
 * tests/test_gpu_bvh.c's traversal does, cut-outs included. Small ray counts: lavapipe is a CPU. Built and run only
 * when the library has the Vulkan backend (PGI_VULKAN). */
#include "gpu_rays_common.h"
#include "test_gpu_util.h"

#include "gpu/gpu_rays.h"


/* GPU against the CPU traversal of the same BVH: rays whose answers differ (prim, or t, u, v
 * beyond 1e-6 relative / 1e-6 absolute), printing the first few. */
static size_t gpu_vs_cpu(const pgi__bvh *b, const pgi__tri_bvh_ray *r, const pgi__hit *gh, size_t n, int any,
                         size_t *exact) {
    size_t bad = 0;
    void *bv = (void *)b; /* the layout's cut-out test, the shader's */
    for (size_t i = 0; i < n; i++) {
        pgi__hit ch;
        if (any) {
            int o =
                pgi__tri_bvh_occluded(b, r[i].org, r[i].dir, r[i].tnear, r[i].tfar, pgi__tri_bvh_mask_filter, bv, NULL);
            int go = gh[i].prim != UINT32_MAX;
            if (o != go && bad++ < 3) fprintf(stderr, "  shadow ray %zu: GPU %d, CPU %d\n", i, go, o);
            *exact += o == go;
            continue;
        }
        pgi__tri_bvh_intersect(b, r[i].org, r[i].dir, r[i].tnear, r[i].tfar, &ch, pgi__tri_bvh_mask_filter, bv, NULL);
        const pgi__hit *g = &gh[i];
        int same = g->prim == ch.prim;
        if (same && ch.prim != UINT32_MAX)
            same =
                fabsf(g->t - ch.t) <= 1e-6f * fabsf(ch.t) && fabsf(g->u - ch.u) <= 1e-6f && fabsf(g->v - ch.v) <= 1e-6f;
        *exact += ch.prim == UINT32_MAX ? same : memcmp(g, &ch, sizeof ch) == 0;
        if (!same && bad++ < 3)
            fprintf(stderr, "  ray %zu: GPU prim %u t %.9g u %.7g v %.7g, CPU prim %u t %.9g u %.7g v %.7g\n", i,
                    g->prim, g->t, g->u, g->v, ch.prim, ch.t, ch.u, ch.v);
    }
    return bad;
}

/* The four ray sets of scene s on the GPU: against the CPU traversal, and against Embree. */
static void check_rays(const pgi_scene *s, pgi__gpu_rays *gr, size_t n, int w, int h, const char *what) {
    pgi__rt *rt = NULL;
    TU_CHECK_OK(pgi__rt_create(s, &rt));
    const pgi__bvh *b = pgi__gpu_rays_bvh(gr);
    size_t cap = n > (size_t)w * h * s->ncams ? n : (size_t)w * h * s->ncams;
    pgi__tri_bvh_ray *r = malloc(cap * sizeof *r);
    pgi__hit *gh = malloc(cap * sizeof *gh), *eh = malloc(cap * sizeof *eh);
    assert_non_null(r);
    assert_non_null(gh);
    assert_non_null(eh);
    for (int k = 0; k < 4; k++) {
        size_t m = gr_rays(s, rt, (gr_kind)k, n, w, h, 500 + (uint64_t)k, r);
        const int any = k == GR_SHADOW;
        for (size_t i = 0; i < m; i++) gh[i] = (pgi__hit){-1.f, -1.f, -1.f, 12345u}; /* every entry is written */
        double t0 = pgi__now_ms();
        TU_CHECK_OK(pgi__gpu_rays_intersect(gr, r, m, any, gh));
        double ms = pgi__now_ms() - t0;
        size_t exact = 0, bad = gpu_vs_cpu(b, r, gh, m, any, &exact);
        fprintf(stderr, "  %-16s %-8s %6zu rays, %.1f ms: %zu differ from the CPU traversal, %zu bit for bit\n", what,
                gr_kind_name[k], m, ms, bad, exact);
        assert_int_equal(bad, 0);
        if (any) {
            size_t differ = 0;
            for (size_t i = 0; i < m; i++) {
                pgi__v3 o = v3(r[i].org[0], r[i].org[1], r[i].org[2]), d = v3(r[i].dir[0], r[i].dir[1], r[i].dir[2]);
                differ += pgi__rt_occluded(rt, o, d, r[i].tnear, r[i].tfar) != (gh[i].prim != UINT32_MAX);
            }
            fprintf(stderr, "  %-16s %-8s against Embree: %zu answers differ\n", what, gr_kind_name[k], differ);
            assert_int_equal(differ, 0);
            continue;
        }
        for (size_t i = 0; i < m; i++) {
            pgi__v3 o = v3(r[i].org[0], r[i].org[1], r[i].org[2]), d = v3(r[i].dir[0], r[i].dir[1], r[i].dir[2]);
            if (!pgi__rt_intersect(rt, o, d, r[i].tnear, r[i].tfar, &eh[i])) eh[i].prim = UINT32_MAX;
        }
        gr_tally c = {0};
        gr_compare(gh, eh, m, pgi__scene_diagonal(s), &c);
        gr_print(what, gr_kind_name[k], &c);
        assert_int_equal(c.missed, 0);
        assert_true(c.extra <= c.rays / 20000);
        assert_int_equal(c.wrong, 0);
        assert_int_equal(c.bad_tuv, 0);
        assert_true((double)c.ties <= (k == GR_PRIMARY ? 0.02 : 0.002) * (double)c.ref_hits + 1.0);
    }
    free(r);
    free(gh);
    free(eh);
    pgi__rt_destroy(rt);
}

static void check_scene(const char *name, size_t n, int w, int h) {
    pgi_scene *s = NULL;
    TU_CHECK_OK(pgi_scene_load(name, &s));
    pgi__gpu_rays *gr = NULL;
    TU_CHECK_OK(pgi__gpu_rays_create(g_gpu, s, &gr));
    check_rays(s, gr, n, w, h, name);
    pgi_named_value mem[16];
    int nm = pgi__gpu_memory(g_gpu, mem, 16);
    double nodes = 0, tris = 0;
    for (int i = 0; i < nm; i++) {
        if (!strcmp(mem[i].name, "gpu_bvh_nodes")) nodes = mem[i].value;
        if (!strcmp(mem[i].name, "gpu_bvh_tris")) tris = mem[i].value;
    }
    const pgi__bvh *b = pgi__gpu_rays_bvh(gr);
    assert_true(nodes >= (double)(b->nnodes * sizeof(pgi__tri_bvh_node)));
    assert_true(tris >= (double)(b->ntris * sizeof(pgi__tri_bvh_tri)));
    pgi__gpu_rays_destroy(gr);
    pgi_scene_destroy(s);
}

static void test_cornell(void **state) {
    (void)state;
    check_scene("cornell", 20000, 64, 48);
}

static void test_sphere_and_plane(void **state) {
    (void)state;
    check_scene("sphere-and-plane", 20000, 64, 48);
}

static void test_sibenik(void **state) {
    (void)state;
    check_scene("sibenik", 20000, 96, 54);
}

/* An animated scene: stale after it moves, updated in place, right again. */
static void test_dynamic(void **state) {
    (void)state;
    pgi_scene *s = NULL;
    TU_CHECK_OK(pgi_scene_load("scenes/cornell-moving.json", &s));
    pgi__gpu_rays *gr = NULL;
    TU_CHECK_OK(pgi__gpu_rays_create(g_gpu, s, &gr));
    assert_false(pgi__gpu_rays_needs_update(gr, s));
    TU_CHECK_OK(pgi_scene_set_time(s, 0.75));
    assert_true(pgi__gpu_rays_needs_update(gr, s));
    TU_CHECK_OK(pgi__gpu_rays_update(gr, s));
    assert_false(pgi__gpu_rays_needs_update(gr, s));
    check_rays(s, gr, 10000, 48, 32, "cornell-moving");
    pgi__gpu_rays_destroy(gr);
    pgi_scene_destroy(s);
}

/* Cut-outs: the lattice's mask on the GPU (bvh_cut_out) opens what Embree's filter opens; again
 * with tiled, shifted texture coordinates (wrapping, negative ones). */
static void test_cutout(void **state) {
    (void)state;
    pgi_scene *s = NULL;
    TU_CHECK_OK(pgi_scene_load("cutout", &s));
    for (int tiled = 0; tiled < 2; tiled++) {
        if (tiled)
            for (size_t i = 0; i < 2 * s->nverts; i++) s->uv[i] = 3.7f * s->uv[i] - 1.3f;
        pgi__gpu_rays *gr = NULL;
        TU_CHECK_OK(pgi__gpu_rays_create(g_gpu, s, &gr));
        assert_true(pgi__gpu_rays_bvh(gr)->nmasks > 0);
        check_rays(s, gr, 20000, 96, 96, tiled ? "cutout tiled" : "cutout");
        pgi__gpu_rays_destroy(gr);
    }
    pgi_scene_destroy(s);
}

/* Other builds on the device: spatial splits (references repeated across leaves) on Sibenik,
 * binary nodes (two empty slots a node) and one triangle a leaf on Cornell; a bad setting is
 * refused and the previous build stays. */
static void test_configs(void **state) {
    (void)state;
    const pgi__tri_bvh_config
        split = {.quality = 2, .width = 4, .max_leaf = 8, .traversal_cost = 1.f, .intersection_cost = 1.f},
        binary = {.quality = 1, .width = 2, .max_leaf = 1, .traversal_cost = 1.f, .intersection_cost = 1.f};
    pgi_scene *s = NULL;
    TU_CHECK_OK(pgi_scene_load("sibenik", &s));
    pgi__gpu_rays *gr = NULL;
    TU_CHECK_OK(pgi__gpu_rays_create(g_gpu, s, &gr));
    TU_CHECK_OK(pgi__gpu_rays_set_config(gr, s, &split));
    assert_true(pgi__gpu_rays_bvh(gr)->ntris > s->ntris);
    check_rays(s, gr, 5000, 48, 27, "sibenik splits");
    pgi__gpu_rays_destroy(gr);
    pgi_scene_destroy(s);
    TU_CHECK_OK(pgi_scene_load("cornell", &s));
    TU_CHECK_OK(pgi__gpu_rays_create(g_gpu, s, &gr));
    TU_CHECK_OK(pgi__gpu_rays_set_config(gr, s, &binary));
    check_rays(s, gr, 5000, 32, 24, "cornell binary");
    const pgi__bvh *before = pgi__gpu_rays_bvh(gr);
    pgi__tri_bvh_config bad = binary;
    bad.width = 3;
    assert_int_equal(pgi__gpu_rays_set_config(gr, s, &bad), PGI_ERR_INVALID_ARG);
    assert_ptr_equal(pgi__gpu_rays_bvh(gr), before);
    pgi__gpu_rays_destroy(gr);
    pgi_scene_destroy(s);
}

/* Rays in the middle of a device buffer (dispatch offsets); an empty batch; a batch split into
 * several dispatches. */
static void test_dispatch_offsets(void **state) {
    (void)state;
    pgi_scene *s = NULL;
    TU_CHECK_OK(pgi_scene_load("cornell", &s));
    pgi__gpu_rays *gr = NULL;
    TU_CHECK_OK(pgi__gpu_rays_create(g_gpu, s, &gr));
    enum { N = 1000, FIRST = 300, M = 500 };
    pgi__tri_bvh_ray *r = malloc(N * sizeof *r);
    pgi__hit *h = malloc(N * sizeof *h);
    assert_non_null(r);
    assert_non_null(h);
    gr_rays(s, NULL, GR_RANDOM, N, 0, 0, 9, r);
    pgi__gpu_buffer *rb = NULL, *hb = NULL;
    TU_CHECK_OK(pgi__gpu_buffer_reserve(g_gpu, &rb, N * sizeof *r, "gpu_test_rays"));
    TU_CHECK_OK(pgi__gpu_buffer_reserve(g_gpu, &hb, N * sizeof *h, "gpu_test_hits"));
    TU_CHECK_OK(pgi__gpu_upload(g_gpu, rb, 0, r, N * sizeof *r));
    TU_CHECK_OK(pgi__gpu_begin(g_gpu));
    TU_CHECK_OK(pgi__gpu_fill(g_gpu, hb, 0, N * sizeof *h, 0xABABABABu));
    TU_CHECK_OK(pgi__gpu_rays_dispatch(gr, rb, hb, FIRST, M, 0));
    assert_int_not_equal(pgi__gpu_rays_dispatch(gr, rb, hb, FIRST, N, 0), PGI_OK); /* past the end */
    TU_CHECK_OK(pgi__gpu_submit_wait(g_gpu));
    TU_CHECK_OK(pgi__gpu_download(g_gpu, hb, 0, h, N * sizeof *h));
    size_t exact = 0;
    for (int i = 0; i < N; i++)
        if (i < FIRST || i >= FIRST + M) assert_int_equal(h[i].prim, 0xABABABABu);
    assert_int_equal(gpu_vs_cpu(pgi__gpu_rays_bvh(gr), r + FIRST, h + FIRST, M, 0, &exact), 0);
    TU_CHECK_OK(pgi__gpu_rays_intersect(gr, r, 0, 0, h));
    /* split into dispatches of 3 groups (192 rays): the same hits */
    pgi__gpu_rays_set_max_groups(gr, 3);
    memset(h, 0, N * sizeof *h);
    TU_CHECK_OK(pgi__gpu_rays_intersect(gr, r, N, 0, h));
    exact = 0;
    assert_int_equal(gpu_vs_cpu(pgi__gpu_rays_bvh(gr), r, h, N, 0, &exact), 0);
    assert_int_equal(exact, N);
    pgi__gpu_buffer_destroy(g_gpu, rb);
    pgi__gpu_buffer_destroy(g_gpu, hb);
    free(r);
    free(h);
    pgi__gpu_rays_destroy(gr);
    pgi_scene_destroy(s);
}

int main(void) {
    tu_keep_lavapipe_loaded();
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_cornell), cmocka_unit_test(test_sphere_and_plane),
        cmocka_unit_test(test_sibenik), cmocka_unit_test(test_dynamic),
        cmocka_unit_test(test_cutout),  cmocka_unit_test(test_dispatch_offsets),
        cmocka_unit_test(test_configs),
    };
    return cmocka_run_group_tests(tests, tu_gpu_setup, tu_gpu_teardown);
}
