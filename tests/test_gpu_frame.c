/* The frame on the GPU (issue "The GPU backend": src/gpu/gpu_scene.h, gpu_view.h, the renderer's
 * --device vulkan path) on whatever Vulkan device the loader finds (CI: lavapipe, a CPU device:
 * small sizes). Built and run only when the library has the Vulkan backend (PGI_VULKAN).
 *   - the scene upload: the surface scene.glsl computes (geometric and shading normals, textured
 *     kd) at random hits equals the CPU's pgi__scene_surface, on Cornell, the cutout scene and a
 *     textured one (Sibenik, when the scenes folder has it);
 *   - view samples: the GPU's G-buffer (view.comp) against pgi__view_build's, pixel by pixel, at
 *     pixel centres and at a jittered sub-pixel point (the same point bit for bit): positions
 *     within 1e-4 of the diagonal, normals and kd within 1e-4, the same flags; pixels that differ
 *     (silhouettes, where the GPU BVH and Embree may round a grazing hit differently, and the glass
 *     choice, which uses other random numbers) counted and bounded;
 *   - direct light (direct.comp, output direct) at 256 samples: mean within 1 % of the CPU's,
 *     PSNR >= 40 dB; the whole frame (Cornell, 200k photons): mean within 1 %, PSNR >= 40 dB;
 *   - the sky's direct light through portals (portal.glsl, window-box-portals, output direct): the
 *     mean within 1 % of the CPU's and of the device's own without portals (window-box), and at
 *     equal samples far less noise than the cosine's (PSNR against a 256-sample CPU reference);
 *     the same with the openings cut into 18 portals (past the 8 an invocation keeps);
 *   - the same seed gives the same bytes twice; progressive frames run; what the GPU frame does not
 *     have is refused by name (PGI_ERR_UNSUPPORTED);
 *   - pgi_renderer_prepare on the device returns the device's view samples and photons: the CPU's
 *     brute force on them equals the device frame's indirect light. */
#include "test_gpu_util.h"
#include "test_util.h"
#include "test_vertex_colours.h"


#include "core/core.h"
#include "gpu/gpu.h"
#include "gpu/gpu_estimator.h"
#include "gpu/gpu_scene.h"
#include "gpu/spirv.h"
#include "gpu/gpu_view.h"
#include "photongi/metrics.h"
#include "rt/rt.h"
#include "scene/bsdf.h"
#include "scene/scene_internal.h"
#include "view/view.h"


/* Sibenik (textured) when the scenes folder has it, else NULL. */
static pgi_scene *load_sibenik(void) {
    char mesh[1024];
    snprintf(mesh, sizeof mesh, "%s/sibenik/sibenik.obj", tu_scenes_dir());
    if (!tu_file_exists("scenes/sibenik.json") || !tu_file_exists(mesh)) {
        fprintf(stderr, "  (no Sibenik: scenes/sibenik.json or %s not found)\n", mesh);
        return NULL;
    }
    pgi_scene *s = tu_scene("scenes/sibenik.json");
    return s;
}

/* ------------------------------------------------------------ scene upload */

static void check_surfaces(const pgi_scene *s, const char *what) {
    pgi__gpu_scene *gs = NULL;
    TU_CHECK_OK(pgi__gpu_scene_create(g_gpu, s, &gs));
    pgi__gpu_kernel *k = NULL;
    struct {
        pgi__gpu_scene_push scene;
        uint32_t count, pad[3];
    } push = {0};
    TU_CHECK_OK(pgi__gpu_kernel_create(g_gpu, pgi__spv_scene_probe, sizeof pgi__spv_scene_probe, "scene_probe",
                                       PGI__GPU_SCENE_NBUF + 2, sizeof push, &k));
    const size_t n = 4096;
    uint32_t *q = malloc(n * 4 * sizeof *q);
    float *res = malloc(n * 12 * sizeof *res);
    assert_non_null(q);
    assert_non_null(res);
    tu_rng r = tu_rng_make(77);
    size_t textured = 0;
    for (size_t i = 0; i < n; i++) {
        uint32_t prim = (uint32_t)(tu_next(&r) % s->ntris);
        float bu = tu_unif(&r), bv = tu_unif(&r);
        if (bu + bv > 1.f) bu = 1.f - bu, bv = 1.f - bv;
        /* textured materials drawn more often: half the queries on them when there are any */
        if ((i & 1) && s->ntexs) {
            for (int tries = 0; tries < 64 && s->mats[s->tri_mat[prim]].tex_kd < 0; tries++)
                prim = (uint32_t)(tu_next(&r) % s->ntris);
        }
        textured += s->mats[s->tri_mat[prim]].tex_kd >= 0;
        q[4 * i] = prim;
        memcpy(&q[4 * i + 1], &bu, 4);
        memcpy(&q[4 * i + 2], &bv, 4);
        q[4 * i + 3] = 0;
    }
    pgi__gpu_buffer *qb = NULL, *rb = NULL;
    TU_CHECK_OK(pgi__gpu_buffer_reserve(g_gpu, &qb, n * 16, "test"));
    TU_CHECK_OK(pgi__gpu_buffer_reserve(g_gpu, &rb, n * 48, "test"));
    TU_CHECK_OK(pgi__gpu_upload(g_gpu, qb, 0, q, n * 16));
    pgi__gpu_buffer *b[PGI__GPU_SCENE_NBUF + 2];
    pgi__gpu_scene_buffers(gs, b);
    b[PGI__GPU_SCENE_NBUF] = qb;
    b[PGI__GPU_SCENE_NBUF + 1] = rb;
    pgi__gpu_scene_info(gs, &push.scene);
    push.count = (uint32_t)n;
    TU_CHECK_OK(pgi__gpu_begin(g_gpu));
    TU_CHECK_OK(pgi__gpu_dispatch(g_gpu, k, b, &push, (uint32_t)(n + 63) / 64, 1, 1));
    TU_CHECK_OK(pgi__gpu_submit_wait(g_gpu));
    TU_CHECK_OK(pgi__gpu_download(g_gpu, rb, 0, res, n * 48));
    size_t bad = 0;
    double worst = 0.0;
    for (size_t i = 0; i < n; i++) {
        float bu, bv;
        memcpy(&bu, &q[4 * i + 1], 4);
        memcpy(&bv, &q[4 * i + 2], 4);
        pgi__surface sf;
        pgi__scene_surface(s, q[4 * i], bu, bv, v3(0.f, 0.f, 0.f), &sf);
        const float want[9] = {sf.ng.x, sf.ng.y, sf.ng.z, sf.ns.x, sf.ns.y, sf.ns.z, sf.kd.x, sf.kd.y, sf.kd.z};
        const float got[9] = {res[12 * i],     res[12 * i + 1], res[12 * i + 2], res[12 * i + 4], res[12 * i + 5],
                              res[12 * i + 6], res[12 * i + 8], res[12 * i + 9], res[12 * i + 10]};
        int ok = 1;
        for (int c = 0; c < 9; c++) {
            double e = fabs((double)got[c] - (double)want[c]);
            if (e > worst) worst = e;
            if (!(e <= 1e-5 + 1e-5 * fabs((double)want[c]))) ok = 0;
        }
        if (!ok && bad++ < 3)
            fprintf(stderr, "  hit %zu (tri %u): GPU ns %g %g %g kd %g %g %g, CPU ns %g %g %g kd %g %g %g\n", i,
                    q[4 * i], got[3], got[4], got[5], got[6], got[7], got[8], want[3], want[4], want[5], want[6],
                    want[7], want[8]);
    }
    fprintf(stderr, "  %-8s %zu hits (%zu textured): %zu differ beyond 1e-5, largest difference %.3g\n", what, n,
            textured, bad, worst);
    assert_int_equal(bad, 0);
    /* the memory entries */
    pgi_named_value m[32];
    int nm = pgi__gpu_memory(g_gpu, m, 32), seen = 0;
    for (int i = 0; i < nm; i++) seen += strcmp(m[i].name, "gpu_scene") == 0 || strcmp(m[i].name, "gpu_textures") == 0;
    assert_int_equal(seen, 2);
    pgi__gpu_buffer_destroy(g_gpu, qb);
    pgi__gpu_buffer_destroy(g_gpu, rb);
    pgi__gpu_kernel_destroy(g_gpu, k);
    pgi__gpu_scene_destroy(gs);
    free(q);
    free(res);
}

