/* The photon tracer's work for many lanes at once (trace_simd.c): the sines and cosines of its
 * sampled angles, and the emission pre-pass's sort keys. Each has an AVX2 build picked at run time
 * and a scalar one; both give the same bits. */
#ifndef PGI__TRACE_SIMD_H
#define PGI__TRACE_SIMD_H

#include "core/core.h"

/* s[i] = sinf(phi), c[i] = cosf(phi) with phi = 2 pi u[i] (phi as pgi_sample_cosine and
 * pgi_sample_sphere compute it: 2.f * PGI__PI * u), for i < n (n a multiple of 8, at most 16).
 * The AVX2 build evaluates glibc's sincosf (its algorithm and coefficients, as libm's FMA variant
 * computes them, 4 lanes a register); it is taken only where it gave libm's bits for a sample of
 * angles when first called (pgi__trace_sincos_fast), else libm's sinf and cosf. */
void pgi__trace_sincos_2pi(const float *u, float *s, float *c, int n);
/* Whether pgi__trace_sincos_2pi takes its AVX2 build (the CPU has AVX2 and FMA, pgi__cpu_narrow is
 * off, and the build agreed with libm when checked). */
int pgi__trace_sincos_fast(void);
/* The AVX2 build alone, for the tests: angles 2 pi u[i], i < n (a multiple of 8); returns 0 where
 * there is none (then s and c are not written). */
int pgi__trace_sincos_2pi_avx2(const float *u, float *s, float *c, int n);

/* Emission sort keys (trace.c emit_key) of n paths: origins (ox, oy, oz), directions (dx, dy,
 * dz), grid centre and radius as the tracer's; key[i] for i < n. */
void pgi__trace_emit_keys(pgi__v3 centre, float radius, const float *ox, const float *oy, const float *oz,
                          const float *dx, const float *dy, const float *dz, int n, uint32_t *key);
/* The scalar key of one path (the reference of both builds). */
uint32_t pgi__trace_emit_key(pgi__v3 centre, float radius, pgi__v3 o, pgi__v3 d);

/* Lambertian scattering of up to 16 hits (trace.c wave_shade), in and out as arrays of lanes:
 * the shading normal (pgi__tri_rec_ns: the vertex normals n at barycentrics bu, bv where
 * the scene has them, else g), pgi__bsdf_sample's Lambertian case (a cosine-weighted direction
 * about the shading normal turned to the side `side` = +-1 of the hit, from u0 and the
 * azimuth's cosine and sine; weight kd), then the roulette with number u3 and the next ray
 * (origin p moved eps along the facing normal ng on wo's side). u0, u1: the direction's numbers
 * (the azimuth 2 pi u1's sine and cosine as pgi__trace_sincos_2pi finds them), u3: the roulette's.
 * alive[i]: the path goes on,
 * with flux f, origin o and direction d. The AVX2 build is pgi__trace_lambert_avx2 (0: none);
 * trace.c computes the same operations lane by lane elsewhere. */
typedef struct pgi__lambert_batch {
    int n, nrm;
    float eps;
    float nv[9][16], bu[16], bv[16], g[3][16], side[16], kd[3][16];
    float u0[16], u1[16], u3[16];
    float flux[3][16], p[3][16], ng[3][16];
    /* out */
    int alive[16];
    float f[3][16], o[3][16], d[3][16];
} pgi__lambert_batch;
int pgi__trace_lambert_avx2(pgi__lambert_batch *b);

#endif
