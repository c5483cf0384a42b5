/* The GPU backend's BVH (src/rt/tri_bvh.h): its CPU traversal, the shader's algorithm on the
 * layout the shader reads, against Embree (src/rt/rt.c) on the built-in scenes and Sibenik:
 * random rays, camera primary rays, segments with tnear > 0 and shadow rays (any hit). Every
 * Embree hit is found, the same triangle is hit except at ties (coplanar or edge-sharing triangles
 * at the same t, at most 0.2 % of the hits), t agrees to 1e-4 relative and u, v to 1e-3. Cut-outs
 * go through the renderer's filter as in Embree; an animated scene is rebuilt after it moves; the
 * build is deterministic. */
#include "gpu_rays_common.h"

static int g_layout_filter;

/* Casts n rays of kind `kind` both ways and checks the agreement; returns the tally. */
static gr_tally check_kind(const pgi_scene *s, const pgi__rt *rt, const pgi__bvh *b, gr_kind kind, size_t n, int w,
                           int h, uint64_t seed, const char *what, pgi__tri_bvh_counters *cnt) {
    size_t cap = kind == GR_PRIMARY ? (size_t)w * h * s->ncams : n;
    pgi__tri_bvh_ray *r = malloc(cap * sizeof *r);
    pgi__hit *got = malloc(cap * sizeof *got), *ref = malloc(cap * sizeof *ref);
    assert_non_null(r);
    assert_non_null(got);
    assert_non_null(ref);
    n = gr_rays(s, rt, kind, n, w, h, seed, r);
    /* the renderer's cut-out test, or (g_layout_filter) the layout's, the shader's */
    pgi__tri_bvh_filter filter = g_layout_filter ? pgi__tri_bvh_mask_filter : pgi__tri_bvh_scene_filter;
    void *user = g_layout_filter ? (void *)b : (void *)s;
    gr_tally c = {0};
    if (kind == GR_SHADOW) {
        size_t differ = 0, occl = 0;
        for (size_t i = 0; i < n; i++) {
            pgi__v3 o = v3(r[i].org[0], r[i].org[1], r[i].org[2]), d = v3(r[i].dir[0], r[i].dir[1], r[i].dir[2]);
            int e = pgi__rt_occluded(rt, o, d, r[i].tnear, r[i].tfar);
            int g = pgi__tri_bvh_occluded(b, r[i].org, r[i].dir, r[i].tnear, r[i].tfar, filter, user, cnt);
            occl += e;
            if (e != g) {
                /* A shadow ray that ends (or starts) on a surface: the closest hit says whether the
                 * blocker lies at the segment's ends, within the tolerance. */
                pgi__hit hh;
                int at_end = pgi__rt_intersect(rt, o, d, 0.f, INFINITY, &hh) &&
                             (fabsf(hh.t - r[i].tfar) <= 1e-4f * r[i].tfar || fabsf(hh.t - r[i].tnear) <= 1e-4f);
                if (!at_end) differ++;
            }
        }
        c.rays = n;
        c.ref_hits = occl;
        c.wrong = differ;
        fprintf(stderr, "  %-18s %-8s %7zu rays %7zu occluded: %zu answers differ\n", what, gr_kind_name[kind], n, occl,
                differ);
    } else {
        for (size_t i = 0; i < n; i++) {
            pgi__v3 o = v3(r[i].org[0], r[i].org[1], r[i].org[2]), d = v3(r[i].dir[0], r[i].dir[1], r[i].dir[2]);
            if (!pgi__rt_intersect(rt, o, d, r[i].tnear, r[i].tfar, &ref[i])) ref[i].prim = UINT32_MAX;
            pgi__tri_bvh_intersect(b, r[i].org, r[i].dir, r[i].tnear, r[i].tfar, &got[i], filter, user, cnt);
        }
        gr_compare(got, ref, n, pgi__scene_diagonal(s), &c);
        gr_print(what, gr_kind_name[kind], &c);
    }
    free(r);
    free(got);
    free(ref);
    return c;
}

