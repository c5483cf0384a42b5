/* Tone mapping for display, the last stage of a frame (DESIGN.md §1):
 * exposure, clamp to [0,1], the exact sRGB OETF, and rounding to nearest to
 * 8 bits. The PNG writer and the metrics use it; the image reader inverts it
 * exactly (src/io/image_io.c), so reading a PNG and tone mapping it at
 * exposure 1 returns the same bytes. */
#include "core/core.h"

#include <pthread.h>
#include <string.h>

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
static unsigned char g_bucket[PGI__TM_BUCKETS + 1];
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

/* Branch-free (the threshold step and the clamps were data-dependent branches): v clamped to
 * [0, 1] (NaN and negatives to 0) reads the same codes, 0 from bucket 0 and 255 from bucket 4096,
 * whose next threshold is g_first[256] = inf. On x86-64 an AVX2 clone is picked at load time (the
 * table reads become gathers, 8 values at a time; no FMA, and each value alone: the same bytes). */
PGI__AVX2_CLONES static void tonemap_span(const float *in, unsigned char *out, size_t n, float exposure) {
    for (size_t i = 0; i < n; i++) {
        const float v = in[i] * exposure;
        const float c = v > 0.f ? (v < 1.f ? v : 1.f) : 0.f;
        const int k = g_bucket[(int)(c * (float)PGI__TM_BUCKETS)];
        out[i] = (unsigned char)(k + (c >= g_first[k + 1]));
    }
}

void pgi_tonemap_srgb8(const pgi_image *img, float exposure, unsigned char *out) {
    if (!img || !img->rgb || !out || img->width <= 0 || img->height <= 0) return;
    pthread_once(&g_tables_once, build_tables);
    const size_t n = (size_t)img->width * (size_t)img->height * 3, chunk = 16384;
    const long long chunks = (long long)((n + chunk - 1) / chunk);
#pragma omp parallel for schedule(static) num_threads(pgi__threads(0)) if (chunks > 4)
    for (long long c = 0; c < chunks; ++c) {
        const size_t i = (size_t)c * chunk;
        tonemap_span(img->rgb + i, out + i, n - i < chunk ? n - i : chunk, exposure);
    }
}
