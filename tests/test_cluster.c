/* The cluster family (Moreau et al. 2016): cluster, cluster-cone and
 * cluster-trivial equal brute (relative 1e-4 per value, identical
 * contributing counts) on data built to exercise what makes them differ from
 * the other estimators: coherent normals (cones that reject and trivially
 * accept), photons larger than whole subtrees, large depth discontinuities,
 * samples seen through mirrors anywhere in space, Phong samples (trivial
 * accept must fall back), several cluster sizes; edge cases; determinism
 * across thread counts; directional within a stated error of cluster. */
#include <omp.h>

#include "test_util.h"

static const char *const k_exact[] = {"cluster", "cluster-cone", "cluster-trivial"};
#define NEXACT 3

typedef struct {
    int w, h;
    float phong;     /* fraction of Blinn-Phong samples */
    float secondary; /* fraction seen through a mirror (anywhere in the box, any normal) */
    int stripes;     /* 1: alternate rows of 3-pixel bands between a near and a far plane */
    float invalid;   /* fraction of sky samples */
} plane_setup;

/* A camera at z = 3 looking down -z at a floor-like plane tilted towards it
 * (normal coherent over large areas, so cones are narrow), optionally cut
 * into near/far stripes (depth discontinuities inside every tile). */
static void make_plane_samples(pgi_view_samples *vs, pgi_camera *cam, const plane_setup *ps, uint64_t seed) {
    TU_CHECK_OK(pgi_view_samples_alloc(vs, ps->w, ps->h));
    const float eye[3] = {0.f, 0.4f, 3.f}, at[3] = {0.f, 0.f, 0.f}, up[3] = {0.f, 1.f, 0.f};
    pgi_camera_look_at(cam, eye, at, up, 40.f, ps->w, ps->h);
    tu_rng r = tu_rng_make(seed);
    for (int y = 0; y < ps->h; y++)
        for (int x = 0; x < ps->w; x++) {
            size_t i = (size_t)y * ps->w + (size_t)x;
            float dir[3], pos[3], n[3] = {0.f, 0.35f, 1.f}, wo[3], kd[3];
            tu_normalize(n);
            tu_pixel_dir(cam, x, y, dir);
            /* plane through (0, 0, zp) with normal n: eye + t dir */
            float zp = (ps->stripes && ((x / 3 + y / 2) & 1)) ? -2.5f : 0.f;
            float num = n[0] * (0.f - eye[0]) + n[1] * (0.f - eye[1]) + n[2] * (zp - eye[2]);
            float t = num / tu_dot(n, dir);
            for (int k = 0; k < 3; k++) pos[k] = eye[k] + t * dir[k];
            for (int k = 0; k < 3; k++) wo[k] = -dir[k];
            tu_normalize(wo);
            /* small normal jitter, as on a bumpy surface */
            for (int k = 0; k < 3; k++) n[k] += tu_range(&r, -0.05f, 0.05f);
            tu_normalize(n);
            for (int k = 0; k < 3; k++) kd[k] = tu_range(&r, 0.2f, 0.8f);
            uint8_t flags = PGI_VS_VALID | PGI_VS_PRIMARY | PGI_VS_LAMBERT;
            float ks = 0.f, shin = 0.f;
            if (tu_unif(&r) < ps->phong) {
                flags = PGI_VS_VALID | PGI_VS_PRIMARY;
                ks = 0.3f;
                shin = 30.f;
            }
            if (tu_unif(&r) < ps->secondary) {
                flags &= (uint8_t)~PGI_VS_PRIMARY;
                for (int k = 0; k < 3; k++) pos[k] = tu_range(&r, -1.5f, 1.5f);
                tu_unit_vec(&r, n);
                tu_unit_vec(&r, wo);
                if (tu_dot(n, wo) < 0.f) n[0] = -n[0], n[1] = -n[1], n[2] = -n[2];
            }
            if (tu_unif(&r) < ps->invalid) flags = 0;
            tu_set_sample(vs, i, pos, n, wo, kd, ks, shin, t, flags);
        }
}

