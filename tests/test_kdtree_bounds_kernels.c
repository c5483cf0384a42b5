/* kdtree (range and k-NN), bounds3d, bounds25d, kernels,
 * stochastic subsampling and the reconstruction filter.
 *  - the exact methods equal brute (relative 1e-4 per value, identical
 *    contributing count) on random photons/samples (mirror samples, spheres
 *    crossing the eye plane, radius larger than the scene), with kernels, and
 *    on the full pipeline (Cornell, a mirror/glass room, Sibenik);
 *  - kdtree k-NN equals a brute-force k-NN selection;
 *  - every kernel integrates to 1 over its disk;
 *  - subsampling: k = 1 is bit-identical to no subsampling, the estimate is
 *    unbiased on a uniform plane, and independent of the thread count;
 *  - the filter keeps constants, removes noise, keeps edges. */
#include "test_random.h"

#include <float.h>
#include <omp.h>

#include "estimators/estimator_internal.h"
#include "filter/bilateral.h"

#define W 48
#define H 40

static float *fbuf(size_t n) {
    float *p = malloc(n * sizeof *p);
    assert_non_null(p);
    for (size_t i = 0; i < n; i++) p[i] = NAN; /* every value must be written */
    return p;
}

/* Brute-force reference of one (photons, samples, radius, kernel), computed
 * once and reused by the comparisons that follow. */
static struct {
    const pgi_photons *ph;
    const pgi_view_samples *vs;
    float radius;
    pgi_kernel kernel;
    float *ref;
    pgi_estimator_stats st;
} g_ref;

static const float *brute_ref(const pgi_photons *ph, const pgi_view_samples *vs, const pgi_camera *cam, float radius,
                              pgi_kernel kernel, pgi_estimator_stats *st) {
    if (!(g_ref.ref && g_ref.ph == ph && g_ref.vs == vs && g_ref.radius == radius && g_ref.kernel == kernel)) {
        free(g_ref.ref);
        g_ref.ref = fbuf(3 * vs->count);
        g_ref.ph = ph, g_ref.vs = vs, g_ref.radius = radius, g_ref.kernel = kernel;
        TU_CHECK_OK(tu_run_estimator("brute", &(tu_est){.radius = radius, .d.kernel = kernel}, ph, vs, cam, g_ref.ref,
                                     &g_ref.st));
    }
    *st = g_ref.st;
    return g_ref.ref;
}
static void brute_ref_forget(void) {
    free(g_ref.ref);
    memset(&g_ref, 0, sizeof g_ref);
}

/* name with desc vs brute with the same radius and kernel. */
static void expect_equal_brute(const char *name, const tu_est *d, const pgi_photons *ph, const pgi_view_samples *vs,
                               const pgi_camera *cam, const char *label) {
    size_t nf = 3 * vs->count;
    float *got = fbuf(nf);
    pgi_estimator_stats rs, gs;
    const float *ref = brute_ref(ph, vs, cam, d->radius, d->d.kernel, &rs);
    TU_CHECK_OK(tu_run_estimator(name, d, ph, vs, cam, got, &gs));
    char what[200];
    snprintf(what, sizeof what, "%s vs brute, %s, r=%g, kernel %d, tile %d, polygon %d", name, label, (double)d->radius,
             (int)d->d.kernel, d->d.tiled.tile_size, d->d.bounds.polygon);
    size_t bad = tu_compare(got, ref, nf, 1e-4, what);
    if (gs.contributing != rs.contributing)
        fprintf(stderr, "  %s: contributing %llu, brute %llu\n", what, (unsigned long long)gs.contributing,
                (unsigned long long)rs.contributing);
    assert_int_equal(bad, 0);
    assert_int_equal(gs.contributing, rs.contributing);
    assert_true(gs.reads >= gs.contributing);
    free(got);
}

typedef struct {
    float radius;
    size_t photons;
} radius_case;
/* tiny, medium, and larger than the whole box (every sphere holds the eye) */
static const radius_case k_cases[] = {{0.015f, 12000}, {0.07f, 6000}, {0.25f, 2000}, {3.0f, 500}};

