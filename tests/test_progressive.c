/* Progressive mode (Knaus & Zwicker 2011): frame 0 is the plain render, the
 * radius follows r_{k+1}^2 = r_k^2 (k+1+alpha)/(k+2), the average restarts
 * when the picture changes, every exact estimator gives the same average,
 * and the error against a converged path-traced reference
 * (pgi_reference_render: the box-filtered pixel integral, same bounce limit)
 * keeps falling as frames accumulate, measured with the PSNR of `photongi
 * compare` (pgi_metrics_compute). */
#include "photongi/metrics.h"
#include "photongi/reference.h"
#include "test_util.h"

static pgi_scene *load(const char *spec) {
    pgi_scene *s = tu_scene(spec);
    return s;
}

/* pgi_render_progressive on a renderer of its own. */
static pgi_status progressive(const pgi_scene *s, const pgi_render_desc *d, int frames, pgi_image *img,
                              pgi_frame_stats *fs) {
    pgi_renderer *r;
    pgi_status st = pgi_renderer_create(s, &r);
    if (st) return st;
    st = pgi_render_progressive(r, d, frames, img, fs);
    pgi_renderer_destroy(r);
    return st;
}

static void test_first_frame_is_plain_render(void **state) {
    (void)state;
    pgi_scene *s = load("cornell");
    pgi_render_desc d =
        {.estimator = "hashgrid", .photons = 5000, .width = 40, .height = 32, .direct_samples = 2, .seed = 7};
    pgi_image a = {0}, b = {0}, c = {0};
    TU_CHECK_OK(pgi_render(s, &d, &a, NULL));
    TU_CHECK_OK(progressive(s, &d, 1, &b, NULL));
    pgi_renderer *r;
    TU_CHECK_OK(pgi_renderer_create(s, &r));
    pgi_progressive *p;
    TU_CHECK_OK(pgi_progressive_create(r, &p));
    pgi_frame_stats fs;
    TU_CHECK_OK(pgi_progressive_step(p, &d, &c, &fs));
    assert_int_equal(fs.frames, 1);
    size_t n = 3 * 40 * 32;
    assert_memory_equal(a.rgb, b.rgb, n * sizeof(float));
    assert_memory_equal(a.rgb, c.rgb, n * sizeof(float));
    pgi_progressive_destroy(p);
    pgi_renderer_destroy(r);
    pgi_image_free(&a);
    pgi_image_free(&b);
    pgi_image_free(&c);
    pgi_scene_destroy(s);
}

static void test_radius_sequence(void **state) {
    (void)state;
    const double alpha = 2.0 / 3.0;
    double r2 = 0.3 * 0.3;
    assert_float_equal(pgi_progressive_radius(0.3f, 0), 0.3f, 1e-7f);
    for (int k = 0; k < 200; k++) {
        r2 *= (k + 1 + alpha) / (k + 2);
        float got = pgi_progressive_radius(0.3f, k + 1);
        assert_true(fabs(got - sqrt(r2)) <= 1e-6 * sqrt(r2));
        assert_true(got < pgi_progressive_radius(0.3f, k));
    }
    /* r^2 ~ k^(alpha-1): after 200 frames r2 / r0^2 is about 200^(-1/3) up to a constant. */
    assert_true(r2 / 0.09 < 0.4 && r2 / 0.09 > 0.1);
    /* The stats report the radius of the last frame. */
    pgi_scene *s = load("cornell");
    pgi_render_desc d =
        {.estimator = "hashgrid", .photons = 2000, .width = 16, .height = 16, .direct_samples = 1, .radius = 0.1f};
    pgi_image img = {0};
    pgi_frame_stats fs;
    TU_CHECK_OK(progressive(s, &d, 5, &img, &fs));
    assert_int_equal(fs.frames, 5);
    assert_float_equal(fs.radius, pgi_progressive_radius(0.1f, 4), 1e-7f);
    pgi_image_free(&img);
    pgi_scene_destroy(s);
}

