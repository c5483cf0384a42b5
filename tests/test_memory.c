/* Honest memory (docs/memory.md): the frame stats list every large allocation, a memory budget
 * (pgi_render_desc.max_memory) refuses a frame that cannot fit before it traces anything, naming
 * what does not fit, and the budget never changes the picture. */
#include <time.h>

#include "test_util.h"

static pgi_scene *load(const char *spec) {
    pgi_scene *s = tu_scene(spec);
    return s;
}

static double entry(const pgi_frame_stats *fs, const char *name) {
    for (int i = 0; i < fs->memory_count; i++)
        if (strcmp(fs->memory_bytes[i].name, name) == 0) return fs->memory_bytes[i].value;
    return -1.0;
}

static double total(const pgi_frame_stats *fs) {
    double t = 0.0;
    for (int i = 0; i < fs->memory_count; i++) t += fs->memory_bytes[i].value;
    return t;
}

/* Every entry the renderer owns is listed, with the bytes its buffers have. */
static void test_stats_list_every_allocation(void **state) {
    (void)state;
    pgi_scene *s = load("cornell");
    const int w = 64, h = 48;
    const uint32_t np = 20000;
    const char *ests[] = {"hashgrid", "cluster-trivial", "bvh"};
    for (size_t e = 0; e < sizeof ests / sizeof ests[0]; e++) {
        pgi_render_desc d = {.estimator = ests[e], .photons = np, .width = w, .height = h, .direct_samples = 1};
        pgi_image img = {0};
        pgi_frame_stats fs;
        TU_CHECK_OK(pgi_render(s, &d, &img, &fs));
        const char *names[] = {"scene",         "textures",     "embree_bvh",    "photons",
                               "trace_scratch", "view_samples", "frame_buffers", "image"};
        for (size_t i = 0; i < sizeof names / sizeof names[0]; i++) {
            if (entry(&fs, names[i]) < 0.0) fail_msg("%s: the stats do not list '%s'", ests[e], names[i]);
        }
        assert_true(entry(&fs, "scene") > 0.0);
        assert_true(entry(&fs, "embree_bvh") > 1024.0); /* Embree's memory monitor counted its BVH */
        assert_true(entry(&fs, "photons") == (double)np * 12 * sizeof(float));
        assert_true(entry(&fs, "view_samples") == (double)(w * h) * ((7 * 3 + 3) * sizeof(float) + 1));
        assert_true(entry(&fs, "frame_buffers") == (double)(w * h) * 6 * sizeof(float)); /* emitted, indirect */
        assert_true(entry(&fs, "image") == (double)(w * h) * 3 * sizeof(float));
        assert_true(entry(&fs, "footprints") < 0.0);      /* fixed radius: none */
        assert_true(entry(&fs, "progressive_sum") < 0.0); /* single frame: none */
        assert_true(fs.memory_count > 8);                 /* and the estimator's own entries */
        assert_true(fs.memory_peak_rss > 0);
        assert_true((double)fs.memory_counted_peak >= total(&fs));
        /* the default budget: the machine's memory */
        assert_true(fs.settings.max_memory == pgi_memory_default_budget());
        assert_true(fs.settings.max_memory > 0 && fs.settings.max_memory != PGI_MEMORY_UNLIMITED);
        pgi_image_free(&img);
    }
    pgi_scene_destroy(s);
}

/* Footprints and the progressive accumulator are listed when they are in use. */
static void test_stats_optional_entries(void **state) {
    (void)state;
    pgi_scene *s = load("cornell");
    pgi_render_desc d = {.estimator = "bvh",
                         .photons = 5000,
                         .width = 40,
                         .height = 32,
                         .direct_samples = 1,
                         .radius_policy = PGI_RADIUS_DIFFERENTIALS};
    pgi_renderer *r;
    TU_CHECK_OK(pgi_renderer_create(s, &r));
    pgi_image img = {0};
    pgi_frame_stats fs;
    TU_CHECK_OK(pgi_renderer_render(r, &d, &img, &fs));
    assert_true(entry(&fs, "footprints") == 5000.0 * 7 * sizeof(float));
    d.radius_policy = PGI_RADIUS_FIXED;
    d.estimator = "hashgrid";
    TU_CHECK_OK(pgi_render_progressive(r, &d, 3, &img, &fs));
    /* the finished blocks' sum, the block in progress (doubles) and the average (floats) */
    assert_true(entry(&fs, "progressive_sum") == 40.0 * 32 * 3 * (2 * sizeof(double) + sizeof(float)));
    pgi_image_free(&img);
    pgi_renderer_destroy(r);
    pgi_scene_destroy(s);
}

