/* The "bvh" estimator (BVH paper §5): with spheres it equals "brute" (same
 * decisions, radiance within 1e-4 relative, identical contributing count) for
 * both builders and every leaf threshold; with per-photon spheres and skewed
 * ellipsoids it equals brute's footprint path, which in turn equals an
 * independent double-precision ellipsoid test; T_auto grows with the photon
 * count; bad settings are rejected. */
#include "test_util.h"

#define W 40
#define H 32

static const float k_eye[3] = {0.3f, 0.4f, 2.5f}, k_at[3] = {0.f, 0.f, 0.f}, k_up[3] = {0.f, 1.f, 0.f};

/* Photons in [-0.5, 0.5]^3; footprint: 0 none, 1 spheres, 2 ellipsoids. */
static void make_photons(pgi_photons *ph, size_t n, uint64_t seed, int footprint, float rmax) {
    TU_CHECK_OK(pgi_photons_alloc(ph, n));
    tu_rng r = tu_rng_make(seed);
    if (footprint) {
        ph->radius = malloc(n * sizeof(float));
        assert_non_null(ph->radius);
    }
    if (footprint == 2) {
        float **a[] = {&ph->sax, &ph->say, &ph->saz, &ph->sbx, &ph->sby, &ph->sbz};
        for (int k = 0; k < 6; k++) assert_non_null(*a[k] = malloc(n * sizeof(float)));
    }
    for (size_t j = 0; j < n; j++) {
        float nn[3];
        tu_random_photon(ph, j, &r, nn);
        if (footprint == 1) ph->radius[j] = tu_range(&r, 0.02f, rmax);
        if (footprint == 2) {
            /* two skewed (non-orthogonal) axes in the tangent plane of n */
            float t[3], b[3], u[3];
            tu_unit_vec(&r, u);
            t[0] = u[1] * nn[2] - u[2] * nn[1], t[1] = u[2] * nn[0] - u[0] * nn[2], t[2] = u[0] * nn[1] - u[1] * nn[0];
            tu_normalize(t);
            b[0] = nn[1] * t[2] - nn[2] * t[1], b[1] = nn[2] * t[0] - nn[0] * t[2], b[2] = nn[0] * t[1] - nn[1] * t[0];
            float la = tu_range(&r, 0.02f, rmax), lb = tu_range(&r, 0.02f, rmax), skew = tu_range(&r, -0.7f, 0.7f);
            float A[3], B[3];
            for (int k = 0; k < 3; k++) A[k] = la * t[k], B[k] = lb * (b[k] + skew * t[k]);
            ph->sax[j] = A[0], ph->say[j] = A[1], ph->saz[j] = A[2];
            ph->sbx[j] = B[0], ph->sby[j] = B[1], ph->sbz[j] = B[2];
            float cx = A[1] * B[2] - A[2] * B[1], cy = A[2] * B[0] - A[0] * B[2], cz = A[0] * B[1] - A[1] * B[0];
            ph->radius[j] = sqrtf(sqrtf(cx * cx + cy * cy + cz * cz));
        }
    }
    ph->count = n;
    ph->emitted = n;
}

static void free_photons(pgi_photons *ph) {
    float *extra[] = {ph->radius, ph->sax, ph->say, ph->saz, ph->sbx, ph->sby, ph->sbz};
    for (int k = 0; k < 7; k++) free(extra[k]);
    pgi_photons_free(ph);
}

/* Samples on camera rays at random depths inside the box; 10% invalid, 10% Phong unless lambert_only. */
static void make_samples(pgi_view_samples *vs, pgi_camera *cam, uint64_t seed, int lambert_only) {
    TU_CHECK_OK(pgi_view_samples_alloc(vs, W, H));
    pgi_camera_look_at(cam, k_eye, k_at, k_up, 25.f, W, H);
    tu_rng r = tu_rng_make(seed);
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            size_t i = (size_t)y * W + (size_t)x;
            float dir[3], pos[3], wo[3];
            tu_pixel_dir(cam, x, y, dir);
            float t = tu_range(&r, 2.0f, 3.1f);
            for (int k = 0; k < 3; k++) pos[k] = cam->eye[k] + t * dir[k];
            float kind = tu_unif(&r);
            uint8_t flags = PGI_VS_VALID | PGI_VS_PRIMARY | PGI_VS_LAMBERT;
            float ks = 0.f, shin = 0.f;
            if (!lambert_only && kind < 0.1f) flags = 0;
            else if (!lambert_only && kind < 0.2f) {
                flags = PGI_VS_VALID | PGI_VS_PRIMARY;
                ks = 0.3f;
                shin = 20.f;
            }
            for (int k = 0; k < 3; k++) wo[k] = cam->eye[k] - pos[k];
            tu_normalize(wo);
            tu_set_random_sample(vs, i, &r, pos, wo, ks, shin, t, flags);
        }
}

