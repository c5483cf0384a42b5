/* The photon tracer's lane-parallel work (trace_simd.h): sines and cosines of sampled angles and
 * the emission sort keys, each as an AVX2 build picked at run time and a scalar build, with the
 * same bits. */
#include "trace_simd.h"

#include <string.h>

#if PGI__AVX2_TARGET
#include <immintrin.h>
#endif

/* --------------------------------------------------------------- sincos */

static void sincos_2pi_scalar(const float *u, float *s, float *c, int n) {
    for (int i = 0; i < n; i++) {
        const float phi = 2.f * PGI__PI * u[i];
        c[i] = cosf(phi);
        s[i] = sinf(phi);
    }
}

#if PGI__AVX2_TARGET
/* glibc's sincosf (sysdeps/ieee754/flt-32/s_sincosf.c, sincosf.h; glibc 2.28 on) for
 * |y| < 120, as its FMA build (__sincosf_fma) computes it: x = y in double, n = the quadrant
 * (reduce_fast: ((int)(x 2^24 2/pi) + 2^23) >> 24), xr = x - n pi/2 (fused), then the two
 * polynomials of sincosf_poly with the contractions gcc made there (each a + b c below is one
 * fused operation), the results swapped in odd quadrants; |y| < 2^-12 gives sin y, cos 1.
 * n = 0 reduces nothing (xr = x exactly), so the path of |y| < pi/4 is the same formula. */
#define SC_C0 0x1p+0
#define SC_C1 -0x1.ffffffd0c621cp-2
#define SC_S1 -0x1.555545995a603p-3
#define SC_C2 0x1.55553e1068f19p-5
#define SC_S2 0x1.1107605230bc4p-7
#define SC_C3 -0x1.6c087e89a359dp-10
#define SC_S3 -0x1.994eb3774cf24p-13
#define SC_C4 0x1.99343027bf8c3p-16
/* (__sincosf_table[0]; quadrants with n & 2 take __sincosf_table[1], whose cosine coefficients
 * are these negated and sine coefficients these: each fused operation of the cosine polynomial
 * then gives the negated result, exactly, so the cosine polynomial's sign is flipped instead.) */

