/* The frame's passes on the CPU and on the GPU device (docs/gpu.md "The GPU frame"):
 *   photongi-bench-gpu-frame [--scene NAME] [--size WxH] [--photons N] [--direct N] [--runs N]
 * renders one warm-up frame per device (lavapipe compiles its kernels on first use), then `runs`
 * frames each, and prints each pass's best time (ms) for both devices and the GPU's device passes.
 * Photons are traced on each device (the GPU frame by trace.comp). Exit 1 with the message when
 * a frame fails (no Vulkan device: the CPU's figures are still printed first). */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "photongi/photongi.h"

static void best(double *b, double v) {
    if (*b < 0.0 || v < *b) *b = v;
}

typedef struct {
    double view, trace, build, estimate, direct, total;
    pgi_named_value passes[PGI_MAX_STAT_ENTRIES];
    int npasses;
} times;

static int run(pgi_renderer *r, const pgi_render_desc *d, int runs, times *t) {
    pgi_image im = {0};
    pgi_frame_stats st;
    memset(t, 0, sizeof *t);
    t->view = t->trace = t->build = t->estimate = t->direct = t->total = -1.0;
    for (int k = 0; k <= runs; k++) {
        if (pgi_renderer_render(r, d, &im, &st) != PGI_OK) {
            fprintf(stderr, "frame failed: %s\n", pgi_last_error());
            pgi_image_free(&im);
            return 1;
        }
        if (k == 0) continue; /* warm-up */
        best(&t->view, st.view_ms);
        best(&t->trace, st.trace_ms);
        best(&t->build, st.build_ms);
        best(&t->estimate, st.estimate_ms);
        best(&t->direct, st.direct_ms);
        if (t->total < 0.0 || st.total_ms < t->total) {
            t->total = st.total_ms;
            t->npasses = st.pass_count;
            memcpy(t->passes, st.passes_ms, sizeof t->passes);
        }
    }
    pgi_image_free(&im);
    return 0;
}

int main(int argc, char **argv) {
    const char *scene = "cornell";
    int w = 1280, h = 720, runs = 3, direct = 16;
    unsigned photons = 200000;
    for (int i = 1; i < argc; i++) {
        if (i + 1 < argc && strcmp(argv[i], "--scene") == 0) scene = argv[++i];
        else if (i + 1 < argc && strcmp(argv[i], "--size") == 0 && sscanf(argv[i + 1], "%dx%d", &w, &h) == 2) i++;
        else if (i + 1 < argc && strcmp(argv[i], "--photons") == 0) photons = (unsigned)strtoul(argv[++i], NULL, 10);
        else if (i + 1 < argc && strcmp(argv[i], "--direct") == 0) direct = atoi(argv[++i]);
        else if (i + 1 < argc && strcmp(argv[i], "--runs") == 0) runs = atoi(argv[++i]);
        else {
            fprintf(stderr, "usage: %s [--scene NAME] [--size WxH] [--photons N] [--direct N] [--runs N]\n", argv[0]);
            return 2;
        }
    }
    pgi_scene *s = NULL;
    pgi_renderer *r = NULL;
    if (pgi_scene_load(scene, &s) != PGI_OK || pgi_renderer_create(s, &r) != PGI_OK) {
        fprintf(stderr, "%s\n", pgi_last_error());
        pgi_scene_destroy(s);
        return 1;
    }
    pgi_render_desc d = {0};
    d.width = w;
    d.height = h;
    d.photons = photons;
    d.direct_samples = direct;
    d.seed = 1;
    times c, g;
    int rc = run(r, &d, runs, &c);
    if (!rc) {
        d.device = PGI_DEVICE_VULKAN;
        rc = run(r, &d, runs, &g);
    }
    if (!rc) {
        printf("%s %dx%d, %u photons, %d direct samples, best of %d (after a warm-up frame)\n", scene, w, h, photons,
               direct, runs);
        printf("| device | view | trace | build | estimate | direct | total |\n|---|---|---|---|---|---|---|\n");
        printf("| cpu | %.1f | %.1f | %.1f | %.1f | %.1f | %.1f |\n", c.view, c.trace, c.build, c.estimate, c.direct,
               c.total);
        printf("| vulkan | %.1f | %.1f | %.1f | %.1f | %.1f | %.1f |\n", g.view, g.trace, g.build, g.estimate, g.direct,
               g.total);
        printf("GPU passes (fastest frame):");
        for (int k = 0; k < g.npasses; k++) printf(" %s %.1f", g.passes[k].name, g.passes[k].value);
        printf("\n");
    }
    pgi_renderer_destroy(r);
    pgi_scene_destroy(s);
    return rc;
}