static void test_scene_upload(void **state) {
    (void)state;
    const char *names[] = {"cornell", "cutout", "window-box"};
    for (int i = 0; i < 3; i++) {
        pgi_scene *s = tu_scene(names[i]);
        check_surfaces(s, names[i]);
        pgi_scene_destroy(s);
    }
    pgi_scene *s = load_sibenik();
    if (s) {
        assert_true(s->ntexs > 0);
        check_surfaces(s, "sibenik");
        pgi_scene_destroy(s);
    }
}

/* An environment map is refused by name. */
static void test_scene_refuses_env_map(void **state) {
    (void)state;
    pgi_scene *s = tu_scene("cornell");
    pgi__env fake = {0};
    float px[3] = {1.f, 1.f, 1.f};
    fake.rgb = px;
    fake.w = fake.h = 1;
    snprintf(fake.path, sizeof fake.path, "%s", "sky.hdr");
    s->env = &fake;
    pgi__gpu_scene *gs = NULL;
    assert_int_equal(pgi__gpu_scene_create(g_gpu, s, &gs), PGI_ERR_UNSUPPORTED);
    assert_null(gs);
    assert_non_null(strstr(pgi_last_error(), "environment map"));
    s->env = NULL;
    pgi_scene_destroy(s);
}


/* ------------------------------------------------------------ view samples */

/* GPU view samples of scene s (w x h, camera 0) against the CPU's; returns the pixels that
 * differ, of which *prim_bad among pixels both call primary. */
static size_t compare_view(const pgi_scene *s, int w, int h, const pgi__subpixel *sp, const char *what,
                           size_t *prim_bad, size_t *valid) {
    pgi_camera cam;
    const pgi_camera_def *cd = &s->cams[0];
    pgi_camera_look_at(&cam, cd->eye, cd->look_at, cd->up, cd->fov_y_deg, w, h);
    pgi__rt *rt = NULL;
    TU_CHECK_OK(pgi__rt_create(s, &rt));
    pgi_view_samples cv = {0}, gv = {0};
    TU_CHECK_OK(pgi_view_samples_alloc(&cv, w, h));
    TU_CHECK_OK(pgi_view_samples_alloc(&gv, w, h));
    const size_t n = (size_t)w * h;
    float *ce = malloc(3 * n * sizeof(float)), *ge = malloc(3 * n * sizeof(float));
    uint64_t rays = 0;
    TU_CHECK_OK(pgi__view_build(s, rt, NULL, &cam, 7, sp, 2, &cv, ce, NULL, &rays));
    pgi__gpu_scene *gs = NULL;
    pgi__gpu_view *v = NULL;
    TU_CHECK_OK(pgi__gpu_scene_create(g_gpu, s, &gs));
    TU_CHECK_OK(pgi__gpu_view_create(g_gpu, &v));
    TU_CHECK_OK(pgi__gpu_view_prepare(v, &cam, 7, sp));
    TU_CHECK_OK(pgi__gpu_begin(g_gpu));
    TU_CHECK_OK(pgi__gpu_view_record(v, gs));
    TU_CHECK_OK(pgi__gpu_submit_wait(g_gpu));
    TU_CHECK_OK(pgi__gpu_view_download(v, s, &gv, ge));
    uint64_t grays = 0, shadow = 0;
    TU_CHECK_OK(pgi__gpu_view_counters(v, &grays, &shadow));
    const float tol_p = 1e-4f * pgi__scene_diagonal(s);
    size_t bad = 0;
    *prim_bad = *valid = 0;
    size_t glossy = 0;
    for (size_t i = 0; i < n; i++) {
        int ok = cv.flags[i] == gv.flags[i];
        glossy += (cv.flags[i] & PGI_VS_VALID) && !(cv.flags[i] & PGI_VS_LAMBERT);
        *valid += (cv.flags[i] & PGI_VS_VALID) != 0;
        for (int c = 0; ok && c < 3; c++) {
            ok = fabsf(cv.pos[3 * i + c] - gv.pos[3 * i + c]) <= tol_p &&
                 fabsf(cv.nrm[3 * i + c] - gv.nrm[3 * i + c]) <= 1e-4f &&
                 fabsf(cv.ngeo[3 * i + c] - gv.ngeo[3 * i + c]) <= 1e-4f &&
                 fabsf(cv.kd[3 * i + c] - gv.kd[3 * i + c]) <= 1e-4f &&
                 fabsf(cv.wo[3 * i + c] - gv.wo[3 * i + c]) <= 1e-4f &&
                 fabsf(cv.weight[3 * i + c] - gv.weight[3 * i + c]) <= 1e-4f &&
                 fabsf(ce[3 * i + c] - ge[3 * i + c]) <= 1e-4f * (1.f + fabsf(ce[3 * i + c]));
        }
        if (ok && (cv.flags[i] & PGI_VS_VALID))
            ok = fabsf(cv.shininess[i] - gv.shininess[i]) <= 1e-6f && fabsf(cv.ks[3 * i] - gv.ks[3 * i]) <= 1e-6f;
        if (ok) continue;
        bad++;
        if ((cv.flags[i] & PGI_VS_PRIMARY) && (gv.flags[i] & PGI_VS_PRIMARY)) (*prim_bad)++;
        if (bad <= 3)
            fprintf(stderr, "    pixel %zu: CPU flags %u pos %g %g %g, GPU flags %u pos %g %g %g\n", i, cv.flags[i],
                    cv.pos[3 * i], cv.pos[3 * i + 1], cv.pos[3 * i + 2], gv.flags[i], gv.pos[3 * i], gv.pos[3 * i + 1],
                    gv.pos[3 * i + 2]);
    }
    fprintf(stderr,
            "  %-16s %dx%d%s: %zu valid (%zu glossy), %zu pixels differ (%zu of them primary on both), rays CPU %llu "
            "GPU %llu\n",
            what, w, h, sp->jitter ? " jittered" : "", *valid, glossy, bad, *prim_bad, (unsigned long long)rays,
            (unsigned long long)grays);
    pgi__gpu_view_destroy(v);
    pgi__gpu_scene_destroy(gs);
    pgi_view_samples_free(&cv);
    pgi_view_samples_free(&gv);
    free(ce);
    free(ge);
    pgi__rt_destroy(rt);
    return bad;
}