/* pgi_render_progressive(N) == N calls of pgi_progressive_step; deterministic. */
static void test_progressive_equals_accumulate(void **state) {
    (void)state;
    pgi_scene *s = load("cornell");
    pgi_render_desc d =
        {.estimator = "tiled", .photons = 4000, .width = 32, .height = 24, .direct_samples = 2, .seed = 3};
    pgi_renderer *r;
    TU_CHECK_OK(pgi_renderer_create(s, &r));
    pgi_progressive *p;
    TU_CHECK_OK(pgi_progressive_create(r, &p));
    pgi_image acc = {0}, prog = {0}, prog2 = {0}, one = {0};
    pgi_frame_stats fs;
    for (int k = 0; k < 6; k++) {
        TU_CHECK_OK(pgi_progressive_step(p, &d, &acc, &fs));
        assert_int_equal(fs.frames, k + 1);
    }
    pgi_render_desc dp = d;
    TU_CHECK_OK(progressive(s, &dp, 6, &prog, NULL));
    dp.threads = 1;
    TU_CHECK_OK(progressive(s, &dp, 6, &prog2, NULL));
    size_t n = 3 * 32 * 24;
    assert_memory_equal(acc.rgb, prog.rgb, n * sizeof(float));
    assert_memory_equal(prog.rgb, prog2.rgb, n * sizeof(float));
    /* The average differs from frame 0 alone (fresh photons were used). */
    TU_CHECK_OK(pgi_render(s, &d, &one, NULL));
    assert_true(memcmp(one.rgb, acc.rgb, n * sizeof(float)) != 0);
    pgi_progressive_destroy(p);
    pgi_renderer_destroy(r);
    pgi_image_free(&acc);
    pgi_image_free(&prog);
    pgi_image_free(&prog2);
    pgi_image_free(&one);
    pgi_scene_destroy(s);
}

/* The fixed summation order (photongi.h, PGI_PROGRESSIVE_BLOCK): up to one block, the plain
 * sequential double sum of the frames (what progressive mode always did); past it, block sums
 * added in block order. Frames rendered standalone with pgi_progressive_frame, in reverse order on a
 * second renderer, and summed by hand in that order give pgi_render_progressive's bytes, at every
 * frame count, whole blocks and a partial last one. */
static void test_block_order(void **state) {
    (void)state;
    pgi_scene *s = load("cornell");
    const pgi_render_desc d = {.photons = 3000, .width = 24, .height = 20, .direct_samples = 2, .seed = 11};
    const int B = PGI_PROGRESSIVE_BLOCK, N = 2 * B + 3;
    const size_t n = 3 * 24 * 20;
    pgi_renderer *r;
    TU_CHECK_OK(pgi_renderer_create(s, &r));
    pgi_image f = {0}, *frames = calloc((size_t)N, sizeof *frames);
    assert_non_null(frames);
    pgi_frame_stats fs;
    TU_CHECK_OK(pgi_progressive_frame(r, &d, 0.f, 0, &frames[0], &fs));
    const float r0 = fs.radius;
    for (int k = N - 1; k >= 1; k--) TU_CHECK_OK(pgi_progressive_frame(r, &d, r0, k, &frames[k], NULL));
    double *total = calloc(n, sizeof *total), *block = calloc(n, sizeof *block), *seq = calloc(n, sizeof *seq);
    float *want = malloc(n * sizeof *want), *plain = malloc(n * sizeof *plain);
    assert_true(total && block && seq && want && plain);
    pgi_image got = {0};
    for (int m = 1; m <= N; m++) {
        /* blocks by hand */
        memset(total, 0, n * sizeof *total);
        for (int b = 0; b * B < m; b++) {
            for (int k = b * B; k < (b + 1) * B && k < m; k++) {
                pgi_block_sum_add(block, frames[k].rgb, n, k == b * B);
            }
            pgi_block_sum_merge(total, block, n);
        }
        const double inv = 1.0 / (double)m;
        for (size_t i = 0; i < n; i++) want[i] = (float)(total[i] * inv);
        TU_CHECK_OK(progressive(s, &d, m, &got, NULL));
        assert_memory_equal(got.rgb, want, n * sizeof(float));
        if (m <= B) { /* one block: the sequential sum */
            memset(seq, 0, n * sizeof *seq);
            for (int k = 0; k < m; k++)
                for (size_t i = 0; i < n; i++) seq[i] += frames[k].rgb[i];
            for (size_t i = 0; i < n; i++) plain[i] = (float)(seq[i] * inv);
            assert_memory_equal(got.rgb, plain, n * sizeof(float));
        }
    }
    for (int k = 0; k < N; k++) pgi_image_free(&frames[k]);
    free(frames);
    free(total);
    free(block);
    free(seq);
    free(want);
    free(plain);
    pgi_image_free(&f);
    pgi_image_free(&got);
    pgi_renderer_destroy(r);
    pgi_scene_destroy(s);
}