static void run_case(const tu_view_setup *g, float secondary, uint64_t seed, const char *label) {
    pgi_view_samples vs;
    pgi_camera cam;
    tu_make_samples(&vs, &cam, g, W, H, seed, secondary);
    for (size_t c = 0; c < sizeof k_cases / sizeof k_cases[0]; c++) {
        pgi_photons ph;
        tu_make_photons(&ph, k_cases[c].photons, seed * 7 + c);
        const float r = k_cases[c].radius;
        expect_equal_brute("kdtree", &(tu_est){.radius = r}, &ph, &vs, &cam, label);
        const int tiles[] = {1, 8, 32, 64};
        for (size_t t = 0; t < 4; t++) {
            expect_equal_brute("bounds3d", &(tu_est){.radius = r, .d.tiled.tile_size = tiles[t]}, &ph, &vs, &cam,
                               label);
            const int polys[] = {4, 6, 8, 32};
            expect_equal_brute("bounds25d",
                               &(tu_est){.radius = r, .d.tiled.tile_size = tiles[t], .d.bounds.polygon = polys[t]}, &ph,
                               &vs, &cam, label);
        }
        /* kernels: every kernel-capable method vs brute with the same kernel */
        for (int k = PGI_KERNEL_CONE; k < PGI_KERNEL_COUNT_; k++) {
            const char *names[] = {"kdtree", "bounds3d", "bounds25d", "hashgrid", "tiled"};
            for (size_t e = 0; e < 5; e++)
                expect_equal_brute(names[e], &(tu_est){.radius = r, .d.kernel = (pgi_kernel)k, .d.tiled.tile_size = 16},
                                   &ph, &vs, &cam, label);
        }
        brute_ref_forget();
        pgi_photons_free(&ph);
    }
    pgi_view_samples_free(&vs);
}

static void test_exact_random(void **state) {
    run_case(&k_outside, 0.f, 21, "primary samples");
    run_case(&k_outside, 0.15f, 22, "15% mirror samples");
}

static void test_exact_eye_inside(void **state) {
    run_case(&k_inside, 0.f, 23, "eye inside the photons");
    run_case(&k_inside, 0.1f, 24, "eye inside, mirror samples");
}

/* Photons hugging the eye plane: many spheres cross z = 0 at the screen
 * border and beside the eye (the near-plane fallbacks). */
static void test_exact_near_plane(void **state) {
    pgi_view_samples vs;
    pgi_camera cam;
    tu_make_samples(&vs, &cam, &k_inside, W, H, 25, 0.05f);
    pgi_photons ph;
    tu_make_photons(&ph, 4000, 26);
    tu_rng r = tu_rng_make(27);
    for (size_t j = 0; j < ph.count; j++) { /* within 0.1 of the eye plane z = 0.2 */
        ph.pz[j] = 0.2f + tu_range(&r, -0.1f, 0.1f);
    }
    const float radii[] = {0.05f, 0.12f, 0.4f};
    for (int k = 0; k < 3; k++) {
        pgi_estimator_stats st;
        float *ref = fbuf(3 * vs.count);
        TU_CHECK_OK(tu_run_estimator("brute", &(tu_est){.radius = radii[k]}, &ph, &vs, &cam, ref, &st));
        assert_true(st.contributing > 0);
        free(ref);
        expect_equal_brute("bounds3d", &(tu_est){.radius = radii[k], .d.tiled.tile_size = 8}, &ph, &vs, &cam,
                           "near plane");
        expect_equal_brute("bounds25d", &(tu_est){.radius = radii[k], .d.tiled.tile_size = 8}, &ph, &vs, &cam,
                           "near plane");
        expect_equal_brute("kdtree", &(tu_est){.radius = radii[k]}, &ph, &vs, &cam, "near plane");
    }
    brute_ref_forget();
    pgi_photons_free(&ph);
    pgi_view_samples_free(&vs);
}

/* Same image whatever the thread count (photon-order scatter, fixed chunks). */
static void test_thread_independent(void **state) {
    pgi_view_samples vs;
    pgi_camera cam;
    tu_make_samples(&vs, &cam, &k_outside, W, H, 28, 0.1f);
    pgi_photons ph;
    tu_make_photons(&ph, 30000, 29);
    const char *names[] = {"kdtree", "bounds3d", "bounds25d", "hashgrid", "tiled"};
    size_t nf = 3 * vs.count;
    for (size_t e = 0; e < 5; e++)
        for (int sub = 1; sub <= 3; sub += 2) {
            if (sub > 1 && strstr(names[e], "bounds")) continue;
            tu_est d = {.radius = 0.08f, .d.subsample = sub, .seed = 3, .d.kernel = PGI_KERNEL_CONE};
            float *a = fbuf(nf), *b = fbuf(nf);
            d.threads = 1;
            TU_CHECK_OK(tu_run_estimator(names[e], &d, &ph, &vs, &cam, a, NULL));
            d.threads = 3;
            TU_CHECK_OK(tu_run_estimator(names[e], &d, &ph, &vs, &cam, b, NULL));
            if (memcmp(a, b, nf * sizeof *a) != 0)
                fail_msg("%s subsample %d: depends on the thread count", names[e], sub);
            free(a);
            free(b);
        }
    pgi_photons_free(&ph);
    pgi_view_samples_free(&vs);
}

