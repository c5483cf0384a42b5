/* The frame on the GPU (issue "The GPU backend": src/gpu/gpu_scene.h, gpu_view.h, the renderer's
 * --device vulkan path) on whatever Vulkan device the loader finds (CI: lavapipe, a CPU device:
 * small sizes). Built and run only when the library has the Vulkan backend (PGI_VULKAN).
 *   - the scene upload: the surface scene.glsl computes (geometric and shading normals, textured
 *     kd) at random hits equals the CPU's pgi__scene_surface, on Cornell, the cutout scene and a
 *     textured one (Sibenik, when the scenes folder has it). */
#include "test_util.h"

#include <dlfcn.h>

#include "core/core.h"
#include "gpu/gpu.h"
#include "gpu/gpu_scene.h"
#include "gpu/spirv.h"
#include "scene/bsdf.h"
#include "scene/scene_internal.h"

static pgi__gpu *g_gpu;

static int setup(void **state) {
    (void)state;
    if (pgi__gpu_create(-1, &g_gpu) != PGI_OK) {
        fprintf(stderr, "no Vulkan device: %s\n", pgi_last_error());
        return -1;
    }
    fprintf(stderr, "device: %s\n", pgi__gpu_device_name(g_gpu));
    return 0;
}

static int teardown(void **state) {
    (void)state;
    pgi__gpu_destroy(g_gpu);
    return 0;
}

/* Sibenik (textured) when the scenes folder has it, else NULL. */
static pgi_scene *load_sibenik(void) {
    char mesh[1024];
    snprintf(mesh, sizeof mesh, "%s/sibenik/sibenik.obj", tu_scenes_dir());
    if (!tu_file_exists("scenes/sibenik.json") || !tu_file_exists(mesh)) {
        fprintf(stderr, "  (no Sibenik: scenes/sibenik.json or %s not found)\n", mesh);
        return NULL;
    }
    pgi_scene *s = NULL;
    TU_CHECK_OK(pgi_scene_load("scenes/sibenik.json", &s));
    return s;
}

/* ------------------------------------------------------------ scene upload */

