/* Everything an estimator may share, by concern:
 *   gather.h     the per-photon contribution test, accumulators, kernels
 *   footprint.h  per-photon footprints (spheres, ellipsoids)
 *   packed.h     photons packed into an estimator's own structure
 *   subsample.h  stochastic subsampling
 *   screen.h     world-to-view transform of the camera
 *   est_common.h stats block and helpers, the registry's vtbls
 *   buf.h        growable buffers
 * New code includes the ones it needs. */
#ifndef PGI_ESTIMATOR_INTERNAL_H
#define PGI_ESTIMATOR_INTERNAL_H

#include "buf.h"
#include "est_common.h"
#include "footprint.h"
#include "gather.h"
#include "packed.h"
#include "screen.h"
#include "subsample.h"

/* directional's table of octant weight normalisations K (est_directional.c): 6 x res x res floats */
const float *pgi__directional_knorm_table(int *res);

#endif