/* pgi_progressive_frame_await_r0: frame k with r0 given once the photons are traced (asked for
 * once), byte for byte the frame of pgi_progressive_frame, also when the photons depend on the
 * radius (guided emission: r0 asked for first); a bad r0 is refused. Frame 0's progress reports
 * carry its radius from "build" on (the automatic one is chosen then). */
typedef struct r0_source {
    float r0;
    int asked;
    int traced, traced_when_asked;        /* the "trace" pass was reported (before r0 was asked for) */
    float radius_before, radius_at_build; /* pgi_progress.radius before r0 was asked for, at "build" */
} r0_source;

static float give_r0(void *user) {
    r0_source *src = user;
    src->asked++;
    src->traced_when_asked = src->traced;
    return src->r0;
}

static void note_trace(void *user, const pgi_progress *p) {
    r0_source *src = user;
    if (strcmp(p->pass, "trace") == 0) src->traced = 1;
    if (!src->asked && p->radius != 0.f) src->radius_before = p->radius;
    if (strcmp(p->pass, "build") == 0) src->radius_at_build = p->radius;
}

typedef struct radius_seen {
    float at_view, at_build, at_direct;
} radius_seen;

static void see_radius(void *user, const pgi_progress *p) {
    radius_seen *rs = user;
    if (strcmp(p->pass, "view") == 0) rs->at_view = p->radius;
    if (strcmp(p->pass, "build") == 0) rs->at_build = p->radius;
    if (strcmp(p->pass, "direct") == 0) rs->at_direct = p->radius;
}

static void test_await_r0(void **state) {
    (void)state;
    pgi_scene *s = load("cornell");
    const size_t n = 3 * 24 * 20;
    for (int guided = 0; guided <= 1; guided++) {
        pgi_render_desc d =
            {.photons = 3000, .width = 24, .height = 20, .direct_samples = 2, .seed = 7, .radius = PGI_RADIUS_AUTO};
        if (guided) d.emission = PGI_EMISSION_GUIDED;
        /* frame 0 on r; frames k on ra and rb, which render the same frames in the same order (a
           renderer's guided emission keeps its guide between frames) */
        pgi_renderer *r, *ra, *r2;
        TU_CHECK_OK(pgi_renderer_create(s, &r));
        TU_CHECK_OK(pgi_renderer_create(s, &ra));
        TU_CHECK_OK(pgi_renderer_create(s, &r2));
        pgi_image f0 = {0}, want = {0}, got = {0};
        pgi_frame_stats fs, fw, fg;
        radius_seen seen = {-1.f, -1.f, -1.f};
        pgi_render_desc dp = d;
        dp.progress = see_radius;
        dp.progress_user = &seen;
        TU_CHECK_OK(pgi_progressive_frame(r, &dp, 0.f, 0, &f0, &fs));
        assert_true(seen.at_view == 0.f); /* automatic: not known yet */
        assert_true(seen.at_build == fs.radius && seen.at_direct == fs.radius && fs.radius > 0.f);
        for (int k = 1; k <= 5; k += 4) {
            TU_CHECK_OK(pgi_progressive_frame(ra, &d, fs.radius, k, &want, &fw));
            r0_source src = {fs.radius, 0, 0, 0, 0.f, 0.f};
            pgi_render_desc dt = d;
            dt.progress = note_trace;
            dt.progress_user = &src;
            TU_CHECK_OK(pgi_progressive_frame_await_r0(r2, &dt, give_r0, &src, k, &got, &fg));
            assert_int_equal(src.asked, 1);
            assert_int_equal(src.traced_when_asked, !guided); /* guided: the photons need the radius */
            assert_true(src.radius_before == 0.f);            /* not known before it is asked for */
            assert_true(src.radius_at_build == pgi_progressive_radius(fs.radius, k));
            assert_int_equal(got.width, want.width);
            assert_memory_equal(got.rgb, want.rgb, n * sizeof(float));
            assert_true(fg.radius == fw.radius && fg.radius == pgi_progressive_radius(fs.radius, k));
            assert_true(fg.photons_stored == fw.photons_stored);
        }
        r0_source bad = {0.f, 0, 0, 0, 0.f, 0.f};
        assert_int_equal(pgi_progressive_frame_await_r0(r2, &d, give_r0, &bad, 2, &got, NULL), PGI_ERR_INVALID_ARG);
        assert_int_equal(bad.asked, 1);
        assert_non_null(strstr(pgi_last_error(), "radius"));
        assert_int_equal(pgi_progressive_frame_await_r0(r2, &d, give_r0, &bad, 0, &got, NULL), PGI_ERR_INVALID_ARG);
        pgi_image_free(&f0);
        pgi_image_free(&want);
        pgi_image_free(&got);
        pgi_renderer_destroy(r);
        pgi_renderer_destroy(ra);
        pgi_renderer_destroy(r2);
    }
    pgi_scene_destroy(s);
}

