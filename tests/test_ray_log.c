/* Ray capture and replay (src/rt/ray_log.h, photongi-bench --limits): a
 * captured frame holds exactly the rays each pass counted, capturing changes
 * no pixel, packets keep their lanes, and every replay style casts every ray
 * and agrees with the captured answers (exactly when cast as captured). */
#include "test_util.h"

#include "pipeline/pipeline.h"
#include "rt/ray_log.h"

static pgi_scene *g_scene;

/* The built-in Cornell box with a moving ball and a mirror box: two Embree
 * geometries, an area light (16 shadow rays per sample) and specular eye
 * paths (single rays in the view pass). */
static int setup(void **state) {
    if (pgi_scene_load("scenes/cornell-moving.json", &g_scene) != PGI_OK) {
        fprintf(stderr, "cannot load cornell-moving: %s\n", pgi_last_error());
        return -1;
    }
    return 0;
}

static int teardown(void **state) {
    pgi_scene_destroy(g_scene);
    return 0;
}

/* 50x30: rows end in a partial packet (invalid lanes). */
static const pgi_render_desc k_desc =
    {.estimator = "hashgrid", .width = 50, .height = 30, .photons = 4000, .radius = 0.08f, .seed = 5, .threads = 2};

static uint64_t pass_rays(const pgi__ray_log *log, pgi__pass p) {
    uint64_t n = 0;
    for (int k = 0; k < PGI__RAY_KIND_COUNT; k++) n += pgi__ray_log_rays(log, p, (pgi__ray_kind)k);
    return n;
}

static void capture(pgi_renderer *r, const pgi_render_desc *d, pgi__ray_log *log, pgi_image *img, pgi_frame_stats *fs) {
    pgi__rt_capture_set(pgi__renderer_rt(r), log);
    TU_CHECK_OK(pgi_renderer_render(r, d, img, fs));
    pgi__rt_capture_set(pgi__renderer_rt(r), NULL);
    TU_CHECK_OK(pgi__ray_log_merge(log));
    assert_int_equal(pgi__ray_log_dropped(log), 0);
}