/* ------------------------------------------------------------------ k-NN */

typedef struct {
    float d2;
    uint32_t j;
} knn_c;
static int knn_cmp(const void *a, const void *b) {
    const knn_c *x = a, *y = b;
    if (x->d2 != y->d2) return x->d2 < y->d2 ? -1 : 1;
    return x->j < y->j ? -1 : x->j > y->j;
}

/* Brute-force k-NN: eligible = d^2 < rmax^2 and dot(n, w_p) > 0 (the same
 * float expressions as pgi__gather), sorted by (d^2, index), the first k;
 * radius^2 = d^2 of the k-th or rmax^2. */
static void brute_knn(const pgi_photons *ph, const pgi_view_samples *vs, float rmax, int k, pgi_kernel kern, float *out,
                      uint64_t *contributing) {
    knn_c *c = malloc(ph->count * sizeof *c);
    *contributing = 0;
    for (size_t i = 0; i < vs->count; i++) {
        pgi__vs v;
        if (!pgi__vs_begin(vs, i, out + 3 * i, &v)) continue;
        size_t m = 0;
        for (size_t j = 0; j < ph->count; j++) {
            float ex = ph->px[j] - v.px, ey = ph->py[j] - v.py, ez = ph->pz[j] - v.pz;
            float d2 = ex * ex + ey * ey + ez * ez;
            if (!(d2 < rmax * rmax)) continue;
            if (!(v.nx * ph->dx[j] + v.ny * ph->dy[j] + v.nz * ph->dz[j] > 0.f)) continue;
            c[m++] = (knn_c){d2, (uint32_t)j};
        }
        qsort(c, m, sizeof *c, knn_cmp);
        size_t take = m < (size_t)k ? m : (size_t)k;
        float r2 = m >= (size_t)k ? c[k - 1].d2 : rmax * rmax;
        if (!(r2 > 0.f)) r2 = fmaxf(1e-12f * rmax * rmax, FLT_MIN); /* documented: k photons at the sample */
        pgi__acc acc = {0};
        for (size_t q = 0; q < take; q++) {
            uint32_t j = c[q].j;
            float w = pgi__kernel_weight(kern, c[q].d2, r2);
            pgi__acc_add(&v, w, ph->dx[j], ph->dy[j], ph->dz[j], ph->fr[j], ph->fg[j], ph->fb[j], &acc);
        }
        pgi__acc_finish_k(&v, &acc, r2, kern, 1.f, out + 3 * i);
        *contributing += acc.contributing;
    }
    free(c);
}

static void test_knn_equals_brute_selection(void **state) {
    pgi_view_samples vs;
    pgi_camera cam;
    tu_make_samples(&vs, &cam, &k_outside, W, H, 31, 0.1f);
    pgi_photons ph;
    tu_make_photons(&ph, 8000, 32);
    /* duplicate some photons exactly: ties in distance break by index */
    for (size_t j = 0; j < 800; j++) {
        size_t s = j * 7 + 1, t = j * 7 + 3;
        ph.px[t] = ph.px[s], ph.py[t] = ph.py[s], ph.pz[t] = ph.pz[s];
    }
    const int ks[] = {1, 6, 50};
    const float rmax[] = {0.06f, 0.15f, 2.0f};
    size_t nf = 3 * vs.count;
    for (int a = 0; a < 3; a++)
        for (int b = 0; b < 3; b++)
            for (int kern = 0; kern < PGI_KERNEL_COUNT_; kern += (a == 1 && b == 1) ? 1 : PGI_KERNEL_COUNT_) {
                float *ref = fbuf(nf), *got = fbuf(nf);
                uint64_t rc;
                brute_knn(&ph, &vs, rmax[b], ks[a], (pgi_kernel)kern, ref, &rc);
                pgi_estimator_stats st;
                tu_est d = {.radius = rmax[b], .d.kdtree.knn = ks[a], .d.kernel = (pgi_kernel)kern};
                TU_CHECK_OK(tu_run_estimator("kdtree", &d, &ph, &vs, &cam, got, &st));
                char what[96];
                snprintf(what, sizeof what, "kdtree knn %d rmax %g kernel %d", ks[a], (double)rmax[b], kern);
                assert_int_equal(tu_compare(got, ref, nf, 1e-4, what), 0);
                assert_int_equal(st.contributing, rc);
                assert_true(rc > 0);
                free(ref);
                free(got);
            }
    pgi_photons_free(&ph);
    pgi_view_samples_free(&vs);
}

