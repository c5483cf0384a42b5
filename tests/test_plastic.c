/* The microfacet plastic (src/scene/bsdf.h, microfacet.c): energy conservation of a white
 * plastic (a white furnace by quadrature), the sampler against the evaluation, and the mesh
 * loader's mapping of MTL illum 2 with the "specular" switch. The path tracer and the photon
 * pipeline agree on a box with a plastic floor in test_reference. */
#include "test_util.h"

#include "scene/bsdf.h"

#define PI_D 3.14159265358979323846

static pgi__material plastic(float ns, float ior, float ks) {
    pgi__material m;
    memset(&m, 0, sizeof m);
    m.type = PGI__MAT_PLASTIC;
    m.kd[0] = m.kd[1] = m.kd[2] = 1.f;
    m.ks[0] = m.ks[1] = m.ks[2] = ks;
    m.shininess = ns;
    m.ior = ior;
    m.tex_kd = -1;
    return m;
}

/* Ns of a roughness alpha (the inverse of pgi__ggx_alpha_from_ns). */
static float ns_of_alpha(float a) { return 2.f / (a * a) - 2.f; }

/* int f(wi, wo) cos(wi) dwi over the upper hemisphere, n = +z, wo at cosine mu, kd as given:
 * the base by a (theta, phi) grid in cosine-weighted coordinates (it is smooth), the lobe by
 * a grid over the half vector h (wi = reflect(wo, h), dwi = 4 (wo.h) dh) whose polar angle
 * follows the lobe's width, tan(theta_h) = alpha tan(pi v / 2), so that alpha = 0.01 is
 * resolved as well as alpha = 1. Independent of the albedo table: it only calls the BRDF. */
static double albedo_quad(const pgi__lobe *l, pgi__v3 kd, float mu) {
    const pgi__v3 n = v3(0.f, 0.f, 1.f), wo = v3(sqrtf(fmaxf(0.f, 1.f - mu * mu)), 0.f, mu);
    const int NT = 400, NP = 200;
    double base = 0.0;
    for (int i = 0; i < NT; i++) {
        double u = (i + 0.5) / NT, ct = sqrt(1.0 - u), st = sqrt(u); /* cosine-weighted: pdf cos/pi */
        for (int j = 0; j < NP; j++) {
            double ph = 2.0 * PI_D * (j + 0.5) / NP;
            pgi__v3 wi = v3((float)(st * cos(ph)), (float)(st * sin(ph)), (float)ct);
            pgi__v3 f = pgi__brdf_eval(kd, l, n, wi, wo);
            float ci = (float)ct;
            double spec = (ci > 0.f && mu > 0.f) ? (double)pgi__ggx_spec(l, n, wi, wo, ci, mu) * l->ks.y : 0.0;
            base += ((double)f.y - spec) * PI_D; /* f cos / (cos / pi) */
        }
    }
    base /= (double)NT * NP;
    const double alpha = sqrt((double)l->a2);
    const int NV = 2000, NH = 256;
    double spec = 0.0;
    for (int i = 0; i < NV; i++) {
        double v = (i + 0.5) / NV, tv = tan(0.5 * PI_D * v);
        double th = atan(alpha * tv);
        double dth = alpha * 0.5 * PI_D * (1.0 + tv * tv) / (1.0 + alpha * alpha * tv * tv); /* d theta / dv */
        double sth = sin(th), cth = cos(th);
        for (int j = 0; j < NH; j++) {
            double ph = 2.0 * PI_D * (j + 0.5) / NH;
            pgi__v3 h = v3((float)(sth * cos(ph)), (float)(sth * sin(ph)), (float)cth);
            float oh = v3_dot(wo, h);
            if (!(oh > 0.f)) continue;
            pgi__v3 wi = v3_sub(v3_scale(h, 2.f * oh), wo);
            float ci = wi.z;
            if (!(ci > 0.f)) continue;
            double f = (double)pgi__ggx_spec(l, n, wi, wo, ci, mu) * l->ks.y;
            spec += f * ci * 4.0 * oh * sth * dth;
        }
    }
    spec *= (1.0 / NV) * (2.0 * PI_D / NH);
    return base + spec;
}

/* White furnace: a white base (kd = 1) under an untinted lobe reflects everything, for
 * every roughness, index and viewing angle: within 1%, and never more than 1 + 1e-3. A base
 * left at kd/pi (no energy awareness) gives 1 + E (4% at normal incidence, up to 60% at
 * grazing); a base reduced by (1 - E(wo)) alone loses the lobe's missing energy. */