static const int k_leaves[] = {1, 2, 4, 8, 16, 32, 64, 128, 256, 512, 0};
#define NLEAVES (sizeof k_leaves / sizeof k_leaves[0])

/* bvh (both builders, every leaf threshold) vs brute on the same input. */
static void compare_bvh(const pgi_photons *ph, const pgi_view_samples *vs, const pgi_camera *cam, float radius,
                        const char *label) {
    size_t nf = 3 * vs->count;
    float *ref = malloc(nf * sizeof *ref), *got = malloc(nf * sizeof *got);
    assert_non_null(ref);
    assert_non_null(got);
    tu_est d = {.radius = radius};
    pgi_estimator_stats rs, gs;
    TU_CHECK_OK(tu_run_estimator("brute", &d, ph, vs, cam, ref, &rs));
    assert_true(rs.contributing > 0);
    for (int b = 0; b < 2; b++)
        for (size_t l = 0; l < NLEAVES; l++) {
            d.d.bvh.build = b;
            d.d.bvh.leaf_size = k_leaves[l];
            for (size_t i = 0; i < nf; i++) got[i] = NAN;
            TU_CHECK_OK(tu_run_estimator("bvh", &d, ph, vs, cam, got, &gs));
            char what[160];
            snprintf(what, sizeof what, "bvh %s leaf %d (used %d) vs brute, %s", b ? "vvh" : "linear", k_leaves[l],
                     gs.leaf_size, label);
            tu_expect_same(what, got, ref, nf, gs.contributing, rs.contributing);
            assert_true(gs.leaf_size >= 1);
            if (k_leaves[l]) assert_int_equal(gs.leaf_size, k_leaves[l]);
            /* the tree prunes: far fewer reads than brute for small footprints */
            if (radius < 0.1f && !ph->radius) assert_true(gs.reads < rs.reads / 4);
        }
    free(ref);
    free(got);
}

static void test_fixed_radius_random(void **state) {
    (void)state;
    const float radii[] = {0.02f, 0.08f, 2.f};
    const size_t counts[] = {6000, 3000, 500};
    for (int c = 0; c < 3; c++) {
        pgi_photons ph;
        pgi_view_samples vs;
        pgi_camera cam;
        make_photons(&ph, counts[c], 21 + (uint64_t)c, 0, 0.f);
        make_samples(&vs, &cam, 31 + (uint64_t)c, 0);
        char label[64];
        snprintf(label, sizeof label, "random, fixed r=%g", (double)radii[c]);
        compare_bvh(&ph, &vs, &cam, radii[c], label);
        free_photons(&ph);
        pgi_view_samples_free(&vs);
    }
}

/* Duplicate positions (identical Morton codes, identical centroids). */
static void test_duplicates(void **state) {
    (void)state;
    pgi_photons ph;
    pgi_view_samples vs;
    pgi_camera cam;
    make_photons(&ph, 3000, 41, 1, 0.2f);
    for (size_t j = 0; j < ph.count; j++)
        if (j % 3) ph.px[j] = ph.px[j - j % 3], ph.py[j] = ph.py[j - j % 3], ph.pz[j] = ph.pz[j - j % 3];
    make_samples(&vs, &cam, 42, 0);
    compare_bvh(&ph, &vs, &cam, 0.05f, "per-photon spheres with duplicate positions");
    free_photons(&ph);
    pgi_view_samples_free(&vs);
}

