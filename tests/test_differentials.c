/* Photon differentials (BVH paper §4) and the radius policies on small
 * analytic set-ups: expansion with distance after a flat diffuse bounce and
 * from a point light, contraction / expansion after concave / convex mirrors
 * (paraxial optics: footprint scale 1 -/+ 2L/R), refraction, Russian
 * roulette's 1/sqrt(p), the curvature of interpolated normals on a
 * tessellated sphere, the footprints of a whole frame, and bad settings. */
#include "test_util.h"

#include "photon/differentials.h"
#include "photon/photon.h"
#include "scene/scene_internal.h"

static float fp_radius(const pgi__pdiff *pd, float delta) {
    pgi__v3 c = v3_cross(v3_scale(pd->dp[0], delta), v3_scale(pd->dp[1], delta));
    return sqrtf(v3_len(c));
}

static void assert_close(double got, double want, double rel, const char *what) {
    if (!(fabs(got - want) <= rel * fabs(want))) fail_msg("%s: got %.9g, expected %.9g", what, got, want);
}

/* Point light, photon straight down onto a plane h below: footprint area share of 4 pi h^2. */
static void test_point_light_spreads(void **state) {
    (void)state;
    pgi__fp_params p;
    pgi__fp_params_init(&p, PGI_RADIUS_DIFFERENTIALS, 0.f, 100.f, 1.f, 10000, 10.f);
    assert_close(p.delta, sqrt(4.0 * 3.14159265358979 / 10000.0), 1e-6, "Delta = 2 sqrt(pi/n)");
    float prev = 0.f;
    for (float h = 0.5f; h < 8.f; h *= 2.f) {
        pgi__pdiff pd;
        pgi__v3 d = v3_norm(v3(0.3f, -1.f, 0.2f));
        pgi__pd_emit_dir(&pd, d, v3(0.f, 0.f, 1.f), 1.f);
        assert_close(v3_len(pd.dd[0]), 1.0, 1e-5, "|d_cos d| (eq. 8)");
        assert_close(v3_len(pd.dd[1]), 1.0, 1e-5, "|d_phi d| (eq. 8)");
        assert_true(fabsf(v3_dot(pd.dd[0], d)) < 1e-5f && fabsf(v3_dot(pd.dd[1], d)) < 1e-5f);
        float t = h / -d.y;
        pgi__pd_transfer(&pd, d, t, v3(0.f, 1.f, 0.f));
        assert_true(fabsf(pd.dp[0].y) < 1e-5f && fabsf(pd.dp[1].y) < 1e-5f); /* on the plane */
        /* ellipse area on the plane = pi Delta^2 t^2 / cos(theta) */
        float r = fp_radius(&pd, p.delta);
        assert_close((double)r * r, (double)p.delta * p.delta * t * t / -d.y, 1e-4, "area after transfer");
        assert_true(r > prev);
        prev = r;
    }
}

/* Flat diffuse bounce: the re-emitted footprint keeps the area at the bounce (eq. 13) and then
 * expands linearly with distance. */
static void test_diffuse_bounce_expands(void **state) {
    (void)state;
    const float delta = 0.05f;
    pgi__pdiff pd = {0};
    pd.dp[0] = v3(0.4f, 0.f, 0.1f);
    pd.dp[1] = v3(-0.1f, 0.f, 0.7f);
    pgi__v3 n = v3(0.f, 1.f, 0.f);
    float r0 = fp_radius(&pd, delta);
    pgi__v3 dout = v3(0.f, 1.f, 0.f);
    pgi__pd_reemit(&pd, dout, n);
    assert_true(pd.diffuse);
    assert_close(fp_radius(&pd, delta), r0, 1e-5, "area kept on re-emission (eq. 13)");
    float v = sqrtf(v3_len(v3_cross(v3(0.4f, 0.f, 0.1f), v3(-0.1f, 0.f, 0.7f))));
    float prev = r0;
    for (float L = 0.5f; L < 10.f; L *= 2.f) {
        pgi__pdiff q = pd;
        pgi__pd_transfer(&q, dout, L, v3(0.f, -1.f, 0.f)); /* a parallel ceiling at distance L */
        float r = fp_radius(&q, delta);
        assert_close(r, delta * (v + L), 1e-4, "footprint radius Delta (v + L)");
        assert_true(r > prev);
        prev = r;
    }
    /* the compressed, smoothed footprint grows too, but slower (||dp||^(1/4)) */
    pgi__fp_params p;
    pgi__fp_params_init(&p, PGI_RADIUS_DIFFERENTIALS, 0.f, 1000.f, 2.f, 5000, 10.f);
    pgi__footprint f1, f2;
    pgi__pdiff q1 = pd, q2 = pd;
    pgi__pd_transfer(&q1, dout, 1.f, v3(0.f, -1.f, 0.f));
    pgi__pd_transfer(&q2, dout, 16.f, v3(0.f, -1.f, 0.f));
    pgi__pd_footprint(&q1, &p, v3(0.f, -1.f, 0.f), &f1);
    pgi__pd_footprint(&q2, &p, v3(0.f, -1.f, 0.f), &f2);
    assert_close(f2.r / f1.r, pow((v + 16.0) / (v + 1.0), 0.25), 1e-3, "||dp||^(-3/4) compression");
    assert_close(f1.r, p.delta * 2.0 * pow(v + 1.0, 0.25), 1e-3, "smoothing factor s");
}