/* Photons on and near the plane(s), arriving mostly from above (some from
 * below: they must be rejected by the hemisphere test or the cones). */
static void make_plane_photons(pgi_photons *ph, size_t n, uint64_t seed, float spread) {
    TU_CHECK_OK(pgi_photons_alloc(ph, n));
    tu_rng r = tu_rng_make(seed);
    for (size_t j = 0; j < n; j++) {
        float d[3];
        ph->px[j] = tu_range(&r, -spread, spread);
        ph->py[j] = tu_range(&r, -spread, spread);
        ph->pz[j] = tu_range(&r, -3.f, 0.3f);
        tu_unit_vec(&r, d);
        if (tu_unif(&r) < 0.85f && d[1] + d[2] < 0.f) d[0] = -d[0], d[1] = -d[1], d[2] = -d[2];
        ph->dx[j] = d[0], ph->dy[j] = d[1], ph->dz[j] = d[2];
        ph->nx[j] = 0.f, ph->ny[j] = 0.f, ph->nz[j] = 1.f;
        ph->fr[j] = tu_range(&r, 0.01f, 1.f);
        ph->fg[j] = tu_range(&r, 0.01f, 1.f);
        ph->fb[j] = tu_range(&r, 0.01f, 1.f);
    }
    ph->count = n;
    ph->emitted = n;
}

/* Runs `name` and brute and requires equal images and contributing counts;
 * returns the estimator's stats. */
static pgi_estimator_stats expect_equal(const char *name, const tu_est *d, const pgi_photons *ph,
                                        const pgi_view_samples *vs, const pgi_camera *cam, const char *label) {
    size_t nf = 3 * vs->count;
    float *ref = malloc(nf * sizeof *ref), *got = malloc(nf * sizeof *got);
    assert_non_null(ref);
    assert_non_null(got);
    pgi_estimator_stats rs, gs;
    tu_est bd = {.radius = d->radius};
    TU_CHECK_OK(tu_run_estimator("brute", &bd, ph, vs, cam, ref, &rs));
    for (size_t i = 0; i < nf; i++) got[i] = NAN;
    TU_CHECK_OK(tu_run_estimator(name, d, ph, vs, cam, got, &gs));
    char what[200];
    snprintf(what, sizeof what, "%s vs brute, %s, r=%g, cluster tile %d", name, label, (double)d->radius,
             d->d.cluster.tile);
    tu_expect_same(what, got, ref, nf, gs.contributing, rs.contributing);
    free(ref);
    free(got);
    return gs;
}

static void plane_case(const plane_setup *ps, size_t nphotons, float radius, float spread, const char *label,
                       uint64_t seed, int check_culling) {
    pgi_view_samples vs;
    pgi_camera cam;
    make_plane_samples(&vs, &cam, ps, seed);
    pgi_photons ph;
    make_plane_photons(&ph, nphotons, seed + 1, spread);
    const int tiles[] = {0, 1, 3, 64, 100}; /* 100: tiles over 4096 samples (comparison sort path) */
    for (size_t t = 0; t < sizeof tiles / sizeof tiles[0]; t++) {
        pgi_estimator_stats st[NEXACT];
        for (int e = 0; e < NEXACT; e++) {
            tu_est d = {.radius = radius, .d.cluster.tile = tiles[t]};
            st[e] = expect_equal(k_exact[e], &d, &ph, &vs, &cam, label);
        }
        assert_true(st[0].contributing > 0);
        if (check_culling && tiles[t] == 0) {
            /* The cones drop photons from below, and trivial accept replaces
             * reads: on coherent Lambertian planes both must actually happen. */
            fprintf(stderr, "  %s: reads cluster %llu, cone %llu, trivial %llu; contributing %llu\n", label,
                    (unsigned long long)st[0].reads, (unsigned long long)st[1].reads, (unsigned long long)st[2].reads,
                    (unsigned long long)st[0].contributing);
            assert_true(st[1].reads < st[0].reads);
            if (check_culling > 1) {
                /* trivially accepted pairs are counted, not read one by one */
                assert_true(st[2].reads_bulk > 0);
                assert_true(st[2].reads - st[2].reads_bulk < st[1].reads);
                assert_true(st[2].contributing <= st[2].reads);
            }
        }
    }
    pgi_photons_free(&ph);
    pgi_view_samples_free(&vs);
}

