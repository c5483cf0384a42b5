/* Cancelling a frame (pgi_render_desc.cancel, pgi_estimate_args.cancel): every estimator returns
 * PGI_ERR_CANCELLED on a requested token; a brute-force frame that would take minutes stops soon
 * after another thread asks; a cancel from the progress callback stops the pass it names; the
 * renderer renders on afterwards as a fresh one would, bit for bit; a cancelled progressive step
 * leaves the average as it was. */
#include <pthread.h>
#include <time.h>

#include "test_util.h"

/* Each test's Cornell box, its renderer and a cancel token. */
typedef struct fixture {
    pgi_scene *s;
    pgi_renderer *r;
    pgi_cancel *c;
} fixture;

static int fixture_setup(void **state) {
    fixture *f = calloc(1, sizeof *f);
    if (!f || pgi_scene_load("cornell", &f->s) || pgi_renderer_create(f->s, &f->r) || pgi_cancel_create(&f->c))
        return -1;
    *state = f;
    return 0;
}

static int fixture_teardown(void **state) {
    fixture *f = *state;
    pgi_cancel_destroy(f->c);
    pgi_renderer_destroy(f->r);
    pgi_scene_destroy(f->s);
    free(f);
    return 0;
}

/* Every registered estimator, given a token already requested, returns PGI_ERR_CANCELLED from
 * build or estimate, and a reset token lets the same estimator finish. */
static void test_every_estimator(void **state) {
    fixture *f = *state;
    pgi_renderer *r = f->r;
    pgi_cancel *c = f->c;
    pgi_frame_inputs in;
    pgi_render_desc d = {.photons = 4000, .radius = 0.1f, .width = 24, .height = 18};
    assert_int_equal(pgi_renderer_prepare(r, &d, &in, NULL), PGI_OK);
    assert_int_equal(pgi_cancel_requested(NULL), 0);
    float *out = malloc(3 * in.samples->count * sizeof(float));
    assert_non_null(out);
    for (size_t i = 0; i < pgi_estimator_count(); i++) {
        const pgi_estimator_vtbl *vt = pgi_estimator_at(i);
        pgi_estimator *e;
        assert_int_equal(pgi_estimator_create(vt->name, &(pgi_estimator_desc){0}, &e), PGI_OK);
        pgi_estimate_args a = {.photons = in.photons,
                               .samples = in.samples,
                               .camera = &in.camera,
                               .out_rgb = out,
                               .radius = in.radius,
                               .cancel = c};
        pgi_cancel_request(c);
        assert_int_equal(pgi_cancel_requested(c), 1);
        pgi_status st = pgi_estimator_build(e, &a);
        if (st == PGI_OK) st = pgi_estimator_estimate(e, &a);
        if (st != PGI_ERR_CANCELLED) fail_msg("%s: status %d on a requested token", vt->name, (int)st);
        assert_non_null(strstr(pgi_last_error(), "cancelled"));
        pgi_cancel_reset(c);
        assert_int_equal(pgi_estimator_build(e, &a), PGI_OK);
        assert_int_equal(pgi_estimator_estimate(e, &a), PGI_OK);
        pgi_estimator_destroy(e);
    }
    free(out);
}

