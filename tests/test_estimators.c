/* Every exact estimator equals "brute" (docs/testing.md): same radiance per
 * view sample up to float summation order (relative 1e-4) and exactly the
 * same number of contributing photon reads. */
#include "test_random.h"

#include "estimators/gather.h"
#include "scene/scene_internal.h"
#include "view/view.h"

#define W 48
#define H 40

static const tu_view_setup *g_view = &k_outside;


/* Compares every exact estimator with brute on (ph, vs, cam). */
static void compare_all(const pgi_photons *ph, const pgi_view_samples *vs, const pgi_camera *cam, float radius,
                        float cell_size, const char *label) {
    size_t nf = 3 * vs->count;
    float *ref = malloc(nf * sizeof *ref), *got = malloc(nf * sizeof *got);
    assert_non_null(ref);
    assert_non_null(got);
    tu_est d = {.radius = radius, .d.hashgrid.cell_size = cell_size};
    pgi_estimator_stats rs, gs;
    TU_CHECK_OK(tu_run_estimator("brute", &d, ph, vs, cam, ref, &rs));
    int compared = 0;
    const int tiles[] = {1, 7, 32, 64}; /* 64: one tile larger than the image */
    for (size_t e = 0; e < pgi_estimator_count(); e++) {
        const pgi_estimator_vtbl *vt = pgi_estimator_at(e);
        assert_non_null(vt);
        if (!vt->exact || strcmp(vt->name, "brute") == 0) continue;
        for (size_t t = 0; t < sizeof tiles / sizeof tiles[0]; t++) {
            d.d.tiled.tile_size = tiles[t];
            for (size_t i = 0; i < nf; i++) got[i] = NAN; /* every value must be written */
            TU_CHECK_OK(tu_run_estimator(vt->name, &d, ph, vs, cam, got, &gs));
            char what[160];
            snprintf(what, sizeof what, "%s vs brute, %s, r=%g, tile %d, cell %g", vt->name, label, (double)radius,
                     tiles[t], (double)cell_size);
            tu_expect_same(what, got, ref, nf, gs.contributing, rs.contributing);
            if (gs.contributing > gs.reads)
                fail_msg("%s: contributing %llu > reads %llu", what, (unsigned long long)gs.contributing,
                         (unsigned long long)gs.reads);
            compared++;
        }
    }
    assert_true(compared > 0);
    free(ref);
    free(got);
}

typedef struct {
    float radius;
    size_t photons;
} radius_case;

/* A tiny radius (most samples see nothing), medium ones, and one larger than
 * the whole box (every photon reaches every sample; the sphere holds the eye).
 * Fewer photons for the large radii keep the tiled copies small at tile size 1. */
static const radius_case k_cases[] = {{0.015f, 20000}, {0.07f, 8000}, {0.25f, 3000}, {3.0f, 800}};

static void run_random_j(float secondary, const char *label, uint64_t seed, int jitter) {
    pgi_view_samples vs;
    pgi_camera cam;
    tu_make_samples_j(&vs, &cam, g_view, W, H, seed, secondary, jitter);
    size_t nprimary = 0, nsecondary = 0;
    for (size_t i = 0; i < vs.count; i++)
        if (vs.flags[i] & PGI_VS_VALID) (vs.flags[i] & PGI_VS_PRIMARY) ? nprimary++ : nsecondary++;
    assert_true(nprimary > 0);
    if (secondary > 0.f) assert_true(nsecondary > 0);
    for (size_t c = 0; c < sizeof k_cases / sizeof k_cases[0]; c++) {
        pgi_photons ph;
        tu_make_photons(&ph, k_cases[c].photons, seed * 31 + c);
        /* The reference must see something, or the comparison proves little. */
        float *ref = malloc(3 * vs.count * sizeof *ref);
        pgi_estimator_stats st;
        TU_CHECK_OK(tu_run_estimator("brute", &(tu_est){.radius = k_cases[c].radius}, &ph, &vs, &cam, ref, &st));
        assert_true(st.contributing > 0);
        assert_true(tu_max_abs(ref, 3 * vs.count) > 0.0);
        free(ref);
        compare_all(&ph, &vs, &cam, k_cases[c].radius, 0.f, label);
        pgi_photons_free(&ph);
    }
    pgi_view_samples_free(&vs);
}