/* --------------------------------------------------------------- kernels */

/* Each kernel, normalised, integrates to 1 over its disk (midpoint rule in
 * the radius, exact in the angle), for several radii. */
static void test_kernel_normalisation(void **state) {
    const float radii[] = {0.01f, 1.f, 37.f};
    for (int k = 0; k < PGI_KERNEL_COUNT_; k++)
        for (int ri = 0; ri < 3; ri++) {
            double r = radii[ri], r2 = r * r, sum = 0.0;
            const int n = 20000;
            for (int s = 0; s < n; s++) {
                double d = (s + 0.5) / n * r;
                double w = pgi__kernel_weight((pgi_kernel)k, (float)(d * d), (float)r2);
                sum += w * 2.0 * PGI__PI * d * (r / n);
            }
            double integral = sum * pgi__kernel_norm((pgi_kernel)k) / (PGI__PI * r2);
            if (fabs(integral - 1.0) > 1e-4) fail_msg("kernel %d, r %g: integral %.6f", k, r, integral);
        }
    /* and the weights have the documented shapes */
    assert_true(fabsf(pgi__kernel_weight(PGI_KERNEL_CONE, 0.25f, 1.f) - 0.5f) < 1e-6f);
    assert_true(fabsf(pgi__kernel_weight(PGI_KERNEL_EPANECHNIKOV, 0.25f, 1.f) - 0.75f) < 1e-6f);
    assert_true(pgi__kernel_weight(PGI_KERNEL_CONSTANT, 0.9f, 1.f) == 1.f);
}

/* A uniform photon density on a plane: every kernel's estimate approaches
 * flux density / pi * kd (the estimator end to end, kernels applied). */
static void make_plane(pgi_photons *ph, size_t n, uint64_t seed, float flux_total) {
    TU_CHECK_OK(pgi_photons_alloc(ph, n));
    tu_rng r = tu_rng_make(seed);
    for (size_t j = 0; j < n; j++) { /* stratified jitter: low-noise uniform density on [-1,1]^2 */
        size_t g = (size_t)sqrt((double)n), gx = j % g, gy = j / g;
        ph->px[j] = -1.f + 2.f * ((float)gx + tu_unif(&r)) / (float)g;
        ph->pz[j] = -1.f + 2.f * ((float)(gy % g) + tu_unif(&r)) / (float)g;
        ph->py[j] = 0.f;
        ph->dx[j] = 0.f, ph->dy[j] = 1.f, ph->dz[j] = 0.f;
        ph->nx[j] = 0.f, ph->ny[j] = 1.f, ph->nz[j] = 0.f;
        ph->fr[j] = ph->fg[j] = ph->fb[j] = flux_total / (float)n;
    }
    ph->count = n;
    ph->emitted = n;
}

/* View samples on the plane y = 0 inside [-0.5, 0.5]^2, seen from above. */
static void make_plane_samples(pgi_view_samples *vs, pgi_camera *cam, int w, int h) {
    TU_CHECK_OK(pgi_view_samples_alloc(vs, w, h));
    pgi_camera_look_at(cam, (float[3]){0.f, 2.f, 0.001f}, (float[3]){0.f, 0.f, 0.f}, (float[3]){0.f, 1.f, 0.f}, 28.f, w,
                       h);
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            size_t i = (size_t)y * w + (size_t)x;
            float dir[3], pos[3], wo[3], n[3] = {0.f, 1.f, 0.f}, kd[3] = {0.5f, 0.5f, 0.5f};
            tu_pixel_dir(cam, x, y, dir);
            float t = (0.f - cam->eye[1]) / dir[1];
            for (int k = 0; k < 3; k++) pos[k] = cam->eye[k] + t * dir[k], wo[k] = -dir[k];
            pos[1] = 0.f;
            tu_normalize(wo);
            tu_set_sample(vs, i, pos, n, wo, kd, 0.f, 0.f, t, PGI_VS_VALID | PGI_VS_PRIMARY | PGI_VS_LAMBERT);
        }
}

