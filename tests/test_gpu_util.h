/* Shared by the tests of the Vulkan backend (test_gpu, test_gpu_rays, test_gpu_frame, test_gpu_trace). */
#ifndef PGI_TEST_GPU_UTIL_H
#define PGI_TEST_GPU_UTIL_H

#include <dlfcn.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "gpu/gpu.h"
#include "scene/scene_internal.h"

/* AddressSanitizer: lavapipe keeps a 128-byte allocation in a global that it never frees; once the
 * loader unloads the driver (vkDestroyInstance) LeakSanitizer sees it as a leak in an unknown module,
 * which no suppression can name. Keeping the driver loaded (RTLD_NODELETE) leaves the block
 * reachable; the library's own allocations are still checked. Call first thing in main. */
static inline void tu_keep_lavapipe_loaded(void) {
#if defined(__SANITIZE_ADDRESS__)
    (void)dlopen("libvulkan_lvp.so", RTLD_NOW | RTLD_NODELETE);
#endif
}

/* The device the tests of one program share: cmocka group setup and teardown. */
static pgi__gpu *g_gpu;

static inline int tu_gpu_setup(void **state) {
    (void)state;
    if (pgi__gpu_create(-1, &g_gpu) != PGI_OK) {
        fprintf(stderr, "no Vulkan device: %s\n", pgi_last_error());
        return -1;
    }
    fprintf(stderr, "device: %s (timestamps: %s)\n", pgi__gpu_device_name(g_gpu),
            pgi__gpu_has_timestamps(g_gpu) ? "yes" : "no");
    return 0;
}

static inline int tu_gpu_teardown(void **state) {
    (void)state;
    pgi__gpu_destroy(g_gpu);
    return 0;
}

/* Gives a loaded scene vertex colours (linear, in [0.1, 1]) that change from vertex to vertex,
 * strongly and in each channel on its own: a fraction of the position scaled differently per
 * channel (what a coloured mesh file loads into pgi_scene.col). Called before a renderer or GPU
 * scene is made of it. */
static inline void tu_add_vertex_colours(pgi_scene *s) {
    free(s->col);
    s->col = malloc(3 * (s->nverts ? s->nverts : 1) * sizeof(float));
    if (!s->col) abort();
    for (size_t v = 0; v < s->nverts; v++) {
        const float *p = s->pos + 3 * v;
        for (int c = 0; c < 3; c++) {
            const float t = 1.3f * p[c] + 0.7f * p[(c + 1) % 3] + 0.37f * (float)c;
            s->col[3 * v + c] = 0.1f + 0.9f * (t - floorf(t));
        }
    }
}

#endif