static void run_random(float secondary, const char *label, uint64_t seed) { run_random_j(secondary, label, seed, 0); }

static void test_random_primary(void **state) { run_random(0.f, "primary samples", 11); }

/* Primary samples anywhere in their pixel (jittered frames; vs.jitter = 0.5),
 * a quarter of them on pixel edges: the screen-space methods (tiled frusta,
 * bounds polygons, cluster tiles) must still find every one. */
static void test_random_jittered(void **state) {
    run_random_j(0.1f, "jittered samples, 10% mirror samples", 14, 1);
    g_view = &k_inside;
    run_random_j(0.f, "jittered, eye inside the photons", 18, 1);
    g_view = &k_outside;
}

static void test_random_with_mirror_samples(void **state) { run_random(0.15f, "15% mirror samples", 12); }

static void test_eye_inside_photons(void **state) {
    g_view = &k_inside;
    run_random(0.f, "eye inside the photons", 16);
    run_random(0.1f, "eye inside the photons, mirror samples", 17);
    g_view = &k_outside;
}

/* Hash grid cells much smaller (and larger) than the radius: same answer. */
static void test_hashgrid_cell_sizes(void **state) {
    pgi_view_samples vs;
    pgi_camera cam;
    tu_make_samples(&vs, &cam, g_view, W, H, 13, 0.1f);
    pgi_photons ph;
    tu_make_photons(&ph, 8000, 14);
    const float r = 0.08f;
    const float cells[] = {r / 8.f, r / 3.f, r, 5.f * r};
    float *ref = malloc(3 * vs.count * sizeof *ref), *got = malloc(3 * vs.count * sizeof *got);
    pgi_estimator_stats rs, gs;
    TU_CHECK_OK(tu_run_estimator("brute", &(tu_est){.radius = r}, &ph, &vs, &cam, ref, &rs));
    assert_true(rs.contributing > 0);
    for (size_t k = 0; k < sizeof cells / sizeof cells[0]; k++) {
        tu_est d = {.radius = r, .d.hashgrid.cell_size = cells[k]};
        for (size_t i = 0; i < 3 * vs.count; i++) got[i] = NAN;
        TU_CHECK_OK(tu_run_estimator("hashgrid", &d, &ph, &vs, &cam, got, &gs));
        char what[96];
        snprintf(what, sizeof what, "hashgrid cell %g, r %g", (double)cells[k], (double)r);
        assert_int_equal(tu_compare(got, ref, 3 * vs.count, 1e-4, what), 0);
        assert_int_equal(gs.contributing, rs.contributing);
    }
    free(ref);
    free(got);
    pgi_photons_free(&ph);
    pgi_view_samples_free(&vs);
}

/* No photons: every estimator writes a zero image and counts nothing. */
static void test_zero_photons(void **state) {
    pgi_view_samples vs;
    pgi_camera cam;
    tu_make_samples(&vs, &cam, g_view, W, H, 15, 0.1f);
    pgi_photons ph;
    TU_CHECK_OK(pgi_photons_alloc(&ph, 0));
    ph.count = 0;
    float *out = malloc(3 * vs.count * sizeof *out);
    for (size_t e = 0; e < pgi_estimator_count(); e++) {
        const pgi_estimator_vtbl *vt = pgi_estimator_at(e);
        for (size_t i = 0; i < 3 * vs.count; i++) out[i] = NAN;
        pgi_estimator_stats st;
        TU_CHECK_OK(tu_run_estimator(vt->name, &(tu_est){.radius = 0.1f}, &ph, &vs, &cam, out, &st));
        for (size_t i = 0; i < 3 * vs.count; i++) {
            if (out[i] != 0.f) fail_msg("%s: value %zu is %g with no photons", vt->name, i, (double)out[i]);
        }
        assert_int_equal(st.contributing, 0);
    }
    free(out);
    pgi_photons_free(&ph);
    pgi_view_samples_free(&vs);
}