static void test_white_furnace(void **state) {
    const float alphas[] = {0.01f, 0.03f, 0.1f, 0.25f, 0.5f, 0.8f, 1.f};
    const float etas[] = {1.5f, 1.33f, 1.45f, 2.2f};
    const float mus[] = {1.f, 0.8f, 0.5f, 0.3f, 0.15f, 0.05f};
    double worst = 0.0, highest = 0.0;
    for (size_t e = 0; e < sizeof etas / sizeof etas[0]; e++)
        for (size_t a = 0; a < sizeof alphas / sizeof alphas[0]; a++) {
            pgi__material m = plastic(ns_of_alpha(alphas[a]), etas[e], pgi__fresnel_f0(etas[e]));
            pgi__lobe l;
            pgi__lobe_of_material(&m, &l);
            assert_int_equal(l.model, PGI__LOBE_GGX);
            assert_true(fabsf(l.ks.y - 1.f) < 1e-5f); /* Ks = F0(eta): the untinted lobe */
            for (size_t k = 0; k < sizeof mus / sizeof mus[0]; k++) {
                double alb = albedo_quad(&l, v3(1.f, 1.f, 1.f), mus[k]);
                if (fabs(alb - 1.0) > fabs(worst)) worst = alb - 1.0;
                if (alb - 1.0 > highest) highest = alb - 1.0;
                if (getenv("PGI_PLASTIC_VERBOSE"))
                    fprintf(stderr, "    alpha %g eta %g mu %g: %+.5f\n", alphas[a], etas[e], mus[k], alb - 1.0);
                if (!getenv("PGI_PLASTIC_VERBOSE") && (fabs(alb - 1.0) > 0.01 || alb > 1.0 + 1e-3))
                    fail_msg("white plastic alpha %g eta %g mu %g: albedo %.5f", alphas[a], etas[e], mus[k], alb);
            }
        }
    fprintf(stderr, "  white furnace: worst albedo deviation %+.4f%%, highest %+.4f%%\n", 100 * worst, 100 * highest);
    /* The table E itself: the lobe alone (kd = 0) at normal incidence of a smooth surface is F0. */
    pgi__material m = plastic(10000.f, 1.5f, 0.04f);
    pgi__lobe l;
    pgi__lobe_of_material(&m, &l);
    double e0 = albedo_quad(&l, v3(0.f, 0.f, 0.f), 1.f);
    fprintf(stderr, "  lobe albedo at normal incidence, alpha %.4f: %.5f (F0 0.04)\n", sqrt(l.a2), e0);
    assert_true(fabs(e0 - 0.04) < 0.002);
    assert_true(fabs(pgi__lobe_E(&l, 1.f) - e0) < 5e-4);
}

/* A coloured base and a tinted lobe conserve less: albedo kd (1 - E) + tint E <= 1. */
static void test_tinted_below_one(void **state) {
    pgi__material m = plastic(30.f, 1.5f, 0.02f); /* tint 0.5 */
    m.kd[0] = 0.8f;
    m.kd[1] = 0.5f;
    m.kd[2] = 0.2f;
    pgi__lobe l;
    pgi__lobe_of_material(&m, &l);
    assert_true(fabsf(l.ks.y - 0.5f) < 1e-4f);
    for (float mu = 0.1f; mu <= 1.f; mu += 0.3f) {
        double alb = albedo_quad(&l, v3_load(m.kd), mu);
        double E = pgi__lobe_E(&l, mu), expect = 0.5 * (1.0 - E) + 0.5 * E; /* green: kd 0.5, tint 0.5 */
        assert_true(fabs(alb - expect) < 0.005);
        assert_true(alb < 1.0);
    }
}

/* The sampler: E[f cos / pdf] (the weight pgi__bsdf_sample returns) equals the albedo by
 * quadrature, the weight equals f cos / pgi__bsdf_pdf sample by sample, and the density
 * integrates (over the upper hemisphere, by quadrature of pgi__bsdf_pdf) to the fraction
 * of samples that stay above the surface. A pdf off by the visible-normal factor G1 or by
 * the 4 (wo.h) Jacobian fails all three; a wrong lobe pick probability fails the last two. */