/* A parallel beam along -z hits a mirror at z = 0 (normal +z) of curvature k (normal differential
 * dn = k dp): k = +1/R convex, -1/R concave. After reflection the footprint at height L scales by
 * 1 + 2 k L (focus of the concave mirror at R/2). */
static float mirror_scale(float k, float L) {
    pgi__pdiff pd = {0};
    pd.dp[0] = v3(1.f, 0.f, 0.f);
    pd.dp[1] = v3(0.f, 1.f, 0.f);
    pgi__v3 d = v3(0.f, 0.f, -1.f), n = v3(0.f, 0.f, 1.f);
    pgi__v3 dn[2] = {v3_scale(pd.dp[0], k), v3_scale(pd.dp[1], k)};
    pgi__pd_reflect(&pd, d, n, dn);
    pgi__pd_transfer(&pd, v3(0.f, 0.f, 1.f), L, v3(0.f, 0.f, -1.f));
    return fp_radius(&pd, 1.f);
}

static void test_curved_mirrors(void **state) {
    (void)state;
    const float R = 2.f;
    assert_close(mirror_scale(0.f, 1.f), 1.0, 1e-6, "flat mirror keeps a parallel beam");
    for (float L = 0.1f; L < 0.9f; L += 0.2f) {
        float cv = mirror_scale(1.f / R, L), cc = mirror_scale(-1.f / R, L);
        assert_close(cv, 1.0 + 2.0 * L / R, 1e-5, "convex mirror expands");
        assert_close(cc, 1.0 - 2.0 * L / R, 1e-5, "concave mirror contracts");
        assert_true(cv > 1.f && cc < 1.f);
    }
    assert_true(mirror_scale(-1.f / R, R / 2.f) < 1e-3f); /* the focus */
}

/* Normal incidence into glass (eta = 1/1.5): the tangential spread of the directions scales by eta. */
static void test_refraction(void **state) {
    (void)state;
    pgi__pdiff pd = {0};
    pd.dd[0] = v3(1.f, 0.f, 0.f);
    pd.dd[1] = v3(0.f, 1.f, 0.f);
    pgi__v3 d = v3(0.f, 0.f, -1.f), n = v3(0.f, 0.f, 1.f), dn[2] = {v3(0.f, 0.f, 0.f), v3(0.f, 0.f, 0.f)};
    float eta = 1.f / 1.5f;
    pgi__pd_refract(&pd, d, n, dn, eta, d);
    assert_close(pd.dd[0].x, eta, 1e-6, "refracted d_cos");
    assert_close(pd.dd[1].y, eta, 1e-6, "refracted d_phi");
    assert_true(fabsf(pd.dd[0].z) < 1e-6f);
}

/* Oblique incidence: the analytic differential of the refracted direction (Igehy) equals the
 * derivative of Snell's law by central differences in the incidence angle. */
static void refract_dir(double a, double eta, double out[3]) {
    double d[3] = {sin(a), 0.0, -cos(a)}, ci = cos(a);
    double ct = sqrt(1.0 - eta * eta * (1.0 - ci * ci));
    for (int k = 0; k < 3; k++) out[k] = eta * d[k] + (eta * ci - ct) * (k == 2 ? 1.0 : 0.0);
}

