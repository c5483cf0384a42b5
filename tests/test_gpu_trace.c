/* Photon tracing on the GPU (src/gpu/gpu_trace.h, shaders/trace.comp) against the CPU tracer
 * (src/photon/trace.c), on whatever Vulkan device the loader finds (CI: lavapipe, a CPU: small
 * photon counts). The two draw different random numbers, so they are compared statistically:
 * photons stored per path emitted within 1 %, total stored flux within 1 %, mean photon position
 * within 1 % of the scene's diagonal, mean incoming direction within 0.01 (Cornell; Cornell with a
 * mirror and a glass sphere; spot, sun and glossy objects; a constant sky; Sibenik, textured,
 * when the large scenes are there). And: the same
 * bytes on two runs and with any batch size, few paths traced for nothing (<= 5 %), the options the
 * GPU lacks refused with a message naming them. Built and run only with the Vulkan backend. */
#include "test_gpu_util.h"
#include "test_util.h"
#include "test_vertex_colours.h"


#include "gpu/gpu_trace.h"
#include "photon/photon.h"
#include "photongi/metrics.h"
#include "rt/rt.h"
#include "scene/scene_internal.h"


typedef struct stats {
    double yield;   /* photons per path emitted */
    double flux[3]; /* total */
    double pos[3];  /* mean position */
    double dir[3];  /* mean incoming direction */
} stats;

static stats photon_stats(const pgi_photons *ph) {
    stats s = {0};
    s.yield = ph->emitted ? (double)ph->count / (double)ph->emitted : 0.0;
    for (size_t j = 0; j < ph->count; j++) {
        s.flux[0] += ph->fr[j], s.flux[1] += ph->fg[j], s.flux[2] += ph->fb[j];
        s.pos[0] += ph->px[j], s.pos[1] += ph->py[j], s.pos[2] += ph->pz[j];
        s.dir[0] += ph->dx[j], s.dir[1] += ph->dy[j], s.dir[2] += ph->dz[j];
    }
    for (int k = 0; k < 3 && ph->count; k++) s.pos[k] /= (double)ph->count, s.dir[k] /= (double)ph->count;
    return s;
}

static double rel(double a, double b) { return fabs(a - b) / fmax(fabs(b), 1e-30); }

/* GPU and CPU photons of scene s: statistically the same. */
static void compare(pgi_scene *s, const char *what, uint32_t photons, int bounces) {
    pgi__rt *rt = NULL;
    TU_CHECK_OK(pgi__rt_create(s, &rt));
    pgi_photons cpu = {0}, gpu = {0};
    TU_CHECK_OK(pgi_photons_alloc(&cpu, photons));
    TU_CHECK_OK(pgi_photons_alloc(&gpu, photons));
    pgi__trace_desc td = {.photons = photons, .bounces = bounces, .seed = 7, .threads = 2};
    pgi__trace_scratch sc = {0};
    uint64_t crays = 0;
    double c0 = pgi__now_ms();
    TU_CHECK_OK(pgi__photons_trace(s, rt, &td, &cpu, &sc, &crays));
    double cms = pgi__now_ms() - c0;
    pgi__trace_scratch_free(&sc);

    pgi__gpu_scene *gs = NULL;
    pgi__gpu_trace *gt = NULL;
    TU_CHECK_OK(pgi__gpu_scene_create(g_gpu, s, &gs));
    TU_CHECK_OK(pgi__gpu_trace_create(g_gpu, gs, &gt));
    pgi__gpu_trace_desc gd = {.photons = photons, .bounces = bounces, .seed = 7};
    pgi__gpu_trace_result r;
    TU_CHECK_OK(pgi__gpu_trace_run(gt, s, &gd, &r));
    TU_CHECK_OK(pgi__gpu_trace_download(gt, &gpu));
    assert_int_equal(r.count, photons);
    assert_int_equal(gpu.count, photons);
    assert_true(r.paths_discarded * 20 <= r.paths_traced); /* <= 5 % traced for nothing */
    stats a = photon_stats(&gpu), b = photon_stats(&cpu);
    const double diag = pgi__scene_diagonal(s);
    fprintf(stderr,
            "  %-16s %u photons: GPU %.1f ms (device %.1f, %d batches, %llu paths, %llu discarded, %llu rays), "
            "CPU %.1f ms (%llu rays)\n"
            "  %-16s yield GPU %.4f CPU %.4f (%.2f %%); flux GPU %.4g %.4g %.4g CPU %.4g %.4g %.4g\n"
            "  %-16s mean position GPU %.4f %.4f %.4f CPU %.4f %.4f %.4f; direction GPU %.4f %.4f %.4f CPU %.4f %.4f "
            "%.4f\n",
            what, photons, r.wall_ms, r.trace_ms, r.batches, (unsigned long long)r.paths_traced,
            (unsigned long long)r.paths_discarded, (unsigned long long)r.rays, cms, (unsigned long long)crays, what,
            a.yield, b.yield, 100.0 * rel(a.yield, b.yield), a.flux[0], a.flux[1], a.flux[2], b.flux[0], b.flux[1],
            b.flux[2], what, a.pos[0], a.pos[1], a.pos[2], b.pos[0], b.pos[1], b.pos[2], a.dir[0], a.dir[1], a.dir[2],
            b.dir[0], b.dir[1], b.dir[2]);
    assert_true(rel(a.yield, b.yield) <= 0.01);
    for (int k = 0; k < 3; k++) {
        assert_true(rel(a.flux[k], b.flux[k]) <= 0.01);
        assert_true(fabs(a.pos[k] - b.pos[k]) <= 0.01 * diag);
        assert_true(fabs(a.dir[k] - b.dir[k]) <= 0.01);
    }
    pgi__gpu_trace_destroy(gt);
    pgi__gpu_scene_destroy(gs);
    pgi_photons_free(&cpu);
    pgi_photons_free(&gpu);
    pgi__rt_destroy(rt);
}