static void test_view_samples(void **state) {
    (void)state;
    const struct {
        const char *name;
        int w, h;
    } sc[] = {{"cornell", 96, 72}, {"cornell-mirrors", 96, 72}, {"cutout", 96, 72}, {"window-box", 64, 48}};
    for (size_t k = 0; k < sizeof sc / sizeof sc[0]; k++) {
        pgi_scene *s = tu_scene(sc[k].name);
        for (int j = 0; j < 2; j++) {
            const pgi__subpixel sp = {.jitter = j, .seed = 99, .index = 3};
            size_t prim_bad, valid;
            size_t bad = compare_view(s, sc[k].w, sc[k].h, &sp, sc[k].name, &prim_bad, &valid);
            const size_t n = (size_t)sc[k].w * sc[k].h;
            /* silhouettes: at most 0.5 % of the pixels; glass (other random numbers): 5 % */
            assert_true(prim_bad <= n / 200 + 2);
            assert_true(bad <= n / 20 + 2);
        }
        pgi_scene_destroy(s);
    }
    pgi_scene *s = load_sibenik();
    if (s) {
        const pgi__subpixel sp = {.jitter = 0, .seed = 1, .index = 0};
        size_t prim_bad, valid;
        size_t bad = compare_view(s, 96, 72, &sp, "sibenik", &prim_bad, &valid);
        assert_true(bad <= 96 * 72 / 200 + 2);
        /* the textures filtered (ray cones, mip levels, anisotropic probes: docs/design.md
           "Textures"), within the same tolerance */
        const pgi__subpixel spf = {.jitter = 0, .seed = 1, .index = 0, .tex_filter = 1};
        bad = compare_view(s, 96, 72, &spf, "sibenik filtered", &prim_bad, &valid);
        assert_true(bad <= 96 * 72 / 200 + 2);
        pgi_scene_destroy(s);
    }
}

/* Vertex colours (Cornell, tu_add_vertex_colours): the upload's kd at random hits (the colours
 * interpolated and multiplied in as pgi__scene_kd), the G-buffer, and the whole frame agree with
 * the CPU's as the uncoloured scenes do. */
static void test_vertex_colours(void **state) {
    (void)state;
    pgi_scene *s = tu_scene("cornell");
    tu_add_vertex_colours(s);
    check_surfaces(s, "coloured");
    const pgi__subpixel sp = {.jitter = 0, .seed = 1, .index = 0};
    size_t prim_bad, valid;
    size_t bad = compare_view(s, 96, 72, &sp, "cornell coloured", &prim_bad, &valid);
    assert_true(valid > 96 * 72 / 2);
    assert_true(bad <= 96 * 72 / 200 + 2);
    pgi_scene_destroy(s);
}

/* ------------------------------------------------------------ frames */

static pgi_render_desc frame_desc(int w, int h, uint32_t photons, int direct, pgi_output out, int device) {
    pgi_render_desc d = {0};
    d.width = w;
    d.height = h;
    d.photons = photons;
    d.direct_samples = direct;
    d.output = out;
    d.seed = 5;
    d.radius = 0.f;
    d.estimator = "hashgrid";
    d.device = device ? PGI_DEVICE_VULKAN : PGI_DEVICE_CPU;
    return d;
}

static double image_mean(const pgi_image *im) {
    double m = 0.0;
    const size_t n = 3 * (size_t)im->width * im->height;
    for (size_t i = 0; i < n; i++) m += im->rgb[i];
    return m / (double)n;
}

/* The GPU frame against the CPU frame: mean within 1 %, PSNR >= 40 dB. */
/* Cornell with glossy walls: white a GGX plastic, red Blinn-Phong (the lobes of view samples and
 * direct light). */
static void make_glossy(pgi_scene *s) {
    for (size_t i = 0; i < s->nmats; i++) {
        pgi__material *m = &s->mats[i];
        if (strcmp(m->name, "white") == 0) {
            m->type = PGI__MAT_PLASTIC;
            m->ks[0] = m->ks[1] = m->ks[2] = 0.04f;
            m->shininess = 60.f;
            m->ior = 1.5f;
        } else if (strcmp(m->name, "red") == 0) {
            m->type = PGI__MAT_PHONG;
            m->ks[0] = m->ks[1] = m->ks[2] = 0.2f;
            m->shininess = 30.f;
        }
    }
}