/* Bad estimator arguments are refused, not crashed on. */
static void test_create_errors(void **state) {
    pgi_estimator *e = (pgi_estimator *)1;
    assert_int_equal(tu_create("no-such-estimator", &(tu_est){.radius = 0.1f}, &e), PGI_ERR_INVALID_ARG);
    assert_null(e);
    assert_non_null(strstr(pgi_last_error(), "no-such-estimator"));
    assert_null(pgi_estimator_find("no-such-estimator"));
    const float bad[] = {0.f, -1.f, NAN, INFINITY};
    for (size_t e2 = 0; e2 < pgi_estimator_count(); e2++)
        for (size_t k = 0; k < sizeof bad / sizeof bad[0]; k++) {
            pgi_estimator *x = NULL;
            assert_int_equal(tu_create(pgi_estimator_at(e2)->name, &(tu_est){.radius = bad[k]}, &x),
                             PGI_ERR_INVALID_ARG);
            assert_null(x);
        }
    assert_non_null(pgi_estimator_find("brute"));
    assert_non_null(pgi_estimator_find("hashgrid"));
    assert_non_null(pgi_estimator_find("tiled"));
}

/* ----------------------------------------------------- full pipeline */

static void pipeline_compare(const char *scene_name, int w, int h, uint32_t photons, float radius) {
    const char *names[] = {"brute", "hashgrid", "tiled"};
    tu_pipeline_vs_brute(scene_name, w, h, photons, radius, names, 3);
}

static void test_cornell_pipeline(void **state) { pipeline_compare("cornell", 96, 96, 20000, 0.08f); }

/* The built-in mirror scene (a mirror wall, a mirror sphere, a glass sphere:
 * a third of the view seen through them, the spheres showing the whole box in
 * a few pixels): every exact estimator equals brute on the real view pass,
 * at a small and a large radius (the random-sample tests vary the tile sizes). */
static void test_cornell_mirrors_pipeline(void **state) {
    const char *exact[32];
    int ne = 0;
    for (size_t e = 0; e < pgi_estimator_count() && ne < 32; e++) {
        const pgi_estimator_vtbl *vt = pgi_estimator_at(e);
        if (vt->exact && !vt->oracle) exact[ne++] = vt->name;
    }
    assert_true(ne >= 3);
    for (int k = 0; k < ne; k += 7) { /* brute and up to 7 more a call */
        const char *names[8] = {"brute"};
        int n = 1;
        for (int j = k; j < ne && n < 8; j++) names[n++] = exact[j];
        tu_pipeline_vs_brute("cornell-mirrors", 80, 64, 15000, 0.05f, names, n);
        tu_pipeline_vs_brute("cornell-mirrors", 48, 40, 2000, 0.5f, names, n);
    }
}

static void test_sibenik_pipeline(void **state) {
    char mesh[1024];
    snprintf(mesh, sizeof mesh, "%s/sibenik/sibenik.obj", tu_scenes_dir());
    if (!tu_file_exists("scenes/sibenik.json") || !tu_file_exists(mesh)) {
        fprintf(stderr, "skipping: scenes/sibenik.json or %s not found (set PHOTONGI_SCENES, run from the repo root)\n",
                mesh);
        skip();
    }
    pipeline_compare("sibenik", 80, 45, 10000, 0.2f); /* the radius the scene shipped with (now automatic) */
}