static void test_planes_lambert(void **state) {
    plane_setup ps = {64, 48, 0.f, 0.f, 0, 0.f};
    plane_case(&ps, 6000, 0.15f, 1.5f, "Lambertian plane", 21, 1);
    /* photons larger than whole subtrees (and than the view): trivial accept high in the tree */
    plane_case(&ps, 600, 1.2f, 1.5f, "Lambertian plane, large photons", 22, 2);
}

static void test_planes_mixed(void **state) {
    plane_setup ps = {56, 40, 0.3f, 0.1f, 0, 0.05f};
    plane_case(&ps, 5000, 0.2f, 1.5f, "30% Phong, 10% mirror samples, sky", 23, 0);
    plane_case(&ps, 500, 2.f, 1.5f, "30% Phong, mirror samples, large photons", 24, 0);
}

static void test_depth_discontinuities(void **state) {
    plane_setup ps = {60, 44, 0.05f, 0.f, 1, 0.f};
    plane_case(&ps, 6000, 0.12f, 1.5f, "near/far stripes", 25, 0);
    plane_case(&ps, 800, 0.9f, 1.5f, "near/far stripes, large photons", 26, 0);
}

/* ------------------------------------------------------------ edge cases */

static void run_all_zero_ok(const pgi_photons *ph, const pgi_view_samples *vs, const pgi_camera *cam, float radius,
                            int expect_zero) {
    const char *names[] = {"cluster", "cluster-cone", "cluster-trivial", "directional"};
    float *out = malloc(3 * vs->count * sizeof *out);
    for (int e = 0; e < 4; e++) {
        for (size_t i = 0; i < 3 * vs->count; i++) out[i] = NAN;
        pgi_estimator_stats st;
        TU_CHECK_OK(tu_run_estimator(names[e], &(tu_est){.radius = radius}, ph, vs, cam, out, &st));
        for (size_t i = 0; i < 3 * vs->count; i++) {
            if (!isfinite(out[i])) fail_msg("%s: value %zu not written or not finite", names[e], i);
            if (expect_zero && out[i] != 0.f) fail_msg("%s: value %zu is %g, expected 0", names[e], i, (double)out[i]);
        }
        if (expect_zero) assert_int_equal(st.contributing, 0);
    }
    free(out);
}

static void test_sky_only(void **state) {
    plane_setup ps = {40, 30, 0.f, 0.f, 0, 1.01f}; /* every sample invalid */
    pgi_view_samples vs;
    pgi_camera cam;
    make_plane_samples(&vs, &cam, &ps, 31);
    pgi_photons ph;
    make_plane_photons(&ph, 2000, 32, 1.5f);
    run_all_zero_ok(&ph, &vs, &cam, 0.3f, 1);
    pgi_photons_free(&ph);
    pgi_view_samples_free(&vs);
}