static void test_kernels_uniform_plane(void **state) {
    pgi_photons ph;
    make_plane(&ph, 160000, 41, 4.f); /* 1 W per unit area */
    pgi_view_samples vs;
    pgi_camera cam;
    make_plane_samples(&vs, &cam, 24, 24);
    float *out = fbuf(3 * vs.count);
    const double expect = 0.5 / PGI__PI * 1.0; /* kd/pi * E */
    for (int k = 0; k < PGI_KERNEL_COUNT_; k++) {
        TU_CHECK_OK(tu_run_estimator("kdtree", &(tu_est){.radius = 0.1f, .d.kernel = (pgi_kernel)k}, &ph, &vs, &cam,
                                     out, NULL));
        double mean = 0.0;
        for (size_t i = 0; i < vs.count; i++) mean += out[3 * i];
        mean /= (double)vs.count;
        if (fabs(mean / expect - 1.0) > 0.01) fail_msg("kernel %d: mean %g, expected %g", k, mean, expect);
    }
    free(out);
    pgi_view_samples_free(&vs);
    pgi_photons_free(&ph);
}

/* ------------------------------------------------------------ subsampling */

static void test_subsample_k1_is_off(void **state) {
    pgi_view_samples vs;
    pgi_camera cam;
    tu_make_samples(&vs, &cam, &k_outside, W, H, 51, 0.1f);
    pgi_photons ph;
    tu_make_photons(&ph, 20000, 52);
    const char *names[] = {"hashgrid", "tiled", "kdtree"};
    size_t nf = 3 * vs.count;
    for (int e = 0; e < 3; e++) {
        float *a = fbuf(nf), *b = fbuf(nf), *c = fbuf(nf);
        pgi_estimator_stats sa, sb;
        TU_CHECK_OK(tu_run_estimator(names[e], &(tu_est){.radius = 0.1f}, &ph, &vs, &cam, a, &sa));
        TU_CHECK_OK(
            tu_run_estimator(names[e], &(tu_est){.radius = 0.1f, .d.subsample = 1, .seed = 9}, &ph, &vs, &cam, b, &sb));
        if (memcmp(a, b, nf * sizeof *a) != 0) fail_msg("%s: subsample 1 differs from no subsampling", names[e]);
        assert_int_equal(sa.reads, sb.reads);
        /* k = 2 visits about a quarter and does change the image */
        pgi_estimator_stats sc;
        TU_CHECK_OK(
            tu_run_estimator(names[e], &(tu_est){.radius = 0.1f, .d.subsample = 2, .seed = 9}, &ph, &vs, &cam, c, &sc));
        assert_true(memcmp(a, c, nf * sizeof *a) != 0);
        double ratio = (double)sc.reads / (double)sa.reads;
        fprintf(stderr, "  %s: subsample 2 reads %.3f of the full gather's\n", names[e], ratio);
        assert_true(ratio > 0.2 && ratio < 0.3);
        free(a);
        free(b);
        free(c);
    }
    pgi_photons_free(&ph);
    pgi_view_samples_free(&vs);
}

/* Unbiased: on a uniform plane, the mean over seeds of the subsampled
 * estimate equals the full estimate (per pixel within 10%, over the image
 * within 1%); a wrong scale (e.g. k instead of k^2) misses by far more. */
