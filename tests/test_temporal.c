/* The temporal picture (pgi_temporal, docs/temporal.md): a still camera converges to exactly the
 * progressive average; the reprojection's camera geometry lands on the analytic pixel, with the
 * pictures' sub-pixel offsets (temporal anti-aliasing) as without; a camera
 * move keeps the history of what stays in view and not of what it reveals or of what turns away;
 * a moved light restarts it; the a-trous filter leaves a constant image unchanged and lowers noise
 * without crossing edges; a moving camera's pictures and the filter are the same bytes on 1 and 3
 * threads; bad settings are refused. */
#include "filter/atrous.h"
#include "pipeline/pipeline.h"
#include "test_util.h"

/* Each test's Cornell box and its renderer. */
typedef struct fixture {
    pgi_scene *s;
    pgi_renderer *r;
} fixture;

static int fixture_setup(void **state) {
    fixture *f = calloc(1, sizeof *f);
    if (!f || pgi_scene_load("cornell", &f->s) || pgi_renderer_create(f->s, &f->r)) return -1;
    *state = f;
    return 0;
}

static int fixture_teardown(void **state) {
    fixture *f = *state;
    pgi_renderer_destroy(f->r);
    pgi_scene_destroy(f->s);
    free(f);
    return 0;
}

static pgi_render_desc small_desc(void) {
    return (pgi_render_desc){.photons = 20000, .radius = 0.05f, .width = 48, .height = 36, .threads = 2};
}

/* A still camera: after max(history, filter_frames) steps the picture is the progressive average of
 * as many frames, bit for bit, and the stats say what faded. */
static void test_still_converges_to_progressive(void **state) {
    fixture *f = *state;
    pgi_renderer *r = f->r;
    pgi_temporal *t;
    assert_int_equal(pgi_temporal_create(r, &(pgi_temporal_desc){.history = 6, .filter = 3, .filter_frames = 4}, &t),
                     PGI_OK);
    const pgi_render_desc d = small_desc();
    pgi_image img = {0}, want = {0};
    pgi_frame_stats fs;
    for (int k = 1; k <= 8; k++) {
        assert_int_equal(pgi_temporal_step(t, &d, &img, &fs), PGI_OK);
        assert_int_equal(fs.frames, k);
        assert_int_equal(fs.temporal.on, 1);
        if (k == 1) assert_int_equal(fs.temporal.restarted, 1);
        assert_true(fabsf(fs.temporal.filter_weight - fmaxf(0.f, 1.f - (float)(k - 1) / 4.f)) < 1e-6f);
        assert_int_equal(fs.temporal.filter_passes, k <= 4 ? 3 : 0);
    }
    assert_int_equal(pgi_render_progressive(r, &d, 8, &want, NULL), PGI_OK);
    assert_memory_equal(img.rgb, want.rgb, 3 * 48 * 36 * sizeof(float));
    pgi_image_free(&img);
    pgi_image_free(&want);
    pgi_temporal_destroy(t);
}

/* The camera geometry: a pixel centre's ray projects back onto that pixel; a point one pixel to the
 * right of the axis lands one pixel right of the centre; a camera turned by the angle of k pixels
 * (small) sees a point k pixels over; a point behind the camera does not land. */
static void test_projection_is_analytic(void **state) {
    (void)state;
    pgi_camera c;
    const float eye[3] = {1.f, 2.f, 3.f}, at[3] = {1.f, 2.f, -7.f}, up[3] = {0.f, 1.f, 0.f};
    pgi_camera_look_at(&c, eye, at, up, 60.f, 64, 48);
    for (int y = 0; y < 48; y += 7)
        for (int x = 0; x < 64; x += 5) {
            float d[3], q[3], px, py, z;
            pgi__temporal_pixel_dir(&c, x, y, d);
            for (int k = 0; k < 3; k++) q[k] = eye[k] + 4.5f * d[k];
            assert_int_equal(pgi__temporal_project(&c, q, 0, &px, &py, &z), 1);
            assert_true(fabsf(px - (float)x) < 1e-3f && fabsf(py - (float)y) < 1e-3f && fabsf(z - 4.5f) < 1e-4f);
            assert_int_equal(pgi__temporal_project(&c, d, 1, &px, &py, &z), 1); /* a direction: the sky */
            assert_true(fabsf(px - (float)x) < 1e-3f && fabsf(py - (float)y) < 1e-3f);
        }
    /* turned left by the angle of 3 pixel widths at the centre: the point on the old axis lands 3
       pixels right of the centre (31.5 + 3) */
    const float px_angle = atanf(2.f * tanf(30.f * 3.14159265f / 180.f) / 48.f); /* one pixel at the centre */
    const float a = 3.f * px_angle;
    const float at2[3] = {eye[0] - 10.f * sinf(a), eye[1], eye[2] - 10.f * cosf(a)};
    pgi_camera c2;
    pgi_camera_look_at(&c2, eye, at2, up, 60.f, 64, 48);
    const float q[3] = {eye[0], eye[1], eye[2] - 10.f};
    float px, py, z;
    assert_int_equal(pgi__temporal_project(&c2, q, 0, &px, &py, &z), 1);
    assert_true(fabsf(px - 34.5f) < 0.01f && fabsf(py - 23.5f) < 1e-3f);
    const float behind[3] = {eye[0], eye[1], eye[2] + 5.f};
    assert_int_equal(pgi__temporal_project(&c, behind, 0, &px, &py, &z), 0);
}

