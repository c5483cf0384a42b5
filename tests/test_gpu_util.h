/* Shared by the tests of the Vulkan backend (test_gpu, test_gpu_rays, test_gpu_frame, test_gpu_trace). */
#ifndef PGI__TEST_GPU_UTIL_H
#define PGI__TEST_GPU_UTIL_H

#include <dlfcn.h>
#include <stdio.h>

#include "gpu/gpu.h"

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

#endif
