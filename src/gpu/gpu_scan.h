/* Exclusive prefix sum of 32-bit words on the device: shaders/hg_scan.comp scans blocks of 1024
 * words and writes each block's total one level up; the levels above are scanned the same way,
 * then shaders/hg_scan_add.comp adds each block's offset back down. Up to 1024^4 words.
 *
 * Used by every pass that turns counts into offsets (the hashgrid's buckets, the cluster family's
 * photon lists, tiled's lists, the photon tracer's compaction):
 *
 *   pgi__gpu_scan sc;  pgi__gpu_scan_create(g, "gpu_hash", &sc);     once
 *   pgi__gpu_scan_reserve(&sc, n);                                   whenever n may have grown
 *   pgi__gpu_scan_record(&sc, counts);                               inside an open sequence
 *   pgi__gpu_scan_destroy(&sc);
 *
 * Integer sums: the result does not depend on the order the device runs the workgroups in. */
#ifndef PGI__GPU_SCAN_H
#define PGI__GPU_SCAN_H

#include "gpu/gpu.h"

#define PGI__GPU_SCAN_LEVELS 4 /* 1024^4 words */

typedef struct pgi__gpu_scan {
    pgi__gpu *g;
    pgi__gpu_kernel *scan, *add;
    pgi__gpu_buffer *totals[PGI__GPU_SCAN_LEVELS]; /* level l + 1: the block totals of level l */
    size_t level_n[PGI__GPU_SCAN_LEVELS + 1];      /* words at each level; level 0: the data */
    int levels;
    const char *what; /* the memory entry of the totals' buffers */
} pgi__gpu_scan;

/* Creates the two kernels; `what` names the memory the level buffers count under. */
pgi_status pgi__gpu_scan_create(pgi__gpu *g, const char *what, pgi__gpu_scan *s);
/* Levels for a scan of n words (n >= 1); PGI_ERR_UNSUPPORTED beyond 1024^4. */
pgi_status pgi__gpu_scan_reserve(pgi__gpu_scan *s, size_t n);
/* Records the scan of the n words (the last reserve's) at the start of `data`. */
pgi_status pgi__gpu_scan_record(pgi__gpu_scan *s, pgi__gpu_buffer *data);
void pgi__gpu_scan_destroy(pgi__gpu_scan *s);

#endif