static void test_per_photon_spheres(void **state) {
    (void)state;
    pgi_photons ph;
    pgi_view_samples vs;
    pgi_camera cam;
    make_photons(&ph, 4000, 51, 1, 0.15f);
    make_samples(&vs, &cam, 52, 0);
    compare_bvh(&ph, &vs, &cam, 1.f, "per-photon spheres");
    free_photons(&ph);
    pgi_view_samples_free(&vs);
}

/* Independent reference: Lambertian samples, the ellipsoid test solved in double by Cramer's rule,
 * radiance = kd/pi * sum flux / (pi |a x b|). */
static void ellipsoid_reference(const pgi_photons *ph, const pgi_view_samples *vs, float *out, uint64_t *contrib) {
    *contrib = 0;
    for (size_t i = 0; i < vs->count; i++) {
        double s[3] = {0, 0, 0};
        const float *x = vs->pos + 3 * i, *nrm = vs->nrm + 3 * i;
        for (size_t j = 0; j < ph->count; j++) {
            double r = ph->radius[j];
            double A[3] = {ph->sax[j], ph->say[j], ph->saz[j]}, B[3] = {ph->sbx[j], ph->sby[j], ph->sbz[j]};
            double C[3] = {r * ph->nx[j], r * ph->ny[j], r * ph->nz[j]};
            double e[3] = {x[0] - ph->px[j], x[1] - ph->py[j], x[2] - ph->pz[j]};
#define DET(a, b, c)                                                                                                   \
    ((a)[0] * ((b)[1] * (c)[2] - (b)[2] * (c)[1]) - (a)[1] * ((b)[0] * (c)[2] - (b)[2] * (c)[0]) +                     \
     (a)[2] * ((b)[0] * (c)[1] - (b)[1] * (c)[0]))
            double det = DET(A, B, C);
            double u = DET(e, B, C) / det, v = DET(A, e, C) / det, w = DET(A, B, e) / det;
#undef DET
            if (!(u * u + v * v + w * w < 1.0)) continue;
            if (!(nrm[0] * ph->dx[j] + nrm[1] * ph->dy[j] + nrm[2] * ph->dz[j] > 0.f)) continue;
            double cx = A[1] * B[2] - A[2] * B[1], cy = A[2] * B[0] - A[0] * B[2], cz = A[0] * B[1] - A[1] * B[0];
            double area = 3.14159265358979 * sqrt(cx * cx + cy * cy + cz * cz);
            s[0] += ph->fr[j] / area, s[1] += ph->fg[j] / area, s[2] += ph->fb[j] / area;
            (*contrib)++;
        }
        for (int k = 0; k < 3; k++) out[3 * i + k] = (float)(vs->kd[3 * i + k] / 3.14159265358979 * s[k]);
    }
}

static void test_ellipsoids(void **state) {
    (void)state;
    pgi_photons ph;
    pgi_view_samples vs;
    pgi_camera cam;
    make_photons(&ph, 3000, 61, 2, 0.2f);
    make_samples(&vs, &cam, 62, 1);
    size_t nf = 3 * vs.count;
    float *ref = malloc(nf * sizeof *ref), *got = malloc(nf * sizeof *got);
    assert_non_null(ref);
    assert_non_null(got);
    uint64_t rc;
    ellipsoid_reference(&ph, &vs, ref, &rc);
    assert_true(rc > 100);
    tu_est d = {.radius = 1.f};
    pgi_estimator_stats st;
    TU_CHECK_OK(tu_run_estimator("brute", &d, &ph, &vs, &cam, got, &st));
    assert_int_equal(tu_compare(got, ref, nf, 1e-4, "brute ellipsoids vs double-precision reference"), 0);
    assert_int_equal(st.contributing, rc);
    free(ref);
    free(got);
    /* every bvh variant vs brute, now also with Phong and invalid samples */
    pgi_view_samples_free(&vs);
    make_samples(&vs, &cam, 63, 0);
    compare_bvh(&ph, &vs, &cam, 1.f, "skewed ellipsoids");
    free_photons(&ph);
    pgi_view_samples_free(&vs);
}