static void test_subsample_unbiased(void **state) {
    pgi_photons ph;
    make_plane(&ph, 40000, 61, 4.f);
    pgi_view_samples vs;
    pgi_camera cam;
    make_plane_samples(&vs, &cam, 16, 16);
    size_t nf = 3 * vs.count;
    float *full = fbuf(nf), *one = fbuf(nf);
    double *mean = calloc(nf, sizeof *mean);
    const char *names[] = {"hashgrid", "tiled", "kdtree"};
    const int seeds = 48;
    for (int e = 0; e < 3; e++) {
        const float r = 0.12f; /* about 450 photons in a disk */
        TU_CHECK_OK(tu_run_estimator(names[e], &(tu_est){.radius = r}, &ph, &vs, &cam, full, NULL));
        memset(mean, 0, nf * sizeof *mean);
        for (int s = 0; s < seeds; s++) {
            TU_CHECK_OK(tu_run_estimator(names[e], &(tu_est){.radius = r, .d.subsample = 3, .seed = 100 + (uint64_t)s},
                                         &ph, &vs, &cam, one, NULL));
            for (size_t i = 0; i < nf; i++) mean[i] += one[i] / seeds;
        }
        double sf = 0.0, sm = 0.0, worst = 0.0;
        for (size_t i = 0; i < nf; i++) {
            sf += full[i];
            sm += mean[i];
            double rel = fabs(mean[i] / full[i] - 1.0);
            if (rel > worst) worst = rel;
        }
        fprintf(stderr, "  %s subsample 3, %d seeds: image mean ratio %.4f, worst pixel %.3f\n", names[e], seeds,
                sm / sf, worst);
        assert_true(fabs(sm / sf - 1.0) < 0.01);
        assert_true(worst < 0.10);
    }
    free(full);
    free(one);
    free(mean);
    pgi_view_samples_free(&vs);
    pgi_photons_free(&ph);
}

/* ---------------------------------------------------------------- filter */

static void test_filter(void **state) {
    pgi_view_samples vs;
    pgi_camera cam;
    make_plane_samples(&vs, &cam, 32, 32);
    size_t n = vs.count;
    /* right half: a wall (other normal) with another value */
    for (size_t i = 0; i < n; i++)
        if ((i % 32) >= 16) vs.nrm[3 * i] = 1.f, vs.nrm[3 * i + 1] = 0.f;
    float *rgb = malloc(3 * n * sizeof *rgb);
    tu_rng r = tu_rng_make(71);
    double var0 = 0.0;
    for (size_t i = 0; i < n; i++) {
        float base = (i % 32) >= 16 ? 10.f : 1.f, noise = tu_range(&r, -0.5f, 0.5f);
        for (int c = 0; c < 3; c++) rgb[3 * i + c] = base * (1.f + noise);
        var0 += noise * noise;
    }
    TU_CHECK_OK(pgi__bilateral_filter(&vs, 3, 0, rgb));
    double var1 = 0.0;
    for (size_t i = 0; i < n; i++) {
        float base = (i % 32) >= 16 ? 10.f : 1.f;
        double e = rgb[3 * i] / base - 1.0;
        var1 += e * e;
        /* no bleeding across the normal edge */
        if (fabs(e) > 0.5) fail_msg("pixel %zu: %g, base %g (edge bled)", i, (double)rgb[3 * i], (double)base);
    }
    fprintf(stderr, "  filter: noise variance %.4f -> %.4f\n", var0 / n, var1 / n);
    assert_true(var1 < 0.25 * var0);
    /* a constant stays constant */
    for (size_t i = 0; i < 3 * n; i++) rgb[i] = 2.5f;
    TU_CHECK_OK(pgi__bilateral_filter(&vs, 2, 0, rgb));
    for (size_t i = 0; i < 3 * n; i++) assert_true(fabsf(rgb[i] - 2.5f) < 1e-5f);
    free(rgb);
    pgi_view_samples_free(&vs);
}

/* --------------------------------------------------------- errors, stats */

