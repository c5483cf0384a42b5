/* The automatic radius (src/photon/auto_radius.c): on a plane of uniformly spread photons (a 2-D
 * Poisson process of density rho) the count within r is Poisson(pi rho r^2), so the k-th
 * neighbour distance d has pi rho d^2 ~ Gamma(k, 1) and its 75 % quantile is known; photons from
 * behind are not counted; the same radius for any thread count; clamps and the renderer's use of
 * it (stats, progressive shrinking from it, the desc's and the scene's radius as overrides). */
#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <cmocka.h>

#include "test_util.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <unistd.h>

#include "core/core.h"
#include "photon/auto_radius.h"
#include "photongi/photongi.h"

/* n photons uniform on the unit square z = 0 arriving from above (dz = dir_z), and a w x h grid
 * of view samples on the square's middle (normal +z). */
static void plane(pgi_photons *ph, size_t n, float dir_z, pgi_view_samples *vs, int w, int h) {
    assert_int_equal(pgi_photons_alloc(ph, n), PGI_OK);
    uint64_t s = 0x9e3779b97f4a7c15ULL;
    for (size_t i = 0; i < n; i++) {
        s = s * 6364136223846793005ULL + 1442695040888963407ULL;
        ph->px[i] = (float)((s >> 40) & 0xffffff) / 16777216.f;
        s = s * 6364136223846793005ULL + 1442695040888963407ULL;
        ph->py[i] = (float)((s >> 40) & 0xffffff) / 16777216.f;
        ph->pz[i] = 0.f;
        ph->dx[i] = 0.f;
        ph->dy[i] = 0.f;
        ph->dz[i] = dir_z;
        ph->fr[i] = ph->fg[i] = ph->fb[i] = 1.f;
        ph->nx[i] = ph->ny[i] = 0.f;
        ph->nz[i] = 1.f;
    }
    ph->count = n;
    ph->emitted = n;
    assert_int_equal(pgi_view_samples_alloc(vs, w, h), PGI_OK);
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            size_t i = (size_t)y * w + x;
            vs->pos[3 * i] = 0.25f + 0.5f * ((float)x + 0.5f) / (float)w;
            vs->pos[3 * i + 1] = 0.25f + 0.5f * ((float)y + 0.5f) / (float)h;
            vs->pos[3 * i + 2] = 0.f;
            vs->nrm[3 * i] = vs->nrm[3 * i + 1] = 0.f;
            vs->nrm[3 * i + 2] = 1.f;
            vs->flags[i] = PGI_VS_VALID | PGI_VS_PRIMARY | PGI_VS_LAMBERT;
        }
}

/* n photons: k grows as n^(2/3); above 262144 photons every s-th one stands for s of them. */
static void uniform_plane(size_t n, int k_want) {
    pgi_photons ph;
    pgi_view_samples vs;
    plane(&ph, n, 1.f, &vs, 64, 64);
    float r1, r2;
    pgi_auto_radius_stats a1, a2;
    assert_int_equal(pgi__auto_radius_choose(&ph, &vs, 1.4142f, 1, &r1, &a1), PGI_OK);
    assert_int_equal(pgi__auto_radius_choose(&ph, &vs, 1.4142f, 2, &r2, &a2), PGI_OK);
    assert_true(r1 == r2); /* bit for bit, whatever the thread count */
    assert_int_equal(a1.k, k_want);
    assert_int_equal(a1.queries, 1024);
    assert_int_equal(a1.starved, 0);
    /* the k-th neighbour distance's quantile q: pi rho d^2 = the q-quantile of Gamma(k, 1), about
     * k + z_q sqrt(k) (Wilson-Hilferty would be closer; 2 % is far below the test's tolerance) */
    const double z75 = 0.6745, k = a1.k;
    double g = k + z75 * sqrt(k), want = sqrt(g / (PGI__PI * (double)n));
    assert_true(fabs(a1.quantile - 0.75f) < 1e-6f);
    if (!(fabs(r1 - want) < 0.04 * want)) fail_msg("n %zu: radius %g, expected %g for k %d", n, (double)r1, want, a1.k);
    /* mean photons gathered at that radius: pi rho r^2 */
    double mean = PGI__PI * (double)n * r1 * r1;
    if (!(fabs(a1.mean_reads - mean) < 0.06 * mean)) fail_msg("mean reads %g, expected %g", a1.mean_reads, mean);
    pgi_photons_free(&ph);
    pgi_view_samples_free(&vs);
}

static void test_uniform_plane(void **state) {
    (void)state;
    uniform_plane(200000, 32);   /* k = 32 at 200k photons, every photon looked at */
    uniform_plane(1200000, 106); /* 32 * 6^(2/3); every 3rd photon, the 35th of them */
}

/* Photons arriving from below the samples' side are not gathered, so none count: every query
 * starves and the radius is clamped to hi. */
static void test_wrong_side_starves(void **state) {
    (void)state;
    pgi_photons ph;
    pgi_view_samples vs;
    plane(&ph, 20000, -1.f, &vs, 16, 16);
    float r;
    pgi_auto_radius_stats a;
    assert_int_equal(pgi__auto_radius_choose(&ph, &vs, 2.f, 0, &r, &a), PGI_OK);
    assert_int_equal(a.starved, a.queries);
    assert_true(r == a.hi);
    assert_true(fabsf(a.hi - 0.05f * 2.f) < 1e-6f);
    pgi_photons_free(&ph);
    pgi_view_samples_free(&vs);
}

