/* The direct pass's area-light pick (src/view/view.h, pgi__area_pick): the guide table picks
 * exactly the light pgi__cdf_pick's binary search picks, for CDFs of many shapes (uniform,
 * steep, runs of zero-power lights, one light holding almost all the power, a few and many
 * lights) and for every u that matters: random ones, each cdf entry and its float neighbours,
 * bucket edges, 0 and the largest u below 1. And a scene's table: the records hold the
 * lights' triangles and the probabilities pgi__cdf_pick gives. */
#include "test_util.h"

#include "scene/scene_internal.h"
#include "view/view.h"

static void check_u(const pgi__area_table *t, float u, const char *what) {
    float p;
    size_t want = pgi__cdf_pick(t->cdf, t->n, u, &p), got = pgi__area_pick(t, u);
    if (got != want) fail_msg("%s (n %zu): u = %.9g picks %zu, binary search %zu", what, t->n, (double)u, got, want);
}

static void check_table(float *w, size_t n, const char *what) {
    pgi__area_table t = {0};
    t.n = n;
    t.cdf = malloc(n * sizeof *t.cdf);
    assert_non_null(t.cdf);
    double tot = 0.0;
    for (size_t k = 0; k < n; k++) {
        tot += w[k];
        t.cdf[k] = (float)tot;
    }
    for (size_t k = 0; k < n; k++) t.cdf[k] = (float)(t.cdf[k] / tot);
    t.cdf[n - 1] = 1.f;
    TU_CHECK_OK(pgi__area_table_guide(&t));
    if (n > 1 && !t.start) fail_msg("%s: no guide table for n %zu", what, n);
    tu_rng r = tu_rng_make(n);
    for (int i = 0; i < 50000; i++) check_u(&t, tu_unif(&r), what);
    const size_t step = n / 5000 + 1; /* every entry of the small tables, a sample of the large */
    for (size_t k = 0; k < n; k += step) {
        check_u(&t, t.cdf[k], what);
        check_u(&t, nextafterf(t.cdf[k], 0.f), what);
        if (t.cdf[k] < 1.f) check_u(&t, nextafterf(t.cdf[k], 1.f), what);
    }
    for (size_t b = 0; b <= t.nb; b += step) {
        float e = (float)((double)b / (double)t.nb);
        check_u(&t, e, what);
        check_u(&t, nextafterf(e, 0.f), what);
        if (e < 1.f) check_u(&t, nextafterf(e, 1.f), what);
    }
    check_u(&t, 0.f, what);
    check_u(&t, nextafterf(1.f, 0.f), what);
    check_u(&t, 1.f, what);
    t.rec = NULL;
    pgi__area_table_free(&t);
}

static void test_same_pick(void **state) {
    (void)state;
    const size_t sizes[] = {1, 2, 3, 7, 64, 1000, 20000, 300000};
    tu_rng r = tu_rng_make(3);
    for (size_t s = 0; s < sizeof sizes / sizeof sizes[0]; s++) {
        size_t n = sizes[s];
        float *w = malloc(n * sizeof *w);
        assert_non_null(w);
        for (size_t k = 0; k < n; k++) w[k] = 1.f;
        check_table(w, n, "uniform");
        for (size_t k = 0; k < n; k++) w[k] = powf(tu_unif(&r), 8.f); /* steep: most of the power in few */
        check_table(w, n, "steep");
        for (size_t k = 0; k < n; k++) w[k] = (k / 5) % 3 == 0 ? 0.f : 0.5f + tu_unif(&r); /* runs of zeros */
        w[n - 1] = 1.f;                                                                    /* some power */
        check_table(w, n, "zero runs");
        for (size_t k = 0; k < n; k++) w[k] = 1e-6f;
        w[n / 2] = 1e6f; /* one light holds almost all the power */
        check_table(w, n, "one bright");
        free(w);
    }
}

/* cornell-box's table: its emissive triangles with their vertices, normals, radiance and area,
 * the probabilities summing to 1. */
static void test_scene_table(void **state) {
    (void)state;
    pgi_scene *s = tu_scene("cornell-box");
    pgi__area_table t;
    TU_CHECK_OK(pgi__area_table_build(s, &t));
    size_t narea = 0;
    for (size_t l = 0; l < s->nlights; l++) narea += s->lights[l].type == PGI__LIGHT_AREA;
    assert_true(narea >= 2);
    assert_int_equal(t.n, narea);
    double psum = 0.0;
    size_t k = 0;
    for (size_t l = 0; l < s->nlights; l++) {
        const pgi__light *lt = &s->lights[l];
        if (lt->type != PGI__LIGHT_AREA) continue;
        const pgi__area_rec *rec = &t.rec[k];
        pgi__v3 y = pgi__triangle_sample(s, lt->tri, 0.3f, 0.6f);
        float su = sqrtf(0.3f), b1 = 1.f - su, b2 = 0.6f * su;
        pgi__v3 z = v3_add(v3_add(v3_scale(rec->a, 1.f - b1 - b2), v3_scale(rec->b, b1)), v3_scale(rec->c, b2));
        assert_memory_equal(&y, &z, sizeof y);
        assert_true(rec->area == lt->area && rec->normal.y == lt->normal[1] && rec->color.x == lt->color[0]);
        float p;
        assert_int_equal(pgi__cdf_pick(t.cdf, t.n, k ? t.cdf[k - 1] : 0.f, &p), k);
        assert_true(p == rec->p);
        psum += rec->p;
        k++;
    }
    assert_true(fabs(psum - 1.0) < 1e-5);
    pgi__area_table_free(&t);
    pgi_scene_destroy(s);
}

TU_MAIN("area_pick", NULL, NULL, cmocka_unit_test(test_same_pick), cmocka_unit_test(test_scene_table))