static void compare_frames_on(const char *scene, void (*modify)(pgi_scene *), const pgi_render_desc *d,
                              const char *what, double min_psnr);

static void compare_frames(const char *scene, const pgi_render_desc *d, const char *what, double min_psnr) {
    compare_frames_on(scene, NULL, d, what, min_psnr);
}

static void compare_frames_on(const char *scene, void (*modify)(pgi_scene *), const pgi_render_desc *d,
                              const char *what, double min_psnr) {
    /* the device's passes on the CPU tracer's photons (frame_gpu.c's test hook): the photons traced on
       the device are an independent photon map, compared in tests/test_gpu_trace.c */
    setenv("PGI_GPU_CPU_PHOTONS", "1", 1);
    pgi_scene *s = tu_scene(scene);
    if (modify) modify(s);
    pgi_renderer *r = tu_renderer(s);
    pgi_image ci = {0}, gi = {0};
    pgi_frame_stats cs, gs;
    pgi_render_desc c = *d, g = *d;
    c.device = PGI_DEVICE_CPU;
    g.device = PGI_DEVICE_VULKAN;
    TU_CHECK_OK(pgi_renderer_render(r, &c, &ci, &cs));
    TU_CHECK_OK(pgi_renderer_render(r, &g, &gi, &gs));
    unsetenv("PGI_GPU_CPU_PHOTONS");
    pgi_metrics m;
    TU_CHECK_OK(pgi_metrics_compute(&gi, &ci, 1.f, &m));
    const double mc = image_mean(&ci), mg = image_mean(&gi);
    fprintf(stderr,
            "  %-10s %-8s %dx%d: mean CPU %.6g GPU %.6g (%+.3f %%), PSNR %.2f dB; rays: primary %llu / %llu, "
            "shadow %llu / %llu; GPU view %.1f ms, direct %.1f ms, estimate %.1f ms\n",
            scene, what, d->width, d->height, mc, mg, 100.0 * (mg - mc) / mc, m.psnr,
            (unsigned long long)cs.primary_rays, (unsigned long long)gs.primary_rays,
            (unsigned long long)cs.shadow_rays, (unsigned long long)gs.shadow_rays, gs.view_ms, gs.direct_ms,
            gs.estimate_ms);
    assert_true(fabs(mg - mc) <= 0.01 * mc);
    assert_true(m.psnr >= min_psnr);
    /* the indirect light alone casts no shadow ray, on either device */
    assert_true(gs.primary_rays > 0);
    if (d->output == PGI_OUTPUT_INDIRECT) assert_true(gs.shadow_rays == 0 && cs.shadow_rays == 0);
    else assert_true(gs.shadow_rays > 0);
    int seen = 0;
    for (int k = 0; k < gs.pass_count; k++)
        seen += strcmp(gs.passes_ms[k].name, "gpu_view") == 0 || strcmp(gs.passes_ms[k].name, "gpu_direct") == 0;
    assert_int_equal(seen, 2);
    pgi_image_free(&ci);
    pgi_image_free(&gi);
    pgi_renderer_destroy(r);
    pgi_scene_destroy(s);
}

static void test_direct_light(void **state) {
    (void)state;
    pgi_render_desc d = frame_desc(64, 48, 20000, 256, PGI_OUTPUT_DIRECT, 1);
    compare_frames("cornell", &d, "direct", 40.0);
    /* the sky through a window, cosine-sampled (as the CPU): both images are noisy at 128 samples
     * (two independent estimates: PSNR about 26 dB), so the mean is the check here */
    d = frame_desc(48, 36, 20000, 128, PGI_OUTPUT_DIRECT, 1);
    compare_frames("window-box", &d, "direct", 20.0);
}

/* One frame of `scene` on `device` with `n` direct samples (output direct, seed 5). */
static void direct_frame(const char *scene, int device, int n, pgi_image *im, pgi_frame_stats *fs) {
    pgi_scene *s = tu_scene(scene);
    pgi_renderer *r = tu_renderer(s);
    pgi_render_desc d = frame_desc(64, 48, 2000, n, PGI_OUTPUT_DIRECT, device);
    TU_CHECK_OK(pgi_renderer_render(r, &d, im, fs));
    pgi_renderer_destroy(r);
    pgi_scene_destroy(s);
}

/* Issue 37 part 4: direct.comp samples the sky through the portals as view.c does (a quarter of
 * the samples cosine-weighted, the rest towards the portals, balance heuristic). At 256 samples
 * its mean is the CPU's and that of the same room without portals (cosine samples only: the same
 * expected value); at 16 it is much closer to a 256-sample CPU reference than the cosine's 16. */
