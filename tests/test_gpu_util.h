/* Shared by the tests of the Vulkan backend (test_gpu, test_gpu_rays, test_gpu_frame, test_gpu_trace). */
#ifndef PGI_TEST_GPU_UTIL_H
#define PGI_TEST_GPU_UTIL_H

#include <dlfcn.h>

/* AddressSanitizer: lavapipe keeps a 128-byte allocation in a global that it never frees; once the
 * loader unloads the driver (vkDestroyInstance) LeakSanitizer sees it as a leak in an unknown module,
 * which no suppression can name. Keeping the driver loaded (RTLD_NODELETE) leaves the block
 * reachable; the library's own allocations are still checked. Call first thing in main. */
static inline void tu_keep_lavapipe_loaded(void) {
#if defined(__SANITIZE_ADDRESS__)
    (void)dlopen("libvulkan_lvp.so", RTLD_NOW | RTLD_NODELETE);
#endif
}

#endif