static void test_refraction_oblique(void **state) {
    (void)state;
    const double eta = 1.0 / 1.5;
    for (double a = 0.2; a < 1.3; a += 0.3) {
        pgi__pdiff pd = {0};
        pd.dd[0] = v3((float)cos(a), 0.f, (float)sin(a)); /* d(d)/d(alpha) */
        pd.dd[1] = v3(0.f, 1.f, 0.f);
        double t[3], tp[3], tm[3], h = 1e-5;
        refract_dir(a, eta, t);
        refract_dir(a + h, eta, tp);
        refract_dir(a - h, eta, tm);
        pgi__v3 d = v3((float)sin(a), 0.f, (float)-cos(a)), n = v3(0.f, 0.f, 1.f);
        pgi__v3 dn[2] = {v3(0.f, 0.f, 0.f), v3(0.f, 0.f, 0.f)};
        pgi__pd_refract(&pd, d, n, dn, (float)eta, v3((float)t[0], (float)t[1], (float)t[2]));
        double fd[3];
        for (int k = 0; k < 3; k++) fd[k] = (tp[k] - tm[k]) / (2 * h);
        double err = fabs(pd.dd[0].x - fd[0]) + fabs(pd.dd[0].y - fd[1]) + fabs(pd.dd[0].z - fd[2]);
        if (!(err < 1e-3 * sqrt(fd[0] * fd[0] + fd[2] * fd[2])))
            fail_msg("alpha %g: refraction differential off by %g", a, err);
    }
}

static void test_roulette(void **state) {
    (void)state;
    pgi__pdiff pd = {0};
    pd.dp[0] = v3(1.f, 0.f, 0.f);
    pd.dp[1] = v3(0.f, 2.f, 0.f);
    float a0 = v3_len(v3_cross(pd.dp[0], pd.dp[1]));
    pgi__pd_roulette(&pd, 0.25f);
    assert_close(v3_len(v3_cross(pd.dp[0], pd.dp[1])), a0 / 0.25, 1e-6, "area times 1/p");
    /* the tracer hook: only for the differentials policy */
    pgi__fp_params p;
    pgi__fp_params_init(&p, PGI_RADIUS_PATH, 0.1f, 1.f, 1.f, 100, 1.f);
    pgi__fp_roulette(&pd, &p, 0.25f);
    assert_close(v3_len(v3_cross(pd.dp[0], pd.dp[1])), a0 / 0.25, 1e-6, "path policy: no change");
    p.policy = PGI_RADIUS_DIFFERENTIALS;
    pgi__fp_roulette(&pd, &p, 0.5f);
    assert_close(v3_len(v3_cross(pd.dp[0], pd.dp[1])), a0 / 0.125, 1e-6, "hook scales");
}

/* The interpolated normals of the built-in tessellated unit sphere: dn = dp / R (outward). */
static void test_sphere_normal_derivative(void **state) {
    (void)state;
    pgi_scene *s = tu_scene("sphere-and-plane");
    const pgi__v3 c = v3(0.f, 1.f, 0.f);
    int checked = 0;
    for (size_t t = 0; t < s->ntris && checked < 50; t += 97) {
        const uint32_t *v = s->tri + 3 * t;
        pgi__v3 a = pgi__scene_vertex(s, v[0]), b = pgi__scene_vertex(s, v[1]), cc = pgi__scene_vertex(s, v[2]);
        pgi__v3 p = v3_scale(v3_add(v3_add(a, b), cc), 1.f / 3.f);
        float rr = v3_len(v3_sub(p, c));
        if (fabsf(rr - 1.f) > 0.02f) continue; /* not the sphere */
        pgi__v3 nrm = v3_norm(v3_sub(p, c)), t1, t2;
        v3_basis(nrm, &t1, &t2);
        pgi__v3 dp[2] = {v3_scale(t1, 0.01f), v3_scale(t2, 0.01f)}, dn[2];
        pgi__pd_normal_derivative(s, (uint32_t)t, 1.f / 3.f, 1.f / 3.f, dp, nrm, dn);
        for (int k = 0; k < 2; k++) {
            float err = v3_len(v3_sub(dn[k], dp[k])) / v3_len(dp[k]);
            if (!(err < 0.1f)) fail_msg("triangle %zu: normal derivative off by %g", t, (double)err);
        }
        /* facing the other way (concave side): the derivative flips */
        pgi__pd_normal_derivative(s, (uint32_t)t, 1.f / 3.f, 1.f / 3.f, dp, v3_neg(nrm), dn);
        assert_true(v3_dot(dn[0], dp[0]) < 0.f);
        checked++;
    }
    assert_true(checked >= 10);
    /* a flat quad (the ground plane) has no curvature */
    pgi_scene_destroy(s);
}

