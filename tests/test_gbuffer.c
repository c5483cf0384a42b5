/* The G-buffer of a frame does not depend on the frames before it: the view pass skips the rows
 * of the planes that hold their defaults already (pgi__view_fill), so a buffer reused across
 * frames -- other cameras, other sizes, rows that flip between defaults (Lambertian, primary,
 * no emitter) and not (glossy, behind a mirror or glass, an emitter, the sky) -- must hold the
 * bytes a fresh one gets, and so must the image composited from it. */
#include "test_util.h"
#include "view/view.h"

static char g_dir[512], g_json[700];

/* tu_write_room's room, with the sky around it. */
static int setup(void **state) {
    (void)state;
    tu_make_tmpdir(g_dir, sizeof g_dir);
    return tu_write_room(g_dir, "\"sky\": {\"color\": [0.2, 0.3, 0.5]}", g_json, sizeof g_json);
}

static int teardown(void **state) {
    (void)state;
    tu_rm_tmpdir(g_dir);
    return 0;
}

/* Frames in turn: the room, the mirror up close, the lamp, the sky, the glossy floor, the room
 * through the glass. */
static const pgi_camera_def k_views[] = {
    {{-0.3f, 1.1f, 3.2f}, {0.1f, 0.8f, -1.f}, {0.f, 1.f, 0.f}, 50.f},
    {{0.2f, 1.f, 0.2f}, {0.f, 1.f, -1.f}, {0.f, 1.f, 0.f}, 60.f},
    {{0.f, 0.5f, 0.f}, {0.f, 2.f, 0.f}, {0.f, 0.f, -1.f}, 70.f},
    {{0.f, 1.f, 3.f}, {0.f, 1.f, 6.f}, {0.f, 1.f, 0.f}, 40.f},
    {{-0.5f, 1.5f, 0.5f}, {0.f, 0.f, 0.f}, {0.f, 1.f, 0.f}, 45.f},
    {{0.35f, 0.3f, 1.5f}, {0.35f, 0.3f, 0.f}, {0.f, 1.f, 0.f}, 35.f},
};
#define NVIEWS (sizeof k_views / sizeof k_views[0])

/* The planes of a and b hold the same bytes. */
static void same_samples(const pgi_view_samples *a, const pgi_view_samples *b, const char *what) {
    assert_int_equal(a->width, b->width);
    assert_int_equal(a->height, b->height);
    const size_t n = a->count;
    const float *pa[] = {a->pos, a->nrm, a->ngeo, a->wo, a->kd, a->ks, a->weight};
    const float *pb[] = {b->pos, b->nrm, b->ngeo, b->wo, b->kd, b->ks, b->weight};
    static const char *const names[] = {"pos", "nrm", "ngeo", "wo", "kd", "ks", "weight"};
    for (int k = 0; k < 7; k++)
        if (memcmp(pa[k], pb[k], 3 * n * sizeof(float)) != 0) fail_msg("%s: plane %s differs", what, names[k]);
    if (memcmp(a->shininess, b->shininess, n * sizeof(float))) fail_msg("%s: plane shininess differs", what);
    if (memcmp(a->ior, b->ior, n * sizeof(float))) fail_msg("%s: plane ior differs", what);
    if (memcmp(a->depth, b->depth, n * sizeof(float))) fail_msg("%s: plane depth differs", what);
    if (memcmp(a->flags, b->flags, n)) fail_msg("%s: plane flags differs", what);
}

/* pgi__view_build into buffers kept across frames with a pgi__view_fill, against fresh buffers
 * without one, and pgi__direct with the record against it without; the record must both skip
 * rows and not skip others for the test to mean much. */