/* The running average restarts when the camera, a light, the time or a setting changes. */
static void test_accumulation_restarts(void **state) {
    (void)state;
    pgi_scene *s = load("sphere-and-plane");
    pgi_render_desc d = {.estimator = "hashgrid", .photons = 2000, .width = 16, .height = 16};
    pgi_renderer *r;
    TU_CHECK_OK(pgi_renderer_create(s, &r));
    pgi_progressive *p;
    TU_CHECK_OK(pgi_progressive_create(r, &p));
    pgi_image img = {0};
    pgi_frame_stats fs;
    TU_CHECK_OK(pgi_progressive_step(p, &d, &img, &fs));
    TU_CHECK_OK(pgi_progressive_step(p, &d, &img, &fs));
    assert_int_equal(fs.frames, 2);
    pgi_camera_def view;
    TU_CHECK_OK(pgi_scene_get_camera(s, 0, &view));
    d.view = &view; /* same camera as the scene's but given as a view: a different desc */
    TU_CHECK_OK(pgi_progressive_step(p, &d, &img, &fs));
    assert_int_equal(fs.frames, 1);
    TU_CHECK_OK(pgi_progressive_step(p, &d, &img, &fs));
    assert_int_equal(fs.frames, 2);
    view.eye[0] += 0.1f;
    TU_CHECK_OK(pgi_progressive_step(p, &d, &img, &fs));
    assert_int_equal(fs.frames, 1);
    TU_CHECK_OK(pgi_progressive_step(p, &d, &img, &fs));
    assert_int_equal(fs.frames, 2);
    pgi_light_group g;
    TU_CHECK_OK(pgi_scene_get_light_group(s, 0, &g));
    g.position[1] += 0.5f;
    TU_CHECK_OK(pgi_scene_set_light_position(s, 0, g.position));
    TU_CHECK_OK(pgi_progressive_step(p, &d, &img, &fs));
    assert_int_equal(fs.frames, 1);
    d.photons = 3000;
    TU_CHECK_OK(pgi_progressive_step(p, &d, &img, &fs));
    assert_int_equal(fs.frames, 1);
    d.threads = 1; /* the thread count does not change the picture */
    TU_CHECK_OK(pgi_progressive_step(p, &d, &img, &fs));
    assert_int_equal(fs.frames, 2);
    pgi_progressive_reset(p);
    TU_CHECK_OK(pgi_progressive_step(p, &d, &img, &fs));
    assert_int_equal(fs.frames, 1);
    pgi_progressive_destroy(p);
    pgi_renderer_destroy(r);
    pgi_image_free(&img);
    pgi_scene_destroy(s);
}