/* Temporal anti-aliasing's geometry: the camera slid 2.5 pixels (at the wall's depth) to the left
 * since the last picture, a wall facing it, and this picture's samples offset within their pixels
 * (the Halton points the step takes): a sample's hit, read back in the previous camera less its
 * offset, lands on the analytic place of its pixel's centre there, 2.5 pixels to the right. */
static void test_jitter_lands_on_pixel(void **state) {
    (void)state;
    const float eye[3] = {1.f, 2.f, 3.f}, at[3] = {1.f, 2.f, -7.f}, up[3] = {0.f, 1.f, 0.f}, depth = 10.f;
    pgi_camera c, prev;
    pgi_camera_look_at(&c, eye, at, up, 60.f, 64, 48);
    const float pitch = 2.f * depth * tanf(30.f * 3.14159265f / 180.f) / 48.f; /* a pixel at the wall */
    const float eye0[3] = {eye[0] - 2.5f * pitch, eye[1], eye[2]}, at0[3] = {at[0] - 2.5f * pitch, at[1], at[2]};
    pgi_camera_look_at(&prev, eye0, at0, up, 60.f, 64, 48);
    const float shifts[][2] = {{0.f, 0.f},           {0.25f, -1.f / 6.f}, {-0.25f, 1.f / 6.f},
                               {-0.375f, -0.38888f}, {0.5f, 0.5f},        {-0.5f, -0.5f}};
    for (size_t s = 0; s < sizeof shifts / sizeof shifts[0]; s++)
        for (int y = 0; y < 48; y += 5)
            for (int x = 0; x < 64; x += 7) {
                float q[3], px, py, cx, cy, z;
                pgi__temporal_hit(&c, x, y, shifts[s], depth, q);
                assert_true(fabsf(q[2] - (eye[2] - depth)) < 1e-4f); /* on the wall */
                assert_int_equal(pgi__temporal_land(&prev, q, shifts[s], &px, &py), 1);
                assert_true(fabsf(px - ((float)x + 2.5f)) < 2e-3f && fabsf(py - (float)y) < 2e-3f);
                /* the sample itself lands its offset away from there */
                assert_int_equal(pgi__temporal_project(&prev, q, 0, &cx, &cy, &z), 1);
                assert_true(fabsf(cx - px - shifts[s][0]) < 1e-4f && fabsf(cy - py - shifts[s][1]) < 1e-4f);
            }
}

/* Camera moves on the Cornell box: a small step keeps nearly every pixel's history; a step past
 * the tall box reveals the wall behind it (fewer kept); turned away (looking out of the box's open
 * side at nothing of the previous view) keeps none; a moved light starts the history afresh. */