/* T_auto = round(16 + 6 * total footprint area / scene area): grows with the photon count. */
static void test_t_auto(void **state) {
    (void)state;
    pgi_view_samples vs;
    pgi_camera cam;
    make_samples(&vs, &cam, 71, 0);
    float *out = malloc(3 * vs.count * sizeof *out);
    assert_non_null(out);
    const size_t counts[] = {1000, 4000, 16000};
    int prev = 0;
    for (int c = 0; c < 3; c++) {
        pgi_photons ph;
        make_photons(&ph, counts[c], 72, 0, 0.f);
        tu_est d = {.radius = 0.1f, .scene_area = 6.f};
        pgi_estimator_stats st;
        TU_CHECK_OK(tu_run_estimator("bvh", &d, &ph, &vs, &cam, out, &st));
        int expect = (int)(16.0 + 6.0 * (double)counts[c] * 3.14159265358979 * 0.01 / 6.0 + 0.5);
        assert_int_equal(st.leaf_size, expect < 1 ? 1 : expect);
        assert_true(st.leaf_size > prev);
        prev = st.leaf_size;
        /* scene_area 0: the surface of the photons' bounding box (about 6 here) */
        d.scene_area = 0.f;
        TU_CHECK_OK(tu_run_estimator("bvh", &d, &ph, &vs, &cam, out, &st));
        assert_true(abs(st.leaf_size - expect) <= (expect - 16) / 10 + 1);
        free_photons(&ph);
    }
    free(out);
    pgi_view_samples_free(&vs);
}

static void test_errors(void **state) {
    (void)state;
    pgi_estimator *e = NULL;
    tu_est d = {.radius = 0.1f, .d.bvh.build = 2};
    assert_int_equal(tu_create("bvh", &d, &e), PGI_ERR_INVALID_ARG);
    assert_non_null(strstr(pgi_last_error(), "BVH build"));
    d.d.bvh.build = 0;
    d.d.bvh.leaf_size = -1;
    assert_int_equal(tu_create("bvh", &d, &e), PGI_ERR_INVALID_ARG);
    assert_non_null(strstr(pgi_last_error(), "leaf size"));
    d.d.bvh.leaf_size = 0;
    d.scene_area = -1.f;
    assert_int_equal(tu_create("bvh", &d, &e), PGI_ERR_INVALID_ARG);
    d.scene_area = 0.f;
    /* per-photon footprints need PGI_EST_CAP_PHOTON_RADIUS: hashgrid refuses them */
    pgi_photons ph;
    pgi_view_samples vs;
    pgi_camera cam;
    make_photons(&ph, 10, 81, 1, 0.1f);
    make_samples(&vs, &cam, 82, 0);
    float *out = malloc(3 * vs.count * sizeof *out);
    assert_non_null(out);
    assert_int_equal(tu_run_estimator("hashgrid", &d, &ph, &vs, &cam, out, NULL), PGI_ERR_INVALID_ARG);
    TU_CHECK_OK(tu_run_estimator("bvh", &d, &ph, &vs, &cam, out, NULL));
    /* ellipsoid axes without the radius array */
    float *r = ph.radius;
    ph.radius = NULL;
    ph.sax = r;
    assert_int_equal(tu_run_estimator("bvh", &d, &ph, &vs, &cam, out, NULL), PGI_ERR_INVALID_ARG);
    ph.sax = NULL;
    ph.radius = r;
    /* zero photons: zero radiance, no crash */
    ph.count = 0;
    TU_CHECK_OK(tu_run_estimator("bvh", &d, &ph, &vs, &cam, out, NULL));
    assert_true(tu_max_abs(out, 3 * vs.count) == 0.0);
    free(out);
    free_photons(&ph);
    pgi_view_samples_free(&vs);
}

/* The whole pipeline on a real scene: bvh (both builders, leaf 1, 16, 512, T_auto) vs brute, with
 * the fixed radius and with the per-photon radius policies. */