/* Every exact estimator averages to the same image as brute. */
static void test_every_exact_estimator(void **state) {
    (void)state;
    pgi_scene *s = load("cornell");
    pgi_render_desc d = {.estimator = "brute",
                         .photons = 3000,
                         .width = 24,
                         .height = 24,
                         .direct_samples = 1,
                         .output = PGI_OUTPUT_INDIRECT};
    pgi_image ref = {0};
    TU_CHECK_OK(progressive(s, &d, 3, &ref, NULL));
    assert_true(tu_max_abs(ref.rgb, 3 * 24 * 24) > 0.0);
    int tested = 0;
    for (size_t i = 0; i < pgi_estimator_count(); i++) {
        const pgi_estimator_vtbl *vt = pgi_estimator_at(i);
        pgi_image img = {0};
        d.estimator = vt->name;
        pgi_status st = progressive(s, &d, 3, &img, NULL);
        if (!vt->exact) {
            assert_int_equal(st, PGI_ERR_INVALID_ARG); /* an approximate estimator's bias never vanishes */
            continue;
        }
        TU_CHECK_OK(st);
        assert_int_equal(tu_compare(img.rgb, ref.rgb, 3 * 24 * 24, 1e-4, vt->name), 0);
        pgi_image_free(&img);
        tested++;
    }
    assert_true(tested >= 3);
    pgi_image_free(&ref);
    pgi_scene_destroy(s);
}

static void test_bad_progressive_requests(void **state) {
    (void)state;
    pgi_scene *s = load("cornell");
    pgi_image img = {0};
    pgi_render_desc d = {.photons = 1000, .width = 8, .height = 8};
    assert_int_equal(progressive(s, &d, 2000000, &img, NULL), PGI_ERR_INVALID_ARG);
    d.output = PGI_OUTPUT_PHOTON_COUNT;
    assert_int_equal(progressive(s, &d, 2, &img, NULL), PGI_ERR_INVALID_ARG);
    assert_non_null(strstr(pgi_last_error(), "photon counts"));
    d.output = PGI_OUTPUT_ALL;
    d.estimator = "no-such";
    assert_int_equal(progressive(s, &d, 2, &img, NULL), PGI_ERR_INVALID_ARG);
    pgi_camera_def bad = {{0, 1, 3}, {0, 1, 3}, {0, 1, 0}, 40.f};
    d.estimator = NULL;
    d.view = &bad;
    assert_int_equal(progressive(s, &d, 2, &img, NULL), PGI_ERR_INVALID_ARG);
    pgi_image_free(&img);
    pgi_scene_destroy(s);
}

/* Error against a converged reference keeps falling as frames accumulate
 * (Cornell box, 64x64, 10k photons a frame): PSNR after 1, 4, 16, 64 and 256
 * frames, each at least 2 dB above the last (measured 24.2, 29.6, 34.5, 39.1,
 * 42.6 dB). The reference (4096 samples a pixel, about 6 s on 2 cores) is
 * near 52 dB, well above the 256-frame image. Pixel centres only (the old
 * sampling; PGI_TEST_JITTER=off in the environment shows it) plateau against
 * the box-filtered reference, as does anything else that keeps the average
 * from converging: 24.2, 27.5, 29.0, 29.6, 29.9 dB, the edges (a large share
 * of 64x64 pixels) keeping their aliasing. */
