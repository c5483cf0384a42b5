/* Analytic oracles (docs/testing.md): uniform photons on a plane, the
 * furnace (closed Lambertian sphere around a point light), and the
 * normalisation of the constant kernel. */
#include "test_util.h"
#include "test_scenes.h"

#define PI_D 3.14159265358979323846

/* Camera at (0, 0, 3) looking down at the plane z = 0; each pixel's centre
 * ray hits the plane at depth 3. `half` is the half-width seen on the plane. */
static void plane_samples(pgi_view_samples *vs, pgi_camera *cam, int w, int h, float half, const float kd[3]) {
    const float eye[3] = {0.f, 0.f, 3.f}, at[3] = {0.f, 0.f, 0.f}, up[3] = {0.f, 1.f, 0.f};
    float fov = 2.f * atanf(half / 3.f) * (float)(180.0 / PI_D);
    TU_CHECK_OK(pgi_view_samples_alloc(vs, w, h));
    pgi_camera_look_at(cam, eye, at, up, fov, w, h);
    const float n[3] = {0.f, 0.f, 1.f};
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            float dir[3], pos[3], wo[3];
            tu_pixel_dir(cam, x, y, dir);
            float t = -eye[2] / dir[2]; /* = 3: forward is -z */
            for (int k = 0; k < 3; k++) pos[k] = eye[k] + t * dir[k];
            pos[2] = 0.f;
            for (int k = 0; k < 3; k++) wo[k] = eye[k] - pos[k];
            tu_normalize(wo);
            tu_set_sample(vs, (size_t)y * w + x, pos, n, wo, kd, 0.f, 0.f, t,
                          PGI_VS_VALID | PGI_VS_PRIMARY | PGI_VS_LAMBERT);
        }
}

/* ------------------------------------------------ uniform photons on a plane */

#define PLANE_L 2.f /* photons on [-1, 1]^2, area A = 4 */
#define PLANE_N 200000
#define PLANE_R 0.1f
#define PLANE_FLUX 2.5e-5f /* per photon: N * flux / A = 1.25 W/m^2 */

/* dz > 0: every photon arrives straight from above, (0, 0, 1). dz < 0: from
 * below the surface: a third straight up from under it (0, 0, -1), a third
 * from random directions of the lower hemisphere (many nearly grazing), and
 * a third exactly tangent (dz = 0: dot(n, w_p) = 0, which must not count). */
static void plane_photons(pgi_photons *ph, float dz) {
    TU_CHECK_OK(pgi_photons_alloc(ph, PLANE_N));
    tu_rng r = tu_rng_make(2024);
    for (size_t j = 0; j < PLANE_N; j++) {
        ph->px[j] = tu_range(&r, -0.5f * PLANE_L, 0.5f * PLANE_L);
        ph->py[j] = tu_range(&r, -0.5f * PLANE_L, 0.5f * PLANE_L);
        ph->pz[j] = 0.f;
        float d[3] = {0.f, 0.f, dz};
        if (dz < 0.f && j % 3 == 1) {
            tu_unit_vec(&r, d);
            d[2] = -fabsf(d[2]);
        } else if (dz < 0.f && j % 3 == 2) {
            float a = tu_range(&r, 0.f, 6.2831853f);
            d[0] = cosf(a), d[1] = sinf(a), d[2] = 0.f;
        }
        ph->dx[j] = d[0], ph->dy[j] = d[1], ph->dz[j] = d[2];
        ph->nx[j] = 0.f, ph->ny[j] = 0.f, ph->nz[j] = 1.f;
        ph->fr[j] = ph->fg[j] = ph->fb[j] = PLANE_FLUX;
    }
    ph->count = PLANE_N;
    ph->emitted = PLANE_N;
}

/* L = kd/pi * E, E = N flux / A. The samples cover [-0.8, 0.8]^2, more than
 * r from the edges at +-1. Poisson noise: n = N pi r^2 / A photons in the
 * disk (about 1571), relative sd 1/sqrt(n) = 2.5%. Each sample must be
 * within 5 sd; the mean over the 24x24 samples (about 80 independent disks)
 * within 1% (its own sd is about 0.3%). */