static void test_cornell(void **state) {
    (void)state;
    pgi_scene *s = tu_scene("cornell");
    compare(s, "cornell", 200000, 4);
    pgi_scene_destroy(s);
}

/* Vertex colours (tu_add_vertex_colours) multiply kd on the GPU as on the CPU: the photons' flux
 * after their first bounces (the colours take a good part of it) agrees. */
static void test_cornell_coloured(void **state) {
    (void)state;
    pgi_scene *s = tu_scene("cornell");
    tu_add_vertex_colours(s);
    compare(s, "cornell coloured", 200000, 4);
    pgi_scene_destroy(s);
}

static void test_cornell_mirrors(void **state) {
    (void)state;
    pgi_scene *s = tu_scene("cornell-mirrors");
    compare(s, "cornell-mirrors", 200000, 6);
    pgi_scene_destroy(s);
}

/* A constant sky (window-box: light through a window; the sky is the only light). */
static void test_sky(void **state) {
    (void)state;
    pgi_scene *s = tu_scene("window-box");
    assert_non_null(s->env);
    compare(s, "window-box", 80000, 4);
    pgi_scene_destroy(s);
}

static void test_sibenik(void **state) {
    (void)state;
    pgi_scene *s = NULL;
    if (pgi_scene_load("sibenik", &s) != PGI_OK) {
        fprintf(stderr, "  sibenik not found (%s): skipped\n", pgi_last_error());
        skip();
    }
    assert_true(s->ntexs > 0);
    compare(s, "sibenik", 150000, 4);
    pgi_scene_destroy(s);
}

/* Spot and sun lights beside Cornell's area light; glossy objects: microfacet plastic and
 * Blinn-Phong. */
static void test_lights_glossy(void **state) {
    (void)state;
    char dir[512], path[700];
    tu_make_tmpdir(dir, sizeof dir);
    snprintf(path, sizeof path, "%s/lights.json", dir);
    assert_int_equal(
        tu_write_file(path,
                      "{\"builtin\": \"cornell\", \"lights\": ["
                      "{\"type\": \"spot\", \"position\": [0, 1.6, 0.5], \"direction\": [0.2, -1, -0.3], "
                      "\"angle\": 35, \"intensity\": [3, 2, 1]},"
                      "{\"type\": \"sun\", \"direction\": [0.3, -0.8, -0.4], \"irradiance\": [0.5, 0.6, 0.7]}],"
                      " \"objects\": ["
                      "{\"shape\": \"sphere\", \"center\": [-0.4, 0.3, 0.3], \"radius\": 0.25, \"material\": "
                      "{\"type\": \"plastic\", \"kd\": [0.6, 0.5, 0.4], \"ks\": [0.04, 0.04, 0.04], \"shininess\": "
                      "30}},"
                      "{\"shape\": \"box\", \"center\": [0.4, 0.2, 0.4], \"size\": [0.3, 0.4, 0.3], \"material\": "
                      "{\"type\": \"phong\", \"kd\": [0.5, 0.6, 0.5], \"ks\": [0.3, 0.3, 0.3], \"shininess\": 40}}]}"),
        0);
    pgi_scene *s = tu_scene(path);
    int types = 0;
    for (size_t i = 0; i < s->nlights; i++) types |= 1 << s->lights[i].type;
    for (size_t i = 0; i < s->nmats; i++) types |= 1 << (8 + s->mats[i].type);
    assert_int_equal(types & 0xE, 0xE);                                                 /* spot, sun, area */
    assert_int_equal(types & (1 << (8 + PGI__MAT_PLASTIC) | 1 << (8 + PGI__MAT_PHONG)), /* both lobes */
                     1 << (8 + PGI__MAT_PLASTIC) | 1 << (8 + PGI__MAT_PHONG));
    compare(s, "lights-glossy", 200000, 5);
    pgi_scene_destroy(s);
    tu_rm_tmpdir(dir);
}

