/* Estimators on the GPU (--device vulkan, docs/gpu.md): the same pgi_estimate_args as the CPU
 * estimators (photons and view samples from the CPU, uploaded each frame), one call that builds
 * and gathers on the device and writes args->out_rgb, and stats in the CPU estimators' form (GPU
 * passes named "gpu_*" with timestamps, the device's buffers as "gpu_*" memory entries). */
#ifndef PGI_GPU_ESTIMATOR_H
#define PGI_GPU_ESTIMATOR_H

#include "gpu/gpu.h"

typedef struct pgi__gpu_est_vtbl {
    const char *name; /* the CPU estimator it mirrors ("hashgrid") */
    /* desc: resolved (pgi_estimator_desc_resolve); options the GPU version lacks are refused here */
    pgi_status (*create)(pgi__gpu *g, const pgi_estimator_desc *desc, void **state);
    pgi_status (*run)(void *state, const pgi_estimate_args *args, pgi_estimator_stats *st);
    void (*destroy)(void *state);
} pgi__gpu_est_vtbl;

/* NULL when `name` has no GPU version. */
const pgi__gpu_est_vtbl *pgi__gpu_est_find(const char *name);
/* "hashgrid, ...": the estimators with a GPU version. */
void pgi__gpu_est_names(char *buf, size_t size);

extern const pgi__gpu_est_vtbl pgi__gpu_est_hashgrid;
extern const pgi__gpu_est_vtbl pgi__gpu_est_cluster_trivial;

#endif