static double now_s(void) {
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

/* The progress callback's view of a frame: it starts a thread that requests the cancel a while
 * after the pass `at` begins (or requests it itself when delay_s is 0). */
typedef struct watch {
    pgi_cancel *c;
    const char *at;
    double delay_s, asked_at;
    int started;
    pthread_t th;
} watch;

static void *cancel_later(void *user) {
    watch *w = user;
    struct timespec ts = {(time_t)w->delay_s, (long)((w->delay_s - (double)(time_t)w->delay_s) * 1e9)};
    nanosleep(&ts, NULL);
    w->asked_at = now_s();
    pgi_cancel_request(w->c);
    return NULL;
}

static void on_progress(void *user, const pgi_progress *p) {
    watch *w = user;
    if (w->started || strcmp(p->pass, w->at) != 0) return;
    if (strcmp(w->at, "trace") == 0 && p->done == 0) return; /* a batch in: the tracer is running */
    w->started = 1;
    if (w->delay_s > 0.0) assert_int_equal(pthread_create(&w->th, NULL, cancel_later, w), 0);
    else {
        w->asked_at = now_s();
        pgi_cancel_request(w->c);
    }
}

/* A brute-force frame of 640x480 pixels and 300 000 photons (about 10^11 photon reads: minutes
 * on two cores) is stopped by another thread 0.3 s into its estimate: it returns
 * PGI_ERR_CANCELLED soon after (well under the frame's time; the bound is loose, for sanitizers
 * and loaded machines), and the renderer then renders a small frame bit for bit as a fresh
 * renderer does. */
static void test_brute_stops(void **state) {
    fixture *f = *state;
    pgi_scene *s = f->s;
    pgi_renderer *r = f->r;
    pgi_cancel *c = f->c;
    watch w = {.c = c, .at = "estimate", .delay_s = 0.3};
    pgi_render_desc d = {.estimator = "brute",
                         .photons = 300000,
                         .radius = 0.05f,
                         .width = 640,
                         .height = 480,
                         .cancel = c,
                         .progress = on_progress,
                         .progress_user = &w};
    pgi_image img = {0};
    pgi_status st = pgi_renderer_render(r, &d, &img, NULL);
    const double stopped = now_s();
    assert_int_equal(w.started, 1);
    pthread_join(w.th, NULL);
    assert_int_equal(st, PGI_ERR_CANCELLED);
    assert_non_null(strstr(pgi_last_error(), "cancelled"));
    const double latency = stopped - w.asked_at;
    print_message("brute 640x480, 300k photons: stopped %.3f s after the request\n", latency);
    assert_true(latency < 20.0);

    /* the renderer renders on: a small frame equals a fresh renderer's */
    pgi_cancel_reset(c);
    pgi_render_desc small = {.photons = 5000, .radius = 0.05f, .width = 40, .height = 30, .cancel = c};
    pgi_image a = {0}, b = {0};
    assert_int_equal(pgi_renderer_render(r, &small, &a, NULL), PGI_OK);
    small.cancel = NULL;
    assert_int_equal(pgi_render(s, &small, &b, NULL), PGI_OK);
    assert_memory_equal(a.rgb, b.rgb, 3 * 40 * 30 * sizeof(float));
    pgi_image_free(&a);
    pgi_image_free(&b);
    pgi_image_free(&img);
}

/* A cancel asked from the progress callback stops the frame at the pass it was asked in: while
 * tracing (between batches), or as the estimate or the direct pass starts. */
static void test_from_progress(void **state) {
    fixture *f = *state;
    pgi_renderer *r = f->r;
    pgi_cancel *c = f->c;
    const char *passes[] = {"view", "trace", "build", "estimate", "direct"};
    for (size_t k = 0; k < sizeof passes / sizeof *passes; k++) {
        pgi_cancel_reset(c);
        watch w = {.c = c, .at = passes[k]};
        pgi_render_desc d = {.photons = 200000,
                             .radius = 0.05f,
                             .width = 64,
                             .height = 48,
                             .cancel = c,
                             .progress = on_progress,
                             .progress_user = &w};
        pgi_image img = {0};
        pgi_frame_stats fs;
        pgi_status st = pgi_renderer_render(r, &d, &img, &fs);
        if (st != PGI_ERR_CANCELLED) fail_msg("cancel at '%s': status %d", passes[k], (int)st);
        if (!strstr(pgi_last_error(), passes[k])) fail_msg("cancel at '%s': message '%s'", passes[k], pgi_last_error());
        pgi_image_free(&img);
    }
}

/* Progressive: two steps, a cancelled third, then the third again: the image of three
 * uninterrupted steps, bit for bit, and the frame count says 3. */
static void test_progressive_kept(void **state) {
    fixture *f = *state;
    pgi_renderer *r = f->r;
    pgi_cancel *c = f->c;
    pgi_render_desc d = {.photons = 5000, .radius = 0.05f, .width = 40, .height = 30, .cancel = c};
    pgi_progressive *p;
    assert_int_equal(pgi_progressive_create(r, &p), PGI_OK);
    pgi_image avg = {0}, want = {0};
    pgi_frame_stats fs;
    for (int k = 0; k < 2; k++) assert_int_equal(pgi_progressive_step(p, &d, &avg, &fs), PGI_OK);
    pgi_cancel_request(c);
    assert_int_equal(pgi_progressive_step(p, &d, &avg, &fs), PGI_ERR_CANCELLED);
    pgi_cancel_reset(c);
    assert_int_equal(pgi_progressive_step(p, &d, &avg, &fs), PGI_OK);
    assert_int_equal(fs.frames, 3);
    d.cancel = NULL; /* not part of the picture */
    assert_int_equal(pgi_render_progressive(r, &d, 3, &want, NULL), PGI_OK);
    assert_memory_equal(avg.rgb, want.rgb, 3 * 40 * 30 * sizeof(float));
    pgi_image_free(&avg);
    pgi_image_free(&want);
    pgi_progressive_destroy(p);
}

TU_MAIN("cancel", NULL, NULL, cmocka_unit_test_setup_teardown(test_every_estimator, fixture_setup, fixture_teardown),
        cmocka_unit_test_setup_teardown(test_brute_stops, fixture_setup, fixture_teardown),
        cmocka_unit_test_setup_teardown(test_from_progress, fixture_setup, fixture_teardown),
        cmocka_unit_test_setup_teardown(test_progressive_kept, fixture_setup, fixture_teardown))