static void test_capture_matches_passes(void **state) {
    pgi_renderer *r;
    TU_CHECK_OK(pgi_renderer_create(g_scene, &r));
    pgi_image plain = {0}, img = {0};
    pgi_frame_stats ps, fs;
    TU_CHECK_OK(pgi_renderer_render(r, &k_desc, &plain, &ps));
    pgi__ray_log *log;
    TU_CHECK_OK(pgi__ray_log_create(&log));
    capture(r, &k_desc, log, &img, &fs);
    /* Capturing changes nothing. */
    assert_memory_equal(plain.rgb, img.rgb, 3 * (size_t)k_desc.width * k_desc.height * sizeof(float));
    /* Each pass's rays, as it counted them; nothing outside the passes. */
    assert_int_equal(pass_rays(log, PGI__PASS_VIEW), fs.primary_rays);
    assert_int_equal(pass_rays(log, PGI__PASS_TRACE), fs.photon_rays);
    assert_int_equal(pass_rays(log, PGI__PASS_DIRECT), fs.shadow_rays);
    assert_int_equal(pass_rays(log, PGI__PASS_NONE), 0);
    assert_true(fs.shadow_rays > 0 && fs.photon_rays > 0);
    /* Primary packets: one per 4x4-pixel tile, every lane recorded, lanes in order. */
    const pgi__ray_rec *R;
    const size_t packets = (size_t)((k_desc.height + 3) / 4) * ((k_desc.width + 3) / 4);
    assert_int_equal(pgi__ray_log_group(log, PGI__PASS_VIEW, PGI__RAY_INTERSECT16, &R), 16 * packets);
    assert_int_equal(pgi__ray_log_rays(log, PGI__PASS_VIEW, PGI__RAY_INTERSECT16), k_desc.width * k_desc.height);
    for (size_t i = 0; i < 16 * packets; i++) {
        assert_int_equal(R[i].packet, i / 16);
        assert_int_equal(R[i].lane, i % 16);
        assert_true(R[i].flags & PGI__RAY_COHERENT);
        assert_int_equal(R[i].kind, PGI__RAY_INTERSECT16);
        assert_int_equal(R[i].pass, PGI__PASS_VIEW);
    }
    /* The mirror box: specular eye rays as single rays; hits on both geometries. */
    assert_true(pgi__ray_log_rays(log, PGI__PASS_VIEW, PGI__RAY_INTERSECT1) > 0);
    assert_int_equal(pgi__ray_log_rays(log, PGI__PASS_VIEW, PGI__RAY_INTERSECT1) + k_desc.width * k_desc.height,
                     fs.primary_rays);
    int geoms = 0;
    size_t n = pgi__ray_log_group(log, PGI__PASS_TRACE, PGI__RAY_INTERSECT16, &R);
    for (size_t i = 0; i < n; i++)
        if (R[i].geom != PGI__RAY_NO_GEOM) geoms |= 1 << R[i].geom;
    assert_int_equal(geoms, 3);

    /* Replays: every style casts every ray; as captured, every answer is the same. */
    const pgi__rt *rt = pgi__renderer_rt(r);
    for (int p = PGI__PASS_VIEW; p < PGI__PASS_COUNT; p++)
        for (int k = 0; k < PGI__RAY_KIND_COUNT; k++) {
            uint64_t rays = pgi__ray_log_rays(log, (pgi__pass)p, (pgi__ray_kind)k);
            if (!rays) continue;
            for (int m = 0; m < PGI__REPLAY_METHOD_COUNT; m++) {
                if (!pgi__rt_replay_supported(rt, (pgi__replay_method)m)) continue;
                pgi__replay_result rr;
                TU_CHECK_OK(pgi__rt_replay(rt, log, (pgi__pass)p, (pgi__ray_kind)k, (pgi__replay_method)m, 2, &rr));
                assert_int_equal(rr.rays, rays);
                if (rays > 100) assert_true(rr.hits > 0);
                assert_true(rr.ms >= 0.0);
                if (m == PGI__REPLAY_CAST) assert_int_equal(rr.mismatches, 0);
                /* Other kernels may split ties on shared edges otherwise. */
                else if (rr.mismatches * 100 > rays)
                    fail_msg("%s/%s as %s: %llu of %llu answers differ",
                             p == 1   ? "view"
                             : p == 2 ? "trace"
                                      : "direct",
                             pgi__ray_kind_name((pgi__ray_kind)k), pgi__replay_method_name((pgi__replay_method)m),
                             (unsigned long long)rr.mismatches, (unsigned long long)rays);
            }
        }

    /* Off again: nothing more is recorded. */
    uint64_t before = pass_rays(log, PGI__PASS_TRACE);
    TU_CHECK_OK(pgi_renderer_render(r, &k_desc, &img, &fs));
    TU_CHECK_OK(pgi__ray_log_merge(log));
    assert_int_equal(pass_rays(log, PGI__PASS_TRACE), before);
    /* A second captured frame adds its rays (as it counted them: the tracer sizes a frame's
       batches from the frame before, so the paths it traces past the last one taken, and
       their rays, may differ from frame to frame; its photons do not). */
    capture(r, &k_desc, log, &img, &fs);
    assert_int_equal(pass_rays(log, PGI__PASS_TRACE), before + fs.photon_rays);
    assert_memory_equal(plain.rgb, img.rgb, 3 * (size_t)k_desc.width * k_desc.height * sizeof(float));
    pgi__ray_log_clear(log);
    TU_CHECK_OK(pgi__ray_log_merge(log));
    assert_int_equal(pass_rays(log, PGI__PASS_TRACE), 0);

    pgi__ray_log_destroy(log);
    pgi_image_free(&plain);
    pgi_image_free(&img);
    pgi_renderer_destroy(r);
}

/* More threads than cores, a log per thread count: the same rays whatever
 * the thread count (the order differs), one buffer per thread. */
static void test_capture_threads(void **state) {
    uint64_t ref[PGI__PASS_COUNT] = {0}, hits_ref = 0;
    const int threads[] = {1, 3, 8};
    for (size_t t = 0; t < sizeof threads / sizeof threads[0]; t++) {
        /* A fresh renderer each time: the photon batches follow the yield of the renderer's
         * last frame, so the paths traced (not the photons) depend on its history. */
        pgi_renderer *r;
        TU_CHECK_OK(pgi_renderer_create(g_scene, &r));
        pgi_render_desc d = k_desc;
        d.threads = threads[t];
        pgi__ray_log *log;
        TU_CHECK_OK(pgi__ray_log_create(&log));
        pgi_image img = {0};
        pgi_frame_stats fs;
        capture(r, &d, log, &img, &fs);
        pgi__replay_result rr;
        TU_CHECK_OK(pgi__rt_replay(pgi__renderer_rt(r), log, PGI__PASS_DIRECT, PGI__RAY_OCCLUDED16, PGI__REPLAY_CAST,
                                   threads[t], &rr));
        assert_int_equal(rr.mismatches, 0);
        for (int p = 0; p < PGI__PASS_COUNT; p++) {
            if (t == 0) ref[p] = pass_rays(log, (pgi__pass)p);
            else assert_int_equal(pass_rays(log, (pgi__pass)p), ref[p]);
        }
        if (t == 0) hits_ref = rr.hits;
        else assert_int_equal(rr.hits, hits_ref);
        pgi__ray_log_destroy(log);
        pgi_image_free(&img);
        pgi_renderer_destroy(r);
    }
}

TU_MAIN("ray_log", setup, teardown, cmocka_unit_test(test_capture_matches_passes),
        cmocka_unit_test(test_capture_threads))