/* A room with a mirror back wall, a glass block, a Blinn-Phong floor and an
 * emissive ceiling quad (written to a temporary folder): view samples seen
 * through the mirror and the glass (not primary), Phong samples, all from
 * the real view pass. */
static void test_mirror_glass_pipeline(void **state) {
    char dir[512], jpath[700];
    tu_make_tmpdir(dir, sizeof dir);
    assert_int_equal(tu_write_room(dir, "", jpath, sizeof jpath), 0);
    /* The view really holds samples seen through the mirror/glass, and Phong samples. */
    {
        pgi_scene *sc = NULL;
        TU_CHECK_OK(pgi_scene_load(jpath, &sc));
        pgi__rt *rt = NULL;
        TU_CHECK_OK(pgi__rt_create(sc, &rt));
        pgi_view_samples vs;
        TU_CHECK_OK(pgi_view_samples_alloc(&vs, 72, 56));
        float *emit = malloc(3 * vs.count * sizeof *emit);
        pgi_camera cam;
        const pgi_camera_def *cd = &sc->cams[0];
        pgi_camera_look_at(&cam, cd->eye, cd->look_at, cd->up, cd->fov_y_deg, 72, 56);
        uint64_t rays = 0;
        const pgi__subpixel centres = {0};
        TU_CHECK_OK(pgi__view_build(sc, rt, NULL, &cam, 1, &centres, 0, &vs, emit, NULL, &rays));
        size_t secondary = 0, phong = 0;
        for (size_t i = 0; i < vs.count; i++) {
            if (!(vs.flags[i] & PGI_VS_VALID)) continue;
            if (!(vs.flags[i] & PGI_VS_PRIMARY)) secondary++;
            if (!(vs.flags[i] & PGI_VS_LAMBERT)) phong++;
        }
        fprintf(stderr, "  room: %zu samples through mirror/glass, %zu Phong, of %zu\n", secondary, phong, vs.count);
        assert_true(secondary > vs.count / 20);
        assert_true(phong > vs.count / 20);
        free(emit);
        pgi_view_samples_free(&vs);
        pgi__rt_destroy(rt);
        pgi_scene_destroy(sc);
    }
    pipeline_compare(jpath, 72, 56, 15000, 0.1f);
    tu_rm_tmpdir(dir);
}

/* The batched glossy gather (gather.h: pgi__gather_push, pgi__gather_flush) gives pgi__gather's
 * sums and count bit for bit, in its AVX2 build and in the narrow one (pgi__cpu_narrow), for GGX
 * and Blinn-Phong lobes of several roughnesses, indices and tints, normals and views (some
 * grazing, some below the surface), photons in and out of range and from both sides, and runs
 * that fill the batch several times and end part full. */
