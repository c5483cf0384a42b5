/* Tone mapping for display, the last stage of a frame (DESIGN.md §1):
 * exposure, clamp to [0,1], the exact sRGB OETF, and rounding to nearest to
 * 8 bits. The PNG writer and the metrics use it; the image reader inverts it
 * exactly (src/io/image_io.c), so reading a PNG and tone mapping it at
 * exposure 1 returns the same bytes. */
#include "core/core.h"

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

void pgi_tonemap_srgb8(const pgi_image *img, float exposure, unsigned char *out) {
    if (!img || !img->rgb || !out || img->width <= 0 || img->height <= 0) return;
    size_t n = (size_t)img->width * (size_t)img->height * 3;
    for (size_t i = 0; i < n; ++i) out[i] = tonemap1(img->rgb[i], exposure);
}