static void test_moves_and_disocclusion(void **state) {
    fixture *f = *state;
    pgi_scene *s = f->s;
    pgi_renderer *r = f->r;
    pgi_temporal *t;
    assert_int_equal(pgi_temporal_create(r, NULL, &t), PGI_OK);
    pgi_camera_def cam;
    assert_int_equal(pgi_scene_get_camera(s, 0, &cam), PGI_OK);
    pgi_render_desc d = small_desc();
    d.view = &cam;
    pgi_image img = {0};
    pgi_frame_stats fs;
    for (int k = 0; k < 3; k++) assert_int_equal(pgi_temporal_step(t, &d, &img, &fs), PGI_OK);
    pgi_camera_def c1 = cam;
    c1.eye[0] += 0.01f, c1.look_at[0] += 0.01f; /* a small step sideways */
    d.view = &c1;
    assert_int_equal(pgi_temporal_step(t, &d, &img, &fs), PGI_OK);
    assert_int_equal(fs.frames, 1);
    assert_int_equal(fs.temporal.restarted, 0);
    const double small = fs.temporal.reused;
    pgi_camera_def c2 = c1;
    c2.eye[0] += 0.6f, c2.look_at[0] += 0.6f; /* past the tall box: the wall behind it shows */
    d.view = &c2;
    assert_int_equal(pgi_temporal_step(t, &d, &img, &fs), PGI_OK);
    const double big = fs.temporal.reused;
    pgi_camera_def c3 = c2;
    for (int k = 0; k < 3; k++) c3.look_at[k] = 2.f * c3.eye[k] - c2.look_at[k]; /* turned around */
    d.view = &c3;
    assert_int_equal(pgi_temporal_step(t, &d, &img, &fs), PGI_OK);
    const double away = fs.temporal.reused;
    print_message("history kept: small step %.3f, past the box %.3f, turned around %.3f\n", small, big, away);
    assert_true(small > 0.85);
    assert_true(big < small && big > 0.2);
    assert_true(away < 0.05);
    /* a light moved: everything restarts */
    d.view = &c2;
    assert_int_equal(pgi_temporal_step(t, &d, &img, &fs), PGI_OK);
    pgi_light_group lg;
    assert_int_equal(pgi_scene_get_light_group(s, 0, &lg), PGI_OK);
    lg.position[1] -= 0.1f;
    assert_int_equal(pgi_scene_set_light_position(s, 0, lg.position), PGI_OK);
    assert_int_equal(pgi_temporal_step(t, &d, &img, &fs), PGI_OK);
    assert_int_equal(fs.temporal.restarted, 1);
    assert_true(fs.temporal.reused == 0.0);
    pgi_image_free(&img);
    pgi_temporal_destroy(t);
}

/* The a-trous filter: a constant irradiance stays constant (to float rounding) whatever the guides;
 * noise on a plane is lowered; two planes at an edge keep their different values; the same bytes
 * on 1 and 3 threads. */
static void test_atrous(void **state) {
    (void)state;
    enum { W = 40, H = 30, N = W * H };
    float *pl = malloc(19 * N * sizeof(float)); /* pos, nrm, alb (3 planes each), depth, mask, rgb+v, scratch */
    assert_non_null(pl);
    float *pos[3] = {pl, pl + N, pl + 2 * N}, *nrm[3] = {pl + 3 * N, pl + 4 * N, pl + 5 * N},
          *alb[3] = {pl + 6 * N, pl + 7 * N, pl + 8 * N}, *depth = pl + 9 * N, *mask = pl + 10 * N,
          *rgb[4] = {pl + 11 * N, pl + 12 * N, pl + 13 * N, pl + 14 * N}, *scratch = pl + 15 * N, *res[3];
    tu_rng rng = tu_rng_make(9);
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            const size_t p = (size_t)y * W + (size_t)x;
            const int right = x >= W / 2; /* two planes: z = 5 facing +z, and x = 1 facing -x */
            pos[0][p] = right ? 1.f : 0.05f * (float)x;
            pos[1][p] = 0.05f * (float)y;
            pos[2][p] = right ? 5.f - 0.05f * (float)(x - W / 2) : 5.f;
            nrm[0][p] = right ? -1.f : 0.f, nrm[1][p] = 0.f, nrm[2][p] = right ? 0.f : 1.f;
            for (int c = 0; c < 3; c++) alb[c][p] = 0.5f + 0.3f * tu_unif(&rng) * (float)(y % 2);
            depth[p] = pos[2][p];
            mask[p] = (x + 3 * y) % 17 != 0 ? 1.f : 0.f; /* a few holes keep their value */
            for (int c = 0; c < 3; c++) rgb[c][p] = 0.75f;
            rgb[3][p] = -1.f; /* the spatial variance */
        }
    const pgi__atrous_guide g =
        {W, H, {pos[0], pos[1], pos[2]}, {nrm[0], nrm[1], nrm[2]}, {alb[0], alb[1], alb[2]}, depth, mask};
    assert_int_equal(pgi__atrous_filter(&g, 5, 2, rgb, scratch, res), PGI_OK);
    for (int c = 0; c < 3; c++)
        for (size_t i = 0; i < N; i++) assert_true(fabsf(res[c][i] - 0.75f) < 1e-5f);
    /* noise: left plane 1 +- 0.5, right plane 3 +- 0.5; the same albedo everywhere */
    double err_before = 0.0, err_after = 0.0;
    float *want = malloc(N * sizeof(float)), *noisy = malloc(3 * N * sizeof(float)),
          *once = malloc(3 * N * sizeof(float));
    assert_non_null(want && noisy && once);
    for (size_t p = 0; p < N; p++) {
        const int right = (int)(p % W) >= W / 2;
        want[p] = right ? 3.f : 1.f;
        for (int c = 0; c < 3; c++) {
            alb[c][p] = 0.5f;
            noisy[c * N + p] = want[p] + tu_range(&rng, -0.5f, 0.5f);
            err_before += fabs(noisy[c * N + p] - want[p]);
        }
    }
    for (int threads = 1; threads <= 3; threads += 2) {
        for (int c = 0; c < 3; c++) memcpy(rgb[c], noisy + c * N, N * sizeof(float));
        for (size_t p = 0; p < N; p++) rgb[3][p] = -1.f;
        assert_int_equal(pgi__atrous_filter(&g, 4, threads, rgb, scratch, res), PGI_OK);
        if (threads == 1) {
            for (int c = 0; c < 3; c++) memcpy(once + c * N, res[c], N * sizeof(float));
            continue;
        }
        for (int c = 0; c < 3; c++) assert_memory_equal(once + c * N, res[c], N * sizeof(float));
    }
    for (int c = 0; c < 3; c++)
        for (size_t i = 0; i < N; i++) err_after += fabs(res[c][i] - want[i]);
    print_message("a-trous on two noisy planes: mean error %.4f -> %.4f\n", err_before / (3 * N), err_after / (3 * N));
    assert_true(err_after < 0.5 * err_before);
    /* the edge holds: the columns next to it stay on their own side */
    for (int y = 2; y < H - 2; y++) {
        const size_t l = (size_t)y * W + W / 2 - 1, rr = l + 1;
        if (mask[l] > 0.f) assert_true(res[0][l] < 1.6f);
        if (mask[rr] > 0.f) assert_true(res[0][rr] > 2.4f);
    }
    assert_int_equal(pgi__atrous_filter(&g, 6, 2, rgb, scratch, res), PGI_ERR_INVALID_ARG);
    free(want), free(noisy), free(once), free(pl);
}