/* Edge ties: at most 0.2 % of the hits of random rays; primary rays through pixel centres in the
 * symmetric built-in scenes hit quads' diagonals exactly (up to 1 % in cornell at 32 x 24), hence
 * 2 % for them. Coplanar overlaps are the scene's own (cornell's boxes stand on the floor with
 * coplanar bottoms, Sibenik has coplanar overlapping faces) and only counted. */
static void assert_agreement(const gr_tally *c, gr_kind kind) {
    assert_int_equal(c->missed, 0);
    assert_true(c->extra <= c->rays / 20000); /* grazing hits at open edges: a few in 10^5 at most */
    assert_int_equal(c->wrong, 0);
    assert_int_equal(c->bad_tuv, 0);
    assert_true((double)c->ties <= (kind == GR_PRIMARY ? 0.02 : 0.002) * (double)c->ref_hits + 1.0);
}

/* The four ray sets of scene `name` (primary rays at w x h a camera). */
static void check_scene(const char *name, size_t n, int w, int h, const pgi__tri_bvh_config *cfg) {
    pgi_scene *s = NULL;
    TU_CHECK_OK(pgi_scene_load(name, &s));
    pgi__rt *rt = NULL;
    TU_CHECK_OK(pgi__rt_create(s, &rt));
    pgi__bvh *b = NULL;
    TU_CHECK_OK(pgi__tri_bvh_build(s, cfg, &b));
    const pgi__tri_bvh_stats *S = &b->stats;
    fprintf(stderr,
            "%s: %zu triangles, %zu refs, %zu inner nodes, %zu leaves (%.2f a leaf), %zu empty slots, depth %d, stack "
            "%d, SAH %.1f, %zu bytes, build %.1f ms, scratch %zu bytes\n",
            name, S->scene_tris, S->tri_refs, S->inner, S->leaves, (double)S->tri_refs / (double)S->leaves,
            S->empty_slots, S->max_depth, S->stack_need, S->sah_cost, S->bytes, S->build_ms, S->build_bytes);
    assert_true(S->stack_need <= PGI__BVH_STACK);
    assert_true(S->tri_refs >= S->scene_tris);
    for (int k = 0; k < 4; k++) {
        gr_tally c = check_kind(s, rt, b, (gr_kind)k, n, w, h, 1000 + (uint64_t)k, name, NULL);
        if (k == GR_SHADOW) assert_int_equal(c.wrong, 0);
        else assert_agreement(&c, (gr_kind)k);
    }
    pgi__tri_bvh_destroy(b);
    pgi__rt_destroy(rt);
    pgi_scene_destroy(s);
}

static void test_cornell(void **state) {
    (void)state;
    check_scene("cornell", 20000, 64, 48, NULL);
}

static void test_sphere_and_plane(void **state) {
    (void)state;
    check_scene("sphere-and-plane", 20000, 64, 48, NULL);
}

