/* `--device cpu|gpu|vulkan[:N]` for the apps (docs/gpu.md). Header only (static inline), shared
 * by photongi and the viewer. */
#ifndef PGI__APPS_DEVICE_H
#define PGI__APPS_DEVICE_H

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "photongi/photongi.h"

#define APP_DEVICE_HELP                                                                                                \
    "  --device cpu|gpu|vulkan[:N]   where the frame runs: cpu (default); gpu or vulkan = the\n"                       \
    "                     Vulkan backend on the first discrete GPU, else integrated, else a CPU\n"                     \
    "                     device (lavapipe); vulkan:N = Vulkan device N ('photongi devices').\n"                       \
    "                     On the GPU the view samples, photons, estimator (all but brute and\n"                        \
    "                     kdtree: 'photongi devices' lists them) and direct light run there\n"                         \
    "                     (docs/gpu.md)\n"

/* Parses v into d->device and d->device_index: 1 when valid, else 0 with a message in err. */
static inline int app_parse_device(const char *v, pgi_render_desc *d, char *err, size_t size) {
    if (strcmp(v, "cpu") == 0) {
        d->device = PGI_DEVICE_CPU;
        d->device_index = 0;
        return 1;
    }
    if (strcmp(v, "gpu") == 0 || strcmp(v, "vulkan") == 0) {
        d->device = PGI_DEVICE_VULKAN;
        d->device_index = 0;
        return 1;
    }
    if (strncmp(v, "vulkan:", 7) == 0) {
        const char *s = v + 7;
        char *end = NULL;
        long n = (*s >= '0' && *s <= '9') ? strtol(s, &end, 10) : -1;
        if (n >= 0 && n < 1024 && end && *end == 0) {
            d->device = PGI_DEVICE_VULKAN;
            d->device_index = PGI_DEVICE_INDEX((int)n);
            return 1;
        }
    }
    snprintf(err, size, "--device must be cpu, gpu, vulkan or vulkan:N (N a device number from 0), got '%s'", v);
    return 0;
}

/* "cpu", "vulkan", "vulkan:N" of a desc. */
static inline const char *app_device_spec(const pgi_render_desc *d, char *buf, size_t size) {
    if (d->device != PGI_DEVICE_VULKAN) snprintf(buf, size, "cpu");
    else if (d->device_index == 0) snprintf(buf, size, "vulkan");
    else snprintf(buf, size, "vulkan:%d", d->device_index - 1);
    return buf;
}

/* Before loading a scene: a Vulkan device in a build without the backend, or an estimator without
 * a GPU version, is refused with a message in err (0); 1 otherwise. */
static inline int app_check_device(const pgi_render_desc *d, const char *estimator, char *err, size_t size) {
    if (d->device != PGI_DEVICE_VULKAN) return 1;
    if (!pgi_vulkan_available()) {
        snprintf(err, size,
                 "--device vulkan: this build of photongi has no Vulkan backend (built without Vulkan/glslc); use "
                 "--device cpu");
        return 0;
    }
    const char *e = estimator && *estimator ? estimator : PGI_DEFAULT_ESTIMATOR;
    const pgi_estimator_vtbl *vt = pgi_estimator_find(e);
    if (!vt || pgi_estimator_runs_on(vt, PGI_DEVICE_VULKAN)) return 1; /* an unknown name: the render's message */
    char names[256];
    pgi_device_estimators(names, sizeof names);
    snprintf(err, size, "estimator '%s' has no GPU version; on --device vulkan: %s", e, names);
    return 0;
}

#endif
