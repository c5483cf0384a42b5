/* photongi-bench --mirrors (bench/mirrors.c): the cost of mirrors and glass in view. */
#ifndef PGI__BENCH_MIRRORS_H
#define PGI__BENCH_MIRRORS_H

/* Renders the built-in cornell-mirrors scene as it is and with its mirrors and
 * glass turned Lambertian, at each photon count of the comma-separated list,
 * with each estimator of the list; prints build + estimate time and the
 * estimator's memory next to hashgrid's; writes csv_path. Returns 0 when
 * everything ran. */
int pgi_bench_mirrors(const char *photon_list, const char *estimators, int frames, int width, int height, float radius,
                      int threads, const char *csv_path);

#endif
