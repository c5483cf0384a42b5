/* Photon tracing on the GPU (src/gpu/gpu_trace.h, shaders/trace.comp) against the CPU tracer
 * (src/photon/trace.c), on whatever Vulkan device the loader finds (CI: lavapipe, a CPU: small
 * photon counts). The two draw different random numbers, so they are compared statistically:
 * photons stored per path emitted within 1 %, total stored flux within 1 %, mean photon position
 * within 1 % of the scene's diagonal, mean incoming direction within 0.01 (Cornell; Cornell with a
 * mirror and a glass sphere; spot, sun and glossy objects; a constant sky; Sibenik, textured,
 * when the large scenes are there). And: the same
 * bytes on two runs and with any batch size, few paths traced for nothing (<= 5 %), the options the
 * GPU lacks refused with a message naming them. Footprints (radius policies path and differentials):
 * GPU against CPU distributions, a closed-form case on both, the same bytes with any batch size.
 * Built and run only with the Vulkan backend. */
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

/* A GPU tracer of scene s (its GPU scene into *gs). */
static pgi__gpu_trace *tracer_of(pgi_scene *s, pgi__gpu_scene **gs) {
    pgi__gpu_trace *gt = NULL;
    TU_CHECK_OK(pgi__gpu_scene_create(g_gpu, s, gs));
    TU_CHECK_OK(pgi__gpu_trace_create(g_gpu, *gs, &gt));
    return gt;
}

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
    pgi__gpu_trace *gt = tracer_of(s, &gs);
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
 * Blinn-Phong (its description written into dir). */
static pgi_scene *lights_glossy_scene(const char *dir) {
    char path[700];
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
    return s;
}

static void test_lights_glossy(void **state) {
    (void)state;
    char dir[512];
    tu_make_tmpdir(dir, sizeof dir);
    pgi_scene *s = lights_glossy_scene(dir);
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
    pgi__gpu_trace *gt = tracer_of(s, &gs);
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

/* ------------------------------------------------------------ footprints (radius policies) */

/* Host footprint arrays for ph (radius, and the semi-axes for ellipsoids); free with fp_free. */
static void fp_alloc(pgi_photons *ph, uint32_t n, int ellipsoids) {
    TU_CHECK_OK(pgi_photons_alloc(ph, n));
    float *b = calloc((size_t)n * (ellipsoids ? 7 : 1), sizeof *b);
    assert_non_null(b);
    ph->radius = b;
    if (ellipsoids) {
        float **ax[] = {&ph->sax, &ph->say, &ph->saz, &ph->sbx, &ph->sby, &ph->sbz};
        for (int k = 0; k < 6; k++) *ax[k] = b + (size_t)(k + 1) * n;
    }
}
static void fp_free(pgi_photons *ph) {
    free(ph->radius);
    ph->radius = ph->sax = ph->say = ph->saz = ph->sbx = ph->sby = ph->sbz = NULL;
    pgi_photons_free(ph);
}

static int cmp_float(const void *a, const void *b) {
    const float x = *(const float *)a, y = *(const float *)b;
    return (x > y) - (x < y);
}

typedef struct fp_stats {
    double mean_r, mean_area, q[3]; /* mean r, mean r^2 (= |a x b| for ellipsoids), r's 10/50/90 % quantiles */
    double small;                   /* fraction of photons with r < 0.9 r_max */
} fp_stats;

static fp_stats footprint_stats(const pgi_photons *ph, float r_max) {
    fp_stats f = {0};
    const size_t n = ph->count;
    float *r = malloc(n * sizeof *r);
    assert_non_null(r);
    for (size_t j = 0; j < n; j++) {
        r[j] = ph->radius[j];
        f.mean_r += r[j];
        f.mean_area += (double)r[j] * r[j];
        f.small += r[j] < 0.9f * r_max;
    }
    qsort(r, n, sizeof *r, cmp_float);
    const double qs[3] = {0.1, 0.5, 0.9};
    for (int k = 0; k < 3; k++) f.q[k] = r[(size_t)(qs[k] * (double)(n - 1))];
    f.mean_r /= (double)n, f.mean_area /= (double)n, f.small /= (double)n;
    free(r);
    return f;
}

/* Each GPU record: the normal a unit vector facing the photon's incoming direction; spheres with
 * zero axes, ellipsoids with tangent axes and r = sqrt(|a x b|); r within r_max. */
static void check_records(const pgi_photons *ph, int ellipsoids, float r_max) {
    for (size_t j = 0; j < ph->count; j++) {
        const float n[3] = {ph->nx[j], ph->ny[j], ph->nz[j]}, d[3] = {ph->dx[j], ph->dy[j], ph->dz[j]};
        assert_true(fabs(tu_dot(n, n) - 1.0) < 1e-4 && tu_dot(n, d) >= -1e-6f);
        assert_true(ph->radius[j] > 0.f && ph->radius[j] <= r_max * 1.0001f);
        if (!ellipsoids) continue;
        const float a[3] = {ph->sax[j], ph->say[j], ph->saz[j]}, b[3] = {ph->sbx[j], ph->sby[j], ph->sbz[j]};
        const double la = sqrt(tu_dot(a, a)), lb = sqrt(tu_dot(b, b));
        assert_true(fabs(tu_dot(a, n)) <= 1e-3 * la + 1e-9 && fabs(tu_dot(b, n)) <= 1e-3 * lb + 1e-9);
        const double c[3] = {(double)a[1] * b[2] - (double)a[2] * b[1], (double)a[2] * b[0] - (double)a[0] * b[2],
                             (double)a[0] * b[1] - (double)a[1] * b[0]};
        const double area = sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]);
        assert_true(fabs(sqrt(area) - ph->radius[j]) <= 1e-3 * ph->radius[j]);
    }
}

