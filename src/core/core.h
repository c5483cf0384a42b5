/* Internal core: status + last error, small vector math, RNG, timers.
 * Every module includes this; nothing here is public API. */
#ifndef PGI__CORE_H
#define PGI__CORE_H

#include <math.h>
#include <stdatomic.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>

#include "photongi/photongi.h"

#define PGI__PI 3.14159265358979323846f
#define PGI__INV_PI 0.31830988618379067154f

/* Records a formatted message as this thread's last error and returns `s`,
 * so that `return pgi__fail(PGI_ERR_IO, "%s: cannot open", path);` reads well. */
pgi_status pgi__fail(pgi_status s, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;
void pgi__clear_error(void);

/* Always-on invariant check (never for user input). */
#define PGI__ASSERT(c)                                                                                                  \
    do {                                                                                                               \
        if (!(c)) pgi__assert_fail(#c, __FILE__, __LINE__);                                                            \
    } while (0)
void pgi__assert_fail(const char *expr, const char *file, int line);

/* Run-time AVX2 dispatch (GCC on x86-64; not under ASan, whose instrumentation the ifunc
 * resolvers of target clones trip over): PGI__AVX2_DISPATCH is 1 where code may carry an AVX2
 * build picked at run time, and PGI__AVX2_CLONES gives a function a default and an AVX2 clone.
 * Without FMA contraction (-ffp-contract=off) both builds give the same bits. */
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && !defined(__SANITIZE_ADDRESS__)
#define PGI__AVX2_DISPATCH 1
#define PGI__AVX2_CLONES __attribute__((target_clones("avx2", "default")))
#else
#define PGI__AVX2_DISPATCH 0
#define PGI__AVX2_CLONES
#endif

/* Whether the builds picked at run time with an explicit test may take their AVX2 path: the CPU
 * has AVX2 and POPCNT (a load and a test: libgcc sets the flags at start-up) and nobody asked
 * for the narrow builds. pgi__cpu_narrow = 1 forces the narrow (SSE) builds everywhere such a
 * test picks, so that a test can check both give the same bits on an AVX2 machine; set it only
 * while no frame is running. (Target clones, PGI__AVX2_CLONES, pick by the CPU alone.) */
/* Where code may hold explicit AVX2 builds (functions with target("avx2") and intrinsics, picked
 * with pgi__cpu_avx2): x86-64 with GCC or clang, sanitizer builds included. */
#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#define PGI__AVX2_TARGET 1
#else
#define PGI__AVX2_TARGET 0
#endif

#if defined(__x86_64__) || defined(__i386__)
extern int pgi__cpu_narrow;
static inline int pgi__cpu_avx2(void) {
    return !pgi__cpu_narrow && __builtin_cpu_supports("avx2") && __builtin_cpu_supports("popcnt");
}
/* Whether the few AVX-512 builds (AVX-512F, picked at run time, e.g. the view pass's texture
 * lookups) may run: pgi__cpu_avx2() and AVX-512F, unless pgi__cpu_no512 = 1 (tests compare them
 * with the AVX2 builds; set it only while no frame is running). */
extern int pgi__cpu_no512;
static inline int pgi__cpu_avx512(void) {
    return pgi__cpu_avx2() && !pgi__cpu_no512 && __builtin_cpu_supports("avx512f");
}
#endif

double pgi__now_ms(void);

/* The cancel token (pgi_cancel_create): a flag set from any thread or a signal handler, read by
 * every thread of the work it was given to, which then stops at its next check. */
struct pgi_cancel {
    atomic_int requested;
};
static inline int pgi__cancelled(const pgi_cancel *c) {
    return c && atomic_load_explicit(&((pgi_cancel *)c)->requested, memory_order_relaxed);
}
/* PGI_ERR_CANCELLED with "WHAT: cancelled" as the last error. */
pgi_status pgi__fail_cancelled(const char *what);

/* Largest image the library allocates, rendered or read (a header that
 * declares more is refused before any pixel is allocated): 8K UHD fits. */
#define PGI__MAX_SIDE PGI_MAX_IMAGE_SIDE
#define PGI__MAX_PIXELS PGI_MAX_IMAGE_PIXELS

/* PGI_ERR_UNSUPPORTED naming `what` (a file, or "image size") when w x h is
 * outside 1..PGI__MAX_SIDE a side or above PGI__MAX_PIXELS. */
pgi_status pgi__check_image_size(const char *what, int64_t w, int64_t h);

/* Threads for a parallel region: the caller's count, or OpenMP's default for
 * 0. The library passes it to every region (num_threads) and never changes
 * the process's OpenMP settings. */
#ifdef _OPENMP
#include <omp.h>
static inline int pgi__threads(int requested) { return requested > 0 ? requested : omp_get_max_threads(); }
#else
static inline int pgi__threads(int requested) { return requested > 0 ? requested : 1; }
#endif

/* sRGB -> linear (srgb.c): the exact sRGB EOTF of c in [0, 1], in double; and
 * the 8-bit table the texture lookup uses (equal to (float) of the formula at
 * i / 255 except for three entries one ulp below; see srgb.c). */
double pgi__srgb_to_linear(double c);
extern const float pgi__srgb8_texture_lut[256];

/* PGI_ERR_INVALID_ARG naming `name` and the registered estimators (estimator.c). */
pgi_status pgi__fail_unknown_estimator(const char *name);

/* Replaces control bytes (but newline and tab) and DEL by '?', in place: text from a file (a scene
 * or material name) printed to a terminal carries no escape sequences. */
void pgi__sanitize(char *text);
/* Why `path` cannot be read as an input file (stat follows links): NULL for a regular file,
 * else "no such file", "is a directory", "is a FIFO, not a regular file", "is a device, not a
 * regular file", ... (static text). Checked before opening: a FIFO would block the open, a
 * device such as /dev/zero never ends. */
const char *pgi__not_regular_file(const char *path);
/* The one checked open of an input file (meshes, material libraries, buffers Assimp reads,
 * textures): opened without blocking (a FIFO cannot hang the open), then refused unless it is a
 * regular file of at most `max_bytes` (0: any size). Returns the stream, or NULL with *why set
 * to static text ("is a FIFO, not a regular file", "larger than ...": the caller names the file)
 * and errno set (EINVAL: not a regular file; EFBIG: too large; else open's). *size (may be
 * NULL) gets the file's size. */
FILE *pgi__fopen_input(const char *path, uint64_t max_bytes, uint64_t *size, const char **why);
/* Appends `name` to the comma-separated list in buf (for "registered: a, b" messages). */
void pgi__list_append(char *buf, size_t cap, const char *name);

/* Aligned allocation for hot arrays (64 bytes); free with pgi__afree. */
void *pgi__aalloc(size_t bytes);
void pgi__afree(void *p);

/* ---------------------------------------------------------------- vectors */
/* Branch-free min/max that compile to one instruction (fmaxf is a libm call
 * unless -ffinite-math-only). Unlike fmaxf they pass a NaN in `b` through. */
/* qsort comparator of floats, ascending (NaN-free input). */
static inline int pgi__cmp_float(const void *a, const void *b) {
    float x = *(const float *)a, y = *(const float *)b;
    return (x > y) - (x < y);
}
static inline float pgi_maxf(float a, float b) { return a > b ? a : b; }
static inline float pgi_minf(float a, float b) { return a < b ? a : b; }

typedef struct {
    float x, y, z;
} pgi__v3;

static inline pgi__v3 v3(float x, float y, float z) {
    pgi__v3 r = {x, y, z};
    return r;
}
static inline pgi__v3 v3_load(const float *p) { return v3(p[0], p[1], p[2]); }
static inline void v3_store(float *p, pgi__v3 a) {
    p[0] = a.x;
    p[1] = a.y;
    p[2] = a.z;
}
static inline pgi__v3 v3_add(pgi__v3 a, pgi__v3 b) { return v3(a.x + b.x, a.y + b.y, a.z + b.z); }
static inline pgi__v3 v3_sub(pgi__v3 a, pgi__v3 b) { return v3(a.x - b.x, a.y - b.y, a.z - b.z); }
static inline pgi__v3 v3_mul(pgi__v3 a, pgi__v3 b) { return v3(a.x * b.x, a.y * b.y, a.z * b.z); }
static inline pgi__v3 v3_scale(pgi__v3 a, float s) { return v3(a.x * s, a.y * s, a.z * s); }
static inline pgi__v3 v3_madd(pgi__v3 a, pgi__v3 b, float s) { return v3(a.x + b.x * s, a.y + b.y * s, a.z + b.z * s); }
static inline float v3_dot(pgi__v3 a, pgi__v3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
static inline pgi__v3 v3_cross(pgi__v3 a, pgi__v3 b) {
    return v3(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}
static inline float v3_len(pgi__v3 a) { return sqrtf(v3_dot(a, a)); }
static inline pgi__v3 v3_norm(pgi__v3 a) {
    float l = v3_len(a);
    return l > 0.f ? v3_scale(a, 1.f / l) : v3(0.f, 0.f, 1.f);
}
static inline pgi__v3 v3_neg(pgi__v3 a) { return v3(-a.x, -a.y, -a.z); }
static inline float v3_maxc(pgi__v3 a) { return pgi_maxf(a.x, pgi_maxf(a.y, a.z)); }
static inline float v3_lum(pgi__v3 a) { return 0.2126f * a.x + 0.7152f * a.y + 0.0722f * a.z; }
static inline pgi__v3 v3_min(pgi__v3 a, pgi__v3 b) {
    return v3(pgi_minf(a.x, b.x), pgi_minf(a.y, b.y), pgi_minf(a.z, b.z));
}
static inline pgi__v3 v3_max(pgi__v3 a, pgi__v3 b) {
    return v3(pgi_maxf(a.x, b.x), pgi_maxf(a.y, b.y), pgi_maxf(a.z, b.z));
}
static inline int v3_finite(pgi__v3 a) { return isfinite(a.x) && isfinite(a.y) && isfinite(a.z); }

/* Orthonormal basis around unit n (Duff et al. 2017). */
static inline void v3_basis(pgi__v3 n, pgi__v3 *t, pgi__v3 *b) {
    float sign = copysignf(1.f, n.z);
    float a = -1.f / (sign + n.z);
    float bb = n.x * n.y * a;
    *t = v3(1.f + sign * n.x * n.x * a, sign * bb, -sign * n.x);
    *b = v3(bb, sign + n.y * n.y * a, -n.y);
}

/* -------------------------------------------------------------------- RNG */
/* PCG32 (O'Neill). One stream per photon path / pixel: seeded from
 * (seed, index) so results do not depend on the thread count. */
typedef struct {
    uint64_t state, inc;
} pgi__rng;

static inline uint64_t pgi__mix64(uint64_t z) {
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
}
static inline uint32_t pgi_rng_u32(pgi__rng *r) {
    uint64_t old = r->state;
    r->state = old * 6364136223846793005ULL + r->inc;
    uint32_t xs = (uint32_t)(((old >> 18u) ^ old) >> 27u);
    uint32_t rot = (uint32_t)(old >> 59u);
    return (xs >> rot) | (xs << ((-rot) & 31));
}
/* pgi_rng_seed in two parts, for many streams of one seed (the photon tracer's paths): the
 * seed's part once (pgi__rng_seed_mix), then each stream's (pgi__rng_seed_mixed); the same
 * generator as pgi_rng_seed(r, seed, stream). */
static inline uint64_t pgi__rng_seed_mix(uint64_t seed) { return pgi__mix64(seed + 0x632be59bd9b4e019ULL); }
static inline void pgi__rng_seed_mixed(pgi__rng *r, uint64_t seed_mix, uint64_t stream) {
    r->state = 0u;
    r->inc = (pgi__mix64(stream ^ 0x9e3779b97f4a7c15ULL) << 1u) | 1u;
    pgi_rng_u32(r);
    r->state += seed_mix;
    pgi_rng_u32(r);
}
static inline void pgi_rng_seed(pgi__rng *r, uint64_t seed, uint64_t stream) {
    pgi__rng_seed_mixed(r, pgi__rng_seed_mix(seed), stream);
}
/* Uniform in [0, 1). */
static inline float pgi_rng_f(pgi__rng *r) { return (float)(pgi_rng_u32(r) >> 8) * (1.f / 16777216.f); }

/* --------------------------------------------------------------- sampling */
/* Each sampler takes the azimuth 2 pi u2; its _cs form takes the azimuth's cosine c and sine s
 * instead (found elsewhere, e.g. for many samples at once: the same bits as cosf and sinf give
 * the same direction). */
static inline pgi__v3 pgi_sample_cosine_cs(float u1, float c, float s) {
    const float r = sqrtf(u1);
    return v3(r * c, r * s, sqrtf(pgi_maxf(1.f - u1, 0.f)));
}
static inline pgi__v3 pgi_sample_cosine(float u1, float u2) {
    const float phi = 2.f * PGI__PI * u2;
    return pgi_sample_cosine_cs(u1, cosf(phi), sinf(phi));
}
static inline pgi__v3 pgi_sample_sphere_cs(float u1, float c, float s) {
    const float z = 1.f - 2.f * u1, r = sqrtf(pgi_maxf(1.f - z * z, 0.f));
    return v3(r * c, r * s, z);
}
static inline pgi__v3 pgi_sample_sphere(float u1, float u2) {
    const float phi = 2.f * PGI__PI * u2;
    return pgi_sample_sphere_cs(u1, cosf(phi), sinf(phi));
}
/* Uniform direction in the cone around +z with cos(theta) >= cos_max. */
static inline pgi__v3 pgi_sample_cone_cs(float u1, float c, float s, float cos_max) {
    const float z = 1.f - u1 * (1.f - cos_max), r = sqrtf(pgi_maxf(1.f - z * z, 0.f));
    return v3(r * c, r * s, z);
}
static inline pgi__v3 pgi_sample_cone(float u1, float u2, float cos_max) {
    const float phi = 2.f * PGI__PI * u2;
    return pgi_sample_cone_cs(u1, cosf(phi), sinf(phi), cos_max);
}
static inline pgi__v3 pgi_to_world(pgi__v3 l, pgi__v3 n) {
    pgi__v3 t, b;
    v3_basis(n, &t, &b);
    return v3_add(v3_add(v3_scale(t, l.x), v3_scale(b, l.y)), v3_scale(n, l.z));
}

#endif