static void test_one_sample(void **state) {
    /* a 1x1 frame, and a large frame with a single valid sample */
    plane_setup one = {1, 1, 0.f, 0.f, 0, 0.f};
    pgi_view_samples vs;
    pgi_camera cam;
    make_plane_samples(&vs, &cam, &one, 33);
    pgi_photons ph;
    make_plane_photons(&ph, 3000, 34, 0.5f);
    for (int e = 0; e < NEXACT; e++) {
        tu_est d = {.radius = 0.3f};
        pgi_estimator_stats st = expect_equal(k_exact[e], &d, &ph, &vs, &cam, "1x1 frame");
        assert_true(st.contributing > 0);
    }
    pgi_view_samples_free(&vs);
    plane_setup big = {50, 40, 0.f, 0.f, 0, 0.f};
    make_plane_samples(&vs, &cam, &big, 35);
    for (size_t i = 0; i < vs.count; i++)
        if (i != 817) vs.flags[i] = 0;
    for (int e = 0; e < NEXACT; e++) {
        tu_est d = {.radius = 0.3f, .d.cluster.tile = 4};
        pgi_estimator_stats st = expect_equal(k_exact[e], &d, &ph, &vs, &cam, "one valid sample");
        assert_true(st.contributing > 0);
    }
    run_all_zero_ok(&ph, &vs, &cam, 0.3f, 0);
    pgi_photons_free(&ph);
    pgi_view_samples_free(&vs);
}

static void test_photons_outside_frustum(void **state) {
    plane_setup ps = {48, 36, 0.1f, 0.f, 0, 0.f};
    pgi_view_samples vs;
    pgi_camera cam;
    make_plane_samples(&vs, &cam, &ps, 36);
    pgi_photons ph;
    make_plane_photons(&ph, 3000, 37, 1.f);
    for (size_t j = 0; j < ph.count; j++) ph.pz[j] = 3.5f + (float)j * 1e-4f; /* behind the eye (z = 3) */
    run_all_zero_ok(&ph, &vs, &cam, 0.3f, 1);
    pgi_photons_free(&ph);
    pgi_view_samples_free(&vs);
}

static void test_radius_larger_than_scene(void **state) {
    plane_setup ps = {40, 32, 0.2f, 0.1f, 1, 0.1f};
    pgi_view_samples vs;
    pgi_camera cam;
    make_plane_samples(&vs, &cam, &ps, 38);
    pgi_photons ph;
    make_plane_photons(&ph, 400, 39, 1.f);
    for (int e = 0; e < NEXACT; e++) {
        tu_est d = {.radius = 50.f};
        pgi_estimator_stats st = expect_equal(k_exact[e], &d, &ph, &vs, &cam, "radius 50 (whole scene)");
        assert_true(st.contributing > 0);
    }
    pgi_photons_free(&ph);
    pgi_view_samples_free(&vs);
}

static void test_create_errors(void **state) {
    const char *names[] = {"cluster", "cluster-cone", "cluster-trivial", "directional"};
    for (int e = 0; e < 4; e++) {
        pgi_estimator *x = NULL;
        tu_est bad[] = {{.radius = 0.1f, .d.cluster.tile = -1},
                        {.radius = 0.1f, .d.cluster.tile = 257},
                        {.radius = 0.1f, .d.directional.level = -2},
                        {.radius = 0.1f, .d.directional.level = 17},
                        {.radius = 0.1f, .d.directional.blur = 65}};
        for (size_t k = 0; k < sizeof bad / sizeof bad[0]; k++) {
            assert_int_equal(tu_create(names[e], &bad[k], &x), PGI_ERR_INVALID_ARG);
            assert_null(x);
            assert_non_null(strstr(pgi_last_error(), names[e]));
        }
        TU_CHECK_OK(tu_create(names[e], &(tu_est){.radius = 0.1f, .d.cluster.tile = 256}, &x));
        pgi_estimator_destroy(x);
    }
    /* only the constant kernel */
    pgi_estimator *x = NULL;
    assert_int_equal(tu_create("cluster-trivial", &(tu_est){.radius = 0.1f, .d.kernel = PGI_KERNEL_CONE}, &x),
                     PGI_ERR_INVALID_ARG);
    /* build/estimate with a camera of another size */
    plane_setup ps = {20, 10, 0.f, 0.f, 0, 0.f};
    pgi_view_samples vs;
    pgi_camera cam;
    make_plane_samples(&vs, &cam, &ps, 40);
    pgi_photons ph;
    make_plane_photons(&ph, 10, 41, 1.f);
    cam.width = 21;
    float *out = malloc(3 * vs.count * sizeof *out);
    assert_int_equal(tu_run_estimator("cluster", &(tu_est){.radius = 0.1f}, &ph, &vs, &cam, out, NULL),
                     PGI_ERR_INVALID_ARG);
    free(out);
    pgi_photons_free(&ph);
    pgi_view_samples_free(&vs);
}