/* GPU and CPU footprints of scene s under `policy`: the same distribution (mean r, mean area, the
 * 10/50/90 % quantiles of r within 3 %; the fraction of photons below 0.9 r_max and each bin's share
 * of the histogram of the radius before the clamp within 0.03); each GPU record well formed. */
static void compare_footprints(pgi_scene *s, const char *what, int policy, uint32_t photons, int bounces) {
    const int ell = policy == PGI_RADIUS_DIFFERENTIALS;
    const float r_max = 0.02f * pgi__scene_diagonal(s), r_min = r_max / 8.f; /* the renderer's defaults */
    pgi__rt *rt = NULL;
    TU_CHECK_OK(pgi__rt_create(s, &rt));
    pgi_photons cpu = {0}, gpu = {0};
    fp_alloc(&cpu, photons, ell);
    fp_alloc(&gpu, photons, ell);
    pgi__trace_desc td = {.photons = photons,
                          .bounces = bounces,
                          .seed = 7,
                          .threads = 2,
                          .radius_policy = policy,
                          .r_min = r_min,
                          .r_max = r_max};
    uint64_t hist[PGI_FOOTPRINT_BINS] = {0};
    td.footprint_hist = hist;
    pgi__trace_scratch sc = {0};
    uint64_t crays = 0;
    TU_CHECK_OK(pgi__photons_trace(s, rt, &td, &cpu, &sc, &crays));
    pgi__trace_scratch_free(&sc);
    pgi__gpu_scene *gs = NULL;
    pgi__gpu_trace *gt = tracer_of(s, &gs);
    pgi__gpu_trace_desc gd =
        {.photons = photons, .bounces = bounces, .seed = 7, .radius_policy = policy, .r_min = r_min, .r_max = r_max};
    pgi__gpu_trace_result r;
    TU_CHECK_OK(pgi__gpu_trace_run(gt, s, &gd, &r));
    int e = -1;
    assert_non_null(pgi__gpu_trace_footprints(gt, &e));
    assert_int_equal(e, ell);
    TU_CHECK_OK(pgi__gpu_trace_download(gt, &gpu));
    assert_int_equal(gpu.count, photons);
    check_records(&gpu, ell, r_max);
    const fp_stats a = footprint_stats(&gpu, r_max), b = footprint_stats(&cpu, r_max);
    fprintf(stderr,
            "  %-16s %-13s %u photons, trace %.1f ms (device): mean r GPU %.5g CPU %.5g (%+.2f %%), mean area GPU "
            "%.5g CPU %.5g (%+.2f %%)\n"
            "  %-16s %-13s r quantiles 10/50/90 %% GPU %.5g %.5g %.5g CPU %.5g %.5g %.5g; below 0.9 r_max GPU "
            "%.4f CPU %.4f\n",
            what, ell ? "differentials" : "path", photons, r.trace_ms, a.mean_r, b.mean_r,
            100.0 * (a.mean_r - b.mean_r) / b.mean_r, a.mean_area, b.mean_area,
            100.0 * (a.mean_area - b.mean_area) / b.mean_area, what, ell ? "differentials" : "path", a.q[0], a.q[1],
            a.q[2], b.q[0], b.q[1], b.q[2], a.small, b.small);
    assert_true(rel(a.mean_r, b.mean_r) <= 0.03);
    assert_true(rel(a.mean_area, b.mean_area) <= 0.03);
    for (int k = 0; k < 3; k++) assert_true(rel(a.q[k], b.q[k]) <= 0.03);
    assert_true(fabs(a.small - b.small) <= 0.03);
    uint64_t sum = 0;
    double worst = 0.0;
    for (int k = 0; k < PGI_FOOTPRINT_BINS; k++) {
        sum += r.footprint_hist[k];
        worst = fmax(worst, fabs((double)r.footprint_hist[k] - (double)hist[k]) / photons);
    }
    fprintf(stderr, "  %-16s %-13s histogram of r before the clamp: bin shares within %.4f\n", what,
            ell ? "differentials" : "path", worst);
    assert_int_equal(sum, photons);
    assert_true(worst <= 0.03);
    pgi__gpu_trace_destroy(gt);
    pgi__gpu_scene_destroy(gs);
    fp_free(&cpu);
    fp_free(&gpu);
    pgi__rt_destroy(rt);
}