/* Same bytes on two runs, and with small batches (many launches): the photons and `emitted` do
 * not depend on how the paths are split. */
static void test_deterministic(void **state) {
    (void)state;
    pgi_scene *s = tu_scene("cornell-mirrors");
    pgi__gpu_scene *gs = NULL;
    pgi__gpu_trace *gt = NULL;
    TU_CHECK_OK(pgi__gpu_scene_create(g_gpu, s, &gs));
    TU_CHECK_OK(pgi__gpu_trace_create(g_gpu, gs, &gt));
    const uint32_t n = 20000;
    pgi_photons ph[3] = {{0}};
    pgi__gpu_trace_desc d = {.photons = n, .bounces = 5, .seed = 11};
    pgi__gpu_trace_result r[3];
    for (int k = 0; k < 3; k++) {
        TU_CHECK_OK(pgi_photons_alloc(&ph[k], n));
        pgi__gpu_trace_set_max_batch(gt, k == 2 ? 777 : 0);
        TU_CHECK_OK(pgi__gpu_trace_run(gt, s, &d, &r[k]));
        TU_CHECK_OK(pgi__gpu_trace_download(gt, &ph[k]));
        fprintf(stderr, "  run %d: %u photons, %llu emitted, %d batches, %llu discarded\n", k, r[k].count,
                (unsigned long long)r[k].emitted, r[k].batches, (unsigned long long)r[k].paths_discarded);
    }
    for (int k = 1; k < 3; k++) {
        assert_int_equal(ph[k].count, n);
        assert_int_equal(ph[k].emitted, ph[0].emitted);
        float *a[] = {ph[0].px, ph[0].py, ph[0].pz, ph[0].dx, ph[0].dy, ph[0].dz, ph[0].fr, ph[0].fg, ph[0].fb};
        float *b[] = {ph[k].px, ph[k].py, ph[k].pz, ph[k].dx, ph[k].dy, ph[k].dz, ph[k].fr, ph[k].fg, ph[k].fb};
        for (int c = 0; c < 9; c++) assert_memory_equal(a[c], b[c], n * sizeof(float));
    }
    assert_true(r[2].batches > r[0].batches);
    /* another seed: other photons */
    d.seed = 12;
    TU_CHECK_OK(pgi__gpu_trace_run(gt, s, &d, &r[1]));
    TU_CHECK_OK(pgi__gpu_trace_download(gt, &ph[1]));
    assert_memory_not_equal(ph[0].px, ph[1].px, n * sizeof(float));
    for (int k = 0; k < 3; k++) pgi_photons_free(&ph[k]);
    pgi__gpu_trace_destroy(gt);
    pgi__gpu_scene_destroy(gs);
    pgi_scene_destroy(s);
}

static double image_mean(const pgi_image *im) {
    double m = 0.0;
    const size_t n = 3 * (size_t)im->width * im->height;
    for (size_t i = 0; i < n; i++) m += im->rgb[i];
    return m / (double)n;
}

/* The whole frame on the device (photons traced there: the CPU tracer does not run) against the
 * CPU's frame: image mean within 1 %, PSNR >= 40 dB at a high photon count (the two photon maps
 * are independent: their noise is what the PSNR sees); the frame's photon stats. */