static void test_portal_direct(void **state) {
    (void)state;
    pgi_image ref = {0}, gp = {0}, gc = {0}, gp16 = {0}, gc16 = {0};
    pgi_frame_stats fs, fp, fc, fp16, fc16;
    direct_frame("window-box-portals", 0, 256, &ref, &fs);
    direct_frame("window-box-portals", 1, 256, &gp, &fp);
    direct_frame("window-box", 1, 256, &gc, &fc);
    const double mr = image_mean(&ref), mp = image_mean(&gp), mc = image_mean(&gc);
    fprintf(stderr,
            "  window-box direct 64x48, 256 samples: mean CPU portals %.6g, GPU portals %.6g (%+.3f %%), GPU cosine "
            "%.6g (%+.3f %%); GPU direct %.1f ms (portals) / %.1f ms (cosine); shadow rays %llu / %llu\n",
            mr, mp, 100.0 * (mp - mr) / mr, mc, 100.0 * (mc - mr) / mr, fp.direct_ms, fc.direct_ms,
            (unsigned long long)fp.shadow_rays, (unsigned long long)fc.shadow_rays);
    assert_true(fabs(mp - mr) <= 0.01 * mr);
    assert_true(fabs(mp - mc) <= 0.01 * mc);
    direct_frame("window-box-portals", 1, 16, &gp16, &fp16);
    direct_frame("window-box", 1, 16, &gc16, &fc16);
    pgi_metrics m_p, m_c;
    TU_CHECK_OK(pgi_metrics_compute(&gp16, &ref, 1.f, &m_p));
    TU_CHECK_OK(pgi_metrics_compute(&gc16, &ref, 1.f, &m_c));
    fprintf(stderr,
            "  window-box direct 64x48, 16 samples against the CPU's 256: PSNR portals %.2f dB, cosine %.2f dB "
            "(%+.2f dB); GPU direct %.1f ms / %.1f ms\n",
            m_p.psnr, m_c.psnr, m_p.psnr - m_c.psnr, fp16.direct_ms, fc16.direct_ms);
    assert_true(m_p.psnr >= m_c.psnr + 6.0);
    /* the default count with portals is the CPU's (PGI_DIRECT_SAMPLES_PORTALS) on the device too */
    pgi_image im = {0};
    pgi_frame_stats f0;
    direct_frame("window-box-portals", 1, 0, &im, &f0);
    assert_int_equal(f0.settings.direct_samples, PGI_DIRECT_SAMPLES_PORTALS);
    /* 18 portals, each opening cut into 3 x 3: past the 8 whose weights an invocation keeps
       (portal.glsl PORTAL_LOCAL), the others' worked out again where needed; the same expected
       image, and still far less noise than the cosine's */
    static const float quad[2][3][3] = {{{-1, 0.7f, -0.7f}, {0, 0.8f, 0}, {0, 0, 0.8f}},
                                        {{-0.1f, 2, -0.5f}, {0.6f, 0, 0}, {0, 0, 0.6f}}};
    char dir[256], path[320], json[8192];
    size_t len = (size_t)snprintf(json, sizeof json, "{\"builtin\": \"window-box\", \"portals\": [");
    for (int q = 0; q < 2; q++)
        for (int a = 0; a < 3; a++)
            for (int b = 0; b < 3; b++) {
                float c[4][3];
                for (int k = 0; k < 3; k++) {
                    const float o = quad[q][0][k] + quad[q][1][k] * (float)a / 3.f + quad[q][2][k] * (float)b / 3.f;
                    c[0][k] = o;
                    c[1][k] = o + quad[q][1][k] / 3.f;
                    c[2][k] = o + quad[q][1][k] / 3.f + quad[q][2][k] / 3.f;
                    c[3][k] = o + quad[q][2][k] / 3.f;
                }
                len += (size_t)snprintf(json + len, sizeof json - len,
                                        "%s{\"quad\": [[%g,%g,%g],[%g,%g,%g],[%g,%g,%g],[%g,%g,%g]]}",
                                        q || a || b ? ", " : "", c[0][0], c[0][1], c[0][2], c[1][0], c[1][1], c[1][2],
                                        c[2][0], c[2][1], c[2][2], c[3][0], c[3][1], c[3][2]);
            }
    snprintf(json + len, sizeof json - len, "]}");
    tu_make_tmpdir(dir, sizeof dir);
    pgi_scene_destroy(tu_scene_text(dir, "grid.json", json, path, sizeof path));
    pgi_image g18 = {0}, g18_16 = {0};
    pgi_frame_stats f18;
    direct_frame(path, 1, 256, &g18, &f18);
    direct_frame(path, 1, 16, &g18_16, &f18);
    pgi_metrics m18;
    TU_CHECK_OK(pgi_metrics_compute(&g18_16, &ref, 1.f, &m18));
    const double m = image_mean(&g18);
    fprintf(stderr, "  18 portals: GPU mean %.6g (%+.3f %% against the CPU's 2), 16 samples PSNR %.2f dB\n", m,
            100.0 * (m - mr) / mr, m18.psnr);
    assert_true(fabs(m - mr) <= 0.01 * mr);
    assert_true(m18.psnr >= m_c.psnr + 6.0);
    tu_rm_tmpdir(dir);
    pgi_image *all[] = {&ref, &gp, &gc, &gp16, &gc16, &im, &g18, &g18_16};
    for (size_t i = 0; i < sizeof all / sizeof all[0]; i++) pgi_image_free(all[i]);
}

static void test_glossy(void **state) {
    (void)state;
    pgi_scene *s = tu_scene("cornell");
    make_glossy(s);
    const pgi__subpixel sp = {.jitter = 0, .seed = 1, .index = 0};
    size_t prim_bad, valid;
    size_t bad = compare_view(s, 64, 48, &sp, "cornell glossy", &prim_bad, &valid);
    assert_true(bad <= 64 * 48 / 200 + 2);
    pgi_scene_destroy(s);
    pgi_render_desc d = frame_desc(64, 48, 200000, 256, PGI_OUTPUT_DIRECT, 1);
    compare_frames_on("cornell", make_glossy, &d, "glossy direct", 40.0);
    d.output = PGI_OUTPUT_ALL;
    compare_frames_on("cornell", make_glossy, &d, "glossy all", 40.0);
}

static void test_whole_frame(void **state) {
    (void)state;
    pgi_render_desc d = frame_desc(64, 48, 200000, 256, PGI_OUTPUT_ALL, 1);
    compare_frames("cornell", &d, "all", 40.0);
    compare_frames_on("cornell", tu_add_vertex_colours, &d, "coloured", 40.0);
    d = frame_desc(64, 48, 200000, 16, PGI_OUTPUT_INDIRECT, 1);
    compare_frames("cornell", &d, "indirect", 40.0);
}

/* A dynamic scene: the frame after pgi_scene_set_time (geometry moved, the GPU scene re-uploaded)
 * agrees with the CPU's at the new time, and a moved light is seen too. */