/* The footprint records follow the photons' compaction: the same bytes with 777-path batches (both
 * policies, cornell-mirrors); none after a fixed-radius run. */
static void test_footprints_deterministic(void **state) {
    (void)state;
    pgi_scene *s = tu_scene("cornell-mirrors");
    pgi__gpu_scene *gs = NULL;
    pgi__gpu_trace *gt = tracer_of(s, &gs);
    const uint32_t n = 20000;
    for (int policy = PGI_RADIUS_PATH; policy <= PGI_RADIUS_DIFFERENTIALS; policy++) {
        const int ell = policy == PGI_RADIUS_DIFFERENTIALS;
        pgi_photons ph[2] = {{0}};
        pgi__gpu_trace_desc d =
            {.photons = n, .bounces = 5, .seed = 11, .radius_policy = policy, .r_min = 0.01f, .r_max = 0.08f};
        pgi__gpu_trace_result r[2];
        for (int k = 0; k < 2; k++) {
            fp_alloc(&ph[k], n, ell);
            pgi__gpu_trace_set_max_batch(gt, k ? 777 : 0);
            TU_CHECK_OK(pgi__gpu_trace_run(gt, s, &d, &r[k]));
            TU_CHECK_OK(pgi__gpu_trace_download(gt, &ph[k]));
            assert_int_equal(ph[k].count, n);
        }
        assert_true(r[1].batches > r[0].batches);
        assert_memory_equal(ph[0].px, ph[1].px, n * sizeof(float));
        assert_memory_equal(ph[0].radius, ph[1].radius, n * sizeof(float));
        assert_memory_equal(ph[0].nx, ph[1].nx, n * sizeof(float));
        if (ell) assert_memory_equal(ph[0].sax, ph[1].sax, 6 * (size_t)n * sizeof(float));
        for (int k = 0; k < 2; k++) fp_free(&ph[k]);
        d.radius_policy = PGI_RADIUS_FIXED;
        TU_CHECK_OK(pgi__gpu_trace_run(gt, s, &d, &r[0]));
        assert_null(pgi__gpu_trace_footprints(gt, NULL));
    }
    pgi__gpu_trace_destroy(gt);
    pgi__gpu_scene_destroy(gs);
    pgi_scene_destroy(s);
}

/* compare_footprints for both policies on scene `name`. */
static void compare_policies(const char *name, uint32_t photons, int bounces) {
    pgi_scene *s = tu_scene(name);
    for (int policy = PGI_RADIUS_PATH; policy <= PGI_RADIUS_DIFFERENTIALS; policy++)
        compare_footprints(s, name, policy, photons, bounces);
    pgi_scene_destroy(s);
}

static void test_footprints_cornell(void **state) {
    (void)state;
    compare_policies("cornell", 200000, 4);
}

/* Mirror and glass: the path policy's caustic photons (r well below r_max), the differentials'
 * reflection and refraction with the sphere's interpolated normals. */
static void test_footprints_mirrors(void **state) {
    (void)state;
    compare_policies("cornell-mirrors", 200000, 6);
}

/* Every light type's emission differentials: spot, sun and area (lights-glossy), the sky
 * (window-box). */
static void test_footprints_lights(void **state) {
    (void)state;
    char dir[512];
    tu_make_tmpdir(dir, sizeof dir);
    pgi_scene *s = lights_glossy_scene(dir);
    compare_footprints(s, "lights-glossy", PGI_RADIUS_DIFFERENTIALS, 100000, 5);
    pgi_scene_destroy(s);
    tu_rm_tmpdir(dir);
    s = tu_scene("window-box");
    compare_footprints(s, "window-box", PGI_RADIUS_DIFFERENTIALS, 40000, 4);
    pgi_scene_destroy(s);
}