static void frame_vs_cpu(const char *scene, uint32_t photons, pgi_output out, int w, int h) {
    pgi_scene *s = tu_scene(scene);
    pgi_renderer *r = tu_renderer(s);
    pgi_render_desc d = {0};
    d.width = w;
    d.height = h;
    d.photons = photons;
    d.direct_samples = 256;
    d.output = out;
    d.seed = 5;
    d.estimator = "hashgrid";
    pgi_image ci = {0}, gi = {0};
    pgi_frame_stats cs, gs;
    d.device = PGI_DEVICE_CPU;
    TU_CHECK_OK(pgi_renderer_render(r, &d, &ci, &cs));
    d.device = PGI_DEVICE_VULKAN;
    TU_CHECK_OK(pgi_renderer_render(r, &d, &gi, &gs));
    pgi_metrics m;
    TU_CHECK_OK(pgi_metrics_compute(&gi, &ci, 1.f, &m));
    const double mc = image_mean(&ci), mg = image_mean(&gi);
    fprintf(stderr,
            "  %-10s %ux%u %u photons: mean CPU %.6g GPU %.6g (%+.3f %%), PSNR %.2f dB; trace CPU %.1f ms, GPU %.1f "
            "ms; emitted CPU %llu GPU %llu, stored %llu / %llu, photon rays %llu / %llu, discarded %llu / %llu\n",
            scene, w, h, photons, mc, mg, 100.0 * (mg - mc) / mc, m.psnr, cs.trace_ms, gs.trace_ms,
            (unsigned long long)cs.photons_emitted, (unsigned long long)gs.photons_emitted,
            (unsigned long long)cs.photons_stored, (unsigned long long)gs.photons_stored,
            (unsigned long long)cs.photon_rays, (unsigned long long)gs.photon_rays,
            (unsigned long long)cs.photon_paths_discarded, (unsigned long long)gs.photon_paths_discarded);
    assert_true(fabs(mg - mc) <= 0.01 * mc);
    assert_true(m.psnr >= 40.0);
    assert_int_equal(gs.photons_stored, photons);
    assert_true(gs.photons_emitted > 0 && gs.photon_rays > gs.photons_emitted);
    assert_true(gs.photon_paths_discarded * 20 <= gs.photons_emitted);
    int pass = 0, mem = 0;
    for (int k = 0; k < gs.pass_count; k++) pass += strcmp(gs.passes_ms[k].name, "gpu_trace") == 0;
    for (int k = 0; k < gs.memory_count; k++)
        mem += strcmp(gs.memory_bytes[k].name, "gpu_photons") == 0 ||
               strcmp(gs.memory_bytes[k].name, "gpu_trace_scratch") == 0;
    assert_int_equal(pass, 1);
    assert_int_equal(mem, 2);
    pgi_image_free(&ci);
    pgi_image_free(&gi);
    pgi_renderer_destroy(r);
    pgi_scene_destroy(s);
}

static void test_frame(void **state) {
    (void)state;
    /* 1M photons: 43.5 dB (200k: 37 dB). Cornell with mirrors and glass is left to the photon
       statistics above: its caustics make the image mean of a small frame vary by +-1.5 % from
       seed to seed on the CPU alone. */
    frame_vs_cpu("cornell", 1000000, PGI_OUTPUT_ALL, 64, 48);
}

static void expect_refused(const pgi__gpu_trace_desc *d, const char *word) {
    assert_int_equal(pgi__gpu_trace_check(d), PGI_ERR_UNSUPPORTED);
    fprintf(stderr, "  refused: %s\n", pgi_last_error());
    assert_non_null(strstr(pgi_last_error(), word));
}

static void test_unsupported(void **state) {
    (void)state;
    pgi__gpu_trace_desc d = {.photons = 1000, .bounces = 4, .seed = 1};
    TU_CHECK_OK(pgi__gpu_trace_check(&d));
    d.radius_policy = PGI_RADIUS_PATH;
    expect_refused(&d, "radius-policy path");
    d.radius_policy = PGI_RADIUS_DIFFERENTIALS;
    expect_refused(&d, "radius-policy differentials");
    d.radius_policy = PGI_RADIUS_FIXED;
    d.emission = PGI_EMISSION_GUIDED;
    expect_refused(&d, "emission guided");
    d.emission = PGI_EMISSION_AUTO;
    expect_refused(&d, "emission auto");
    d.emission = PGI_EMISSION_PORTAL;
    expect_refused(&d, "emission portal");
    d.emission = PGI_EMISSION_UNIFORM;
    d.store = PGI_STORE_VIEW;
    expect_refused(&d, "store view");
}

int main(void) {
    tu_keep_lavapipe_loaded();
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_unsupported),
        cmocka_unit_test(test_deterministic),
        cmocka_unit_test(test_cornell),
        cmocka_unit_test(test_cornell_coloured),
        cmocka_unit_test(test_cornell_mirrors),
        cmocka_unit_test(test_lights_glossy),
        cmocka_unit_test(test_sky),
        cmocka_unit_test(test_sibenik),
        cmocka_unit_test(test_frame),
    };
    return cmocka_run_group_tests(tests, tu_gpu_setup, tu_gpu_teardown);
}