/* Four angles y (floats, |y| < 120): their sines and cosines, rounded to float. */
__attribute__((target("avx2,fma"))) static inline void sincos4(__m128 y, __m128 *sn, __m128 *cs) {
    const __m256d x = _mm256_cvtps_pd(y);
    const __m128i n =
        _mm_srai_epi32(_mm_add_epi32(_mm256_cvttpd_epi32(_mm256_mul_pd(x, _mm256_set1_pd(0x1.45f306dc9c883p+23))),
                                     _mm_set1_epi32(0x800000)),
                       24);
    const __m256d xr = _mm256_fnmadd_pd(_mm256_cvtepi32_pd(n), _mm256_set1_pd(0x1.921fb54442d18p+0), x);
    const __m256i n64 = _mm256_cvtepi32_epi64(n);
    /* the sign of the sine in quadrant n & 3: + - - + (a product by -1: the sign bit) */
    const __m256i neg = _mm256_slli_epi64(_mm256_xor_si256(n64, _mm256_srli_epi64(n64, 1)), 63);
    const __m256i negc = _mm256_slli_epi64(_mm256_srli_epi64(n64, 1), 63); /* n & 2 */
    const __m256d q1 = _mm256_castsi256_pd(_mm256_slli_epi64(n64, 63));    /* n & 1: blendv reads the sign bit */
    const __m256d xs = _mm256_xor_pd(xr, _mm256_castsi256_pd(neg));        /* x = xr * sign */
    const __m256d x2 = _mm256_mul_pd(xr, xr);
    const __m256d c1v = _mm256_fmadd_pd(x2, _mm256_set1_pd(SC_C1), _mm256_set1_pd(SC_C0));
    const __m256d s1v = _mm256_fmadd_pd(x2, _mm256_set1_pd(SC_S3), _mm256_set1_pd(SC_S2));
    const __m256d c2v = _mm256_fmadd_pd(x2, _mm256_set1_pd(SC_C4), _mm256_set1_pd(SC_C3));
    const __m256d x3 = _mm256_mul_pd(x2, xs), x4 = _mm256_mul_pd(x2, x2);
    const __m256d x5 = _mm256_mul_pd(x2, x3), x6 = _mm256_mul_pd(x2, x4);
    const __m256d sp = _mm256_fmadd_pd(x3, _mm256_set1_pd(SC_S1), xs);
    const __m256d cp = _mm256_fmadd_pd(x4, _mm256_set1_pd(SC_C2), c1v);
    const __m256d S = _mm256_fmadd_pd(s1v, x5, sp);
    const __m256d C = _mm256_xor_pd(_mm256_fmadd_pd(c2v, x6, cp), _mm256_castsi256_pd(negc));
    /* odd quadrants: the sine is the cosine polynomial and the cosine the sine's */
    const __m128 sf = _mm256_cvtpd_ps(_mm256_blendv_pd(S, C, q1)), cf = _mm256_cvtpd_ps(_mm256_blendv_pd(C, S, q1));
    /* |y| < 2^-12: sin y = y, cos y = 1 */
    const __m128 tiny = _mm_castsi128_ps(
        _mm_cmplt_epi32(_mm_and_si128(_mm_castps_si128(y), _mm_set1_epi32(0x7fffffff)), _mm_set1_epi32(0x39800000)));
    *sn = _mm_blendv_ps(sf, y, tiny);
    *cs = _mm_blendv_ps(cf, _mm_set1_ps(1.f), tiny);
}

__attribute__((target("avx2,fma"))) static void sincos_2pi_avx2(const float *u, float *s, float *c, int n) {
    const __m256 tp = _mm256_set1_ps(2.f * PGI__PI);
    for (int i = 0; i < n; i += 8) {
        const __m256 phi = _mm256_mul_ps(tp, _mm256_loadu_ps(u + i));
        /* outside |phi| < 120 (u outside [0, 1), NaN): libm */
        const int far = _mm256_movemask_ps(_mm256_castsi256_ps(
            _mm256_cmpgt_epi32(_mm256_and_si256(_mm256_castps_si256(phi), _mm256_set1_epi32(0x7fffffff)),
                               _mm256_set1_epi32(0x42efffff))));
        __m128 s0, c0, s1, c1;
        sincos4(_mm256_castps256_ps128(phi), &s0, &c0);
        sincos4(_mm256_extractf128_ps(phi, 1), &s1, &c1);
        _mm_storeu_ps(s + i, s0);
        _mm_storeu_ps(s + i + 4, s1);
        _mm_storeu_ps(c + i, c0);
        _mm_storeu_ps(c + i + 4, c1);
        if (far)
            for (int k = 0; k < 8; k++)
                if (far >> k & 1) sincos_2pi_scalar(u + i + k, s + i + k, c + i + k, 1);
    }
}

/* 0: not checked yet, 1: the AVX2 build agrees with libm, 2: it does not (or no AVX2 and FMA). */
static int g_sincos_state;