/* A moving camera's pictures (reprojection, blend, filter) are the same bytes on 1 and 3 threads. */
static void test_threads_same_bytes(void **state) {
    fixture *f = *state;
    pgi_camera_def cam;
    assert_int_equal(pgi_scene_get_camera(f->s, 0, &cam), PGI_OK);
    pgi_image img[2] = {{0}, {0}};
    for (int m = 0; m < 2; m++) {
        pgi_temporal *t;
        assert_int_equal(pgi_temporal_create(f->r, NULL, &t), PGI_OK);
        pgi_render_desc d = small_desc();
        d.threads = m ? 3 : 1;
        pgi_camera_def c = cam;
        d.view = &c;
        for (int k = 0; k < 4; k++) {
            c.eye[0] += 0.01f, c.look_at[0] += 0.01f;
            assert_int_equal(pgi_temporal_step(t, &d, &img[m], NULL), PGI_OK);
        }
        pgi_temporal_destroy(t);
    }
    assert_memory_equal(img[0].rgb, img[1].rgb, 3 * 48 * 36 * sizeof(float));
    pgi_image_free(&img[0]);
    pgi_image_free(&img[1]);
}

/* Settings out of range, AOVs given, the GPU: refused with a message. */
static void test_refusals(void **state) {
    fixture *f = *state;
    pgi_renderer *r = f->r;
    pgi_temporal *t = NULL;
    assert_int_equal(pgi_temporal_create(r, &(pgi_temporal_desc){.history = 300}, &t), PGI_ERR_INVALID_ARG);
    assert_int_equal(pgi_temporal_create(r, &(pgi_temporal_desc){.filter = 6}, &t), PGI_ERR_INVALID_ARG);
    assert_null(t);
    assert_int_equal(pgi_temporal_create(r, NULL, &t), PGI_OK);
    pgi_render_desc d = small_desc();
    pgi_aovs a = {0};
    d.aovs = &a;
    pgi_image img = {0};
    assert_int_equal(pgi_temporal_step(t, &d, &img, NULL), PGI_ERR_INVALID_ARG);
    d.aovs = NULL;
    d.device = PGI_DEVICE_VULKAN;
    assert_int_equal(pgi_temporal_step(t, &d, &img, NULL), PGI_ERR_UNSUPPORTED);
    assert_non_null(strstr(pgi_last_error(), "CPU"));
    pgi_temporal_destroy(t);
}

TU_MAIN("temporal", NULL, NULL,
        cmocka_unit_test_setup_teardown(test_still_converges_to_progressive, fixture_setup, fixture_teardown),
        cmocka_unit_test(test_projection_is_analytic), cmocka_unit_test(test_jitter_lands_on_pixel),
        cmocka_unit_test_setup_teardown(test_moves_and_disocclusion, fixture_setup, fixture_teardown),
        cmocka_unit_test(test_atrous),
        cmocka_unit_test_setup_teardown(test_threads_same_bytes, fixture_setup, fixture_teardown),
        cmocka_unit_test_setup_teardown(test_refusals, fixture_setup, fixture_teardown))