/* Cut-outs: the lattice's masked triangles go through pgi__scene_cut_out, as Embree's filter. */
static void test_cutout(void **state) {
    (void)state;
    check_scene("cutout", 20000, 96, 96, NULL);
    /* the layout's cut-out test (masks[], alpha[]: what the shader reads) */
    g_layout_filter = 1;
    check_scene("cutout", 20000, 96, 96, NULL);
    g_layout_filter = 0;
    /* Without the filter the lattice is solid: camera 2 (straight down on it) then sees the
     * lattice where Embree sees through it, about the open fraction of the pixels. */
    pgi_scene *s = NULL;
    TU_CHECK_OK(pgi_scene_load("cutout", &s));
    pgi__rt *rt = NULL;
    TU_CHECK_OK(pgi__rt_create(s, &rt));
    pgi__bvh *b = NULL;
    TU_CHECK_OK(pgi__tri_bvh_build(s, NULL, &b));
    pgi_camera cam;
    const pgi_camera_def *cd = &s->cams[2];
    pgi_camera_look_at(&cam, cd->eye, cd->look_at, cd->up, cd->fov_y_deg, 96, 96);
    size_t differ = 0, masked = 0;
    for (int y = 0; y < 96; y++)
        for (int x = 0; x < 96; x++) {
            pgi__v3 d = pgi__camera_dir(&cam, x, y);
            const float dd[3] = {d.x, d.y, d.z};
            pgi__hit e, g;
            pgi__rt_intersect(rt, v3_load(cam.eye), d, 0.f, INFINITY, &e);
            pgi__tri_bvh_intersect(b, cam.eye, dd, 0.f, INFINITY, &g, NULL, NULL, NULL);
            differ += e.prim != g.prim;
            masked += g.prim != UINT32_MAX && pgi__mat_masked(&s->mats[s->tri_mat[g.prim]]);
        }
    fprintf(stderr, "  cutout without the filter: %zu of %d pixels differ from Embree's\n", differ, 96 * 96);
    assert_true(masked > 0);
    assert_true(fabs((double)differ / (96.0 * 96.0) - PGI__CUTOUT_OPEN_FRACTION) < 0.1);
    /* The layout's test is the renderer's: the same answer at random points of every masked
     * triangle, tiled texture coordinates included. */
    assert_true(b->nmasks > 0 && b->nalpha > 0);
    tu_rng g = tu_rng_make(3);
    size_t tested = 0, cut = 0;
    for (size_t i = 0; i < b->ntris; i++) {
        if (!(b->tris[i].flags & PGI__BVH_TRI_MASKED)) continue;
        for (int k = 0; k < 20000; k++) {
            float u = tu_unif(&g), v = tu_unif(&g);
            if (u + v > 1.f) u = 1.f - u, v = 1.f - v;
            int a = pgi__tri_bvh_mask_filter(b, &b->tris[i], u, v), e = pgi__scene_cut_out(s, b->tris[i].prim, u, v);
            assert_int_equal(a, e);
            tested++;
            cut += a;
        }
    }
    fprintf(stderr, "  cutout: layout and renderer agree at %zu points (%zu cut out)\n", tested, cut);
    assert_true(cut > tested / 5 && cut < tested / 2);
    /* tiled and shifted texture coordinates (wrapping, negative ones) */
    pgi__tri_bvh_destroy(b);
    assert_non_null(s->uv);
    for (size_t i = 0; i < 2 * s->nverts; i++) s->uv[i] = 3.7f * s->uv[i] - 1.3f;
    TU_CHECK_OK(pgi__tri_bvh_build(s, NULL, &b));
    tested = cut = 0;
    for (size_t i = 0; i < b->ntris; i++) {
        if (!(b->tris[i].flags & PGI__BVH_TRI_MASKED)) continue;
        for (int k = 0; k < 20000; k++) {
            float u = tu_unif(&g), v = tu_unif(&g);
            if (u + v > 1.f) u = 1.f - u, v = 1.f - v;
            int a = pgi__tri_bvh_mask_filter(b, &b->tris[i], u, v), e = pgi__scene_cut_out(s, b->tris[i].prim, u, v);
            assert_int_equal(a, e);
            tested++;
            cut += a;
        }
    }
    fprintf(stderr, "  cutout, tiled: layout and renderer agree at %zu points (%zu cut out)\n", tested, cut);
    assert_true(cut > tested / 5 && cut < tested / 2);
    pgi__tri_bvh_destroy(b);
    pgi__rt_destroy(rt);
    pgi_scene_destroy(s);
}

static void test_sibenik(void **state) {
    (void)state;
    check_scene("sibenik", 50000, 160, 90, NULL);
}

/* The other builds: spatial splits (triangles referenced from several leaves; on Sibenik too),
 * binary nodes, one triangle a leaf. */
static void test_configs(void **state) {
    (void)state;
    const pgi__tri_bvh_config cfgs[] = {
        {.quality = 2, .width = 4, .max_leaf = 8, .traversal_cost = 1.f, .intersection_cost = 1.f},
        {.quality = 2, .width = 2, .max_leaf = 4, .traversal_cost = 1.f, .intersection_cost = 1.f},
        {.quality = 1, .width = 4, .max_leaf = 1, .traversal_cost = 1.f, .intersection_cost = 1.f},
    };
    for (size_t i = 0; i < sizeof cfgs / sizeof cfgs[0]; i++) check_scene("cornell", 5000, 32, 24, &cfgs[i]);
    check_scene("sibenik", 10000, 64, 36, &cfgs[0]);
    pgi_scene *s = NULL;
    TU_CHECK_OK(pgi_scene_load("cornell", &s));
    pgi__bvh *b = NULL;
    pgi__tri_bvh_config bad = pgi__tri_bvh_default_config();
    bad.max_leaf = 17;
    assert_int_equal(pgi__tri_bvh_build(s, &bad, &b), PGI_ERR_INVALID_ARG);
    assert_null(b);
    assert_non_null(strstr(pgi_last_error(), "max_leaf"));
    pgi_scene_destroy(s);
}