/* A photon count that cannot fit is refused before tracing, with a message naming the photons,
 * their bytes and how many would fit; the renderer still renders afterwards. */
static void test_budget_refuses_photons(void **state) {
    (void)state;
    pgi_scene *s = load("cornell");
    pgi_renderer *r;
    TU_CHECK_OK(pgi_renderer_create(s, &r));
    pgi_render_desc d = {.estimator = "hashgrid",
                         .photons = PGI_MAX_PHOTONS,
                         .width = 40,
                         .height = 32,
                         .direct_samples = 1,
                         .max_memory = 256u << 20};
    pgi_image img = {0};
    pgi_frame_stats fs;
    double t0 = (double)clock() / CLOCKS_PER_SEC;
    assert_int_equal(pgi_renderer_render(r, &d, &img, &fs), PGI_ERR_OOM);
    double cpu = (double)clock() / CLOCKS_PER_SEC - t0;
    const char *msg = pgi_last_error();
    if (!strstr(msg, "photons: 100000000 photons need") || !strstr(msg, "over the memory budget of 256 MiB") ||
        !strstr(msg, "photons fit") || !strstr(msg, "hashgrid"))
        fail_msg("unclear message: %s", msg);
    assert_true(cpu < 1.0); /* refused up front: nothing traced */
    assert_null(img.rgb);   /* nothing handed out */
    d.photons = 10000;      /* what fits renders */
    TU_CHECK_OK(pgi_renderer_render(r, &d, &img, &fs));
    assert_true(fs.settings.max_memory == 256u << 20);
    /* the same through pgi_renderer_prepare */
    d.photons = PGI_MAX_PHOTONS;
    pgi_frame_inputs in;
    assert_int_equal(pgi_renderer_prepare(r, &d, &in, NULL), PGI_ERR_OOM);
    assert_non_null(strstr(pgi_last_error(), "photons: 100000000 photons need"));
    pgi_image_free(&img);
    pgi_renderer_destroy(r);
    pgi_scene_destroy(s);
}

/* A frame too big without any photon names its largest part. */
static void test_budget_refuses_frame(void **state) {
    (void)state;
    pgi_scene *s = load("cornell");
    pgi_render_desc d = {.photons = 1000, .width = 4096, .height = 4096, .max_memory = 64u << 20};
    pgi_image img = {0};
    assert_int_equal(pgi_render(s, &d, &img, NULL), PGI_ERR_OOM);
    const char *msg = pgi_last_error();
    if (!strstr(msg, "view_samples: the frame needs") || !strstr(msg, "before any photon") ||
        !strstr(msg, "over the memory budget of 64.0 MiB"))
        fail_msg("unclear message: %s", msg);
    assert_null(img.rgb);
    pgi_scene_destroy(s);
}

/* The budget is not part of the picture: the same bits with none, the default and a tight one. */
static void test_budget_keeps_the_image(void **state) {
    (void)state;
    pgi_scene *s = load("cornell");
    pgi_render_desc d = {.estimator = "cluster-trivial", .photons = 20000, .width = 48, .height = 40, .seed = 3};
    pgi_image a = {0}, b = {0}, c = {0};
    pgi_frame_stats fs;
    TU_CHECK_OK(pgi_render(s, &d, &a, &fs));
    d.max_memory = PGI_MEMORY_UNLIMITED;
    TU_CHECK_OK(pgi_render(s, &d, &b, NULL));
    d.max_memory = (uint64_t)(total(&fs) * 2.0);
    TU_CHECK_OK(pgi_render(s, &d, &c, NULL));
    assert_memory_equal(a.rgb, b.rgb, 48 * 40 * 3 * sizeof(float));
    assert_memory_equal(a.rgb, c.rgb, 48 * 40 * 3 * sizeof(float));
    pgi_image_free(&a);
    pgi_image_free(&b);
    pgi_image_free(&c);
    pgi_scene_destroy(s);
}

TU_MAIN("memory", NULL, NULL, cmocka_unit_test(test_stats_list_every_allocation),
        cmocka_unit_test(test_stats_optional_entries), cmocka_unit_test(test_budget_refuses_photons),
        cmocka_unit_test(test_budget_refuses_frame), cmocka_unit_test(test_budget_keeps_the_image))