static void test_error_falls(void **state) {
    (void)state;
    pgi_scene *s = load("cornell");
    const int W = 64, H = 64;
    pgi_render_desc d =
        {.estimator = "hashgrid", .photons = 10000, .width = W, .height = H, .direct_samples = 4, .seed = 11};
    pgi_reference_desc rd = {.width = W, .height = H, .seed = 987654321, .spp = 4096};
    pgi_image ref = {0}, img = {0};
    uint64_t spp = 0;
    TU_CHECK_OK(pgi_reference_render(s, &rd, &ref, &spp));
    assert_int_equal(spp, 4096);
    pgi_renderer *r;
    TU_CHECK_OK(pgi_renderer_create(s, &r));
    pgi_progressive *pr;
    TU_CHECK_OK(pgi_progressive_create(r, &pr));
    const char *jitter = getenv("PGI_TEST_JITTER"); /* "off": the old pixel-centre sampling, to see it plateau */
    if (jitter && strcmp(jitter, "off") == 0) d.jitter = PGI_JITTER_OFF;
    const int marks[5] = {1, 4, 16, 64, 256};
    double p[5];
    pgi_frame_stats fs;
    for (int k = 1, m = 0; k <= 256; k++) {
        TU_CHECK_OK(pgi_progressive_step(pr, &d, &img, &fs));
        if (k == marks[m]) {
            pgi_metrics mt;
            TU_CHECK_OK(pgi_metrics_compute(&img, &ref, 1.f, &mt));
            p[m++] = mt.psnr;
        }
    }
    fprintf(stderr, "  PSNR vs reference at 1, 4, 16, 64, 256 frames: %.2f %.2f %.2f %.2f %.2f dB\n", p[0], p[1], p[2],
            p[3], p[4]);
    for (int m = 1; m < 5; m++)
        if (!(p[m] > p[m - 1] + 2.0))
            fail_msg("PSNR after %d frames (%.2f dB) is not 2 dB above %d frames' (%.2f dB)", marks[m], p[m],
                     marks[m - 1], p[m - 1]);
    pgi_progressive_destroy(pr);
    pgi_renderer_destroy(r);
    pgi_image_free(&ref);
    pgi_image_free(&img);
    pgi_scene_destroy(s);
}

/* A progressive render creates its estimator once: the radius changes every
 * frame, but it is a per-frame argument, not an option of the estimator. */
static void test_estimator_created_once(void **state) {
    (void)state;
    pgi_scene *s = load("cornell");
    pgi_render_desc d = {.estimator = "tiled", .photons = 2000, .width = 16, .height = 16, .direct_samples = 1};
    pgi_renderer *r;
    TU_CHECK_OK(pgi_renderer_create(s, &r));
    pgi_image img = {0};
    pgi_frame_stats fs;
    TU_CHECK_OK(pgi_render_progressive(r, &d, 8, &img, &fs));
    assert_int_equal(fs.frames, 8);
    assert_int_equal(fs.estimators_created, 1);
    /* the same renderer keeps it for the next render; other options make a new one */
    TU_CHECK_OK(pgi_render_progressive(r, &d, 2, &img, &fs));
    assert_int_equal(fs.estimators_created, 0);
    d.est.tiled.tile_size = 32;
    TU_CHECK_OK(pgi_renderer_render(r, &d, &img, &fs));
    assert_int_equal(fs.estimators_created, 1);
    assert_int_equal(fs.settings.est.tiled.tile_size, 32);
    d.est.tiled.tile_size = 0; /* the default, resolved in the stats: tiled's own */
    TU_CHECK_OK(pgi_renderer_render(r, &d, &img, &fs));
    assert_int_equal(fs.settings.est.tiled.tile_size, 16);
    d.estimator = "bounds25d"; /* the row's default for the others that share it */
    TU_CHECK_OK(pgi_renderer_render(r, &d, &img, &fs));
    assert_int_equal(fs.settings.est.tiled.tile_size, 32);
    assert_true(fs.settings.photons == 2000 && fs.settings.seed == 1 && fs.settings.bounces == 4);
    pgi_renderer_destroy(r);
    pgi_image_free(&img);
    pgi_scene_destroy(s);
}

/* Progress reports (pgi_render_desc.progress): every pass in order on the calling thread, the
 * tracer's photons up to the total, the frame of a progressive render; the image does not change,
 * and a different callback or user pointer does not restart a running average. */
typedef struct progress_log {
    int n;
    char pass[512][12];
    uint64_t done[512], total[512];
    int frame[512], frames[512];
    double elapsed[512];
} progress_log;

static void log_progress(void *user, const pgi_progress *p) {
    progress_log *l = user;
    if (l->n >= 512) return;
    snprintf(l->pass[l->n], sizeof l->pass[0], "%s", p->pass);
    l->done[l->n] = p->done;
    l->total[l->n] = p->total;
    l->frame[l->n] = p->frame;
    l->frames[l->n] = p->frames;
    l->elapsed[l->n] = p->elapsed_ms;
    l->n++;
}

/* Checks the log of `frames` frames of `photons` photons: each frame reports view, trace (0 of
 * photons first, photons of photons last, never falling), build, estimate, direct. */