/* ----------------------------------------------------- full pipeline */

static void pipeline_vs_brute(const char *scene_name, int w, int h, uint32_t photons, float radius) {
    const char *names[] = {"brute", "cluster", "cluster-cone", "cluster-trivial"};
    tu_pipeline_vs_brute(scene_name, w, h, photons, radius, names, 4);
}

static void test_cornell_pipeline(void **state) {
    pipeline_vs_brute("cornell", 96, 96, 20000, 0.08f);
    pipeline_vs_brute("cornell", 64, 48, 3000, 0.6f); /* photons larger than subtrees */
    /* mirrors and glass in view: the mirror-seen samples' own subtree keyed by position */
    pipeline_vs_brute("cornell-mirrors", 96, 96, 20000, 0.06f);
    pipeline_vs_brute("cornell-mirrors", 64, 48, 3000, 0.6f);
}

static int have_sibenik(void) {
    char mesh[1024];
    snprintf(mesh, sizeof mesh, "%s/sibenik/sibenik.obj", tu_scenes_dir());
    if (!tu_file_exists("scenes/sibenik.json") || !tu_file_exists(mesh)) {
        fprintf(stderr, "skipping: scenes/sibenik.json or %s not found (set PHOTONGI_SCENES)\n", mesh);
        return 0;
    }
    return 1;
}

static void test_sibenik_pipeline(void **state) {
    if (!have_sibenik()) skip();
    pipeline_vs_brute("sibenik", 80, 45, 10000, 0.2f); /* the radius the scene shipped with, deep views */
}

/* ------------------------------------------------------- determinism */

static void test_thread_counts(void **state) {
    pgi_scene *scene = tu_scene("cornell");
    const char *names[] = {"cluster", "cluster-cone", "cluster-trivial", "directional"};
    const int threads[] = {1, 2, 5};
    const int S = 64;
    size_t bytes = 3 * (size_t)S * S * sizeof(float);
    for (int e = 0; e < 4; e++) {
        pgi_image ref = {0};
        pgi_frame_stats rs;
        for (int t = 0; t < 3; t++) {
            pgi_image img = {0};
            pgi_frame_stats fs;
            pgi_render_desc d = {.estimator = names[e],
                                 .width = S,
                                 .height = S,
                                 .photons = 20000,
                                 .radius = 0.1f,
                                 .threads = threads[t],
                                 .seed = 7};
            TU_CHECK_OK(pgi_render(scene, &d, t ? &img : &ref, t ? &fs : &rs));
            if (!t) continue;
            if (memcmp(img.rgb, ref.rgb, bytes) != 0)
                fail_msg("%s: %d threads differ from 1 thread", names[e], threads[t]);
            assert_int_equal(fs.reads, rs.reads);
            assert_int_equal(fs.contributing, rs.contributing);
            assert_int_equal(fs.nodes_visited, rs.nodes_visited);
            pgi_image_free(&img);
        }
        assert_true(tu_max_abs(ref.rgb, 3 * (size_t)S * S) > 0.0);
        pgi_image_free(&ref);
    }
    pgi_scene_destroy(scene);
}

/* --------------------------------------------------------- directional */

