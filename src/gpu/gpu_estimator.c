/* The registry of GPU estimators (gpu_estimator.h). */
#include "gpu/gpu_estimator.h"

#include <string.h>

#include "core/core.h"

static const pgi__gpu_est_vtbl *const k_gpu_estimators[] = {&pgi__gpu_est_hashgrid, &pgi__gpu_est_cluster_trivial,
                                                            &pgi__gpu_est_directional, &pgi__gpu_est_tiled};
#define NGPU (sizeof k_gpu_estimators / sizeof k_gpu_estimators[0])

const pgi__gpu_est_vtbl *pgi__gpu_est_find(const char *name) {
    for (size_t i = 0; name && i < NGPU; i++)
        if (strcmp(k_gpu_estimators[i]->name, name) == 0) return k_gpu_estimators[i];
    return NULL;
}

void pgi__gpu_est_names(char *buf, size_t size) {
    if (size) buf[0] = 0;
    for (size_t i = 0; i < NGPU; i++) pgi__list_append(buf, size, k_gpu_estimators[i]->name);
}
