/* Stable radix sort on the device (gpu_sort.h). */
#include "gpu/gpu_sort.h"

#include <string.h>

#include "core/core.h"

#ifdef PGI__HAVE_VULKAN
#include "gpu/spirv.h"

#define BLOCK 256 /* pairs a workgroup (shaders/sort_radix.comp) */

/* shaders/sort_radix.comp Push */
typedef struct {
    uint32_t n, shift, nblocks, mode, from_value, interleaved, pad0, pad1;
} sort_push;
_Static_assert(sizeof(sort_push) == 32 && offsetof(sort_push, interleaved) == 20, "sort_radix.comp Push");

pgi_status pgi__gpu_sort_create(pgi__gpu *g, const char *what, pgi__gpu_sort *s) {
    memset(s, 0, sizeof *s);
    s->g = g;
    s->what = what;
    pgi_status st = pgi__gpu_kernel_create(g, pgi__spv_sort_radix, sizeof pgi__spv_sort_radix, "sort_radix", 5,
                                           sizeof(sort_push), &s->pass);
    if (!st) st = pgi__gpu_scan_create(g, what, &s->scan);
    if (st) pgi__gpu_sort_destroy(s);
    return st;
}

void pgi__gpu_sort_destroy(pgi__gpu_sort *s) {
    if (!s->g) return;
    pgi__gpu_kernel_destroy(s->g, s->pass);
    for (int i = 0; i < 2; i++) {
        pgi__gpu_buffer_destroy(s->g, s->keys[i]);
        pgi__gpu_buffer_destroy(s->g, s->values[i]);
    }
    pgi__gpu_buffer_destroy(s->g, s->hist);
    pgi__gpu_scan_destroy(&s->scan);
    memset(s, 0, sizeof *s);
}

pgi_status pgi__gpu_sort_reserve(pgi__gpu_sort *s, size_t n) {
    if (n == 0) n = 1;
    if (n > UINT32_MAX / 2)
        return pgi__fail(PGI_ERR_UNSUPPORTED, "GPU sort of %zu pairs: at most 2^31 (%s)", n, s->what);
    const size_t nblocks = (n + BLOCK - 1) / BLOCK;
    pgi_status st;
    for (int i = 0; i < 2; i++)
        if ((st = pgi__gpu_buffer_reserve(s->g, &s->keys[i], n * 4, s->what)) ||
            (st = pgi__gpu_buffer_reserve(s->g, &s->values[i], n * 4, s->what)))
            return st;
    if ((st = pgi__gpu_buffer_reserve(s->g, &s->hist, nblocks * 256 * 4, s->what)) ||
        (st = pgi__gpu_scan_reserve(&s->scan, nblocks * 256)))
        return st;
    s->n = n;
    return PGI_OK;
}

pgi_status pgi__gpu_sort_record(pgi__gpu_sort *s, pgi__gpu_buffer *pairs, size_t n, int value_bits, int key_bits,
                                pgi__gpu_buffer **keys, pgi__gpu_buffer **values) {
    if (n > s->n || value_bits < 0 || value_bits > 32 || key_bits < 0 || key_bits > 32)
        return pgi__fail(PGI_ERR_INTERNAL, "GPU sort (%s): %zu pairs, %d + %d bits (reserved for %zu)", s->what, n,
                         value_bits, key_bits, s->n);
    const int vpasses = (value_bits + 7) / 8, passes = n ? vpasses + (key_bits + 7) / 8 : 0;
    if (passes == 0 && n) return pgi__fail(PGI_ERR_INTERNAL, "GPU sort (%s): no bits to sort by", s->what);
    const size_t nblocks = (n + BLOCK - 1) / BLOCK;
    /* the scan runs over the last reserve's blocks; the words past this sort's come after every
     * offset it reads, so whatever they hold does not matter */
    pgi_status st = PGI_OK;
    pgi__gpu_buffer *kin = n ? pairs : s->keys[0], *vin = n ? pairs : s->values[0];
    int out = 0;
    for (int p = 0; !st && p < passes; p++) {
        const int from_value = p < vpasses;
        sort_push q = {.n = (uint32_t)n,
                       .shift = (uint32_t)(8 * (from_value ? p : p - vpasses)),
                       .nblocks = (uint32_t)nblocks,
                       .from_value = (uint32_t)from_value,
                       .interleaved = kin == pairs};
        pgi__gpu_buffer *b[] = {kin, vin, s->hist, s->keys[out], s->values[out]};
        if ((st = pgi__gpu_dispatch_1d(s->g, s->pass, b, &q, nblocks * BLOCK, BLOCK)) ||
            (st = pgi__gpu_scan_record(&s->scan, s->hist)))
            break;
        q.mode = 1;
        st = pgi__gpu_dispatch_1d(s->g, s->pass, b, &q, nblocks * BLOCK, BLOCK);
        kin = s->keys[out];
        vin = s->values[out];
        out ^= 1;
    }
    if (st) return st;
    *keys = kin;
    *values = vin;
    return PGI_OK;
}

#endif /* PGI__HAVE_VULKAN: the callers are Vulkan-only too */