static void test_errors(void **state) {
    pgi_estimator *e = NULL;
    assert_int_equal(tu_create("kdtree", &(tu_est){.radius = 0.1f, .d.kdtree.knn = -1}, &e), PGI_ERR_INVALID_ARG);
    assert_int_equal(tu_create("tiled", &(tu_est){.radius = 0.1f, .d.kdtree.knn = 4}, &e), PGI_ERR_INVALID_ARG);
    assert_non_null(strstr(pgi_last_error(), "kdtree"));
    assert_int_equal(tu_create("kdtree", &(tu_est){.radius = 0.1f, .d.kdtree.knn = 4, .d.subsample = 2}, &e),
                     PGI_ERR_INVALID_ARG);
    assert_int_equal(tu_create("bounds25d", &(tu_est){.radius = 0.1f, .d.bounds.polygon = 5}, &e), PGI_ERR_INVALID_ARG);
    assert_int_equal(tu_create("bounds3d", &(tu_est){.radius = 0.1f, .d.subsample = 2}, &e), PGI_ERR_INVALID_ARG);
    assert_int_equal(tu_create("kdtree", &(tu_est){.radius = 0.1f, .d.kernel = 7}, &e), PGI_ERR_INVALID_ARG);
    assert_null(e);
    /* the render description is validated too */
    pgi_scene *scene = NULL;
    TU_CHECK_OK(pgi_scene_load("cornell", &scene));
    pgi_image img = {0};
    const pgi_render_desc bad[] = {
        {.estimator = "kdtree", .est.kdtree.knn = -2, .width = 8, .height = 8},
        {.estimator = "hashgrid", .est.kdtree.knn = 3, .width = 8, .height = 8},
        {.estimator = "tiled", .est.kernel = 3, .width = 8, .height = 8},
        {.estimator = "tiled", .est.subsample = 65, .width = 8, .height = 8},
        {.estimator = "tiled", .filter = 17, .width = 8, .height = 8},
        {.estimator = "bounds25d", .est.bounds.polygon = 3, .width = 8, .height = 8},
    };
    for (size_t k = 0; k < sizeof bad / sizeof bad[0]; k++)
        assert_int_equal(pgi_render(scene, &bad[k], &img, NULL), PGI_ERR_INVALID_ARG);
    pgi_scene_destroy(scene);
}

/* The 2.5D bound wastes fewer tests than the 3D bound; more polygon
 * vertices never test more pixels. */
static void test_bounds_wasted_tests(void **state) {
    pgi_view_samples vs;
    pgi_camera cam;
    tu_make_samples(&vs, &cam, &k_outside, W, H, 81, 0.f);
    pgi_photons ph;
    tu_make_photons(&ph, 20000, 82);
    float *out = fbuf(3 * vs.count);
    pgi_estimator_stats s3, s4, s8, s32;
    TU_CHECK_OK(tu_run_estimator("bounds3d", &(tu_est){.radius = 0.1f}, &ph, &vs, &cam, out, &s3));
    TU_CHECK_OK(
        tu_run_estimator("bounds25d", &(tu_est){.radius = 0.1f, .d.bounds.polygon = 4}, &ph, &vs, &cam, out, &s4));
    TU_CHECK_OK(
        tu_run_estimator("bounds25d", &(tu_est){.radius = 0.1f, .d.bounds.polygon = 8}, &ph, &vs, &cam, out, &s8));
    TU_CHECK_OK(
        tu_run_estimator("bounds25d", &(tu_est){.radius = 0.1f, .d.bounds.polygon = 32}, &ph, &vs, &cam, out, &s32));
    fprintf(stderr,
            "  tests (covered): 3D %llu (%llu), 2.5D/4 %llu (%llu), /8 %llu (%llu), /32 %llu (%llu); contributing "
            "%llu\n",
            (unsigned long long)s3.reads, (unsigned long long)s3.nodes_visited, (unsigned long long)s4.reads,
            (unsigned long long)s4.nodes_visited, (unsigned long long)s8.reads, (unsigned long long)s8.nodes_visited,
            (unsigned long long)s32.reads, (unsigned long long)s32.nodes_visited, (unsigned long long)s3.contributing);
    assert_true(s8.reads < s3.reads);
    assert_true(s8.nodes_visited < s3.nodes_visited);
    assert_true(s8.nodes_visited <= s4.nodes_visited);
    assert_true(s32.nodes_visited <= s8.nodes_visited);
    assert_true(s32.reads >= s32.contributing);
    free(out);
    pgi_photons_free(&ph);
    pgi_view_samples_free(&vs);
}

/* ------------------------------------------------------ full pipeline */

static void pipeline_compare(const char *scene_name, int w, int h, uint32_t photons, float radius) {
    pgi_scene *scene = NULL;
    TU_CHECK_OK(pgi_scene_load(scene_name, &scene));
    pgi_renderer *r = NULL;
    TU_CHECK_OK(pgi_renderer_create(scene, &r));
    const char *names[] = {"brute", "kdtree", "bounds3d", "bounds25d"};
    pgi_image img[4] = {{0}};
    pgi_frame_stats fs[4];
    for (int kern = 0; kern < 2; kern++) {
        for (int k = 0; k < 4; k++) {
            pgi_render_desc d = {.estimator = names[k],
                                 .photons = photons,
                                 .width = w,
                                 .height = h,
                                 .output = PGI_OUTPUT_INDIRECT,
                                 .seed = 5,
                                 .est.kernel = kern * 2};
            if (radius > 0.f) d.radius = radius;
            TU_CHECK_OK(pgi_renderer_render(r, &d, &img[k], &fs[k]));
        }
        assert_true(fs[0].contributing > 0);
        for (int k = 1; k < 4; k++) {
            char what[128];
            snprintf(what, sizeof what, "%s: %s vs brute, kernel %d", scene_name, names[k], kern * 2);
            assert_int_equal(tu_compare(img[k].rgb, img[0].rgb, 3 * (size_t)w * h, 1e-4, what), 0);
            assert_int_equal(fs[k].contributing, fs[0].contributing);
        }
    }
    for (int k = 0; k < 4; k++) pgi_image_free(&img[k]);
    pgi_renderer_destroy(r);
    pgi_scene_destroy(scene);
}