static void pipeline(const char *scene_name, int w, int h, uint32_t photons, int policy) {
    pgi_scene *scene = tu_scene(scene_name);
    pgi_renderer *r = tu_renderer(scene);
    pgi_render_desc d = {.estimator = "brute",
                         .photons = photons,
                         .width = w,
                         .height = h,
                         .output = PGI_OUTPUT_INDIRECT,
                         .seed = 3,
                         .radius_policy = policy};
    pgi_image ref = {0}, img = {0};
    pgi_frame_stats rs, fs;
    TU_CHECK_OK(pgi_renderer_render(r, &d, &ref, &rs));
    assert_true(rs.contributing > 0);
    assert_true(tu_max_abs(ref.rgb, 3 * (size_t)w * h) > 0.0);
    const int leaves[] = {1, 16, 512, 0};
    d.estimator = "bvh";
    for (int b = 0; b < 2; b++)
        for (int l = 0; l < 4; l++) {
            d.est.bvh.build = b;
            d.est.bvh.leaf_size = leaves[l];
            TU_CHECK_OK(pgi_renderer_render(r, &d, &img, &fs));
            char what[160];
            snprintf(what, sizeof what, "%s policy %d: bvh %s leaf %d (used %d) vs brute", scene_name, policy,
                     b ? "vvh" : "linear", leaves[l], fs.leaf_size);
            tu_expect_same(what, img.rgb, ref.rgb, 3 * (size_t)w * h, fs.contributing, rs.contributing);
            assert_true(fs.leaf_size >= 1);
        }
    pgi_image_free(&ref);
    pgi_image_free(&img);
    pgi_renderer_destroy(r);
    pgi_scene_destroy(scene);
}

static void test_cornell(void **state) {
    (void)state;
    pipeline("cornell", 64, 64, 20000, PGI_RADIUS_FIXED);
}

static void test_cornell_policies(void **state) {
    (void)state;
    pipeline("cornell", 48, 48, 8000, PGI_RADIUS_PATH);
    pipeline("cornell", 48, 48, 8000, PGI_RADIUS_DIFFERENTIALS);
}

static void test_sibenik(void **state) {
    (void)state;
    char mesh[1024];
    snprintf(mesh, sizeof mesh, "%s/sibenik/sibenik.obj", tu_scenes_dir());
    if (!tu_file_exists("scenes/sibenik.json") || !tu_file_exists(mesh)) {
        fprintf(stderr, "skipping: scenes/sibenik.json or %s not found\n", mesh);
        skip();
    }
    pipeline("sibenik", 64, 36, 10000, PGI_RADIUS_FIXED);
    pipeline("sibenik", 48, 27, 6000, PGI_RADIUS_DIFFERENTIALS);
}

/* Same seed, same bytes for 1, 2 and 8 threads (both builders, differentials footprints). */
static void test_determinism(void **state) {
    (void)state;
    pgi_scene *scene = tu_scene("cornell");
    for (int b = 0; b < 2; b++) {
        pgi_image ref = {0};
        const int threads[] = {1, 2, 8};
        for (int k = 0; k < 3; k++) {
            pgi_render_desc d = {.estimator = "bvh",
                                 .width = 40,
                                 .height = 40,
                                 .photons = 6000,
                                 .threads = threads[k],
                                 .seed = 7,
                                 .est.bvh.build = b,
                                 .radius_policy = PGI_RADIUS_DIFFERENTIALS,
                                 .output = PGI_OUTPUT_INDIRECT};
            pgi_image img = {0};
            TU_CHECK_OK(pgi_render(scene, &d, &img, NULL));
            if (k == 0) ref = img;
            else {
                assert_memory_equal(img.rgb, ref.rgb, 3 * 40 * 40 * sizeof(float));
                pgi_image_free(&img);
            }
        }
        pgi_image_free(&ref);
    }
    pgi_scene_destroy(scene);
}

TU_MAIN("bvh", NULL, NULL, cmocka_unit_test(test_errors), cmocka_unit_test(test_fixed_radius_random),
        cmocka_unit_test(test_duplicates), cmocka_unit_test(test_per_photon_spheres), cmocka_unit_test(test_ellipsoids),
        cmocka_unit_test(test_t_auto), cmocka_unit_test(test_cornell), cmocka_unit_test(test_cornell_policies),
        cmocka_unit_test(test_sibenik), cmocka_unit_test(test_determinism))