/* Relative L1 distance sum|a - b| / sum|b| over all values. */
static double rel_l1(const float *a, const float *b, size_t n) {
    double num = 0.0, den = 0.0;
    for (size_t i = 0; i < n; i++) {
        num += fabs((double)a[i] - (double)b[i]);
        den += fabs((double)b[i]);
    }
    return den > 0.0 ? num / den : 0.0;
}

/* On smooth lighting directional approximates cluster: on the Cornell box
 * (many photons, a radius that gives a smooth image, 2-pixel clusters so that
 * leaves are small next to the photons, as at 1080p) the relative L1
 * distance of the indirect images must stay under 8 % (measured 0.042; 0.16
 * with the paper's unnormalised 2 max(0, n.d_o) weight, +16 % too bright), and
 * under 6 % without the blur (0.030); the mean within 3 %; not a copy. */
static void test_directional_close_to_cluster(void **state) {
    pgi_scene *scene = tu_scene("cornell");
    pgi_renderer *r = tu_renderer(scene);
    const int S = 128;
    pgi_image ref = {0}, dir = {0};
    pgi_render_desc d = {.estimator = "cluster",
                         .width = S,
                         .height = S,
                         .photons = 100000,
                         .radius = 0.12f,
                         .output = PGI_OUTPUT_INDIRECT,
                         .seed = 3,
                         .est.cluster.tile = 2};
    TU_CHECK_OK(pgi_renderer_render(r, &d, &ref, NULL));
    d.estimator = "directional";
    TU_CHECK_OK(pgi_renderer_render(r, &d, &dir, NULL));
    double e = rel_l1(dir.rgb, ref.rgb, 3 * (size_t)S * S);
    double sa = 0, sb = 0;
    for (size_t i = 0; i < 3 * (size_t)S * S; i++) sa += dir.rgb[i], sb += ref.rgb[i];
    fprintf(stderr,
            "  directional vs cluster, Cornell %dx%d, 100k photons, r 0.12: relative L1 %.4f, mean ratio %.4f\n", S, S,
            e, sa / sb);
    assert_true(e < 0.08);
    assert_true(e > 1e-4);
    assert_true(fabs(sa / sb - 1.0) < 0.03);
    d.est.directional.blur = PGI_DIRECTIONAL_NO_BLUR;
    pgi_image nob = {0};
    TU_CHECK_OK(pgi_renderer_render(r, &d, &nob, NULL));
    double e2 = rel_l1(nob.rgb, ref.rgb, 3 * (size_t)S * S);
    fprintf(stderr, "  without blur: relative L1 %.4f\n", e2);
    assert_true(e2 < 0.06);
    pgi_image_free(&ref);
    pgi_image_free(&dir);
    pgi_image_free(&nob);
    pgi_renderer_destroy(r);
    pgi_scene_destroy(scene);
}

/* directional at its default cluster tile (from the image size) keeps the indirect light within 3 % of
 * the exact cluster estimate: the Cornell box at 64, 128 and 256 pixels (with 8-pixel leaves it was
 * 27 % dark at 64x64 and 11 % at 128x128), and Sibenik and fireplace-room at 128 pixels where their
 * files are found (with octant weights normalised for uniform light Sibenik was 4.0 % dark; measured
 * now +1.9 % and -1.9 %). */
static void directional_mean(const char *scene_name, int S, unsigned photons) {
    pgi_scene *scene = tu_scene(scene_name);
    pgi_renderer *r = tu_renderer(scene);
    pgi_image ref = {0}, dir = {0};
    pgi_render_desc d = {.estimator = "cluster",
                         .width = S,
                         .height = S,
                         .photons = photons,
                         .output = PGI_OUTPUT_INDIRECT};
    TU_CHECK_OK(pgi_renderer_render(r, &d, &ref, NULL));
    d.estimator = "directional";
    TU_CHECK_OK(pgi_renderer_render(r, &d, &dir, NULL));
    double sa = 0, sb = 0;
    for (size_t i = 0; i < 3 * (size_t)S * S; i++) sa += dir.rgb[i], sb += ref.rgb[i];
    fprintf(stderr, "  directional vs cluster, %s %dx%d, default tile: mean ratio %.4f\n", scene_name, S, S, sa / sb);
    assert_true(sb > 0);
    assert_true(fabs(sa / sb - 1.0) < 0.03);
    pgi_image_free(&ref);
    pgi_image_free(&dir);
    pgi_renderer_destroy(r);
    pgi_scene_destroy(scene);
}

