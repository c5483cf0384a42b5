/* Small helpers shared by the photongi tests (static inline, header only):
 * a deterministic RNG, image comparison, temporary files, scene paths and a
 * one-call estimator run. Include after <cmocka.h>'s prerequisites. */
#ifndef PGI__TEST_UTIL_H
#define PGI__TEST_UTIL_H

#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "photongi/photongi.h"

/* PGI_TEST_FILTER=PATTERN (a cmocka pattern, * a wildcard) runs only the tests it names: one test of
 * a long file (test_gpu_frame on lavapipe takes minutes). Every test main calls it. */
static inline void tu_filter_from_env(void) {
    const char *filter = getenv("PGI_TEST_FILTER");
    if (filter && *filter) cmocka_set_test_filter(filter);
}

/* A test program's main: runs the tests given (cmocka_unit_test(fn), ...) as the group `name`,
 * with the group's setup and teardown (NULL: none). */
#define TU_MAIN(name, setup, teardown, ...)                                                                            \
    int main(void) {                                                                                                   \
        const struct CMUnitTest tests[] = {__VA_ARGS__};                                                               \
        tu_filter_from_env();                                                                                          \
        return cmocka_run_group_tests_name(name, tests, setup, teardown);                                              \
    }

/* ------------------------------------------------------------------ RNG */

typedef struct tu_rng {
    uint64_t s;
} tu_rng;

static inline tu_rng tu_rng_make(uint64_t seed) {
    tu_rng r = {seed * 0x9E3779B97F4A7C15ull + 0x632BE59BD9B4E019ull};
    return r;
}

