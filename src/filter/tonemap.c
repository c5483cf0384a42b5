/* Tone mapping for display, the last stage of a frame (docs/design.md, "One frame"):
 * exposure, clamp to [0,1], the exact sRGB OETF, and rounding to nearest to
 * 8 bits. The PNG writer and the metrics use it; the image reader inverts it
 * exactly (src/io/image_io.c), so reading a PNG and tone mapping it at
 * exposure 1 returns the same bytes. */
#include "core/core.h"

#include <pthread.h>
#include <string.h>
#if PGI__AVX2_TARGET
#include <immintrin.h> /* tonemap_span_avx2 */
#endif

/* Exact piecewise sRGB OETF (IEC 61966-2-1), in double so the 8-bit round
 * trip below is not at the mercy of float rounding. */
static double srgb_oetf(double v) { return v <= 0.0031308 ? 12.92 * v : 1.055 * pow(v, 1.0 / 2.4) - 0.055; }

static unsigned char tonemap1(float value, float exposure) {
    float v = value * exposure;
    if (!(v > 0.f)) return 0; /* negatives and NaN */
    if (v >= 1.f) return 255; /* includes +inf */
    double s = srgb_oetf((double)v) * 255.0 + 0.5;
    int b = (int)s;
    return (unsigned char)(b > 255 ? 255 : b);
}

/* The same bytes without a pow a channel: tonemap1 is non-decreasing in v, so code k starts at
 * a threshold g_first[k] (the smallest float that maps to k, found by bisection on the float's
 * bits) and g_bucket[b] is the code of b/4096, the lowest value of bucket b. The curve climbs at
 * most 3294 codes per unit (its linear toe), under one code per 1/4096 bucket, so a value is at
 * most one threshold above its bucket's code (the loop below runs once or not at all). */
#define PGI__TM_BUCKETS 4096
static float g_first[257];
/* 3 bytes of padding: tonemap_span_avx2 gathers 4 bytes from a bucket's place */
static unsigned char g_bucket[PGI__TM_BUCKETS + 4];
static pthread_once_t g_tables_once = PTHREAD_ONCE_INIT;

static void build_tables(void) {
    for (int k = 1; k <= 255; k++) {
        uint32_t lo = 0, hi = 0x3f800000u; /* 0 maps below k, 1.0f to 255 >= k */
        while (hi - lo > 1) {
            uint32_t mid = lo + (hi - lo) / 2;
            float v;
            memcpy(&v, &mid, sizeof v);
            if (tonemap1(v, 1.f) >= k) hi = mid;
            else lo = mid;
        }
        memcpy(&g_first[k], &hi, sizeof hi);
    }
    g_first[0] = 0.f;
    g_first[256] = INFINITY;
    for (int b = 0; b <= PGI__TM_BUCKETS; b++) g_bucket[b] = tonemap1((float)b / (float)PGI__TM_BUCKETS, 1.f);
}

/* A value's code: v clamped to [0, 1] (NaN and negatives to 0) reads the same codes, 0 from bucket 0
 * and 255 from bucket 4096, whose next threshold is g_first[256] = inf. */
static void tonemap_span(const float *in, unsigned char *out, size_t n, float exposure) {
    for (size_t i = 0; i < n; i++) {
        const float v = in[i] * exposure;
        const float c = v > 0.f ? (v < 1.f ? v : 1.f) : 0.f;
        const int k = g_bucket[(int)(c * (float)PGI__TM_BUCKETS)];
        out[i] = (unsigned char)(k + (c >= g_first[k + 1]));
    }
}

#if PGI__AVX2_TARGET
/* tonemap_span 32 values a step, the same operations (no FMA): the clamps as compare masks, the two
 * table reads as gathers. gcc left the loop above scalar, with a branch a clamp, even in an AVX2
 * clone (1 ns a value: 4 ms of a 1920x1080 frame at two threads). */
__attribute__((target("avx2"))) static void tonemap_span_avx2(const float *in, unsigned char *out, size_t n,
                                                              float exposure) {
    const __m256 e = _mm256_set1_ps(exposure), one = _mm256_set1_ps(1.f), zero = _mm256_setzero_ps(),
                 scale = _mm256_set1_ps((float)PGI__TM_BUCKETS);
    const __m256i byte = _mm256_set1_epi32(0xff), order = _mm256_setr_epi32(0, 4, 1, 5, 2, 6, 3, 7);
    size_t i = 0;
    for (; i + 32 <= n; i += 32) {
        __m256i k[4];
        for (int q = 0; q < 4; q++) {
            const __m256 v = _mm256_mul_ps(_mm256_loadu_ps(in + i + 8 * q), e);
            const __m256 c = _mm256_and_ps(_mm256_blendv_ps(one, v, _mm256_cmp_ps(v, one, _CMP_LT_OQ)),
                                           _mm256_cmp_ps(v, zero, _CMP_GT_OQ));
            const __m256i b = _mm256_cvttps_epi32(_mm256_mul_ps(c, scale));
            const __m256i kb =
                _mm256_and_si256(_mm256_i32gather_epi32((const int *)(const void *)g_bucket, b, 1), byte);
            const __m256 t = _mm256_i32gather_ps(g_first + 1, kb, 4);
            /* the compare's mask is -1 where c reaches the next threshold */
            k[q] = _mm256_sub_epi32(kb, _mm256_castps_si256(_mm256_cmp_ps(c, t, _CMP_GE_OQ)));
        }
        const __m256i w = _mm256_packus_epi16(_mm256_packs_epi32(k[0], k[1]), _mm256_packs_epi32(k[2], k[3]));
        _mm256_storeu_si256((__m256i *)(void *)(out + i), _mm256_permutevar8x32_epi32(w, order));
    }
    tonemap_span(in + i, out + i, n - i, exposure);
}
#endif

void pgi_tonemap_srgb8(const pgi_image *img, float exposure, unsigned char *out) {
    if (!img || !img->rgb || !out || img->width <= 0 || img->height <= 0) return;
    pthread_once(&g_tables_once, build_tables);
    const size_t n = (size_t)img->width * (size_t)img->height * 3, chunk = 16384;
    const long long chunks = (long long)((n + chunk - 1) / chunk);
#if PGI__AVX2_TARGET
    const int avx2 = pgi__cpu_avx2();
#endif
#pragma omp parallel for schedule(static) num_threads(pgi__threads(0)) if (chunks > 4)
    for (long long c = 0; c < chunks; ++c) {
        const size_t i = (size_t)c * chunk, m = n - i < chunk ? n - i : chunk;
#if PGI__AVX2_TARGET
        if (avx2) tonemap_span_avx2(img->rgb + i, out + i, m, exposure);
        else
#endif
            tonemap_span(img->rgb + i, out + i, m, exposure);
    }
}