static void test_uniform_plane(void **state) {
    const float kd[3] = {0.7f, 0.5f, 0.3f};
    const int w = 24, h = 24;
    pgi_view_samples vs;
    pgi_camera cam;
    plane_samples(&vs, &cam, w, h, 0.8f, kd);
    pgi_photons ph;
    plane_photons(&ph, 1.f);
    const double A = (double)PLANE_L * PLANE_L, E = PLANE_N * (double)PLANE_FLUX / A;
    const double nd = PLANE_N * PI_D * PLANE_R * PLANE_R / A, sd = 1.0 / sqrt(nd);
    float *out = malloc(3 * vs.count * sizeof *out);
    int tested = 0;
    for (size_t e = 0; e < pgi_estimator_count(); e++) {
        const pgi_estimator_vtbl *vt = pgi_estimator_at(e);
        if (!vt->exact) continue;
        pgi_estimator_stats st;
        TU_CHECK_OK(tu_run_estimator(vt->name, &(tu_est){.radius = PLANE_R}, &ph, &vs, &cam, out, &st));
        for (int c = 0; c < 3; c++) {
            const double expect = kd[c] / PI_D * E;
            double sum = 0.0, worst = 0.0;
            for (size_t i = 0; i < vs.count; i++) {
                double rel = out[3 * i + c] / expect - 1.0;
                sum += out[3 * i + c];
                if (fabs(rel) > fabs(worst)) worst = rel;
            }
            double mean_rel = sum / (double)vs.count / expect - 1.0;
            if (fabs(worst) > 5.0 * sd || fabs(mean_rel) > 0.01)
                fail_msg("%s channel %d: expected %g; mean off by %.3f%%, worst sample off by %.2f%% (5 sd = %.2f%%)",
                         vt->name, c, expect, 100.0 * mean_rel, 100.0 * worst, 500.0 * sd);
        }
        /* Every photon in a disk arrives from above: contributing ~ samples * n. */
        double per = (double)st.contributing / (double)vs.count;
        assert_true(fabs(per / nd - 1.0) < 0.01);
        tested++;
    }
    assert_true(tested >= 3);
    free(out);
    pgi_photons_free(&ph);
    pgi_view_samples_free(&vs);
}

/* Photons arriving from below the surface or exactly along it do not count. */
static void test_plane_from_below(void **state) {
    const float kd[3] = {0.7f, 0.5f, 0.3f};
    pgi_view_samples vs;
    pgi_camera cam;
    plane_samples(&vs, &cam, 24, 24, 0.8f, kd);
    pgi_photons ph;
    plane_photons(&ph, -1.f);
    float *out = malloc(3 * vs.count * sizeof *out);
    for (size_t e = 0; e < pgi_estimator_count(); e++) {
        const pgi_estimator_vtbl *vt = pgi_estimator_at(e);
        if (!vt->exact) continue; /* approximate ones (directional) have their own bounds */
        for (size_t i = 0; i < 3 * vs.count; i++) out[i] = NAN;
        pgi_estimator_stats st;
        TU_CHECK_OK(tu_run_estimator(vt->name, &(tu_est){.radius = PLANE_R}, &ph, &vs, &cam, out, &st));
        for (size_t i = 0; i < 3 * vs.count; i++)
            if (out[i] != 0.f) fail_msg("%s: value %zu is %g for photons from below", vt->name, i, (double)out[i]);
        assert_int_equal(st.contributing, 0);
    }
    free(out);
    pgi_photons_free(&ph);
    pgi_view_samples_free(&vs);
}

/* ------------------------------------------------ kernel normalisation */

/* One photon of flux 1 at the origin, samples on a 160x160 grid of cells
 * covering [-1.05 r, 1.05 r]^2: sum(estimate * cell area) / (kd/pi) is the
 * integral of the kernel over the plane, 1 within 1% (the pixel-centre
 * rasterisation of the disk is good to about 0.2%). */
static void test_kernel_normalisation(void **state) {
    const float r = 0.1f, half = 1.05f * r;
    const float kd[3] = {1.f, 0.5f, 0.25f};
    const int n = 160;
    pgi_view_samples vs;
    pgi_camera cam;
    plane_samples(&vs, &cam, n, n, half, kd);
    pgi_photons ph;
    TU_CHECK_OK(pgi_photons_alloc(&ph, 1));
    ph.px[0] = ph.py[0] = ph.pz[0] = 0.f;
    ph.dx[0] = 0.f, ph.dy[0] = 0.f, ph.dz[0] = 1.f;
    ph.nx[0] = 0.f, ph.ny[0] = 0.f, ph.nz[0] = 1.f;
    ph.fr[0] = ph.fg[0] = ph.fb[0] = 1.f;
    ph.count = ph.emitted = 1;
    /* Cell area from the actual sample spacing on the plane. */
    double dx = vs.pos[3 * 1 + 0] - vs.pos[0], dy = vs.pos[1] - vs.pos[3 * (size_t)n + 1];
    double cell = fabs(dx * dy);
    assert_true(fabs(sqrt(cell) - 2.0 * half / n) < 1e-3 * half);
    float *out = malloc(3 * vs.count * sizeof *out);
    for (size_t e = 0; e < pgi_estimator_count(); e++) {
        const pgi_estimator_vtbl *vt = pgi_estimator_at(e);
        if (!vt->exact) continue; /* approximate ones (directional) have their own bounds */
        pgi_estimator_stats st;
        TU_CHECK_OK(tu_run_estimator(vt->name, &(tu_est){.radius = r}, &ph, &vs, &cam, out, &st));
        for (int c = 0; c < 3; c++) {
            double integral = 0.0;
            for (size_t i = 0; i < vs.count; i++) integral += out[3 * i + c] * cell;
            integral /= kd[c] / PI_D;
            if (fabs(integral - 1.0) > 0.01) fail_msg("%s channel %d: kernel integral %.5f", vt->name, c, integral);
        }
        /* The photon is read by the samples inside its disk only. */
        double inside = PI_D * r * r / cell;
        assert_true(fabs((double)st.contributing / inside - 1.0) < 0.01);
    }
    free(out);
    pgi_photons_free(&ph);
    pgi_view_samples_free(&vs);
}

