/* Everything an estimator may share, by concern:
 *   gather.h     the per-photon contribution test, accumulators, kernels
 *   footprint.h  per-photon footprints (spheres, ellipsoids)
 *   packed.h     photons packed into an estimator's own structure
 *   subsample.h  stochastic subsampling
 *   screen.h     world-to-view transform of the camera
 *   est_common.h stats block and helpers, the registry's vtbls
 *   buf.h        growable buffers
 * New code includes the ones it needs. */
#ifndef PGI__ESTIMATOR_INTERNAL_H
#define PGI__ESTIMATOR_INTERNAL_H

#include "buf.h"
#include "est_common.h"
#include "footprint.h"
#include "gather.h"
#include "packed.h"
#include "screen.h"
#include "subsample.h"

/* The cluster tile of a frame: `tile` when given, else (0: directional's default) a 64th of the image's
 * shorter side, 1..8 pixels (8 from 512 pixels up). A leaf then spans about the same part of the view
 * at any image size. directional takes a leaf's flux when the photon's sphere holds the leaf's centre,
 * so leaves wide in the scene lose light: with 8-pixel leaves at 128x128 the Cornell box's indirect
 * light was 5 % dark (14 % at 64x64), Sponza's 5.5 % at 256x256; from the image size, within 0.3 % and
 * 2 % (docs/cluster.md). */
static inline int pgi__cluster_tile(int tile, int width, int height) {
    if (tile > 0) return tile;
    const int t = (width < height ? width : height) / 64;
    return t < 1 ? 1 : t > 8 ? 8 : t;
}

/* The start of view sample i in an estimator's loop over the samples: NULL once the caller asked
 * to cancel (pgi__est_stop) or where the sample takes no indirect light (pgi__vs_begin has then
 * written its output); else its output, with v set up for the gathers. */
static inline float *pgi__est_sample(const pgi__est_common *c, const pgi_estimate_args *a, long long ii, pgi__vs *v) {
    const size_t i = (size_t)ii;
    float *out = a->out_rgb + 3 * i;
    return !pgi__est_stop(c) && pgi__vs_begin(a->samples, i, out, v) ? out : NULL;
}

#endif
