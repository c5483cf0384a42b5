/* Same seed, same bytes, whatever the thread count (docs/design.md, "Determinism"); a
 * different seed gives a different image. */
#include "core/core.h"
#include "test_util.h"
#include "test_vertex_colours.h"

static pgi_scene *g_scene;
static pgi_jitter g_jitter; /* sub-pixel positions of the frames rendered */

static int setup(void **state) {
    if (pgi_scene_load("cornell", &g_scene) != PGI_OK) {
        fprintf(stderr, "cannot load cornell: %s\n", pgi_last_error());
        return -1;
    }
    return 0;
}

static int teardown(void **state) {
    pgi_scene_destroy(g_scene);
    return 0;
}

static void render(const char *est, int size, uint32_t photons, int threads, uint64_t seed, pgi_image *img,
                   pgi_frame_stats *fs) {
    pgi_render_desc d = {.estimator = est,
                         .width = size,
                         .height = size,
                         .photons = photons,
                         .radius = 0.08f,
                         .threads = threads,
                         .seed = seed,
                         .jitter = g_jitter};
    TU_CHECK_OK(pgi_render(g_scene, &d, img, fs));
    assert_int_equal(img->width, size);
    assert_int_equal(img->height, size);
}

static void same_bytes(const char *est, int size, uint32_t photons) {
    const int threads[] = {1, 2, 8};
    pgi_image ref = {0};
    pgi_frame_stats rs;
    render(est, size, photons, threads[0], 42, &ref, &rs);
    size_t bytes = 3 * (size_t)size * size * sizeof(float);
    assert_true(rs.contributing > 0);
    assert_true(tu_max_abs(ref.rgb, 3 * (size_t)size * size) > 0.0);
    for (size_t k = 1; k < sizeof threads / sizeof threads[0]; k++) {
        pgi_image img = {0};
        pgi_frame_stats fs;
        render(est, size, photons, threads[k], 42, &img, &fs);
        assert_int_equal(fs.threads, threads[k]);
        if (memcmp(img.rgb, ref.rgb, bytes) != 0) {
            size_t first = 0;
            while (first < 3 * (size_t)size * size && memcmp(&img.rgb[first], &ref.rgb[first], sizeof(float)) == 0)
                first++;
            fail_msg("%s: %d threads differ from 1 thread (first at float %zu: %.9g vs %.9g)", est, threads[k], first,
                     (double)img.rgb[first], (double)ref.rgb[first]);
        }
        assert_int_equal(fs.photons_stored, rs.photons_stored);
        assert_int_equal(fs.photons_emitted, rs.photons_emitted);
        assert_int_equal(fs.contributing, rs.contributing);
        assert_int_equal(fs.reads, rs.reads);
        pgi_image_free(&img);
    }
    /* Another seed: other photons, other image. */
    pgi_image other = {0};
    pgi_frame_stats os;
    render(est, size, photons, 2, 43, &other, &os);
    assert_true(memcmp(other.rgb, ref.rgb, bytes) != 0);
    pgi_image_free(&other);
    pgi_image_free(&ref);
}

static void test_tiled(void **state) { same_bytes("tiled", 64, 20000); }
static void test_hashgrid(void **state) { same_bytes("hashgrid", 64, 20000); }
static void test_brute(void **state) { same_bytes("brute", 32, 4000); }

/* Jittered view samples (a point per pixel from the seed): still the same
 * bytes at any thread count, and not the image of pixel centres. bounds25d
 * finds the samples by projecting photon bounds onto the screen. */
static void test_jittered(void **state) {
    g_jitter = PGI_JITTER_ON;
    same_bytes("tiled", 64, 20000);
    same_bytes("bounds25d", 48, 10000);
    pgi_image on = {0}, off = {0};
    pgi_frame_stats fs;
    render("tiled", 48, 5000, 2, 42, &on, &fs);
    g_jitter = PGI_JITTER_AUTO;
    render("tiled", 48, 5000, 2, 42, &off, &fs);
    assert_true(memcmp(on.rgb, off.rgb, 3 * 48 * 48 * sizeof(float)) != 0);
    pgi_image_free(&on);
    pgi_image_free(&off);
}

/* The renderer keeps buffers between frames: a second frame with the same
 * settings is the same image as the first, and as a fresh renderer's. */
