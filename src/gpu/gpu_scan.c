/* Exclusive prefix sum on the device (gpu_scan.h). */
#include "gpu/gpu_scan.h"

#include <string.h>

#include "core/core.h"

#ifdef PGI__HAVE_VULKAN
#include "gpu/spirv.h"

/* shaders/hashgrid.glsl Push, which the scan kernels share: they read n (byte 12) */
typedef struct {
    float f[3];
    uint32_t n, mask, pad[7];
} scan_push;
_Static_assert(sizeof(scan_push) == 48 && offsetof(scan_push, n) == 12, "hashgrid.glsl Push (n)");

pgi_status pgi__gpu_scan_create(pgi__gpu *g, const char *what, pgi__gpu_scan *s) {
    memset(s, 0, sizeof *s);
    s->g = g;
    s->what = what;
    pgi_status st =
        pgi__gpu_kernel_create(g, pgi__spv_hg_scan, sizeof pgi__spv_hg_scan, "scan", 2, sizeof(scan_push), &s->scan);
    if (!st)
        st = pgi__gpu_kernel_create(g, pgi__spv_hg_scan_add, sizeof pgi__spv_hg_scan_add, "scan_add", 2,
                                    sizeof(scan_push), &s->add);
    if (st) pgi__gpu_scan_destroy(s);
    return st;
}

void pgi__gpu_scan_destroy(pgi__gpu_scan *s) {
    if (!s->g) return;
    pgi__gpu_kernel_destroy(s->g, s->scan);
    pgi__gpu_kernel_destroy(s->g, s->add);
    for (int i = 0; i < PGI__GPU_SCAN_LEVELS; i++) pgi__gpu_buffer_destroy(s->g, s->totals[i]);
    memset(s, 0, sizeof *s);
}

pgi_status pgi__gpu_scan_reserve(pgi__gpu_scan *s, size_t n) {
    size_t level_n[PGI__GPU_SCAN_LEVELS + 1] = {n};
    int levels = 0;
    while (levels < PGI__GPU_SCAN_LEVELS && (levels == 0 || level_n[levels] > 1)) {
        level_n[levels + 1] = (level_n[levels] + 1023) / 1024;
        levels++;
    }
    if (n == 0 || n > UINT32_MAX || level_n[levels] > 1)
        return pgi__fail(PGI_ERR_UNSUPPORTED, "GPU prefix sum of %zu words: at most 2^32 - 1 (%s)", n, s->what);
    for (int l = 1; l <= levels; l++) {
        pgi_status st = pgi__gpu_buffer_reserve(s->g, &s->totals[l - 1], level_n[l] * 4, s->what);
        if (st) return st;
    }
    memcpy(s->level_n, level_n, sizeof level_n);
    s->levels = levels;
    return PGI_OK;
}

pgi_status pgi__gpu_scan_record(pgi__gpu_scan *s, pgi__gpu_buffer *data) {
    pgi__gpu_buffer *lv[PGI__GPU_SCAN_LEVELS + 1] = {data};
    for (int l = 1; l <= s->levels; l++) lv[l] = s->totals[l - 1];
    pgi_status st;
    for (int l = 0; l < s->levels; l++) {
        scan_push q = {.n = (uint32_t)s->level_n[l]};
        if ((st =
                 pgi__gpu_dispatch_1d(s->g, s->scan, (pgi__gpu_buffer *[]){lv[l], lv[l + 1]}, &q, s->level_n[l], 1024)))
            return st;
    }
    for (int l = s->levels - 2; l >= 0; l--) {
        scan_push q = {.n = (uint32_t)s->level_n[l]};
        if ((st = pgi__gpu_dispatch_1d(s->g, s->add, (pgi__gpu_buffer *[]){lv[l], lv[l + 1]}, &q, s->level_n[l], 256)))
            return st;
    }
    return PGI_OK;
}

#endif /* PGI__HAVE_VULKAN: the callers are Vulkan-only too */