/* ------------------------------------------------ furnace */

/* The furnace scene: tests/test_scenes.h. */

/* Mean and worst relative deviation of all pixels (all channels) from `expect`. */
static void image_vs(const pgi_image *img, double expect, double *mean_rel, double *worst_rel) {
    size_t n = 3 * (size_t)img->width * img->height;
    double sum = 0.0, worst = 0.0;
    for (size_t i = 0; i < n; i++) {
        sum += img->rgb[i];
        double rel = img->rgb[i] / expect - 1.0;
        if (!(fabs(rel) <= fabs(worst))) worst = rel;
    }
    *mean_rel = sum / (double)n / expect - 1.0;
    *worst_rel = worst;
}

static void furnace_render(int bounces, pgi_output output, pgi_image *img) {
    pgi_scene *s = tu_scene(tu_furnace_json);
    pgi_scene_info info;
    pgi_scene_get_info(s, &info);
    assert_int_equal(info.point_lights, 1);
    assert_true(info.triangles > 10000);
    pgi_render_desc d = {.estimator = "hashgrid",
                         .width = 64,
                         .height = 48,
                         .bounces = bounces,
                         .photons = 400000,
                         .radius = 0.1f,
                         .output = output,
                         .seed = 3};
    pgi_frame_stats fs;
    TU_CHECK_OK(pgi_render(s, &d, img, &fs));
    assert_int_equal(fs.photons_stored, 400000);
    pgi_scene_destroy(s);
}

/* Direct light: every point of the sphere gets E0 = I/R^2, so L = rho/pi * E0.
 * Flat facets move points inward by at most 1 - cos(pi/64) = 0.12%, and
 * irradiance on a facet stays within about 0.3% of E0: each pixel within 1%. */
static void test_furnace_direct(void **state) {
    pgi_image img = {0};
    furnace_render(4, PGI_OUTPUT_DIRECT, &img);
    double expect = FURNACE_RHO / PI_D * FURNACE_I, mean, worst;
    image_vs(&img, expect, &mean, &worst);
    if (fabs(worst) > 0.01)
        fail_msg("direct: expected %g, mean off by %.3f%%, worst pixel off by %.3f%%", expect, 100 * mean, 100 * worst);
    pgi_image_free(&img);
}

/* Indirect light with B bounces: photons are stored at hits 2..B+1 of a path
 * (after 1..B bounces); after k bounces the irradiance they carry is
 * rho^k E0 (the sphere's inside is uniformly lit, every bounce keeps the
 * fraction rho), so
 *     L_ind = rho/pi * sum_{k=1..B} rho^k E0 = rho^2 E0/pi * (1 - rho^B)/(1 - rho).
 * Tolerance: the mean over the pixels within 2%. The noise of the mean is
 * about 0.5% (about 1000 photons a disk, about 45 independent disks in the
 * view); the kernel's chord-distance sphere cuts a cap of area exactly pi r^2
 * from a sphere (no curvature bias), and faceting biases by well under 1%. */
static void furnace_indirect(int bounces) {
    pgi_image img = {0};
    furnace_render(bounces, PGI_OUTPUT_INDIRECT, &img);
    const double rho = FURNACE_RHO, E0 = FURNACE_I;
    double expect = rho * rho * E0 / PI_D * (1.0 - pow(rho, bounces)) / (1.0 - rho), mean, worst;
    image_vs(&img, expect, &mean, &worst);
    fprintf(stderr, "  furnace B=%d: expected %.5f, mean off by %+.3f%%, worst pixel %+.2f%%\n", bounces, expect,
            100 * mean, 100 * worst);
    if (fabs(mean) > 0.02)
        fail_msg("indirect, %d bounces: expected %g, mean off by %.3f%%", bounces, expect, 100 * mean);
    /* Per pixel: about 1000 photons (sd ~3%); 20% is far beyond the noise. */
    if (fabs(worst) > 0.2) fail_msg("indirect, %d bounces: worst pixel off by %.2f%%", bounces, 100 * worst);
    pgi_image_free(&img);
}

static void test_furnace_indirect_4(void **state) { furnace_indirect(4); }
static void test_furnace_indirect_1(void **state) { furnace_indirect(1); }

int main(void) {
    const struct CMUnitTest plane[] = {
        cmocka_unit_test(test_uniform_plane),
        cmocka_unit_test(test_plane_from_below),
        cmocka_unit_test(test_kernel_normalisation),
    };
    const struct CMUnitTest furnace[] = {
        cmocka_unit_test(test_furnace_direct),
        cmocka_unit_test(test_furnace_indirect_4),
        cmocka_unit_test(test_furnace_indirect_1),
    };
    int fails = cmocka_run_group_tests_name("analytic: plane and kernel", plane, NULL, NULL);
    fails += cmocka_run_group_tests_name("analytic: furnace", furnace, tu_furnace_setup, tu_furnace_teardown);
    return fails;
}