static void test_renderer_reuse(void **state) {
    pgi_renderer *r;
    TU_CHECK_OK(pgi_renderer_create(g_scene, &r));
    pgi_render_desc big =
        {.estimator = "tiled", .width = 64, .height = 64, .photons = 20000, .radius = 0.08f, .seed = 9};
    pgi_render_desc small = big;
    small.width = 40, small.height = 24, small.photons = 5000, small.estimator = "hashgrid";
    pgi_image a = {0}, b = {0}, c = {0}, fresh = {0};
    TU_CHECK_OK(pgi_renderer_render(r, &big, &a, NULL));
    TU_CHECK_OK(pgi_renderer_render(r, &small, &b, NULL));
    TU_CHECK_OK(pgi_renderer_render(r, &big, &c, NULL));
    TU_CHECK_OK(pgi_render(g_scene, &big, &fresh, NULL));
    size_t bytes = 3 * 64 * 64 * sizeof(float);
    assert_memory_equal(a.rgb, c.rgb, bytes);
    assert_memory_equal(a.rgb, fresh.rgb, bytes);
    pgi_image_free(&a);
    pgi_image_free(&b);
    pgi_image_free(&c);
    pgi_image_free(&fresh);
    pgi_renderer_destroy(r);
}

/* The narrow (SSE), AVX2 and AVX-512 builds picked at run time (view directions, surfaces,
 * uniform tiles and texel lookups, the cluster family's subtree and top passes) give the same
 * bytes: renders with pgi__cpu_narrow and pgi__cpu_no512 on and off, at sizes that leave partial
 * tiles and blocks. On a CPU without AVX2 (AVX-512F) those sides take the narrower builds. */
static void narrow_vs_wide(pgi_scene *sc, const char *est, int w, int h, uint32_t photons) {
#if defined(__x86_64__) || defined(__i386__)
    pgi_render_desc d = {.estimator = est, .width = w, .height = h, .photons = photons, .threads = 2, .seed = 5};
    pgi_image wide = {0}, narrow = {0}, avx2 = {0};
    pgi_frame_stats fw, fn, f2;
    TU_CHECK_OK(pgi_render(sc, &d, &wide, &fw));
    pgi__cpu_narrow = 1;
    pgi_status st = pgi_render(sc, &d, &narrow, &fn);
    pgi__cpu_narrow = 0;
    TU_CHECK_OK(st);
    pgi__cpu_no512 = 1;
    st = pgi_render(sc, &d, &avx2, &f2);
    pgi__cpu_no512 = 0;
    TU_CHECK_OK(st);
    assert_true(fw.contributing > 0);
    if (memcmp(wide.rgb, narrow.rgb, 3 * (size_t)w * h * sizeof(float)) != 0)
        fail_msg("%s %dx%d: the narrow builds' image differs from the widest builds'", est, w, h);
    if (memcmp(wide.rgb, avx2.rgb, 3 * (size_t)w * h * sizeof(float)) != 0)
        fail_msg("%s %dx%d: the AVX2 builds' image differs from the AVX-512 builds'", est, w, h);
    assert_int_equal(fw.nodes_visited, fn.nodes_visited);
    assert_int_equal(fw.reads, fn.reads);
    assert_int_equal(fw.reads, f2.reads);
    pgi_image_free(&wide);
    pgi_image_free(&narrow);
    pgi_image_free(&avx2);
#else
    (void)sc, (void)est, (void)w, (void)h, (void)photons;
#endif
}

static void test_narrow_builds(void **state) {
    narrow_vs_wide(g_scene, "cluster-trivial", 203, 117, 20000);
    narrow_vs_wide(g_scene, "directional", 75, 61, 10000);
    pgi_scene *sc = tu_scene("cornell-mirrors");
    narrow_vs_wide(sc, "cluster", 97, 66, 20000);
    pgi_scene_destroy(sc);
    /* vertex colours (the uniform tiles' and the lane path's kd, the photon tracer's) */
    TU_CHECK_OK(pgi_scene_load("cornell", &sc));
    tu_add_vertex_colours(sc);
    narrow_vs_wide(sc, "cluster-trivial", 203, 117, 20000);
    pgi_scene_destroy(sc);
    /* Sibenik's textures (colour texels through the AVX2 footprints), where the scenes are */
    char mesh[1024];
    snprintf(mesh, sizeof mesh, "%s/sibenik/sibenik.obj", tu_scenes_dir());
    if (!tu_file_exists("scenes/sibenik.json") || !tu_file_exists(mesh)) {
        fprintf(stderr, "skipping Sibenik: scenes/sibenik.json or %s not found (set PHOTONGI_SCENES)\n", mesh);
        return;
    }
    TU_CHECK_OK(pgi_scene_load("scenes/sibenik.json", &sc));
    narrow_vs_wide(sc, "cluster-trivial", 322, 181, 50000);
    tu_add_vertex_colours(sc); /* and vertex colours under the textures */
    narrow_vs_wide(sc, "cluster-trivial", 322, 181, 50000);
    pgi_scene_destroy(sc);
}

TU_MAIN("determinism", setup, teardown, cmocka_unit_test(test_tiled), cmocka_unit_test(test_hashgrid),
        cmocka_unit_test(test_brute), cmocka_unit_test(test_jittered), cmocka_unit_test(test_renderer_reuse),
        cmocka_unit_test(test_narrow_builds))