static void test_directional_small_images(void **state) {
    (void)state;
    const int sizes[] = {64, 128, 256};
    for (int k = 0; k < 3; k++) directional_mean("cornell", sizes[k], 200000);
    const char *shipped[][2] = {{"sibenik", "sibenik/sibenik.obj"},
                                {"fireplace-room", "fireplace-room/fireplace_room.obj"}};
    for (int k = 0; k < 2; k++) {
        char json[256], mesh[1024];
        snprintf(json, sizeof json, "scenes/%s.json", shipped[k][0]);
        snprintf(mesh, sizeof mesh, "%s/%s", tu_scenes_dir(), shipped[k][1]);
        if (!tu_file_exists(json) || !tu_file_exists(mesh)) {
            fprintf(stderr, "  (%s: %s or %s not found)\n", shipped[k][0], json, mesh);
            continue;
        }
        directional_mean(shipped[k][0], 128, 200000);
    }
}

/* Light arriving uniformly over the hemisphere (flux ~ cos about the normal,
 * photons spread evenly on a plane), or as one beam 75 degrees off the normal,
 * must give directional the exact irradiance whatever way the plane's normal
 * sits among the view-space octants: seen head-on (a view axis: the paper's
 * 2 max(0, n.d) weight gives 2/sqrt(3) = +15.5 % to uniform light), obliquely,
 * and rolled. Mean over the image against hashgrid (exact), within 2 %. (Octant
 * weights normalised for uniform light pass the first and fail the beam seen
 * obliquely.) */