/* No valid view sample: the old default. */
static void test_no_samples(void **state) {
    (void)state;
    pgi_photons ph;
    pgi_view_samples vs;
    plane(&ph, 1000, 1.f, &vs, 8, 8);
    for (int i = 0; i < 64; i++) vs.flags[i] = 0;
    float r;
    pgi_auto_radius_stats a;
    assert_int_equal(pgi__auto_radius_choose(&ph, &vs, 10.f, 0, &r, &a), PGI_OK);
    assert_int_equal(a.queries, 0);
    assert_true(fabsf(r - 0.2f) < 1e-6f);
    pgi_photons_free(&ph);
    pgi_view_samples_free(&vs);
}

/* The renderer: with PGI_RADIUS_AUTO (and without a radius anywhere: a mesh file) the frame's radius
 * is automatic and the stats say so; a desc radius overrides it; progressive frames shrink from
 * frame 0's automatic radius. */
static void test_renderer(void **state) {
    (void)state;
    pgi_scene *s;
    assert_int_equal(pgi_scene_load("sphere-and-plane", &s), PGI_OK);
    pgi_render_desc d = {.photons = 20000, .width = 48, .height = 32, .radius = PGI_RADIUS_AUTO};
    pgi_image img = {0};
    pgi_frame_stats fs;
    assert_int_equal(pgi_render(s, &d, &img, &fs), PGI_OK);
    assert_int_equal(fs.auto_radius.used, 1);
    assert_true(fs.radius > 0.f && fs.radius >= fs.auto_radius.lo && fs.radius <= fs.auto_radius.hi);
    assert_true(fs.settings.radius == fs.radius);
    const float r_auto = fs.radius;
    d.radius = 0.5f * r_auto;
    assert_int_equal(pgi_render(s, &d, &img, &fs), PGI_OK);
    assert_int_equal(fs.auto_radius.used, 0);
    assert_true(fs.radius == 0.5f * r_auto);
    d.radius = -2.f;
    assert_int_equal(pgi_render(s, &d, &img, &fs), PGI_ERR_INVALID_ARG);
    d.radius = PGI_RADIUS_AUTO;
    d.radius_policy = PGI_RADIUS_PATH;
    d.estimator = "bvh";
    assert_int_equal(pgi_render(s, &d, &img, &fs), PGI_ERR_INVALID_ARG);
    d.radius_policy = PGI_RADIUS_FIXED;
    d.estimator = NULL;

    pgi_renderer *r;
    pgi_progressive *p;
    assert_int_equal(pgi_renderer_create(s, &r), PGI_OK);
    assert_int_equal(pgi_progressive_create(r, &p), PGI_OK);
    d.radius = PGI_RADIUS_AUTO;
    assert_int_equal(pgi_progressive_step(p, &d, &img, &fs), PGI_OK);
    assert_true(fs.radius == r_auto); /* same photons, same view: same choice */
    assert_int_equal(pgi_progressive_step(p, &d, &img, &fs), PGI_OK);
    assert_int_equal(pgi_progressive_step(p, &d, &img, &fs), PGI_OK);
    assert_int_equal(fs.frames, 3);
    assert_true(fs.radius == pgi_progressive_radius(r_auto, 2));
    assert_int_equal(fs.auto_radius.used, 1); /* frame 2's radius comes from frame 0's choice */
    assert_true(fs.auto_radius.knn > 0.f);
    pgi_progressive_destroy(p);
    pgi_renderer_destroy(r);
    pgi_image_free(&img);
    pgi_scene_destroy(s);
}

/* A description with a mesh and no radius anywhere gets the automatic radius by default. */
static void test_description_without_radius(void **state) {
    (void)state;
    char dir[] = "/tmp/pgi_auto_radius_XXXXXX";
    assert_non_null(mkdtemp(dir));
    char obj[256], json[256];
    snprintf(obj, sizeof obj, "%s/floor.obj", dir);
    snprintf(json, sizeof json, "%s/floor.json", dir);
    FILE *f = fopen(obj, "w");
    assert_non_null(f);
    fputs("v -1 0 -1\nv 1 0 -1\nv 1 0 1\nv -1 0 1\nv -1 2 -1\nv 1 2 -1\nv 1 2 1\nv -1 2 1\n"
          "f 1 4 3 2\nf 5 6 7 8\n",
          f);
    fclose(f);
    f = fopen(json, "w");
    assert_non_null(f);
    fputs("{\"mesh\": \"floor.obj\", \"cameras\": [{\"eye\": [0, 1, 0.9], \"look_at\": [0, 0, 0], "
          "\"up\": [0, 1, 0], \"fov_y\": 60}], \"lights\": [{\"type\": \"point\", \"position\": [0, 1, 0], "
          "\"intensity\": [1, 1, 1]}]}\n",
          f);
    fclose(f);
    pgi_scene *s;
    if (pgi_scene_load(json, &s) != PGI_OK) fail_msg("%s", pgi_last_error());
    pgi_scene_info info;
    pgi_scene_get_info(s, &info);
    assert_true(info.defaults.radius == 0.f);
    pgi_render_desc d = {.photons = 5000, .width = 32, .height = 24};
    pgi_image img = {0};
    pgi_frame_stats fs;
    assert_int_equal(pgi_render(s, &d, &img, &fs), PGI_OK);
    assert_int_equal(fs.auto_radius.used, 1);
    assert_true(fs.radius >= fs.auto_radius.lo && fs.radius <= fs.auto_radius.hi);
    pgi_image_free(&img);
    pgi_scene_destroy(s);
    remove(obj);
    remove(json);
    rmdir(dir);
}

TU_MAIN("auto radius", NULL, NULL, cmocka_unit_test(test_uniform_plane), cmocka_unit_test(test_wrong_side_starves),
        cmocka_unit_test(test_no_samples), cmocka_unit_test(test_renderer),
        cmocka_unit_test(test_description_without_radius))