/* An animated scene: after it moves the BVH is stale, a rebuild agrees with Embree's update. */
static void test_dynamic(void **state) {
    (void)state;
    pgi_scene *s = NULL;
    TU_CHECK_OK(pgi_scene_load("scenes/cornell-moving.json", &s));
    pgi__rt *rt = NULL;
    TU_CHECK_OK(pgi__rt_create(s, &rt));
    pgi__bvh *b = NULL;
    TU_CHECK_OK(pgi__tri_bvh_build(s, NULL, &b));
    assert_false(pgi__tri_bvh_needs_update(b, s));
    TU_CHECK_OK(pgi_scene_set_time(s, 0.75));
    assert_true(pgi__tri_bvh_needs_update(b, s));
    TU_CHECK_OK(pgi__rt_update(rt, s));
    pgi__tri_bvh_destroy(b);
    TU_CHECK_OK(pgi__tri_bvh_build(s, NULL, &b));
    assert_false(pgi__tri_bvh_needs_update(b, s));
    for (int k = 0; k < 4; k++) {
        gr_tally c = check_kind(s, rt, b, (gr_kind)k, 10000, 48, 32, 77 + (uint64_t)k, "cornell-moving t=0.75", NULL);
        if (k == GR_SHADOW) assert_int_equal(c.wrong, 0);
        else assert_agreement(&c, (gr_kind)k);
    }
    pgi__tri_bvh_destroy(b);
    pgi__rt_destroy(rt);
    pgi_scene_destroy(s);
}

/* Two builds of the same scene are the same bytes; a scene without a triangle builds an empty root
 * that every ray misses. */
static void test_deterministic_and_empty(void **state) {
    (void)state;
    pgi_scene *s = NULL;
    TU_CHECK_OK(pgi_scene_load("sibenik", &s));
    pgi__bvh *a = NULL, *b = NULL;
    TU_CHECK_OK(pgi__tri_bvh_build(s, NULL, &a));
    TU_CHECK_OK(pgi__tri_bvh_build(s, NULL, &b));
    assert_int_equal(a->nnodes, b->nnodes);
    assert_int_equal(a->ntris, b->ntris);
    assert_memory_equal(a->nodes, b->nodes, a->nnodes * sizeof *a->nodes);
    assert_memory_equal(a->tris, b->tris, a->ntris * sizeof *a->tris);
    assert_true(pgi__tri_bvh_memory(a) >= a->stats.bytes);
    pgi__tri_bvh_destroy(a);
    pgi__tri_bvh_destroy(b);
    size_t nt = s->ntris;
    s->ntris = 0;
    TU_CHECK_OK(pgi__tri_bvh_build(s, NULL, &a));
    s->ntris = nt;
    assert_int_equal(a->nnodes, 1);
    assert_int_equal(a->ntris, 0);
    pgi__hit h;
    const float o[3] = {0, 0, 0}, d[3] = {0, 0, 1};
    assert_int_equal(pgi__tri_bvh_intersect(a, o, d, 0.f, INFINITY, &h, NULL, NULL, NULL), 0);
    assert_int_equal(h.prim, UINT32_MAX);
    assert_int_equal(pgi__tri_bvh_occluded(a, o, d, 0.f, INFINITY, NULL, NULL, NULL), 0);
    pgi__tri_bvh_destroy(a);
    pgi_scene_destroy(s);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_cornell),
        cmocka_unit_test(test_sphere_and_plane),
        cmocka_unit_test(test_cutout),
        cmocka_unit_test(test_sibenik),
        cmocka_unit_test(test_configs),
        cmocka_unit_test(test_dynamic),
        cmocka_unit_test(test_deterministic_and_empty),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