/* End to end through the tracer: a spot light 2 above a small mirror cap (curvature radius 4,
 * concave, flat or convex, smooth vertex normals), the reflected caustic caught by a black ceiling
 * 3 above the mirror. Paraxial optics: the beam's linear size at the ceiling is 2 (concave: source
 * at the focus, parallel beam), 5 (flat: virtual source 2 behind) and 8 (convex: virtual source 1
 * behind) units of the spread at 1 from the source; the footprint radii follow. */
static double caustic_median_radius(const char *dir, int curvature) {
    char path[700], json[1400], jpath[700];
    snprintf(path, sizeof path, "%s/mirror.mtl", dir);
    assert_int_equal(tu_write_file(path, "newmtl mirror\nKd 0 0 0\nKs 1 1 1\nillum 3\n"
                                         "newmtl black\nKd 0 0 0\nillum 1\n"),
                     0);
    enum { G = 24 };
    size_t cap = 200000, len = 0;
    char *obj = malloc(cap);
    assert_non_null(obj);
    len += (size_t)snprintf(obj + len, cap - len, "mtllib mirror.mtl\n");
    const double R = 4.0;
    for (int i = 0; i <= G; i++)
        for (int j = 0; j <= G; j++) {
            double x = -0.5 + (double)i / G, z = -0.5 + (double)j / G, y = 0.0, nx = 0.0, ny = 1.0, nz = 0.0;
            if (curvature) {
                /* concave: centre (0, R, 0), normal towards it; convex: centre (0, -R, 0), outward */
                double cy = curvature < 0 ? R : -R, h = sqrt(R * R - x * x - z * z);
                y = curvature < 0 ? cy - h : cy + h;
                nx = (curvature < 0 ? -x : x) / R, ny = (curvature < 0 ? cy - y : y - cy) / R,
                nz = (curvature < 0 ? -z : z) / R;
            }
            len += (size_t)snprintf(obj + len, cap - len, "v %.7f %.7f %.7f\nvn %.7f %.7f %.7f\n", x, y, z, nx, ny, nz);
        }
    len += (size_t)snprintf(obj + len, cap - len, "usemtl mirror\n");
    for (int i = 0; i < G; i++)
        for (int j = 0; j < G; j++) {
            int a = i * (G + 1) + j + 1, b = a + 1, c = a + G + 2, d = a + G + 1;
            len += (size_t)snprintf(obj + len, cap - len, "f %d//%d %d//%d %d//%d %d//%d\n", a, a, b, b, c, c, d, d);
        }
    int base = (G + 1) * (G + 1);
    len += (size_t)snprintf(obj + len, cap - len,
                            "v -20 3 -20\nv 20 3 -20\nv 20 3 20\nv -20 3 20\nusemtl black\nf %d %d %d %d\n", base + 1,
                            base + 2, base + 3, base + 4);
    snprintf(path, sizeof path, "%s/mirror%d.obj", dir, curvature + 1);
    assert_int_equal(tu_write_file(path, obj), 0);
    free(obj);
    snprintf(json, sizeof json,
             "{\"mesh\": \"%s\", \"camera\": {\"eye\": [0, 1, 5], \"look_at\": [0, 1, 0]},\n"
             " \"lights\": [{\"type\": \"spot\", \"position\": [0, 2, 0], \"direction\": [0, -1, 0], "
             "\"angle\": 10, \"intensity\": [10, 10, 10]}]}\n",
             path);
    snprintf(jpath, sizeof jpath, "%s/mirror%d.json", dir, curvature + 1);
    assert_int_equal(tu_write_file(jpath, json), 0);
    pgi_scene *sc = tu_scene(jpath);
    pgi__rt *rt = NULL;
    TU_CHECK_OK(pgi__rt_create(sc, &rt));
    const uint32_t n = 3000;
    pgi_photons ph;
    TU_CHECK_OK(pgi_photons_alloc(&ph, n));
    float *buf = malloc(7 * n * sizeof(float));
    assert_non_null(buf);
    ph.radius = buf;
    float **ax[] = {&ph.sax, &ph.say, &ph.saz, &ph.sbx, &ph.sby, &ph.sbz};
    for (int k = 0; k < 6; k++) *ax[k] = buf + (size_t)(k + 1) * n;
    uint64_t hist[PGI_FOOTPRINT_BINS] = {0}, rays = 0;
    pgi__trace_desc td = {.photons = n,
                          .bounces = 3,
                          .seed = 9,
                          .radius_policy = PGI_RADIUS_DIFFERENTIALS,
                          .r_min = 1.f,
                          .r_max = 100.f,
                          .smoothing = 1.f,
                          .footprint_hist = hist};
    pgi__trace_scratch scr = {0};
    TU_CHECK_OK(pgi__photons_trace(sc, rt, &td, &ph, &scr, &rays));
    assert_int_equal(ph.count, n);
    float *r = malloc(n * sizeof *r);
    assert_non_null(r);
    for (size_t j = 0; j < n; j++) {
        assert_true(fabsf(ph.py[j] - 3.f) < 1e-3f); /* every photon is a caustic on the ceiling */
        r[j] = ph.radius[j];
    }
    /* median by partial selection sort on a copy (n is small) */
    for (size_t i = 0; i <= n / 2; i++)
        for (size_t j = i + 1; j < n; j++)
            if (r[j] < r[i]) {
                float t = r[i];
                r[i] = r[j];
                r[j] = t;
            }
    double med = r[n / 2];
    free(r);
    free(buf);
    ph.radius = NULL;
    for (int k = 0; k < 6; k++) *ax[k] = NULL;
    pgi_photons_free(&ph);
    pgi__trace_scratch_free(&scr);
    pgi__rt_destroy(rt);
    pgi_scene_destroy(sc);
    return med;
}