static void test_view_build_reuse(void **state) {
    (void)state;
    pgi_scene *sc = tu_scene(g_json);
    pgi__rt *rt = NULL;
    TU_CHECK_OK(pgi__rt_create(sc, &rt));
    static const int sizes[][2] = {{72, 56}, {72, 56}, {40, 30}, {72, 56}, {64, 48}, {64, 48}};
    pgi_view_samples kept = {0};
    float *kept_emit = NULL;
    pgi__view_fill fill = {0};
    size_t skipped = 0, written = 0;
    int frame = 0;
    for (int pass = 0; pass < 2; pass++)
        for (size_t v = 0; v < NVIEWS; v++, frame++) {
            const int W = sizes[frame % 6][0], H = sizes[frame % 6][1];
            if (kept.width != W || kept.height != H) {
                /* the renderer's order: the record forgets what a reallocated buffer held */
                pgi__view_fill_forget(&fill);
                pgi_view_samples_free(&kept);
                free(kept_emit);
                TU_CHECK_OK(pgi_view_samples_alloc(&kept, W, H));
                kept_emit = malloc(3 * kept.count * sizeof(float));
                assert_non_null(kept_emit);
                /* garbage, not zeros: nothing may pass for a default that was not written */
                for (size_t i = 0; i < 3 * kept.count; i++) kept_emit[i] = kept.weight[i] = kept.ks[i] = -0.f;
                for (size_t i = 0; i < kept.count; i++) kept.shininess[i] = kept.ior[i] = -0.f;
            }
            pgi_camera cam;
            const pgi_camera_def *cd = &k_views[v];
            pgi_camera_look_at(&cam, cd->eye, cd->look_at, cd->up, cd->fov_y_deg, W, H);
            const pgi__subpixel sp = {.jitter = pass, .seed = 5, .index = (uint32_t)frame};
            uint64_t rays = 0;
            size_t before = 0;
            if (fill.rows && fill.width == W && fill.height == H)
                for (size_t e = 0; e < (size_t)fill.height * (size_t)fill.cols; e++) before += fill.rows[e] != 0;
            TU_CHECK_OK(pgi__view_build(sc, rt, NULL, &cam, 3, &sp, 2, &kept, kept_emit, &fill, &rays));
            pgi_view_samples fresh;
            TU_CHECK_OK(pgi_view_samples_alloc(&fresh, W, H));
            float *fresh_emit = malloc(3 * fresh.count * sizeof(float));
            assert_non_null(fresh_emit);
            TU_CHECK_OK(pgi__view_build(sc, rt, NULL, &cam, 3, &sp, 1, &fresh, fresh_emit, NULL, &rays));
            char what[64];
            snprintf(what, sizeof what, "frame %d (view %zu, %dx%d)", frame, v, W, H);
            same_samples(&kept, &fresh, what);
            if (memcmp(kept_emit, fresh_emit, 3 * fresh.count * sizeof(float)) != 0) fail_msg("%s: emit differs", what);
            /* every entry says what its row holds */
            for (int y = 0; y < H; y++)
                for (int c = 0; c < fill.cols; c++) {
                    const unsigned f = fill.rows[(size_t)y * (size_t)fill.cols + (size_t)c];
                    for (int x = c * PGI__FILL_W; x < W && x < (c + 1) * PGI__FILL_W; x++) {
                        const size_t i = (size_t)y * (size_t)W + (size_t)x;
                        for (int q = 0; q < 3; q++) {
                            if (f & PGI__FILL_WEIGHT) assert_true(kept.weight[3 * i + q] == 1.f);
                            if (f & PGI__FILL_EMIT)
                                assert_true(kept_emit[3 * i + q] == 0.f && !signbit(kept_emit[3 * i + q]));
                            if (f & PGI__FILL_LOBE)
                                assert_true(kept.ks[3 * i + q] == 0.f && !signbit(kept.ks[3 * i + q]));
                        }
                        if (f & PGI__FILL_LOBE) {
                            assert_true(kept.shininess[i] == 0.f && !signbit(kept.shininess[i]));
                            assert_true(kept.ior[i] == 0.f && !signbit(kept.ior[i]));
                        }
                    }
                }
            /* direct light reads the weights the record does not know to be 1 */
            float *dk = malloc(3 * fresh.count * sizeof(float)), *df = malloc(3 * fresh.count * sizeof(float));
            assert_true(dk && df);
            TU_CHECK_OK(pgi__direct(sc, rt, &kept, &fill, NULL, 4, 9, 2, dk, &rays));
            TU_CHECK_OK(pgi__direct(sc, rt, &fresh, NULL, NULL, 4, 9, 1, df, &rays));
            if (memcmp(dk, df, 3 * fresh.count * sizeof(float)) != 0) fail_msg("%s: direct light differs", what);
            free(dk);
            free(df);
            skipped += before;
            written += (size_t)H * (size_t)fill.cols - before;
            free(fresh_emit);
            pgi_view_samples_free(&fresh);
        }
    fprintf(stderr, "  rows that held defaults before their frame: %zu, the others: %zu\n", skipped, written);
    assert_true(skipped > 0 && written > 0);
    pgi__view_fill_free(&fill);
    free(kept_emit);
    pgi_view_samples_free(&kept);
    pgi__rt_destroy(rt);
    pgi_scene_destroy(sc);
}