static void test_sample_matches_eval(void **state) {
    const float alphas[] = {0.05f, 0.3f, 0.9f};
    const float mus[] = {0.9f, 0.4f, 0.1f};
    const float kds[] = {0.2f, 0.8f};
    tu_rng r = tu_rng_make(11);
    for (size_t a = 0; a < 3; a++)
        for (size_t k = 0; k < 3; k++)
            for (size_t d = 0; d < 2; d++) {
                pgi__material m = plastic(ns_of_alpha(alphas[a]), 1.5f, 0.04f);
                m.kd[0] = m.kd[1] = m.kd[2] = kds[d];
                pgi__surface sf;
                memset(&sf, 0, sizeof sf);
                sf.ng = sf.ns = v3(0.f, 0.f, 1.f);
                sf.mat = &m;
                sf.kd = v3_load(m.kd);
                pgi__lobe l;
                pgi__lobe_of_material(&m, &l);
                const float mu = mus[k];
                pgi__v3 wi = v3(sqrtf(1.f - mu * mu), 0.f, mu);
                const int N = 400000;
                double sum = 0.0, sum2 = 0.0;
                int kept = 0;
                for (int s = 0; s < N; s++) {
                    pgi__v3 wo, w;
                    float u1 = tu_unif(&r), u2 = tu_unif(&r), u3 = tu_unif(&r);
                    if (!pgi__bsdf_sample(&sf, wi, u1, u2, u3, &wo, &w)) continue;
                    kept++;
                    sum += w.y;
                    sum2 += (double)w.y * w.y;
                    if (s % 97 == 0) {
                        float pdf = pgi__bsdf_pdf(&sf, wi, wo);
                        pgi__v3 f = pgi__brdf_eval(sf.kd, &l, sf.ns, wi, wo);
                        double expect = f.y * wo.z / pdf;
                        if (!(fabs(w.y - expect) <= 1e-4 * fmax(1.0, expect)))
                            fail_msg("weight %g vs f cos / pdf %g", w.y, expect);
                    }
                }
                double mean = sum / N, sd = sqrt(fmax(0.0, sum2 / N - mean * mean) / N);
                double alb = albedo_quad(&l, sf.kd, mu);
                /* pdf over the hemisphere by quadrature: the base part (cosine grid) + the lobe
                 * part (half-vector grid), as albedo_quad */
                double ip = 0.0;
                const int NT = 300, NP = 150;
                for (int i = 0; i < NT; i++)
                    for (int j = 0; j < NP; j++) {
                        double u = (i + 0.5) / NT, ct = sqrt(1.0 - u), st = sqrt(u), ph = 2.0 * PI_D * (j + 0.5) / NP;
                        pgi__v3 wo = v3((float)(st * cos(ph)), (float)(st * sin(ph)), (float)ct);
                        double p = pgi__bsdf_pdf(&sf, wi, wo);
                        ip += p / (ct / PI_D);
                    }
                ip /= (double)NT * NP;
                double frac = (double)kept / N;
                fprintf(stderr,
                        "  alpha %.2f mu %.1f kd %.1f: E[w] %.5f +- %.5f, albedo %.5f; pdf integral %.4f, kept "
                        "%.4f\n",
                        alphas[a], mu, kds[d], mean, sd, alb, ip, frac);
                if (fabs(mean - alb) > 4.0 * sd + 2e-3)
                    fail_msg("alpha %g mu %g kd %g: mean weight %g, albedo %g", alphas[a], mu, kds[d], mean, alb);
                if (alphas[a] >= 0.3f && fabs(ip - frac) > 0.01)
                    fail_msg("alpha %g mu %g: pdf integrates to %g, samples kept %g", alphas[a], mu, ip, frac);
            }
}

/* MTL illum 2 (Ks 0.04, Ns 198, Kd 0.98): a plastic by default (kd as given, Ni absent ->
 * 1.5); "specular": "phong" in the description, or pgi_scene_set_specular, gives the papers'
 * Blinn-Phong (kd lowered to 1 - Ks) and back. */
