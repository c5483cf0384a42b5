/* Stable radix sort of (key, value) pairs of 32-bit words on the device: shaders/sort_radix.comp
 * sorts by 8 bits a pass (a histogram per block of 256 pairs, gpu_scan.h's exclusive sum of the
 * histograms, then each pair written at its digit's offset plus its rank in the block), least
 * significant first: the values' low bits, then the keys'. Sorting by the value first and the key
 * second orders the pairs by (key, value); a pair's place is a function of the input alone, whatever
 * order the device runs the workgroups in.
 *
 * Used where the CPU sorts by a key: the cluster family's photon order (Morton cells) and its photon
 * lists (node entry, then photon).
 *
 *   pgi__gpu_sort so;  pgi__gpu_sort_create(g, "gpu_photon_lists", &so);      once
 *   pgi__gpu_sort_reserve(&so, n);                  outside a sequence, whenever n may have grown
 *   pgi__gpu_sort_record(&so, pairs, n, value_bits, key_bits, &keys, &values);   inside one
 *   pgi__gpu_sort_destroy(&so);
 *
 * The sorted keys and values come in two of the sort's own buffers (*keys, *values: valid until the
 * next record). Cost: (value_bits + key_bits) / 8 passes, rounded up, of two dispatches and a scan. */
#ifndef PGI__GPU_SORT_H
#define PGI__GPU_SORT_H

#include "gpu/gpu.h"
#include "gpu/gpu_scan.h"

typedef struct pgi__gpu_sort {
    pgi__gpu *g;
    pgi__gpu_kernel *pass;
    pgi__gpu_buffer *keys[2], *values[2], *hist;
    pgi__gpu_scan scan;
    size_t n; /* the last reserve's */
    const char *what;
} pgi__gpu_sort;

pgi_status pgi__gpu_sort_create(pgi__gpu *g, const char *what, pgi__gpu_sort *s);
/* Buffers for up to n pairs (n >= 1); they grow and are kept. */
pgi_status pgi__gpu_sort_reserve(pgi__gpu_sort *s, size_t n);
/* Records the sort of the n pairs (n <= the last reserve's) at the start of `pairs` (key, value
 * interleaved) by the low value_bits of the value, then the low key_bits of the key (each 0..32). */
pgi_status pgi__gpu_sort_record(pgi__gpu_sort *s, pgi__gpu_buffer *pairs, size_t n, int value_bits, int key_bits,
                                pgi__gpu_buffer **keys, pgi__gpu_buffer **values);
void pgi__gpu_sort_destroy(pgi__gpu_sort *s);

#endif