/* One renderer over a sequence of cameras and sizes against a fresh renderer at each: the same
 * view samples (pgi_renderer_prepare) and the same image (the composite reads the record). */
static void test_renderer_reuse(void **state) {
    (void)state;
    pgi_scene *sc = tu_scene(g_json);
    pgi_renderer *kept = tu_renderer(sc);
    static const int sizes[][2] = {{80, 48}, {80, 48}, {33, 21}, {80, 48}};
    static const pgi_output outputs[] = {PGI_OUTPUT_ALL, PGI_OUTPUT_DIRECT, PGI_OUTPUT_INDIRECT};
    pgi_estimator *est = NULL;
    TU_CHECK_OK(pgi_estimator_create("cluster-trivial", &(pgi_estimator_desc){0}, &est));
    pgi_image a = {0}, b = {0};
    int frame = 0;
    for (int pass = 0; pass < 2; pass++)
        for (size_t v = 0; v < NVIEWS; v++, frame++) {
            pgi_render_desc d = {.estimator = "cluster-trivial",
                                 .width = sizes[frame % 4][0],
                                 .height = sizes[frame % 4][1],
                                 .photons = 3000,
                                 .radius = 0.1f,
                                 .threads = 2,
                                 .seed = 11,
                                 .view = &k_views[v],
                                 .output = outputs[(frame + pass) % 3]};
            char what[64];
            snprintf(what, sizeof what, "frame %d (view %zu)", frame, v);
            pgi_frame_inputs in_kept, in_fresh;
            pgi_renderer *fresh = tu_renderer(sc);
            TU_CHECK_OK(pgi_renderer_prepare(kept, &d, &in_kept, NULL));
            TU_CHECK_OK(pgi_renderer_prepare(fresh, &d, &in_fresh, NULL));
            same_samples(in_kept.samples, in_fresh.samples, what);
            pgi_renderer_destroy(fresh);
            /* the indirect image is the weight times the estimate, whatever the composite skips */
            const size_t nf = 3 * (size_t)d.width * (size_t)d.height;
            float *expect = malloc(nf * sizeof(float));
            assert_non_null(expect);
            pgi_estimate_args ea = {.photons = in_kept.photons,
                                    .samples = in_kept.samples,
                                    .camera = &in_kept.camera,
                                    .out_rgb = expect,
                                    .radius = in_kept.radius,
                                    .seed = in_kept.seed,
                                    .threads = d.threads,
                                    .scene_area = in_kept.scene_area};
            TU_CHECK_OK(pgi_estimator_build(est, &ea));
            TU_CHECK_OK(pgi_estimator_estimate(est, &ea));
            for (size_t i = 0; i < nf; i++) expect[i] *= in_kept.samples->weight[i];
            /* the next camera's frame in the same renderer, then this one's: its image */
            const pgi_camera_def *next = &k_views[(v + 1) % NVIEWS];
            pgi_render_desc dn = d;
            dn.view = next;
            TU_CHECK_OK(pgi_renderer_render(kept, &dn, &a, NULL));
            TU_CHECK_OK(pgi_renderer_render(kept, &d, &a, NULL));
            TU_CHECK_OK(pgi_render(sc, &d, &b, NULL));
            assert_int_equal(a.width, b.width);
            if (memcmp(a.rgb, b.rgb, 3 * (size_t)a.width * (size_t)a.height * sizeof(float)) != 0)
                fail_msg("%s: image differs", what);
            if (d.output == PGI_OUTPUT_INDIRECT && memcmp(a.rgb, expect, nf * sizeof(float)) != 0)
                fail_msg("%s: the indirect image is not weight x estimate", what);
            /* the lamp seen straight on: its emission (Ke 20) is in the image */
            if (v == 2 && d.output != PGI_OUTPUT_INDIRECT) assert_true(tu_max_abs(a.rgb, nf) >= 20.0);
            free(expect);
        }
    pgi_image_free(&a);
    pgi_image_free(&b);
    pgi_estimator_destroy(est);
    pgi_renderer_destroy(kept);
    pgi_scene_destroy(sc);
}

TU_MAIN("gbuffer", setup, teardown, cmocka_unit_test(test_view_build_reuse), cmocka_unit_test(test_renderer_reuse))