static void test_mirror_scenes(void **state) {
    (void)state;
    char dir[512];
    tu_make_tmpdir(dir, sizeof dir);
    double cc = caustic_median_radius(dir, -1), fl = caustic_median_radius(dir, 0), cv = caustic_median_radius(dir, 1);
    fprintf(stderr, "  caustic footprint medians: concave %g, flat %g, convex %g\n", cc, fl, cv);
    assert_true(cc < fl && fl < cv);
    assert_close(cc / fl, 2.0 / 5.0, 0.1, "concave / flat");
    assert_close(cv / fl, 8.0 / 5.0, 0.1, "convex / flat");
    tu_rm_tmpdir(dir);
}

/* A whole frame: every footprint positive, finite, at most r_max; the histogram counts every
 * photon; path radii within [r_min, r_max]. */
static void test_frame_footprints(void **state) {
    (void)state;
    pgi_scene *scene = tu_scene("cornell");
    pgi_renderer *r = tu_renderer(scene);
    pgi_image img = {0};
    pgi_frame_stats fs;
    for (int policy = PGI_RADIUS_PATH; policy <= PGI_RADIUS_DIFFERENTIALS; policy++) {
        pgi_render_desc d = {.estimator = "bvh",
                             .photons = 5000,
                             .width = 32,
                             .height = 32,
                             .radius_policy = policy,
                             .r_max = 0.1f,
                             .r_min = 0.02f,
                             .output = PGI_OUTPUT_INDIRECT};
        TU_CHECK_OK(pgi_renderer_render(r, &d, &img, &fs));
        assert_int_equal(fs.radius_policy, policy);
        assert_close(fs.footprint_bin_width, 0.1 / 14.0, 1e-6, "bin width r_max/14");
        uint64_t sum = 0;
        for (int k = 0; k < PGI_FOOTPRINT_BINS; k++) sum += fs.footprint_hist[k];
        assert_int_equal(sum, fs.photons_stored);
        if (policy == PGI_RADIUS_PATH) {
            /* no mirrors: rho is tiny, every radius just below r_max (bins 13 and 14) */
            assert_int_equal(fs.footprint_hist[13] + fs.footprint_hist[14], sum);
        } else {
            int used = 0;
            for (int k = 0; k < PGI_FOOTPRINT_BINS; k++) used += fs.footprint_hist[k] > 0;
            assert_true(used >= 5); /* a spread of sizes, not one */
        }
        assert_true(tu_max_abs(img.rgb, 3 * 32 * 32) > 0.0);
    }
    /* the fixed policy reports no histogram */
    pgi_render_desc d = {.estimator = "bvh", .photons = 2000, .width = 16, .height = 16};
    TU_CHECK_OK(pgi_renderer_render(r, &d, &img, &fs));
    assert_true(fs.footprint_bin_width == 0.f);
    pgi_image_free(&img);
    pgi_renderer_destroy(r);
    pgi_scene_destroy(scene);
}

