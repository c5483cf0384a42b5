/* Hooks shared by the estimator vtbls. */
#include "est_common.h"

void pgi__est_default_stats(const void *state, pgi_estimator_stats *out) {
    *out = ((const pgi__est_common *)state)->st;
}