/* A point light between two parallel Lambertian planes (kd 0.5) a distance H apart, one bounce:
 * every photon is stored on one plane after a diffuse bounce on the other, and its footprint is
 * known from the photon alone (tests/test_differentials.c's cases, chained). The bounce point is
 * x1 = p + wi L with cos2 = |wi.n|, L = H / cos2; the light is t1 = |x1 - light| away from it at
 * cos1. Differentials: the re-emitted origin offset v = t1 / sqrt(cos1) (eq. 13, pl = 1), roulette
 * R = 0.5 (1/sqrt(R)), transfer over L: semi-axes s Delta ((v + L) / sqrt(R))^(1/4) times
 * cos2^(-1/4) along the plane of incidence, so r = s Delta ((v + L)^2 / (R cos2))^(1/8) and the axis
 * ratio cos2^(-1/4). Path: rho = (0.5 / pi) cos2 1e-3, r = r_min + (r_max - r_min) sqrt(1 - rho). */
/* The worst error of ph's footprints against the planes' analytic ones (below), in units of the
 * tolerance (pass: <= 1): differentials r to 1e-4; path rho = 1 - r^2 (r_min 0, r_max 1) to 1 % plus
 * 4e-7 (a float r near 1); the worst relative error of the ellipses' axis ratio into *ratio_err. */
static double analytic_error(const pgi_photons *ph, int ell, double eps, double *ratio_err) {
    const double H = 2.0, light[3] = {0.0, 0.5, 0.0}, R = 0.5, sm = 1.0,
                 delta = sqrt(4.0 * 3.14159265358979 / ph->count);
    double worst = 0.0;
    *ratio_err = 0.0;
    for (size_t j = 0; j < ph->count; j++) {
        const double p[3] = {ph->px[j], ph->py[j], ph->pz[j]}, wi[3] = {ph->dx[j], ph->dy[j], ph->dz[j]};
        const double cos2 = fabs(wi[1]), L = H / cos2;
        double got, want;
        if (ell) {
            /* the bounce's ray left eps off the plane: Lt to p, its origin above x1 */
            const double Lt = L - eps / cos2, ys = p[1] > 1.0 ? 0.0 : H;
            assert_true(fabs(p[1] - (H - ys)) < 1e-4);
            const double x1[3] = {p[0] + wi[0] * Lt, ys, p[2] + wi[2] * Lt};
            const double e[3] = {x1[0] - light[0], x1[1] - light[1], x1[2] - light[2]};
            const double t1 = sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2]), cos1 = fabs(e[1]) / t1;
            const double v = t1 / sqrt(cos1);
            want = sm * delta * pow((v + Lt) * (v + Lt) / (R * cos2), 0.125);
            got = ph->radius[j];
            const float a[3] = {ph->sax[j], ph->say[j], ph->saz[j]}, b[3] = {ph->sbx[j], ph->sby[j], ph->sbz[j]};
            *ratio_err = fmax(*ratio_err, fabs(sqrt(tu_dot(a, a) / tu_dot(b, b)) * pow(cos2, 0.25) - 1.0));
        } else {
            want = (0.5 / 3.14159265358979) * cos2 * 1e-3; /* rho, from r = sqrt(1 - rho) */
            got = 1.0 - (double)ph->radius[j] * ph->radius[j];
        }
        worst = fmax(worst, fabs(got - want) / (ell ? 1e-4 * want : 4e-7 + 1e-2 * want));
    }
    return worst;
}

/* A point light between two parallel Lambertian planes (kd 0.5) a distance H apart, one bounce:
 * every photon is stored on one plane after a diffuse bounce on the other, and its footprint is
 * known from the photon alone (tests/test_differentials.c's cases, chained). The bounce point is
 * x1 = p + wi L with cos2 = |wi.n|, L = H / cos2; the light is t1 = |x1 - light| away from it at
 * cos1. Differentials: the re-emitted origin offset v = t1 / sqrt(cos1) (eq. 13, pl = 1), roulette
 * R = 0.5 (1/sqrt(R)), transfer over L: semi-axes s Delta ((v + L) / sqrt(R))^(1/4) times
 * cos2^(-1/4) along the plane of incidence, so r = s Delta ((v + L)^2 / (R cos2))^(1/8) and the axis
 * ratio cos2^(-1/4). Path: rho = (0.5 / pi) cos2 1e-3, r = r_min + (r_max - r_min) sqrt(1 - rho).
 * The GPU's and the CPU's photons both. */