static void test_glossy_batch_bits(void **state) {
    (void)state;
    tu_rng r = tu_rng_make(41);
    enum { NP = 300 };
    static float ph[NP][9];
    int multi = 0; /* cases whose batch filled at least once, with a specular sum */
    for (int it = 0; it < 400; it++) {
        pgi__vs v;
        memset(&v, 0, sizeof v);
        float n[3], wo[3];
        tu_unit_vec(&r, n);
        tu_unit_vec(&r, wo);
        if (it % 4 != 3 && n[0] * wo[0] + n[1] * wo[1] + n[2] * wo[2] < 0.f) /* mostly above */
            for (int d = 0; d < 3; d++) wo[d] = -wo[d];
        v.px = tu_range(&r, -1.f, 1.f), v.py = tu_range(&r, -1.f, 1.f), v.pz = tu_range(&r, -1.f, 1.f);
        v.nx = n[0], v.ny = n[1], v.nz = n[2];
        v.wo = v3(wo[0], wo[1], wo[2]);
        v.kd = v3(tu_unif(&r), tu_unif(&r), it % 5 == 0 ? 0.f : tu_unif(&r));
        v.lambert = 0;
        const pgi__lobe_model model = it % 3 == 2 ? PGI__LOBE_PHONG : PGI__LOBE_GGX;
        const float ks[3] = {tu_unif(&r), tu_unif(&r), tu_unif(&r)};
        const float sh = model == PGI__LOBE_PHONG ? tu_range(&r, 1.f, 2000.f) : tu_range(&r, 0.f, 1.1f);
        pgi__lobe_init(&v.lobe, model, v3(ks[0], ks[1], ks[2]), sh, tu_range(&r, 1.f, 3.f));
        v.one_m_eo = pgi__lobe_one_m_eo(&v.lobe, v3(v.nx, v.ny, v.nz), v.wo);
        const float r2 = tu_range(&r, 0.1f, 2.f);
        const int np = (int)(tu_next(&r) % NP);
        for (int j = 0; j < np; j++) {
            float w[3];
            tu_unit_vec(&r, w);
            ph[j][0] = v.px + tu_range(&r, -1.f, 1.f), ph[j][1] = v.py + tu_range(&r, -1.f, 1.f);
            ph[j][2] = v.pz + tu_range(&r, -1.f, 1.f);
            ph[j][3] = w[0], ph[j][4] = w[1], ph[j][5] = w[2];
            ph[j][6] = tu_unif(&r), ph[j][7] = tu_unif(&r), ph[j][8] = tu_unif(&r);
        }
        pgi__acc ref = {0};
        for (int j = 0; j < np; j++)
            pgi__gather(&v, r2, ph[j][0], ph[j][1], ph[j][2], ph[j][3], ph[j][4], ph[j][5], ph[j][6], ph[j][7],
                        ph[j][8], &ref);
        multi += ref.contributing > PGI__GATHER_BATCH && ref.sr > 0.f;
        for (int narrow = 0; narrow < 2; narrow++) {
#if defined(__x86_64__) || defined(__i386__)
            pgi__cpu_narrow = narrow;
#endif
            pgi__acc got = {0};
            pgi__gather_batch b;
            b.n = 0;
            for (int j = 0; j < np; j++)
                pgi__gather_push(&v, r2, ph[j][0], ph[j][1], ph[j][2], ph[j][3], ph[j][4], ph[j][5], ph[j][6], ph[j][7],
                                 ph[j][8], &got, &b);
            pgi__gather_flush(&v, &b, &got);
#if defined(__x86_64__) || defined(__i386__)
            pgi__cpu_narrow = 0;
#endif
            if (memcmp(&got, &ref, sizeof got) != 0)
                fail_msg("case %d (%s, %d photons, narrow %d): batch (%a %a %a | %a %a %a, %u) != gather (%a %a %a | "
                         "%a %a %a, %u)",
                         it, model == PGI__LOBE_GGX ? "GGX" : "Phong", np, narrow, (double)got.fr, (double)got.fg,
                         (double)got.fb, (double)got.sr, (double)got.sg, (double)got.sb, got.contributing,
                         (double)ref.fr, (double)ref.fg, (double)ref.fb, (double)ref.sr, (double)ref.sg, (double)ref.sb,
                         ref.contributing);
        }
    }
    assert_true(multi > 20);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_create_errors),         cmocka_unit_test(test_zero_photons),
        cmocka_unit_test(test_random_primary),        cmocka_unit_test(test_random_with_mirror_samples),
        cmocka_unit_test(test_random_jittered),       cmocka_unit_test(test_eye_inside_photons),
        cmocka_unit_test(test_hashgrid_cell_sizes),   cmocka_unit_test(test_cornell_pipeline),
        cmocka_unit_test(test_mirror_glass_pipeline), cmocka_unit_test(test_cornell_mirrors_pipeline),
        cmocka_unit_test(test_sibenik_pipeline),      cmocka_unit_test(test_glossy_batch_bits),
    };
    return cmocka_run_group_tests_name("estimators", tests, NULL, NULL);
}