static void test_dynamic(void **state) {
    (void)state;
    pgi_scene *s = tu_scene("scenes/cornell-moving.json");
    pgi_renderer *r = tu_renderer(s);
    pgi_render_desc d = frame_desc(48, 36, 20000, 64, PGI_OUTPUT_ALL, 1);
    d.radius = 0.05f;
    pgi_image a = {0}, b = {0}, c = {0};
    TU_CHECK_OK(pgi_renderer_render(r, &d, &a, NULL));
    TU_CHECK_OK(pgi_scene_set_time(s, 1.0));
    TU_CHECK_OK(pgi_renderer_render(r, &d, &b, NULL));
    d.device = PGI_DEVICE_CPU;
    TU_CHECK_OK(pgi_renderer_render(r, &d, &c, NULL));
    const double ma = image_mean(&a), mb = image_mean(&b), mc = image_mean(&c);
    pgi_metrics m;
    TU_CHECK_OK(pgi_metrics_compute(&b, &c, 1.f, &m));
    fprintf(stderr, "  cornell-moving: t=0 mean %.6g, t=1 GPU %.6g CPU %.6g (%+.3f %%), PSNR %.2f dB\n", ma, mb, mc,
            100.0 * (mb - mc) / mc, m.psnr);
    assert_true(memcmp(a.rgb, b.rgb, 3 * 48 * 36 * sizeof(float)) != 0);
    assert_true(fabs(mb - mc) <= 0.01 * mc);
    /* independent photon maps (the device traces its own, gpu_trace.h) of 20k photons: 26.6 dB */
    assert_true(m.psnr >= 24.0);
    pgi_image_free(&a);
    pgi_image_free(&b);
    pgi_image_free(&c);
    pgi_renderer_destroy(r);
    pgi_scene_destroy(s);
}

static void test_deterministic(void **state) {
    (void)state;
    pgi_scene *s = tu_scene("cornell-mirrors");
    pgi_render_desc d = frame_desc(40, 30, 20000, 8, PGI_OUTPUT_ALL, 1);
    d.jitter = PGI_JITTER_ON;
    pgi_image a = {0}, b = {0};
    for (int k = 0; k < 2; k++) {
        pgi_renderer *r = tu_renderer(s);
        TU_CHECK_OK(pgi_renderer_render(r, &d, k ? &b : &a, NULL));
        pgi_renderer_destroy(r);
    }
    assert_memory_equal(a.rgb, b.rgb, 3 * 40 * 30 * sizeof(float));
    pgi_image_free(&a);
    pgi_image_free(&b);
    pgi_scene_destroy(s);
}

static void test_progressive(void **state) {
    (void)state;
    pgi_scene *s = tu_scene("cornell");
    pgi_renderer *r = tu_renderer(s);
    pgi_render_desc d = frame_desc(40, 30, 20000, 4, PGI_OUTPUT_ALL, 1);
    d.radius = 0.05f;
    pgi_image im = {0};
    pgi_frame_stats st;
    TU_CHECK_OK(pgi_render_progressive(r, &d, 3, &im, &st));
    assert_int_equal(st.frames, 3);
    assert_true(image_mean(&im) > 0.0);
    pgi_image_free(&im);
    pgi_renderer_destroy(r);
    pgi_scene_destroy(s);
}

static void expect_refused(pgi_renderer *r, const pgi_render_desc *d, const char *word) {
    pgi_image im = {0};
    assert_int_equal(pgi_renderer_render(r, d, &im, NULL), PGI_ERR_UNSUPPORTED);
    if (!strstr(pgi_last_error(), word)) fprintf(stderr, "  message without '%s': %s\n", word, pgi_last_error());
    assert_non_null(strstr(pgi_last_error(), word));
    assert_null(im.rgb);
}

static void test_refusals(void **state) {
    (void)state;
    pgi_scene *s = tu_scene("cornell");
    pgi_renderer *r = tu_renderer(s);
    pgi_render_desc d = frame_desc(16, 12, 1000, 1, PGI_OUTPUT_ALL, 1);
    /* --radius-policy path/differentials: refused before the device by the CPU's own check (hashgrid
     * has no per-photon footprints); an estimator with them on the CPU and not on the device is
     * refused by name (test_radius_policies) */
    pgi_render_desc e = d;
    e.radius_policy = PGI_RADIUS_PATH;
    e.radius = 0.05f;
    {
        pgi_image im = {0};
        assert_int_not_equal(pgi_renderer_render(r, &e, &im, NULL), PGI_OK);
    }
    e = d;
    e.emission = PGI_EMISSION_GUIDED;
    expect_refused(r, &e, "--emission");
    e = d;
    e.store = PGI_STORE_VIEW;
    e.radius = 0.05f;
    expect_refused(r, &e, "--store view");
    e = d;
    e.filter = 2;
    expect_refused(r, &e, "--filter");
    e = d;
    e.output = PGI_OUTPUT_PHOTON_COUNT;
    expect_refused(r, &e, "--output counts");
    e = d;
    e.shift[0] = 0.25f;
    expect_refused(r, &e, "sub-pixel shift");
    /* an option the estimator takes on the CPU and not on the device */
    e = d;
    e.est.subsample = 4;
    expect_refused(r, &e, "--subsample 4 with estimator 'hashgrid'");
    e = d;
    e.estimator = "kdtree";
    expect_refused(r, &e, "no GPU version");
    pgi_renderer_destroy(r);
    pgi_scene_destroy(s);
    /* portal emission: refused by name on the device (the scene has portals, so the CPU's own
       check passes it) */
    TU_CHECK_OK(pgi_scene_load("window-box-portals", &s));
    TU_CHECK_OK(pgi_renderer_create(s, &r));
    e = d;
    e.emission = PGI_EMISSION_PORTAL;
    expect_refused(r, &e, "--emission portal");
    /* auto (photongi render's default) is the uniform emission the device traces, and says so */
    e = d;
    e.emission = PGI_EMISSION_AUTO;
    {
        pgi_image im = {0};
        pgi_frame_stats fs;
        TU_CHECK_OK(pgi_renderer_render(r, &e, &im, &fs));
        assert_int_equal(fs.settings.emission, PGI_EMISSION_UNIFORM);
        assert_int_equal(fs.emission.used, PGI_EMISSION_UNIFORM);
        assert_non_null(strstr(fs.emission.reason, "GPU"));
        pgi_image_free(&im);
    }
    pgi_renderer_destroy(r);
    pgi_scene_destroy(s);
}

static int has_pass(const pgi_frame_stats *st, const char *name) {
    for (int k = 0; k < st->pass_count; k++)
        if (strcmp(st->passes_ms[k].name, name) == 0) return 1;
    return 0;
}