static void test_footprints_analytic(void **state) {
    (void)state;
    char dir[512], path[700], text[1024];
    tu_make_tmpdir(dir, sizeof dir);
    snprintf(path, sizeof path, "%s/planes.mtl", dir);
    assert_int_equal(tu_write_file(path, "newmtl grey\nKd 0.5 0.5 0.5\nKs 0 0 0\n"), 0);
    snprintf(path, sizeof path, "%s/planes.obj", dir);
    assert_int_equal(tu_write_file(path, "mtllib planes.mtl\nusemtl grey\n"
                                         "v -400 0 -400\nv 400 0 -400\nv 400 0 400\nv -400 0 400\n"
                                         "v -400 2 -400\nv 400 2 -400\nv 400 2 400\nv -400 2 400\n"
                                         "f 1 3 2\nf 1 4 3\nf 5 6 7\nf 5 7 8\n"),
                     0);
    snprintf(text, sizeof text,
             "{\"name\": \"planes\", \"mesh\": \"%s\", \"lights\": [{\"type\": \"point\", \"position\": [0, 0.5, 0], "
             "\"intensity\": [1, 1, 1]}]}",
             path);
    pgi_scene *s = tu_scene_text(dir, "planes.json", text, path, sizeof path);
    const uint32_t n = 20000;
    pgi__rt *rt = NULL;
    TU_CHECK_OK(pgi__rt_create(s, &rt));
    pgi__gpu_scene *gs = NULL;
    pgi__gpu_trace *gt = tracer_of(s, &gs);
    for (int policy = PGI_RADIUS_PATH; policy <= PGI_RADIUS_DIFFERENTIALS; policy++) {
        const int ell = policy == PGI_RADIUS_DIFFERENTIALS;
        pgi_photons ph = {0}, cpu = {0};
        fp_alloc(&ph, n, ell);
        fp_alloc(&cpu, n, ell);
        /* r_max large: no clamp for the differentials; [0, 1] for the path policy */
        const float r_max = ell ? 100.f : 1.f;
        const pgi__gpu_trace_desc gd =
            {.photons = n, .bounces = 1, .seed = 3, .radius_policy = policy, .r_max = r_max, .smoothing = 1.f};
        pgi__gpu_trace_result r;
        TU_CHECK_OK(pgi__gpu_trace_run(gt, s, &gd, &r));
        TU_CHECK_OK(pgi__gpu_trace_download(gt, &ph));
        assert_int_equal(ph.count, n);
        pgi__trace_desc td = {.photons = n,
                              .bounces = 1,
                              .seed = 3,
                              .threads = 2,
                              .radius_policy = policy,
                              .r_max = r_max,
                              .smoothing = 1.f};
        pgi__trace_scratch sc = {0};
        uint64_t crays = 0;
        TU_CHECK_OK(pgi__photons_trace(s, rt, &td, &cpu, &sc, &crays));
        pgi__trace_scratch_free(&sc);
        double gr, cr;
        const double ge = analytic_error(&ph, ell, pgi__scene_epsilon(s), &gr),
                     ce = analytic_error(&cpu, ell, pgi__scene_epsilon(s), &cr);
        fprintf(stderr,
                "  analytic %-13s %u photons: worst error / tolerance GPU %.3f CPU %.3f (axis ratio %.2e, %.2e)\n",
                ell ? "differentials" : "path", n, ge, ce, gr, cr);
        assert_true(ge <= 1.0 && ce <= 1.0);
        assert_true(gr <= 1e-4 && cr <= 1e-4);
        fp_free(&ph);
        fp_free(&cpu);
    }
    pgi__gpu_trace_destroy(gt);
    pgi__gpu_scene_destroy(gs);
    pgi__rt_destroy(rt);
    pgi_scene_destroy(s);
    tu_rm_tmpdir(dir);
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
    /* the radius policies are traced, with valid bounds */
    d.radius_policy = PGI_RADIUS_PATH;
    d.r_max = 0.1f;
    TU_CHECK_OK(pgi__gpu_trace_check(&d));
    d.radius_policy = PGI_RADIUS_DIFFERENTIALS;
    TU_CHECK_OK(pgi__gpu_trace_check(&d));
    d.r_max = 0.f;
    assert_int_equal(pgi__gpu_trace_check(&d), PGI_ERR_INVALID_ARG);
    assert_non_null(strstr(pgi_last_error(), "radius-policy differentials"));
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
        cmocka_unit_test(test_footprints_analytic),
        cmocka_unit_test(test_footprints_deterministic),
        cmocka_unit_test(test_footprints_cornell),
        cmocka_unit_test(test_footprints_mirrors),
        cmocka_unit_test(test_footprints_lights),
        cmocka_unit_test(test_frame),
    };
    return cmocka_run_group_tests(tests, tu_gpu_setup, tu_gpu_teardown);
}