static void check_progress_log(const progress_log *l, int frames, uint64_t photons) {
    static const char *const order[] = {"view", "trace", "build", "estimate", "direct"};
    int i = 0;
    for (int k = 0; k < frames; k++) {
        int at = 0;
        uint64_t last = 0;
        int first_trace = -1, last_trace = -1;
        for (; i < l->n && l->frame[i] == k; i++) {
            assert_int_equal(l->frames[i], frames);
            if (i > 0) assert_true(l->elapsed[i] >= l->elapsed[i - 1]);
            while (at < 5 && strcmp(l->pass[i], order[at]) != 0) at++;
            if (at == 5) fail_msg("frame %d: pass '%s' out of order", k, l->pass[i]);
            if (at == 1) {
                assert_int_equal(l->total[i], photons);
                assert_true(l->done[i] >= last && l->done[i] <= photons);
                last = l->done[i];
                if (first_trace < 0) first_trace = i;
                last_trace = i;
            }
        }
        if (at != 4) fail_msg("frame %d: the passes end at '%s', not 'direct'", k, at < 5 ? order[at] : "?");
        assert_true(first_trace >= 0);
        assert_int_equal(l->done[first_trace], 0);
        assert_int_equal(l->done[last_trace], photons);
    }
    assert_int_equal(i, l->n);
}

static void test_progress_callback(void **state) {
    (void)state;
    pgi_scene *s = load("cornell");
    pgi_render_desc d = {.estimator = "hashgrid", .photons = 20000, .width = 24, .height = 16, .direct_samples = 1};
    pgi_image plain = {0}, reported = {0};
    progress_log *l = calloc(1, sizeof *l);
    assert_non_null(l);
    TU_CHECK_OK(pgi_render(s, &d, &plain, NULL));
    pgi_render_desc dp = d;
    dp.progress = log_progress;
    dp.progress_user = l;
    pgi_frame_stats fs;
    TU_CHECK_OK(pgi_render(s, &dp, &reported, &fs));
    assert_memory_equal(plain.rgb, reported.rgb, 3 * sizeof(float) * 24 * 16);
    assert_null(fs.settings.progress);
    assert_null(fs.settings.progress_user);
    check_progress_log(l, 1, 20000);

    /* pgi_render_progressive: frame k of 3 */
    memset(l, 0, sizeof *l);
    TU_CHECK_OK(progressive(s, &d, 3, &plain, NULL));
    TU_CHECK_OK(progressive(s, &dp, 3, &reported, &fs));
    assert_memory_equal(plain.rgb, reported.rgb, 3 * sizeof(float) * 24 * 16);
    assert_int_equal(fs.frames, 3);
    check_progress_log(l, 3, 20000);

    /* stepping: another user pointer is the same picture */
    pgi_renderer *r;
    TU_CHECK_OK(pgi_renderer_create(s, &r));
    pgi_progressive *p;
    TU_CHECK_OK(pgi_progressive_create(r, &p));
    TU_CHECK_OK(pgi_progressive_step(p, &d, &reported, &fs));
    memset(l, 0, sizeof *l);
    TU_CHECK_OK(pgi_progressive_step(p, &dp, &reported, &fs));
    assert_int_equal(fs.frames, 2);
    assert_true(l->n > 0 && l->frame[0] == 0 && l->frames[0] == 1);
    pgi_progressive_destroy(p);
    pgi_renderer_destroy(r);
    free(l);
    pgi_image_free(&plain);
    pgi_image_free(&reported);
    pgi_scene_destroy(s);
}

TU_MAIN("progressive", NULL, NULL, cmocka_unit_test(test_first_frame_is_plain_render),
        cmocka_unit_test(test_radius_sequence), cmocka_unit_test(test_progressive_equals_accumulate),
        cmocka_unit_test(test_block_order), cmocka_unit_test(test_await_r0),
        cmocka_unit_test(test_accumulation_restarts), cmocka_unit_test(test_estimator_created_once),
        cmocka_unit_test(test_every_exact_estimator), cmocka_unit_test(test_bad_progressive_requests),
        cmocka_unit_test(test_error_falls), cmocka_unit_test(test_progress_callback))
