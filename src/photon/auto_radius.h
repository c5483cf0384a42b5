/* The automatic gather radius: chosen each frame from the photon density the camera sees.
 *
 * For up to PGI__AUTO_QUERIES view samples spread over the image, the distance to the K-th
 * nearest photon that the sample would gather (the same hemisphere test as every estimator:
 * the photon arrives from the sample's side) is found in a hashed grid of the stored photons;
 * the radius is a quantile of those distances, so that most of what the camera sees gathers
 * about K photons: smooth where the view is dimly lit, no larger than needed where it is bright.
 * It is clamped to [lo, hi] (a fraction of the scene's diagonal), which keeps the gather cost
 * predictable when the view sees almost no photons. Deterministic: the queries and the grid do
 * not depend on the thread count. */
#ifndef PGI__AUTO_RADIUS_H
#define PGI__AUTO_RADIUS_H

#include "core/core.h"
#include "photongi/estimator.h"
#include "photongi/photongi.h"

#define PGI__AUTO_QUERIES 1024

/* Chooses the radius (*radius) for photons `ph` seen by samples `vs` in a scene of diagonal `diag`;
 * `how` says how (pgi_auto_radius_stats). With no valid sample or too few photons it is the old
 * default, 2 % of the diagonal. */
pgi_status pgi__auto_radius_choose(const pgi_photons *ph, const pgi_view_samples *vs, float diag, int threads,
                                   float *radius, pgi_auto_radius_stats *how);

#endif
