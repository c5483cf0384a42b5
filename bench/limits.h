/* photongi-bench --limits (bench/limits.c): each ray pass next to raw Embree on the same rays. */
#ifndef PGI__BENCH_LIMITS_H
#define PGI__BENCH_LIMITS_H

/* Runs the limits benchmark on each scene of the comma-separated list; writes csv_path.
 * Returns 0 when every scene ran. */
int pgi_bench_limits(const char *scenes, const char *estimator, int frames, unsigned photons, int width, int height,
                     float radius, int threads, const char *csv_path);

#endif