/* pgi_renderer_prepare on the device: its view samples and photons (the device's own: traced there),
 * read back into the frame inputs. A CPU estimator on them gives the indirect light the device's
 * frame renders from the same inputs (--output indirect, the GPU hashgrid); the automatic radius
 * reads the same inputs; a refused setting is named. */
static void test_prepare(void **state) {
    (void)state;
    pgi_scene *s = NULL;
    TU_CHECK_OK(pgi_scene_load("cornell", &s));
    pgi_renderer *r = NULL;
    TU_CHECK_OK(pgi_renderer_create(s, &r));
    for (int automatic = 0; automatic < 2; automatic++) {
        pgi_render_desc d = frame_desc(48, 36, 5000, 1, PGI_OUTPUT_INDIRECT, 1);
        d.radius = automatic ? PGI_RADIUS_AUTO : 0.05f;
        pgi_frame_inputs in;
        pgi_frame_stats ps;
        TU_CHECK_OK(pgi_renderer_prepare(r, &d, &in, &ps));
        assert_string_not_equal(ps.device, "cpu");
        assert_true(has_pass(&ps, "gpu_trace") && has_pass(&ps, "gpu_view") && has_pass(&ps, "gpu_readback"));
        assert_int_equal(in.samples->width, 48);
        assert_int_equal(in.samples->height, 36);
        assert_true(in.photons->count > 0);
        assert_int_equal(in.photons->count, ps.photons_stored);
        assert_true(in.radius > 0.f);
        if (!automatic) assert_true(in.radius == 0.05f);
        const size_t n = 48 * 36;
        float *rad = calloc(3 * n, sizeof(float)), *want = calloc(3 * n, sizeof(float));
        assert_non_null(rad);
        assert_non_null(want);
        pgi_estimator *e = NULL;
        TU_CHECK_OK(pgi_estimator_create("brute", &(pgi_estimator_desc){0}, &e));
        const pgi_estimate_args a = {.photons = in.photons,
                                     .samples = in.samples,
                                     .camera = &in.camera,
                                     .out_rgb = rad,
                                     .radius = in.radius,
                                     .seed = in.seed,
                                     .scene_area = in.scene_area};
        TU_CHECK_OK(pgi_estimator_build(e, &a));
        TU_CHECK_OK(pgi_estimator_estimate(e, &a));
        pgi_estimator_destroy(e);
        pgi__indirect_image(in.samples, rad, 0, want);
        pgi_image im = {0};
        pgi_frame_stats fs;
        TU_CHECK_OK(pgi_renderer_render(r, &d, &im, &fs));
        assert_true(fs.radius == in.radius);
        assert_int_equal(fs.photons_stored, ps.photons_stored);
        assert_int_equal(tu_compare(im.rgb, want, 3 * n, 1e-4, "prepare on the device: cpu brute vs the frame"), 0);
        pgi_image_free(&im);
        free(rad);
        free(want);
    }
    /* what the device lacks for the view samples or photons is refused by name */
    pgi_render_desc d = frame_desc(16, 12, 1000, 1, PGI_OUTPUT_ALL, 1);
    d.emission = PGI_EMISSION_GUIDED;
    pgi_frame_inputs in;
    assert_int_equal(pgi_renderer_prepare(r, &d, &in, NULL), PGI_ERR_UNSUPPORTED);
    assert_non_null(strstr(pgi_last_error(), "--emission guided"));
    /* ... and what only the frame after them reads is not */
    d = frame_desc(16, 12, 1000, 1, PGI_OUTPUT_ALL, 1);
    d.filter = 2;
    TU_CHECK_OK(pgi_renderer_prepare(r, &d, &in, NULL));
    pgi_renderer_destroy(r);
    pgi_scene_destroy(s);
}

/* The mean indirect light of the frame inputs through CPU estimator `name` (with their footprints). */
static double indirect_mean(const pgi_frame_inputs *in, const char *name, int w, int h) {
    const size_t n = (size_t)w * h;
    float *rad = calloc(3 * n, sizeof(float)), *img = calloc(3 * n, sizeof(float));
    assert_non_null(rad);
    assert_non_null(img);
    pgi_estimator *e = NULL;
    TU_CHECK_OK(pgi_estimator_create(name, &(pgi_estimator_desc){0}, &e));
    const pgi_estimate_args a = {.photons = in->photons,
                                 .samples = in->samples,
                                 .camera = &in->camera,
                                 .out_rgb = rad,
                                 .radius = in->radius,
                                 .seed = in->seed,
                                 .scene_area = in->scene_area};
    TU_CHECK_OK(pgi_estimator_build(e, &a));
    TU_CHECK_OK(pgi_estimator_estimate(e, &a));
    pgi_estimator_destroy(e);
    pgi__indirect_image(in->samples, rad, 0, img);
    double m = 0.0;
    for (size_t i = 0; i < 3 * n; i++) m += img[i];
    free(rad);
    free(img);
    return m / (double)(3 * n);
}

/* Radius policies on the device: the GPU tracer's footprints (tests/test_gpu_trace.c compares them
 * with the CPU's). A frame whose GPU estimator reads no footprints is refused by name (each
 * estimator that takes them on the CPU, runs on the device and lacks them there); one that reads
 * them gives the CPU frame's indirect light (mean within 3 %, Cornell 64x48, 200k photons, both
 * policies). pgi_renderer_prepare reads the footprints back with the photons: radius,
 * the ellipsoids' semi-axes and the normals (and its stats hold their histogram), and the CPU bvh estimator on those inputs gives the
 * indirect light of the CPU's own inputs (mean within 2 %, Cornell 200k photons). */