/* More photons (fixed radius) -> larger T_auto leaves (BVH paper §5.3). */
static void test_t_auto_grows(void **state) {
    (void)state;
    pgi_scene *scene = tu_scene("cornell");
    pgi_renderer *r = tu_renderer(scene);
    pgi_image img = {0};
    pgi_frame_stats fs;
    int prev = 0;
    const uint32_t counts[] = {5000, 20000, 80000};
    for (int k = 0; k < 3; k++) {
        pgi_render_desc d = {.estimator = "bvh", .photons = counts[k], .width = 16, .height = 16};
        TU_CHECK_OK(pgi_renderer_render(r, &d, &img, &fs));
        assert_true(fs.leaf_size > prev);
        prev = fs.leaf_size;
    }
    pgi_image_free(&img);
    pgi_renderer_destroy(r);
    pgi_scene_destroy(scene);
}

static void test_bad_settings(void **state) {
    (void)state;
    pgi_scene *scene = tu_scene("cornell");
    pgi_image img = {0};
    pgi_render_desc d = {.estimator = "bvh", .photons = 100, .width = 8, .height = 8, .radius_policy = PGI_RADIUS_PATH};
    d.r_min = 0.2f, d.r_max = 0.1f;
    assert_int_equal(pgi_render(scene, &d, &img, NULL), PGI_ERR_INVALID_ARG);
    assert_non_null(strstr(pgi_last_error(), "r_min"));
    d.r_min = -1.f;
    assert_int_equal(pgi_render(scene, &d, &img, NULL), PGI_ERR_INVALID_ARG);
    d.r_min = 0.f, d.r_max = NAN;
    assert_int_equal(pgi_render(scene, &d, &img, NULL), PGI_ERR_INVALID_ARG);
    d.r_max = INFINITY;
    assert_int_equal(pgi_render(scene, &d, &img, NULL), PGI_ERR_INVALID_ARG);
    d.r_max = 0.f, d.smoothing = -2.f;
    assert_int_equal(pgi_render(scene, &d, &img, NULL), PGI_ERR_INVALID_ARG);
    d.smoothing = 0.f, d.radius_policy = 7;
    assert_int_equal(pgi_render(scene, &d, &img, NULL), PGI_ERR_INVALID_ARG);
    d.radius_policy = PGI_RADIUS_DIFFERENTIALS, d.estimator = "hashgrid";
    assert_int_equal(pgi_render(scene, &d, &img, NULL), PGI_ERR_INVALID_ARG);
    assert_non_null(strstr(pgi_last_error(), "per-photon"));
    d.estimator = "bvh", d.est.bvh.leaf_size = -3;
    assert_int_equal(pgi_render(scene, &d, &img, NULL), PGI_ERR_INVALID_ARG);
    d.est.bvh.leaf_size = 0, d.est.bvh.build = 5;
    assert_int_equal(pgi_render(scene, &d, &img, NULL), PGI_ERR_INVALID_ARG);
    d.est.bvh.build = PGI_BVH_VVH;
    TU_CHECK_OK(pgi_render(scene, &d, &img, NULL));
    pgi_image_free(&img);
    pgi_scene_destroy(scene);
}

TU_MAIN("differentials", NULL, NULL, cmocka_unit_test(test_point_light_spreads),
        cmocka_unit_test(test_diffuse_bounce_expands), cmocka_unit_test(test_curved_mirrors),
        cmocka_unit_test(test_refraction), cmocka_unit_test(test_refraction_oblique), cmocka_unit_test(test_roulette),
        cmocka_unit_test(test_sphere_normal_derivative), cmocka_unit_test(test_mirror_scenes),
        cmocka_unit_test(test_frame_footprints), cmocka_unit_test(test_t_auto_grows),
        cmocka_unit_test(test_bad_settings))