static void test_mtl_mapping(void **state) {
    char dir[512], path[700], json[1200];
    tu_make_tmpdir(dir, sizeof dir);
    snprintf(path, sizeof path, "%s/q.mtl", dir);
    assert_int_equal(tu_write_file(path, "newmtl floor\nKd 0.98 0.98 0.98\nKs 0.04 0.04 0.04\nNs 198\nillum 2\n"
                                         "newmtl wall\nKd 0.5 0.5 0.5\nillum 1\n"),
                     0);
    snprintf(path, sizeof path, "%s/q.obj", dir);
    assert_int_equal(tu_write_file(path, "mtllib q.mtl\nv 0 0 0\nv 1 0 0\nv 1 0 1\nv 0 1 0\n"
                                         "usemtl floor\nf 1 3 2\nusemtl wall\nf 1 2 4\n"),
                     0);
    char obj[700];
    snprintf(obj, sizeof obj, "%s", path);
    for (int variant = 0; variant < 3; variant++) {
        const char *spec = variant == 0 ? "" : variant == 1 ? ", \"specular\": \"phong\"" : ", \"specular\": \"ggx\"";
        snprintf(json, sizeof json,
                 "{\"mesh\": \"%s\"%s, \"lights\": [{\"type\": \"point\", \"position\": [0.5, 2, 0.5], "
                 "\"intensity\": [1, 1, 1]}]}",
                 obj, spec);
        snprintf(path, sizeof path, "%s/q%d.json", dir, variant);
        assert_int_equal(tu_write_file(path, json), 0);
        pgi_scene *s = tu_scene(path);
        const pgi__material *fl = NULL;
        for (size_t i = 0; i < s->nmats; i++)
            if (strcmp(s->mats[i].name, "floor") == 0) fl = &s->mats[i];
        assert_non_null(fl);
        pgi_scene_info info;
        pgi_scene_get_info(s, &info);
        assert_int_equal(info.glossy_materials, 1);
        if (variant == 1) {
            assert_int_equal(fl->type, PGI__MAT_PHONG);
            assert_int_equal(info.specular, PGI_SPECULAR_PHONG);
            assert_true(fabsf(fl->kd[0] - 0.96f) < 1e-6f);
            /* the switch both ways */
            TU_CHECK_OK(pgi_scene_set_specular(s, PGI_SPECULAR_GGX));
            assert_int_equal(fl->type, PGI__MAT_PLASTIC);
            assert_true(fabsf(fl->kd[0] - 0.98f) < 1e-6f);
            TU_CHECK_OK(pgi_scene_set_specular(s, PGI_SPECULAR_DEFAULT)); /* the description's */
            assert_int_equal(fl->type, PGI__MAT_PHONG);
        } else {
            assert_int_equal(fl->type, PGI__MAT_PLASTIC);
            assert_int_equal(info.specular, PGI_SPECULAR_GGX);
            assert_true(fabsf(fl->kd[0] - 0.98f) < 1e-6f);
            assert_true(fabsf(fl->ior - 1.5f) < 1e-6f);
            pgi__lobe l;
            pgi__lobe_of_material(fl, &l);
            assert_true(fabsf(l.s - sqrtf(2.f / 200.f)) < 1e-6f); /* alpha = sqrt(2 / (Ns + 2)) = 0.1 */
            TU_CHECK_OK(pgi_scene_set_specular(s, PGI_SPECULAR_PHONG));
            assert_int_equal(fl->type, PGI__MAT_PHONG);
            assert_true(fabsf(fl->kd[0] - 0.96f) < 1e-6f);
        }
        for (size_t i = 0; i < s->nmats; i++)
            if (strcmp(s->mats[i].name, "wall") == 0) assert_int_equal(s->mats[i].type, PGI__MAT_LAMBERT);
        assert_int_equal(pgi_scene_set_specular(s, (pgi_specular)7), PGI_ERR_INVALID_ARG);
        pgi_scene_destroy(s);
    }
    snprintf(json, sizeof json, "{\"mesh\": \"%s\", \"specular\": \"blinn\"}", obj);
    snprintf(path, sizeof path, "%s/bad.json", dir);
    assert_int_equal(tu_write_file(path, json), 0);
    pgi_scene *s = NULL;
    assert_int_equal(pgi_scene_load(path, &s), PGI_ERR_PARSE);
    assert_non_null(strstr(pgi_last_error(), "specular"));
    tu_rm_tmpdir(dir);
}

TU_MAIN("plastic", NULL, NULL, cmocka_unit_test(test_white_furnace), cmocka_unit_test(test_tinted_below_one),
        cmocka_unit_test(test_sample_matches_eval), cmocka_unit_test(test_mtl_mapping))