static void test_directional_uniform_hemisphere(void **state) {
    const float n[3] = {0.f, 0.f, 1.f}, tx[3] = {1.f, 0.f, 0.f}, ty[3] = {0.f, 1.f, 0.f};
    const struct {
        float tilt, turn, roll; /* degrees: eye tilted off the normal, turned about it, camera up rolled */
    } views[] = {{0.f, 0.f, 0.f}, {40.f, 25.f, 0.f}, {55.f, 70.f, 30.f}, {20.f, 200.f, 45.f}};
    const int S = 64;
    pgi_photons ph;
    const size_t np = 300000;
    TU_CHECK_OK(pgi_photons_alloc(&ph, np));
    for (int beam = 0; beam < 2; beam++) {
        tu_rng r = tu_rng_make(77);
        const float bt = 75.f * 3.14159265f / 180.f, bp = 0.6f; /* the beam: polar and azimuth angles */
        for (size_t j = 0; j < np; j++) {
            float u1 = tu_unif(&r), u2 = tu_unif(&r), a = tu_range(&r, -4.f, 4.f), b = tu_range(&r, -4.f, 4.f);
            float rr = beam ? sinf(bt) : sqrtf(u1), ph_ = beam ? bp : 6.28318530718f * u2,
                  z = beam ? cosf(bt) : sqrtf(1.f - u1);
            float d[3];
            for (int k = 0; k < 3; k++) d[k] = tx[k] * rr * cosf(ph_) + ty[k] * rr * sinf(ph_) + n[k] * z;
            ph.px[j] = a, ph.py[j] = b, ph.pz[j] = 0.f;
            ph.dx[j] = d[0], ph.dy[j] = d[1], ph.dz[j] = d[2];
            ph.nx[j] = n[0], ph.ny[j] = n[1], ph.nz[j] = n[2];
            ph.fr[j] = ph.fg[j] = ph.fb[j] = 1.f;
        }
        ph.count = np;
        ph.emitted = np;
        for (size_t v = 0; v < sizeof views / sizeof views[0]; v++) {
            const float dg = 3.14159265f / 180.f, ti = views[v].tilt * dg, tu = views[v].turn * dg,
                        ro = views[v].roll * dg;
            float eye[3], at[3] = {0.f, 0.f, 0.f}, up[3];
            for (int k = 0; k < 3; k++)
                eye[k] = 3.f * (n[k] * cosf(ti) + sinf(ti) * (tx[k] * cosf(tu) + ty[k] * sinf(tu)));
            for (int k = 0; k < 3; k++) up[k] = ty[k] * cosf(ro) + tx[k] * sinf(ro) + 0.3f * n[k];
            pgi_camera cam;
            pgi_view_samples vs;
            TU_CHECK_OK(pgi_view_samples_alloc(&vs, S, S));
            pgi_camera_look_at(&cam, eye, at, up, 40.f, S, S);
            for (int y = 0; y < S; y++)
                for (int x = 0; x < S; x++) {
                    size_t i = (size_t)y * S + (size_t)x;
                    float dir[3], pos[3], wo[3], kd[3] = {1.f, 1.f, 1.f};
                    tu_pixel_dir(&cam, x, y, dir);
                    float t = -eye[2] / dir[2]; /* the plane z = 0 */
                    for (int k = 0; k < 3; k++) pos[k] = eye[k] + t * dir[k], wo[k] = -dir[k];
                    tu_normalize(wo);
                    tu_set_sample(&vs, i, pos, n, wo, kd, 0.f, 0.f, t, PGI_VS_VALID | PGI_VS_PRIMARY | PGI_VS_LAMBERT);
                }
            float *ref = malloc(3 * vs.count * sizeof *ref), *got = malloc(3 * vs.count * sizeof *got);
            tu_est d = {.radius = 0.15f};
            d.d.cluster.tile = 2;
            pgi_estimator_stats st;
            TU_CHECK_OK(tu_run_estimator("hashgrid", &d, &ph, &vs, &cam, ref, &st));
            TU_CHECK_OK(tu_run_estimator("directional", &d, &ph, &vs, &cam, got, &st));
            double sa = 0.0, sb = 0.0;
            for (size_t i = 0; i < 3 * vs.count; i++) sa += got[i], sb += ref[i];
            double ratio = sa / sb;
            fprintf(stderr, "  directional / exact, %s, plane seen at tilt %g, turn %g, roll %g: %.4f\n",
                    beam ? "beam 75 degrees off the normal" : "uniform light", (double)views[v].tilt,
                    (double)views[v].turn, (double)views[v].roll, ratio);
            assert_true(sb > 0.0);
            assert_true(fabs(ratio - 1.0) < 0.02);
            free(ref);
            free(got);
            pgi_view_samples_free(&vs);
        }
    }
    pgi_photons_free(&ph);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_create_errors),
        cmocka_unit_test(test_planes_lambert),
        cmocka_unit_test(test_planes_mixed),
        cmocka_unit_test(test_depth_discontinuities),
        cmocka_unit_test(test_sky_only),
        cmocka_unit_test(test_one_sample),
        cmocka_unit_test(test_photons_outside_frustum),
        cmocka_unit_test(test_radius_larger_than_scene),
        cmocka_unit_test(test_cornell_pipeline),
        cmocka_unit_test(test_sibenik_pipeline),
        cmocka_unit_test(test_thread_counts),
        cmocka_unit_test(test_directional_close_to_cluster),
        cmocka_unit_test(test_directional_small_images),
        cmocka_unit_test(test_directional_uniform_hemisphere),
    };
    return cmocka_run_group_tests_name("cluster", tests, NULL, NULL);
}