static void check_surfaces(const pgi_scene *s, const char *what) {
    pgi__gpu_scene *gs = NULL;
    TU_CHECK_OK(pgi__gpu_scene_create(g_gpu, s, &gs));
    pgi__gpu_kernel *k = NULL;
    struct {
        pgi__gpu_scene_push scene;
        uint32_t count, pad[3];
    } push = {0};
    TU_CHECK_OK(pgi__gpu_kernel_create(g_gpu, pgi__spv_scene_probe, sizeof pgi__spv_scene_probe, "scene_probe",
                                       PGI__GPU_SCENE_NBUF + 2, sizeof push, &k));
    const size_t n = 4096;
    uint32_t *q = malloc(n * 4 * sizeof *q);
    float *res = malloc(n * 12 * sizeof *res);
    assert_non_null(q);
    assert_non_null(res);
    tu_rng r = tu_rng_make(77);
    size_t textured = 0;
    for (size_t i = 0; i < n; i++) {
        uint32_t prim = (uint32_t)(tu_next(&r) % s->ntris);
        float bu = tu_unif(&r), bv = tu_unif(&r);
        if (bu + bv > 1.f) bu = 1.f - bu, bv = 1.f - bv;
        /* textured materials drawn more often: half the queries on them when there are any */
        if ((i & 1) && s->ntexs) {
            for (int tries = 0; tries < 64 && s->mats[s->tri_mat[prim]].tex_kd < 0; tries++)
                prim = (uint32_t)(tu_next(&r) % s->ntris);
        }
        textured += s->mats[s->tri_mat[prim]].tex_kd >= 0;
        q[4 * i] = prim;
        memcpy(&q[4 * i + 1], &bu, 4);
        memcpy(&q[4 * i + 2], &bv, 4);
        q[4 * i + 3] = 0;
    }
    pgi__gpu_buffer *qb = NULL, *rb = NULL;
    TU_CHECK_OK(pgi__gpu_buffer_reserve(g_gpu, &qb, n * 16, "test"));
    TU_CHECK_OK(pgi__gpu_buffer_reserve(g_gpu, &rb, n * 48, "test"));
    TU_CHECK_OK(pgi__gpu_upload(g_gpu, qb, 0, q, n * 16));
    pgi__gpu_buffer *b[PGI__GPU_SCENE_NBUF + 2];
    pgi__gpu_scene_buffers(gs, b);
    b[PGI__GPU_SCENE_NBUF] = qb;
    b[PGI__GPU_SCENE_NBUF + 1] = rb;
    pgi__gpu_scene_info(gs, &push.scene);
    push.count = (uint32_t)n;
    TU_CHECK_OK(pgi__gpu_begin(g_gpu));
    TU_CHECK_OK(pgi__gpu_dispatch(g_gpu, k, b, &push, (uint32_t)(n + 63) / 64, 1, 1));
    TU_CHECK_OK(pgi__gpu_submit_wait(g_gpu));
    TU_CHECK_OK(pgi__gpu_download(g_gpu, rb, 0, res, n * 48));
    size_t bad = 0;
    double worst = 0.0;
    for (size_t i = 0; i < n; i++) {
        float bu, bv;
        memcpy(&bu, &q[4 * i + 1], 4);
        memcpy(&bv, &q[4 * i + 2], 4);
        pgi__surface sf;
        pgi__scene_surface(s, q[4 * i], bu, bv, v3(0.f, 0.f, 0.f), &sf);
        const float want[9] = {sf.ng.x, sf.ng.y, sf.ng.z, sf.ns.x, sf.ns.y, sf.ns.z, sf.kd.x, sf.kd.y, sf.kd.z};
        const float got[9] = {res[12 * i],     res[12 * i + 1], res[12 * i + 2], res[12 * i + 4], res[12 * i + 5],
                              res[12 * i + 6], res[12 * i + 8], res[12 * i + 9], res[12 * i + 10]};
        int ok = 1;
        for (int c = 0; c < 9; c++) {
            double e = fabs((double)got[c] - (double)want[c]);
            if (e > worst) worst = e;
            if (!(e <= 1e-5 + 1e-5 * fabs((double)want[c]))) ok = 0;
        }
        if (!ok && bad++ < 3)
            fprintf(stderr, "  hit %zu (tri %u): GPU ns %g %g %g kd %g %g %g, CPU ns %g %g %g kd %g %g %g\n", i,
                    q[4 * i], got[3], got[4], got[5], got[6], got[7], got[8], want[3], want[4], want[5], want[6],
                    want[7], want[8]);
    }
    fprintf(stderr, "  %-8s %zu hits (%zu textured): %zu differ beyond 1e-5, largest difference %.3g\n", what, n,
            textured, bad, worst);
    assert_int_equal(bad, 0);
    /* the memory entries */
    pgi_named_value m[32];
    int nm = pgi__gpu_memory(g_gpu, m, 32), seen = 0;
    for (int i = 0; i < nm; i++) seen += strcmp(m[i].name, "gpu_scene") == 0 || strcmp(m[i].name, "gpu_textures") == 0;
    assert_int_equal(seen, 2);
    pgi__gpu_buffer_destroy(g_gpu, qb);
    pgi__gpu_buffer_destroy(g_gpu, rb);
    pgi__gpu_kernel_destroy(g_gpu, k);
    pgi__gpu_scene_destroy(gs);
    free(q);
    free(res);
}

static void test_scene_upload(void **state) {
    (void)state;
    const char *names[] = {"cornell", "cutout", "window-box"};
    for (int i = 0; i < 3; i++) {
        pgi_scene *s = NULL;
        TU_CHECK_OK(pgi_scene_load(names[i], &s));
        check_surfaces(s, names[i]);
        pgi_scene_destroy(s);
    }
    pgi_scene *s = load_sibenik();
    if (s) {
        assert_true(s->ntexs > 0);
        check_surfaces(s, "sibenik");
        pgi_scene_destroy(s);
    }
}

/* An environment map is refused by name. */
static void test_scene_refuses_env_map(void **state) {
    (void)state;
    pgi_scene *s = NULL;
    TU_CHECK_OK(pgi_scene_load("cornell", &s));
    pgi__env fake = {0};
    float px[3] = {1.f, 1.f, 1.f};
    fake.rgb = px;
    fake.w = fake.h = 1;
    snprintf(fake.path, sizeof fake.path, "%s", "sky.hdr");
    s->env = &fake;
    pgi__gpu_scene *gs = NULL;
    assert_int_equal(pgi__gpu_scene_create(g_gpu, s, &gs), PGI_ERR_UNSUPPORTED);
    assert_null(gs);
    assert_non_null(strstr(pgi_last_error(), "environment map"));
    s->env = NULL;
    pgi_scene_destroy(s);
}

/* lavapipe keeps one global block it never frees; keep the driver loaded under ASan (test_gpu.c). */
static void keep_lavapipe_loaded(void) {
#if defined(__SANITIZE_ADDRESS__)
    (void)dlopen("libvulkan_lvp.so", RTLD_NOW | RTLD_NODELETE);
#endif
}

int main(void) {
    keep_lavapipe_loaded();
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_scene_upload),
        cmocka_unit_test(test_scene_refuses_env_map),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