static void test_radius_policies(void **state) {
    (void)state;
    pgi_scene *s = tu_scene("cornell");
    pgi_renderer *r = tu_renderer(s);
    int refused = 0, rendered = 0;
    for (size_t i = 0; i < pgi_estimator_count(); i++) {
        const pgi_estimator_vtbl *vt = pgi_estimator_at(i);
        if (!(vt->caps & PGI_EST_CAP_PHOTON_RADIUS) || !pgi_estimator_runs_on(vt, PGI_DEVICE_VULKAN)) continue;
        for (int policy = PGI_RADIUS_PATH; policy <= PGI_RADIUS_DIFFERENTIALS; policy++) {
            pgi_render_desc d = frame_desc(16, 12, 2000, 1, PGI_OUTPUT_ALL, 1);
            d.estimator = vt->name;
            d.radius_policy = policy;
            pgi_image im = {0};
            const pgi_status st = pgi_renderer_render(r, &d, &im, NULL);
            if (pgi__gpu_est_caps(vt->name) & PGI_EST_CAP_PHOTON_RADIUS) {
                TU_CHECK_OK(st);
                pgi_image_free(&im);
                /* the device's footprints through its estimator: the CPU frame's indirect light */
                pgi_image ci = {0};
                d = frame_desc(64, 48, 200000, 1, PGI_OUTPUT_INDIRECT, 1);
                d.estimator = vt->name;
                d.radius_policy = policy;
                TU_CHECK_OK(pgi_renderer_render(r, &d, &im, NULL));
                d.device = PGI_DEVICE_CPU;
                TU_CHECK_OK(pgi_renderer_render(r, &d, &ci, NULL));
                const double mg = image_mean(&im), mc = image_mean(&ci);
                fprintf(stderr, "  %s %-13s 64x48 200k photons, indirect: mean GPU %.6g CPU %.6g (%+.2f %%)\n",
                        vt->name, policy == PGI_RADIUS_PATH ? "path" : "differentials", mg, mc, 100.0 * (mg - mc) / mc);
                assert_true(fabs(mg - mc) <= 0.03 * mc);
                pgi_image_free(&ci);
                rendered++;
            } else {
                char word[96];
                snprintf(word, sizeof word, "--radius-policy %s with estimator '%s'",
                         policy == PGI_RADIUS_PATH ? "path" : "differentials", vt->name);
                assert_int_equal(st, PGI_ERR_UNSUPPORTED);
                fprintf(stderr, "  refused: %s\n", pgi_last_error());
                assert_non_null(strstr(pgi_last_error(), word));
                assert_null(im.rgb);
                refused++;
            }
            pgi_image_free(&im);
        }
    }
    fprintf(stderr, "  %d frames refused by name, %d rendered\n", refused, rendered);
    /* prepare: the footprints read back */
    const int w = 48, h = 36;
    for (int policy = PGI_RADIUS_PATH; policy <= PGI_RADIUS_DIFFERENTIALS; policy++) {
        const int ell = policy == PGI_RADIUS_DIFFERENTIALS;
        pgi_render_desc d = frame_desc(w, h, 200000, 1, PGI_OUTPUT_INDIRECT, 1);
        d.estimator = "bvh";
        d.radius_policy = policy;
        pgi_frame_inputs in;
        pgi_frame_stats ps;
        TU_CHECK_OK(pgi_renderer_prepare(r, &d, &in, &ps));
        const pgi_photons *ph = in.photons;
        assert_int_equal(ph->count, 200000);
        uint64_t hist_sum = 0; /* the stats' histogram of the radius before the clamp */
        for (int k = 0; k < PGI_FOOTPRINT_BINS; k++) hist_sum += ps.footprint_hist[k];
        assert_int_equal(hist_sum, 200000);
        assert_non_null(ph->radius);
        assert_true(ell ? ph->sax != NULL : ph->sax == NULL);
        double mean_r = 0.0;
        size_t spheres = 0;
        for (size_t j = 0; j < ph->count; j++) {
            assert_true(ph->radius[j] > 0.f && ph->radius[j] <= in.radius * 1.0001f);
            const float nrm[3] = {ph->nx[j], ph->ny[j], ph->nz[j]}, dir[3] = {ph->dx[j], ph->dy[j], ph->dz[j]};
            assert_true(fabs(tu_dot(nrm, nrm) - 1.0) < 1e-4 && tu_dot(nrm, dir) >= -1e-6f);
            if (ell) spheres += ph->sax[j] == 0.f && ph->say[j] == 0.f && ph->saz[j] == 0.f;
            mean_r += ph->radius[j];
        }
        assert_int_equal(spheres, 0);
        mean_r /= (double)ph->count;
        const double gpu = indirect_mean(&in, "bvh", w, h);
        d.device = PGI_DEVICE_CPU;
        TU_CHECK_OK(pgi_renderer_prepare(r, &d, &in, NULL));
        double cpu_r = 0.0;
        for (size_t j = 0; j < in.photons->count; j++) cpu_r += in.photons->radius[j];
        cpu_r /= (double)in.photons->count;
        const double cpu = indirect_mean(&in, "bvh", w, h);
        fprintf(stderr,
                "  prepare %-13s mean r GPU %.5g CPU %.5g; CPU bvh indirect mean GPU inputs %.5g CPU %.5g (%+.2f %%)\n",
                ell ? "differentials" : "path", mean_r, cpu_r, gpu, cpu, 100.0 * (gpu - cpu) / cpu);
        assert_true(fabs(mean_r - cpu_r) <= 0.03 * cpu_r);
        assert_true(fabs(gpu - cpu) <= 0.02 * cpu);
    }
    /* back to the fixed radius: no footprints */
    pgi_render_desc d = frame_desc(16, 12, 2000, 1, PGI_OUTPUT_INDIRECT, 1);
    d.radius = 0.05f;
    pgi_frame_inputs in;
    TU_CHECK_OK(pgi_renderer_prepare(r, &d, &in, NULL));
    assert_null(in.photons->radius);
    pgi_renderer_destroy(r);
    pgi_scene_destroy(s);
}

int main(void) {
    tu_keep_lavapipe_loaded();
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_scene_upload),    cmocka_unit_test(test_scene_refuses_env_map),
        cmocka_unit_test(test_view_samples),    cmocka_unit_test(test_vertex_colours),
        cmocka_unit_test(test_direct_light),    cmocka_unit_test(test_glossy),
        cmocka_unit_test(test_whole_frame),     cmocka_unit_test(test_dynamic),
        cmocka_unit_test(test_deterministic),   cmocka_unit_test(test_progressive),
        cmocka_unit_test(test_refusals),        cmocka_unit_test(test_prepare),
        cmocka_unit_test(test_radius_policies), cmocka_unit_test(test_portal_direct),
    };
    tu_filter_from_env(); /* e.g. PGI_TEST_FILTER=test_portal_direct */
    return cmocka_run_group_tests(tests, tu_gpu_setup, tu_gpu_teardown);
}