static void test_cornell_pipeline(void **state) { pipeline_compare("cornell", 96, 72, 20000, 0.08f); }

static void test_sibenik_pipeline(void **state) {
    char mesh[1024];
    snprintf(mesh, sizeof mesh, "%s/sibenik/sibenik.obj", tu_scenes_dir());
    if (!tu_file_exists("scenes/sibenik.json") || !tu_file_exists(mesh)) {
        fprintf(stderr, "skipping: scenes/sibenik.json or %s not found\n", mesh);
        skip();
    }
    pipeline_compare("sibenik", 80, 45, 10000, 0.f);
}

/* A room with a mirror wall (samples seen through it) and a glass block. */
static void test_mirror_pipeline(void **state) {
    char dir[512], path[700];
    tu_make_tmpdir(dir, sizeof dir);
    snprintf(path, sizeof path, "%s/room.mtl", dir);
    assert_int_equal(tu_write_file(path, "newmtl white\nKd 0.7 0.7 0.7\nillum 1\n"
                                         "newmtl mirror\nKd 0 0 0\nKs 0.9 0.9 0.9\nillum 3\n"
                                         "newmtl lamp\nKd 0.8 0.8 0.8\nKe 20 20 20\nillum 1\n"),
                     0);
    snprintf(path, sizeof path, "%s/room.obj", dir);
    assert_int_equal(tu_write_file(path, "mtllib room.mtl\n"
                                         "v -1 0 -1\nv 1 0 -1\nv 1 0 1\nv -1 0 1\n"
                                         "v -1 2 -1\nv 1 2 -1\nv 1 2 1\nv -1 2 1\n"
                                         "v -0.3 1.98 -0.3\nv 0.3 1.98 -0.3\nv 0.3 1.98 0.3\nv -0.3 1.98 0.3\n"
                                         "usemtl white\nf 1 4 3 2\nf 5 6 7 8\nf 2 3 7 6\nf 1 5 8 4\n"
                                         "usemtl mirror\nf 1 2 6 5\n"
                                         "usemtl lamp\nf 9 10 11 12\n"),
                     0);
    char json[1400], jpath[700];
    snprintf(json, sizeof json,
             "{\"mesh\": \"%s\", \"camera\": {\"eye\": [-0.3, 1.1, 3.2], \"look_at\": [0.1, 0.8, -1], \"fov_y\": "
             "50}}\n",
             path);
    snprintf(jpath, sizeof jpath, "%s/room.json", dir);
    assert_int_equal(tu_write_file(jpath, json), 0);
    pipeline_compare(jpath, 64, 48, 15000, 0.1f);
    tu_rm_tmpdir(dir);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_errors),
        cmocka_unit_test(test_kernel_normalisation),
        cmocka_unit_test(test_kernels_uniform_plane),
        cmocka_unit_test(test_exact_random),
        cmocka_unit_test(test_exact_eye_inside),
        cmocka_unit_test(test_exact_near_plane),
        cmocka_unit_test(test_thread_independent),
        cmocka_unit_test(test_knn_equals_brute_selection),
        cmocka_unit_test(test_subsample_k1_is_off),
        cmocka_unit_test(test_subsample_unbiased),
        cmocka_unit_test(test_filter),
        cmocka_unit_test(test_bounds_wasted_tests),
        cmocka_unit_test(test_cornell_pipeline),
        cmocka_unit_test(test_mirror_pipeline),
        cmocka_unit_test(test_sibenik_pipeline),
    };
    return cmocka_run_group_tests_name("kdtree_bounds_kernels", tests, NULL, NULL);
}