/* splitmix64 */
static inline uint64_t tu_next(tu_rng *r) {
    uint64_t z = (r->s += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

/* Uniform in [0, 1). */
static inline float tu_unif(tu_rng *r) { return (float)(tu_next(r) >> 40) * (1.0f / 16777216.0f); }
static inline double tu_unifd(tu_rng *r) { return (double)(tu_next(r) >> 11) * (1.0 / 9007199254740992.0); }
static inline float tu_range(tu_rng *r, float lo, float hi) { return lo + (hi - lo) * tu_unif(r); }

/* Uniform unit vector. */
static inline void tu_unit_vec(tu_rng *r, float out[3]) {
    float z = 2.f * tu_unif(r) - 1.f, phi = 6.28318530718f * tu_unif(r);
    float s = sqrtf(fmaxf(0.f, 1.f - z * z));
    out[0] = s * cosf(phi);
    out[1] = s * sinf(phi);
    out[2] = z;
}

/* ------------------------------------------------------------ vectors */

static inline float tu_dot(const float *a, const float *b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
static inline void tu_normalize(float *a) {
    float l = sqrtf(tu_dot(a, a));
    if (l > 0.f) a[0] /= l, a[1] /= l, a[2] /= l;
}

/* ------------------------------------------------------- image compare */

/* Largest |value| of n floats. */
static inline double tu_max_abs(const float *a, size_t n) {
    double m = 0.0;
    for (size_t i = 0; i < n; i++)
        if (fabs((double)a[i]) > m) m = fabs((double)a[i]);
    return m;
}

/* Counts the floats of `got` that differ from `ref` by more than
 * rel * max(|ref|, 1e-6 * max|ref|); non-finite values always count.
 * Prints the first few mismatches (index as pixel, channel). */
static inline size_t tu_compare(const float *got, const float *ref, size_t nfloats, double rel, const char *what) {
    double floor_ = 1e-6 * tu_max_abs(ref, nfloats);
    size_t bad = 0;
    for (size_t i = 0; i < nfloats; i++) {
        double a = got[i], b = ref[i];
        double tol = rel * fmax(fabs(b), floor_);
        if (!isfinite(a) || !(fabs(a - b) <= tol)) {
            if (bad < 5)
                fprintf(stderr, "  %s: pixel %zu channel %zu: got %.9g, expected %.9g (tolerance %.3g)\n", what, i / 3,
                        i % 3, a, b, tol);
            bad++;
        }
    }
    if (bad) fprintf(stderr, "  %s: %zu of %zu values differ\n", what, bad, nfloats);
    return bad;
}

/* ------------------------------------------------------------- files */

static inline int tu_file_exists(const char *p) {
    struct stat st;
    return stat(p, &st) == 0 && S_ISREG(st.st_mode);
}

/* Writes `text` to `path`; returns 0 on success. */
static inline int tu_write_file(const char *path, const char *text) {
    FILE *f = fopen(path, "wb");
    if (!f) return -1;
    size_t n = strlen(text);
    int ok = fwrite(text, 1, n, f) == n;
    return (fclose(f) == 0 && ok) ? 0 : -1;
}

/* Writes a room open at the front into folder dir -- a Blinn-Phong floor, red and white walls, a
 * mirror back wall, a glass block and an emissive ceiling quad (room.obj, room.mtl) -- and its
 * scene file room.json (path into json_path) with the camera the tests start from and `extra`
 * JSON members (e.g. a sky; "" for none). Returns 0 on success. */
static inline int tu_write_room(const char *dir, const char *extra, char *json_path, size_t n) {
    char path[700], json[1600];
    snprintf(path, sizeof path, "%s/room.mtl", dir);
    if (tu_write_file(path, "newmtl white\nKd 0.7 0.7 0.7\nillum 1\n"
                            "newmtl red\nKd 0.7 0.1 0.1\nillum 1\n"
                            "newmtl floor\nKd 0.5 0.5 0.4\nKs 0.3 0.3 0.3\nNs 30\nillum 2\n"
                            "newmtl mirror\nKd 0 0 0\nKs 0.9 0.9 0.9\nillum 3\n"
                            "newmtl glass\nKd 0 0 0\nKs 1 1 1\nNi 1.5\nillum 7\n"
                            "newmtl lamp\nKd 0.8 0.8 0.8\nKe 20 20 20\nillum 1\n"))
        return -1;
    snprintf(path, sizeof path, "%s/room.obj", dir);
    if (tu_write_file(path, "mtllib room.mtl\n"
                            "v -1 0 -1\nv 1 0 -1\nv 1 0 1\nv -1 0 1\n"                             /* 1-4 floor */
                            "v -1 2 -1\nv 1 2 -1\nv 1 2 1\nv -1 2 1\n"                             /* 5-8 ceiling */
                            "v -0.3 1.98 -0.3\nv 0.3 1.98 -0.3\nv 0.3 1.98 0.3\nv -0.3 1.98 0.3\n" /* 9-12 lamp */
                            "v 0.1 0 0.1\nv 0.6 0 0.1\nv 0.6 0 0.6\nv 0.1 0 0.6\n"         /* 13-16 glass bottom */
                            "v 0.1 0.6 0.1\nv 0.6 0.6 0.1\nv 0.6 0.6 0.6\nv 0.1 0.6 0.6\n" /* 17-20 glass top */
                            "usemtl floor\nf 1 4 3 2\n"
                            "usemtl white\nf 5 6 7 8\nf 2 3 7 6\n"
                            "usemtl red\nf 1 5 8 4\n"
                            "usemtl mirror\nf 1 2 6 5\n"
                            "usemtl lamp\nf 9 10 11 12\n"
                            "usemtl glass\nf 13 14 15 16\nf 17 20 19 18\nf 13 17 18 14\nf 14 18 19 15\n"
                            "f 15 19 20 16\nf 16 20 17 13\n"))
        return -1;
    snprintf(json, sizeof json,
             "{\"mesh\": \"%s\", \"camera\": {\"eye\": [-0.3, 1.1, 3.2], \"look_at\": [0.1, 0.8, -1], "
             "\"fov_y\": 50}%s%s}\n",
             path, *extra ? ", " : "", extra);
    snprintf(json_path, n, "%s/room.json", dir);
    return tu_write_file(json_path, json);
}

/* Creates a fresh temporary folder (buf receives its path). */
static inline void tu_make_tmpdir(char *buf, size_t n) {
    const char *base = getenv("TMPDIR");
    snprintf(buf, n, "%s/pgi-test-XXXXXX", base && *base ? base : "/tmp");
    if (!mkdtemp(buf)) {
        fprintf(stderr, "cannot create a temporary folder %s\n", buf);
        abort();
    }
}

/* Removes a folder made by tu_make_tmpdir (only paths under a pgi-test- folder). */
static inline void tu_rm_tmpdir(const char *dir) {
    if (!strstr(dir, "/pgi-test-")) return;
    char cmd[1200];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", dir);
    if (system(cmd) != 0) fprintf(stderr, "could not remove %s\n", dir);
}

/* A temporary folder for a group of tests (cmocka group fixtures): tu_dir, made by tu_dir_setup
 * and removed with what is in it by tu_dir_teardown. */
static char tu_dir[512] __attribute__((unused));
static inline int tu_dir_setup(void **state) {
    (void)state;
    tu_make_tmpdir(tu_dir, sizeof tu_dir);
    return 0;
}
static inline int tu_dir_teardown(void **state) {
    (void)state;
    tu_rm_tmpdir(tu_dir);
    return 0;
}

/* Folder with the large scenes: $PHOTONGI_SCENES, else ../shared/scenes. */
static inline const char *tu_scenes_dir(void) {
    const char *e = getenv("PHOTONGI_SCENES");
    return e && *e ? e : "../shared/scenes";
}

/* ------------------------------------------------------------ photons */

/* Random photon j: position uniform in [-0.5, 0.5]^3, uniform unit direction
 * and normal, flux in [0.01, 1) per channel (drawn from r in this order).
 * `nrm` (may be NULL) receives the normal. */
static inline void tu_random_photon(pgi_photons *ph, size_t j, tu_rng *r, float nrm[3]) {
    float d[3], nn[3];
    ph->px[j] = tu_range(r, -0.5f, 0.5f);
    ph->py[j] = tu_range(r, -0.5f, 0.5f);
    ph->pz[j] = tu_range(r, -0.5f, 0.5f);
    tu_unit_vec(r, d);
    tu_unit_vec(r, nn);
    ph->dx[j] = d[0], ph->dy[j] = d[1], ph->dz[j] = d[2];
    ph->nx[j] = nn[0], ph->ny[j] = nn[1], ph->nz[j] = nn[2];
    ph->fr[j] = tu_range(r, 0.01f, 1.f);
    ph->fg[j] = tu_range(r, 0.01f, 1.f);
    ph->fb[j] = tu_range(r, 0.01f, 1.f);
    if (nrm) nrm[0] = nn[0], nrm[1] = nn[1], nrm[2] = nn[2];
}

/* ---------------------------------------------------------- estimators */

/* An estimator's creation options (d) plus the per-frame arguments the tests vary. */
typedef struct tu_est {
    float radius;
    uint64_t seed;
    int threads;
    float scene_area;
    pgi_estimator_desc d;
} tu_est;

static inline pgi_estimate_args tu_args(const tu_est *t, const pgi_photons *ph, const pgi_view_samples *vs,
                                        const pgi_camera *cam, float *out) {
    pgi_estimate_args a = {.photons = ph,
                           .samples = vs,
                           .camera = cam,
                           .out_rgb = out,
                           .radius = t->radius,
                           .seed = t->seed,
                           .threads = t->threads,
                           .scene_area = t->scene_area};
    return a;
}

/* Creates estimator `name` and checks that it accepts the per-frame values of t (a build over
 * an empty frame); on failure *out is NULL and the status is the library's. */
static inline pgi_status tu_create(const char *name, const tu_est *t, pgi_estimator **out) {
    pgi_status s = pgi_estimator_create(name, &t->d, out);
    if (s) return s;
    pgi_photons ph = {0};
    pgi_view_samples vs = {0};
    pgi_camera cam;
    const float eye[3] = {0, 0, 0}, at[3] = {0, 0, 1}, up[3] = {0, 1, 0};
    pgi_camera_look_at(&cam, eye, at, up, 60.f, 1, 1);
    if ((s = pgi_view_samples_alloc(&vs, 1, 1)) == PGI_OK) {
        pgi_estimate_args a = tu_args(t, &ph, &vs, &cam, NULL);
        s = pgi_estimator_build(*out, &a);
        pgi_view_samples_free(&vs);
    }
    if (s) {
        pgi_estimator_destroy(*out);
        *out = NULL;
    }
    return s;
}

/* create + build + estimate + stats in one call; returns the first failure. */
static inline pgi_status tu_run_estimator(const char *name, const tu_est *t, const pgi_photons *ph,
                                          const pgi_view_samples *vs, const pgi_camera *cam, float *out,
                                          pgi_estimator_stats *st) {
    pgi_estimator *e = NULL;
    pgi_status s = pgi_estimator_create(name, &t->d, &e);
    if (s) return s;
    pgi_estimate_args a = tu_args(t, ph, vs, cam, out);
    s = pgi_estimator_build(e, &a);
    if (!s) s = pgi_estimator_estimate(e, &a);
    if (!s && st) pgi_estimator_get_stats(e, st);
    pgi_estimator_destroy(e);
    return s;
}

/* Fails the test with the library's message when `expr` is not PGI_OK. */
#define TU_CHECK_OK(expr)                                                                                              \
    do {                                                                                                               \
        pgi_status tu_st_ = (expr);                                                                                    \
        if (tu_st_ != PGI_OK) fail_msg("%s failed: %s (%s)", #expr, pgi_status_string(tu_st_), pgi_last_error());      \
    } while (0)

/* The scene `name` (pgi_scene_load), or the test fails with the library's message. */
static inline pgi_scene *tu_scene(const char *name) {
    pgi_scene *s = NULL;
    const pgi_status st = pgi_scene_load(name, &s);
    if (st != PGI_OK) fail_msg("pgi_scene_load(\"%s\") failed: %s (%s)", name, pgi_status_string(st), pgi_last_error());
    return s;
}

/* Writes `text` to DIR/NAME (the path into `path`, `cap` bytes) and loads it (tu_scene). */
static inline pgi_scene *tu_scene_text(const char *dir, const char *name, const char *text, char *path, size_t cap) {
    snprintf(path, cap, "%s/%s", dir, name);
    if (tu_write_file(path, text)) fail_msg("cannot write %s", path);
    return tu_scene(path);
}

/* A renderer of scene `s` (pgi_renderer_create), or the test fails with the library's message. */
static inline pgi_renderer *tu_renderer(const pgi_scene *s) {
    pgi_renderer *r = NULL;
    TU_CHECK_OK(pgi_renderer_create(s, &r));
    return r;
}

/* Requires `got` to equal the oracle's `ref` (nf floats, relative 1e-4, see
 * tu_compare) with the same number of contributing photon reads; prints both
 * counts when they differ. `what` names the comparison in messages. */
static inline void tu_expect_same(const char *what, const float *got, const float *ref, size_t nf,
                                  uint64_t got_contributing, uint64_t ref_contributing) {
    size_t bad = tu_compare(got, ref, nf, 1e-4, what);
    if (got_contributing != ref_contributing)
        fprintf(stderr, "  %s: contributing %llu, brute %llu\n", what, (unsigned long long)got_contributing,
                (unsigned long long)ref_contributing);
    assert_int_equal(bad, 0);
    assert_int_equal(got_contributing, ref_contributing);
}

/* The whole pipeline on a scene: renders it (indirect light, seed 5) with each
 * of names[0..n) (names[0] the oracle, "brute"; n <= 8) and requires
 * every other estimator to equal it: radiance within 1e-4 relative and the
 * same number of contributing photon reads. radius <= 0: the scene's default. */
static inline void tu_pipeline_vs_brute(const char *scene_name, int w, int h, uint32_t photons, float radius,
                                        const char *const *names, int n) {
    assert_true(n >= 2 && n <= 8);
    pgi_scene *scene = NULL;
    TU_CHECK_OK(pgi_scene_load(scene_name, &scene));
    pgi_renderer *r = NULL;
    TU_CHECK_OK(pgi_renderer_create(scene, &r));
    pgi_image img[8] = {{0}};
    pgi_frame_stats fs[8];
    for (int k = 0; k < n; k++) {
        pgi_render_desc d = {.estimator = names[k],
                             .photons = photons,
                             .width = w,
                             .height = h,
                             .output = PGI_OUTPUT_INDIRECT,
                             .seed = 5};
        if (radius > 0.f) d.radius = radius;
        TU_CHECK_OK(pgi_renderer_render(r, &d, &img[k], &fs[k]));
        assert_int_equal(img[k].width, w);
        assert_int_equal(img[k].height, h);
        assert_string_equal(fs[k].estimator, names[k]);
    }
    assert_true(fs[0].photons_stored == photons);
    assert_true(fs[0].contributing > 0);
    assert_true(tu_max_abs(img[0].rgb, 3 * (size_t)w * h) > 0.0);
    for (int k = 1; k < n; k++) {
        char what[1024]; /* scene_name may be a long temporary path */
        snprintf(what, sizeof what, "%s: %s vs %s", scene_name, names[k], names[0]);
        assert_int_equal(fs[k].photons_stored, fs[0].photons_stored);
        tu_expect_same(what, img[k].rgb, img[0].rgb, 3 * (size_t)w * h, fs[k].contributing, fs[0].contributing);
    }
    for (int k = 0; k < n; k++) pgi_image_free(&img[k]);
    pgi_renderer_destroy(r);
    pgi_scene_destroy(scene);
}

/* Direction through the point (x + jx, y + jy) of the image, (jx, jy) in
 * [0, 1]^2 inside pixel (x, y) (not normalised; its component along
 * cam->forward is 1, so eye + t * dir has view depth t). */
static inline void tu_pixel_dir_at(const pgi_camera *cam, int x, int y, float jx, float jy, float dir[3]) {
    float u = (2.f * ((float)x + jx) / (float)cam->width - 1.f) * cam->tan_half_fov_y * cam->aspect;
    float v = (1.f - 2.f * ((float)y + jy) / (float)cam->height) * cam->tan_half_fov_y;
    for (int k = 0; k < 3; k++) dir[k] = cam->forward[k] + u * cam->right[k] + v * cam->up[k];
}

/* Direction through the centre of pixel (x, y) (as tu_pixel_dir_at). */
static inline void tu_pixel_dir(const pgi_camera *cam, int x, int y, float dir[3]) {
    tu_pixel_dir_at(cam, x, y, 0.5f, 0.5f, dir);
}

/* Sets view sample i as a Lambertian (or Phong when ks > 0) sample. */
static inline void tu_set_sample(pgi_view_samples *vs, size_t i, const float pos[3], const float nrm[3],
                                 const float wo[3], const float kd[3], float ks, float shininess, float depth,
                                 uint8_t flags) {
    for (int k = 0; k < 3; k++) {
        vs->pos[3 * i + k] = pos[k];
        vs->nrm[3 * i + k] = nrm[k];
        vs->ngeo[3 * i + k] = nrm[k];
        vs->wo[3 * i + k] = wo[k];
        vs->kd[3 * i + k] = kd[k];
        vs->ks[3 * i + k] = ks;
        vs->weight[3 * i + k] = 1.f;
    }
    vs->shininess[i] = shininess;
    if (vs->ior) vs->ior[i] = 1.5f;
    vs->depth[i] = depth;
    vs->flags[i] = flags;
}

/* tu_set_sample with what the random view samples draw last from r: a unit normal turned to face
 * wo and a diffuse albedo in [0.1, 0.9] a channel. */
static inline void tu_set_random_sample(pgi_view_samples *vs, size_t i, tu_rng *r, const float pos[3],
                                        const float wo[3], float ks, float shininess, float depth, uint8_t flags) {
    float n[3], kd[3];
    tu_unit_vec(r, n);
    if (tu_dot(n, wo) < 0.f) n[0] = -n[0], n[1] = -n[1], n[2] = -n[2];
    for (int k = 0; k < 3; k++) kd[k] = tu_range(r, 0.1f, 0.9f);
    tu_set_sample(vs, i, pos, n, wo, kd, ks, shininess, depth, flags);
}

#endif