static int sincos_check(void) {
    if (!(__builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma"))) return 2;
    /* every 241st of the 2^24 angles the tracer's numbers give, and the first 4096 (the small and
       tiny ranges) */
    enum { N = 256 };
    float u[N], s[N], c[N], s1[N], c1[N];
    int m = 0;
    for (uint32_t k = 0; k < (1u << 24); k += k < 4096 ? 1 : 241) {
        u[m++] = (float)k * (1.f / 16777216.f);
        if (m == N || k + 241 >= (1u << 24)) {
            while (m % 8) u[m++] = 0.5f;
            sincos_2pi_avx2(u, s, c, m);
            sincos_2pi_scalar(u, s1, c1, m);
            for (int i = 0; i < m; i++)
                if (memcmp(&s[i], &s1[i], sizeof(float)) || memcmp(&c[i], &c1[i], sizeof(float))) return 2;
            m = 0;
        }
    }
    return 1;
}

int pgi__trace_sincos_fast(void) {
    if (!pgi__cpu_avx2()) return 0;
    int st = __atomic_load_n(&g_sincos_state, __ATOMIC_ACQUIRE);
    if (!st) {
        st = sincos_check(); /* threads that race here compute the same answer */
        __atomic_store_n(&g_sincos_state, st, __ATOMIC_RELEASE);
    }
    return st == 1;
}

int pgi__trace_sincos_2pi_avx2(const float *u, float *s, float *c, int n) {
    if (!(__builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma"))) return 0;
    sincos_2pi_avx2(u, s, c, n);
    return 1;
}
#else
int pgi__trace_sincos_fast(void) { return 0; }
int pgi__trace_sincos_2pi_avx2(const float *u, float *s, float *c, int n) {
    (void)u, (void)s, (void)c, (void)n;
    return 0;
}
#endif

void pgi__trace_sincos_2pi(const float *u, float *s, float *c, int n) {
#if PGI__AVX2_TARGET
    if (pgi__trace_sincos_fast()) {
        sincos_2pi_avx2(u, s, c, n);
        return;
    }
#endif
    sincos_2pi_scalar(u, s, c, n);
}

/* ------------------------------------------------------------ sort keys */

/* Emission sort key of a path: its origin's cell of a 32^3 grid over the bounding sphere's cube
 * (the sun's and sky's disks start just outside the scene's box), then its direction's cell of a
 * 256 x 256 octahedral map, each in Morton order, so that paths close in key start close
 * together and leave in nearly the same direction: the packets of first_hits. 31 bits. */
static inline uint32_t spread2(uint32_t x) { /* 8 bits -> every other of 16 */
    x &= 0xff;
    x = (x | (x << 4)) & 0x0f0f;
    x = (x | (x << 2)) & 0x3333;
    return (x | (x << 1)) & 0x5555;
}
static inline uint32_t spread3(uint32_t x) { /* 5 bits -> every third of 15 */
    x &= 0x1f;
    x = (x | (x << 8)) & 0x0300f00f;
    x = (x | (x << 4)) & 0x030c30c3;
    return (x | (x << 2)) & 0x09249249;
}
static inline uint32_t cellq(float x, int n) {
    /* max, then min (NaN: 0), without branches: maxss and minss */
    const float y = x > 0.f ? x : 0.f, top = (float)(n - 1);
    return (uint32_t)(y < top ? y : top);
}
uint32_t pgi__trace_emit_key(pgi__v3 centre, float radius, pgi__v3 o, pgi__v3 d) {
    const float so = 16.f / (1.02f * radius);
    const uint32_t ox = cellq((o.x - centre.x) * so + 16.f, 32), oy = cellq((o.y - centre.y) * so + 16.f, 32),
                   oz = cellq((o.z - centre.z) * so + 16.f, 32);
    const float l1 = fabsf(d.x) + fabsf(d.y) + fabsf(d.z);
    float px = l1 > 0.f ? d.x / l1 : 0.f, py = l1 > 0.f ? d.y / l1 : 0.f;
    if (d.z < 0.f) {
        const float tx = (1.f - fabsf(py)) * (px >= 0.f ? 1.f : -1.f),
                    ty = (1.f - fabsf(px)) * (py >= 0.f ? 1.f : -1.f);
        px = tx;
        py = ty;
    }
    const uint32_t dx = cellq((px + 1.f) * 128.f, 256), dy = cellq((py + 1.f) * 128.f, 256);
    return (spread3(ox) | spread3(oy) << 1 | spread3(oz) << 2) << 16 | spread2(dx) | spread2(dy) << 1;
}

#if PGI__AVX2_TARGET
__attribute__((target("avx2"))) static inline __m256i cellq8(__m256 x, float top) {
    /* maxps(x, 0) = x > 0 ? x : 0, minps(y, top) = y < top ? y : top: cellq's selects */
    return _mm256_cvttps_epi32(_mm256_min_ps(_mm256_max_ps(x, _mm256_setzero_ps()), _mm256_set1_ps(top)));
}
__attribute__((target("avx2"))) static inline __m256i spread2_8(__m256i x) {
    x = _mm256_and_si256(x, _mm256_set1_epi32(0xff));
    x = _mm256_and_si256(_mm256_or_si256(x, _mm256_slli_epi32(x, 4)), _mm256_set1_epi32(0x0f0f));
    x = _mm256_and_si256(_mm256_or_si256(x, _mm256_slli_epi32(x, 2)), _mm256_set1_epi32(0x3333));
    return _mm256_and_si256(_mm256_or_si256(x, _mm256_slli_epi32(x, 1)), _mm256_set1_epi32(0x5555));
}
__attribute__((target("avx2"))) static inline __m256i spread3_8(__m256i x) {
    x = _mm256_and_si256(x, _mm256_set1_epi32(0x1f));
    x = _mm256_and_si256(_mm256_or_si256(x, _mm256_slli_epi32(x, 8)), _mm256_set1_epi32(0x0300f00f));
    x = _mm256_and_si256(_mm256_or_si256(x, _mm256_slli_epi32(x, 4)), _mm256_set1_epi32(0x030c30c3));
    return _mm256_and_si256(_mm256_or_si256(x, _mm256_slli_epi32(x, 2)), _mm256_set1_epi32(0x09249249));
}
/* pgi__trace_emit_key for 8 paths: its operations on the same values, its selects as blends. */
__attribute__((target("avx2"))) static void emit_keys_avx2(pgi__v3 centre, float radius, const float *ox,
                                                           const float *oy, const float *oz, const float *dx,
                                                           const float *dy, const float *dz, int n, uint32_t *key) {
    const __m256 so = _mm256_set1_ps(16.f / (1.02f * radius)), k16 = _mm256_set1_ps(16.f), one = _mm256_set1_ps(1.f),
                 k128 = _mm256_set1_ps(128.f), zero = _mm256_setzero_ps();
    const __m256 absm = _mm256_castsi256_ps(_mm256_set1_epi32(0x7fffffff));
    int i = 0;
    for (; i + 8 <= n; i += 8) {
        const __m256i cx =
            cellq8(_mm256_add_ps(_mm256_mul_ps(_mm256_sub_ps(_mm256_loadu_ps(ox + i), _mm256_set1_ps(centre.x)), so),
                                 k16),
                   31.f);
        const __m256i cy =
            cellq8(_mm256_add_ps(_mm256_mul_ps(_mm256_sub_ps(_mm256_loadu_ps(oy + i), _mm256_set1_ps(centre.y)), so),
                                 k16),
                   31.f);
        const __m256i cz =
            cellq8(_mm256_add_ps(_mm256_mul_ps(_mm256_sub_ps(_mm256_loadu_ps(oz + i), _mm256_set1_ps(centre.z)), so),
                                 k16),
                   31.f);
        const __m256 x = _mm256_loadu_ps(dx + i), y = _mm256_loadu_ps(dy + i), z = _mm256_loadu_ps(dz + i);
        const __m256 l1 =
            _mm256_add_ps(_mm256_add_ps(_mm256_and_ps(x, absm), _mm256_and_ps(y, absm)), _mm256_and_ps(z, absm));
        const __m256 pos = _mm256_cmp_ps(l1, zero, _CMP_GT_OQ);
        __m256 px = _mm256_and_ps(pos, _mm256_div_ps(x, l1)), py = _mm256_and_ps(pos, _mm256_div_ps(y, l1));
        /* d.z < 0: the lower half folded; (px >= 0 ? 1 : -1) times a: a with its sign flipped where px < 0
           (or NaN: neither >= 0) */
        const __m256 below = _mm256_cmp_ps(z, zero, _CMP_LT_OQ);
        const __m256 fx =
            _mm256_mul_ps(_mm256_sub_ps(one, _mm256_and_ps(py, absm)),
                          _mm256_blendv_ps(_mm256_set1_ps(-1.f), one, _mm256_cmp_ps(px, zero, _CMP_GE_OQ)));
        const __m256 fy =
            _mm256_mul_ps(_mm256_sub_ps(one, _mm256_and_ps(px, absm)),
                          _mm256_blendv_ps(_mm256_set1_ps(-1.f), one, _mm256_cmp_ps(py, zero, _CMP_GE_OQ)));
        px = _mm256_blendv_ps(px, fx, below);
        py = _mm256_blendv_ps(py, fy, below);
        const __m256i ex = cellq8(_mm256_mul_ps(_mm256_add_ps(px, one), k128), 255.f);
        const __m256i ey = cellq8(_mm256_mul_ps(_mm256_add_ps(py, one), k128), 255.f);
        const __m256i hi = _mm256_or_si256(_mm256_or_si256(spread3_8(cx), _mm256_slli_epi32(spread3_8(cy), 1)),
                                           _mm256_slli_epi32(spread3_8(cz), 2));
        const __m256i k = _mm256_or_si256(_mm256_slli_epi32(hi, 16),
                                          _mm256_or_si256(spread2_8(ex), _mm256_slli_epi32(spread2_8(ey), 1)));
        _mm256_storeu_si256((__m256i *)(key + i), k);
    }
    for (; i < n; i++) key[i] = pgi__trace_emit_key(centre, radius, v3(ox[i], oy[i], oz[i]), v3(dx[i], dy[i], dz[i]));
}
#endif

void pgi__trace_emit_keys(pgi__v3 centre, float radius, const float *ox, const float *oy, const float *oz,
                          const float *dx, const float *dy, const float *dz, int n, uint32_t *key) {
#if PGI__AVX2_TARGET
    if (pgi__cpu_avx2()) {
        emit_keys_avx2(centre, radius, ox, oy, oz, dx, dy, dz, n, key);
        return;
    }
#endif
    for (int i = 0; i < n; i++)
        key[i] = pgi__trace_emit_key(centre, radius, v3(ox[i], oy[i], oz[i]), v3(dx[i], dy[i], dz[i]));
}

/* -------------------------------------------------- Lambertian scattering */

#if PGI__AVX2_TARGET
typedef struct v8x3 {
    __m256 x, y, z;
} v8x3;
__attribute__((target("avx2"))) static inline v8x3 ld3(const float (*a)[16], int i) {
    return (v8x3){_mm256_loadu_ps(a[0] + i), _mm256_loadu_ps(a[1] + i), _mm256_loadu_ps(a[2] + i)};
}
__attribute__((target("avx2"))) static inline void st3(float (*a)[16], int i, v8x3 v) {
    _mm256_storeu_ps(a[0] + i, v.x);
    _mm256_storeu_ps(a[1] + i, v.y);
    _mm256_storeu_ps(a[2] + i, v.z);
}
__attribute__((target("avx2"))) static inline v8x3 scale3(v8x3 a, __m256 s) {
    return (v8x3){_mm256_mul_ps(a.x, s), _mm256_mul_ps(a.y, s), _mm256_mul_ps(a.z, s)};
}
__attribute__((target("avx2"))) static inline v8x3 add3(v8x3 a, v8x3 b) {
    return (v8x3){_mm256_add_ps(a.x, b.x), _mm256_add_ps(a.y, b.y), _mm256_add_ps(a.z, b.z)};
}
__attribute__((target("avx2"))) static inline __m256 dot3(v8x3 a, v8x3 b) {
    return _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(a.x, b.x), _mm256_mul_ps(a.y, b.y)), _mm256_mul_ps(a.z, b.z));
}
__attribute__((target("avx2"))) static inline v8x3 neg3(v8x3 a) { /* v3_neg: the sign bits */
    const __m256 m = _mm256_set1_ps(-0.f);
    return (v8x3){_mm256_xor_ps(a.x, m), _mm256_xor_ps(a.y, m), _mm256_xor_ps(a.z, m)};
}
__attribute__((target("avx2"))) static inline v8x3 sel3(__m256 m, v8x3 a, v8x3 b) { /* m ? a : b */
    return (v8x3){_mm256_blendv_ps(b.x, a.x, m), _mm256_blendv_ps(b.y, a.y, m), _mm256_blendv_ps(b.z, a.z, m)};
}
__attribute__((target("avx2"))) static inline __m256 finite8(__m256 x) {
    return _mm256_cmp_ps(_mm256_and_ps(x, _mm256_castsi256_ps(_mm256_set1_epi32(0x7fffffff))), _mm256_set1_ps(INFINITY),
                         _CMP_LT_OQ);
}

/* The operations of trace.c's lane-by-lane code (pgi__tri_rec_ns, pgi__bsdf_sample's
 * Lambertian case, pgi_to_world, the roulette), 8 lanes an instruction: +-*, / and sqrt are
 * IEEE operations either way; pgi_maxf and pgi_minf are maxps and minps with the operands in
 * their order; a ? b : c a blend. */
__attribute__((target("avx2,fma"))) static void lambert_avx2(pgi__lambert_batch *b) {
    const __m256 zero = _mm256_setzero_ps(), one = _mm256_set1_ps(1.f), eps = _mm256_set1_ps(b->eps);
    for (int i = 0; i < b->n; i += 8) {
        const v8x3 g = ld3(b->g, i);
        v8x3 ns = g;
        if (b->nrm) {
            const __m256 bu = _mm256_loadu_ps(b->bu + i), bv = _mm256_loadu_ps(b->bv + i);
            const __m256 bw = _mm256_sub_ps(_mm256_sub_ps(one, bu), bv);
            const v8x3 n0 = ld3((const float(*)[16])b->nv[0], i), n1 = ld3((const float(*)[16])b->nv[3], i),
                       n2 = ld3((const float(*)[16])b->nv[6], i);
            v8x3 n = add3(add3(scale3(n0, bw), scale3(n1, bu)), scale3(n2, bv));
            const __m256 len = _mm256_sqrt_ps(dot3(n, n));
            const __m256 ok = _mm256_and_ps(_mm256_cmp_ps(len, zero, _CMP_GT_OQ), finite8(len));
            n = scale3(n, _mm256_div_ps(one, len));
            const __m256 back = _mm256_cmp_ps(dot3(n, g), zero, _CMP_LT_OQ);
            ns = sel3(ok, sel3(back, neg3(n), n), g);
        }
        const __m256 side = _mm256_loadu_ps(b->side + i);
        const v8x3 gn = scale3(g, side), sn = scale3(ns, side);
        /* pgi_sample_cosine(u0, u1) with the azimuth's cosine and sine */
        const __m256 u0 = _mm256_loadu_ps(b->u0 + i), rr = _mm256_sqrt_ps(u0);
        __m128 s0, c0, s1, c1; /* the azimuth's sine and cosine (sincos_2pi_avx2) */
        const __m256 phi = _mm256_mul_ps(_mm256_set1_ps(2.f * PGI__PI), _mm256_loadu_ps(b->u1 + i));
        sincos4(_mm256_castps256_ps128(phi), &s0, &c0);
        sincos4(_mm256_extractf128_ps(phi, 1), &s1, &c1);
        const __m256 cx = _mm256_mul_ps(rr, _mm256_set_m128(c1, c0)), cy = _mm256_mul_ps(rr, _mm256_set_m128(s1, s0)),
                     cz = _mm256_sqrt_ps(_mm256_max_ps(_mm256_sub_ps(one, u0), zero));
        /* pgi_to_world(c, sn): v3_basis (Duff et al.) */
        const __m256 sign = _mm256_or_ps(_mm256_and_ps(sn.z, _mm256_set1_ps(-0.f)), one); /* copysignf(1, z) */
        const __m256 a = _mm256_div_ps(_mm256_set1_ps(-1.f), _mm256_add_ps(sign, sn.z));
        const __m256 bb = _mm256_mul_ps(_mm256_mul_ps(sn.x, sn.y), a);
        const __m256 nsign = _mm256_xor_ps(sign, _mm256_set1_ps(-0.f));
        const v8x3 t = {_mm256_add_ps(one, _mm256_mul_ps(_mm256_mul_ps(_mm256_mul_ps(sign, sn.x), sn.x), a)),
                        _mm256_mul_ps(sign, bb), _mm256_mul_ps(nsign, sn.x)};
        const v8x3 bt = {bb, _mm256_add_ps(sign, _mm256_mul_ps(_mm256_mul_ps(sn.y, sn.y), a)),
                         _mm256_xor_ps(sn.y, _mm256_set1_ps(-0.f))};
        const v8x3 wo = add3(add3(scale3(t, cx), scale3(bt, cy)), scale3(sn, cz));
        const __m256 scat = _mm256_cmp_ps(dot3(wo, gn), zero, _CMP_GT_OQ);
        /* the roulette (weight kd) */
        const v8x3 f = ld3(b->flux, i), kd = ld3(b->kd, i);
        const v8x3 nf = {_mm256_mul_ps(f.x, kd.x), _mm256_mul_ps(f.y, kd.y), _mm256_mul_ps(f.z, kd.z)};
        const __m256 mf = _mm256_max_ps(f.x, _mm256_max_ps(f.y, f.z));
        const __m256 q = _mm256_div_ps(_mm256_max_ps(nf.x, _mm256_max_ps(nf.y, nf.z)), mf);
        /* a roulette number below 0: no roulette (trace.c keep_first), probability 1 */
        const __m256 u3 = _mm256_loadu_ps(b->u3 + i);
        const __m256 R =
            _mm256_and_ps(_mm256_cmp_ps(mf, zero, _CMP_GT_OQ),
                          _mm256_blendv_ps(_mm256_min_ps(q, one), one, _mm256_cmp_ps(u3, zero, _CMP_LT_OQ)));
        const __m256 go = _mm256_and_ps(scat, _mm256_cmp_ps(u3, R, _CMP_LT_OQ));
        const v8x3 f2 = scale3(nf, _mm256_div_ps(one, R));
        const __m256 alive =
            _mm256_and_ps(go, _mm256_and_ps(finite8(f2.x), _mm256_and_ps(finite8(f2.y), finite8(f2.z))));
        const v8x3 ng = ld3(b->ng, i), p = ld3(b->p, i);
        const v8x3 off = sel3(_mm256_cmp_ps(dot3(wo, ng), zero, _CMP_GE_OQ), ng, neg3(ng));
        st3(b->f, i, f2);
        st3(b->o, i, add3(p, scale3(off, eps)));
        st3(b->d, i, wo);
        _mm256_storeu_si256((__m256i *)(b->alive + i), _mm256_castps_si256(alive));
    }
}

int pgi__trace_lambert_avx2(pgi__lambert_batch *b) {
    if (!pgi__cpu_avx2() || !__builtin_cpu_supports("fma")) return 0;
    lambert_avx2(b);
    return 1;
}
#else
int pgi__trace_lambert_avx2(pgi__lambert_batch *b) {
    (void)b;
    return 0;
}
#endif
