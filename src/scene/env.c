/* Environment light (sky): radiance arriving from infinitely far away, from
 * every direction. Two kinds:
 *   - a constant sky: radiance `sky` from the hemisphere above the horizon
 *     (up . w > 0) and `ground` from below it (the same by default: a
 *     uniform sky);
 *   - an equirectangular (latitude-longitude) map of radiance, scaled; row 0
 *     is the zenith (up), the last row the nadir; column u looks at azimuth
 *     phi = 2 pi (u - 1/2) + rotation, measured about `up` from the frame's
 *     -z axis towards its +x axis (for up = +y: the world's -z and +x), so
 *     that a map seen from inside is not mirrored.
 * A map is piecewise constant (nearest texel) and importance-sampled by a
 * 2-D table: a row by its sum of luminance x texel solid angle, then a column
 * by luminance, then a uniform direction in the texel (uniform in cos(theta)
 * and phi): the density is lum(L(w)) / sum(lum x solid angle), exactly
 * proportional to the luminance of the radiance, so every photon from the map
 * carries the same luminance and a constant map gives the uniform sky. */
#include <stdio.h>
#include <string.h>

#include "io/io_internal.h"
#include "scene_internal.h"

void pgi__env_destroy(pgi__env *e) {
    if (!e) return;
    free(e->rgb);
    free(e->cdf_row);
    free(e->cdf_col);
    free(e);
}

/* The frame of `up` (unit): x, y = up, z (for up = +y the identity). */
static void env_frame(pgi__env *e, pgi__v3 up) {
    up = v3_norm(up);
    pgi__v3 ref = fabsf(up.z) < 0.9f ? v3(0.f, 0.f, 1.f) : v3(1.f, 0.f, 0.f);
    pgi__v3 x = v3_norm(v3_cross(up, ref));
    pgi__v3 z = v3_cross(x, up);
    v3_store(e->fx, x);
    v3_store(e->fy, up);
    v3_store(e->fz, z);
}

static pgi_status check_up(const char *what, const float up[3]) {
    pgi__v3 u = v3_load(up);
    if (!v3_finite(u) || !(v3_len(u) > 0.f))
        return pgi__fail(PGI_ERR_PARSE, "%s: the sky's up direction must be 3 finite numbers, not all zero", what);
    return PGI_OK;
}

pgi_status pgi__env_create_constant(const char *what, const float sky[3], const float ground[3], const float up[3],
                                    pgi__env **out) {
    *out = NULL;
    pgi_status st = check_up(what, up);
    if (st) return st;
    for (int c = 0; c < 3; c++)
        if (!(sky[c] >= 0.f && sky[c] <= PGI_MAX_RADIANCE) || !(ground[c] >= 0.f && ground[c] <= PGI_MAX_RADIANCE))
            return pgi__fail(PGI_ERR_PARSE, "%s: the sky's radiance must be in 0..%g", what, (double)PGI_MAX_RADIANCE);
    pgi__env *e = calloc(1, sizeof *e);
    if (!e) return pgi__fail(PGI_ERR_OOM, "%s: out of memory for the sky", what);
    memcpy(e->sky, sky, sizeof e->sky);
    memcpy(e->ground, ground, sizeof e->ground);
    env_frame(e, v3_load(up));
    float ls = v3_lum(v3_load(sky)), lg = v3_lum(v3_load(ground));
    e->p_sky = ls + lg > 0.f ? ls / (ls + lg) : 0.5f;
    for (int c = 0; c < 3; c++) e->integral[c] = 2.0 * PGI__PI * ((double)sky[c] + (double)ground[c]);
    e->light.type = PGI__LIGHT_ENV;
    *out = e;
    return PGI_OK;
}

/* Solid angle of a texel of row i of an h-row map w wide. */
static double row_solid_angle(int i, int w, int h) {
    double t0 = PGI__PI * (double)i / h, t1 = PGI__PI * (double)(i + 1) / h;
    return 2.0 * PGI__PI / w * (cos(t0) - cos(t1));
}

pgi_status pgi__env_create_map(const char *what, const char *path, float scale, float rotation_deg, const float up[3],
                               pgi__env **out) {
    *out = NULL;
    pgi_status st = check_up(what, up);
    if (st) return st;
    if (!isfinite(scale) || scale < 0.f)
        return pgi__fail(PGI_ERR_PARSE, "%s: the environment's scale must be finite and non-negative", what);
    pgi_image img = {0};
    int hdr = 0;
    if ((st = pgi__image_read(path, &img, &hdr))) {
        /* pgi__image_read names the file and the problem; say which key asked for it */
        char msg[1024];
        snprintf(msg, sizeof msg, "%s", pgi_last_error());
        return pgi__fail(st, "%s: environment.map: %s", what, msg);
    }
    const int w = img.width, h = img.height;
    const size_t n = (size_t)w * (size_t)h;
    for (size_t i = 0; i < 3 * n; i++)
        if (!isfinite(img.rgb[i]) || img.rgb[i] < 0.f) {
            const char *why = isfinite(img.rgb[i]) ? "negative" : "not finite (NaN or Inf)";
            pgi_image_free(&img);
            return pgi__fail(PGI_ERR_PARSE, "%s: environment map %s: pixel (%zu, %zu) is %s", what, path,
                             i / 3 % (size_t)w, i / 3 / (size_t)w, why);
        } else if (!((double)img.rgb[i] * scale <= (double)PGI_MAX_RADIANCE)) {
            const double v = img.rgb[i];
            pgi_image_free(&img);
            return pgi__fail(PGI_ERR_PARSE,
                             "%s: environment map %s: pixel (%zu, %zu) = %g times scale %g is out of range (0..%g, a "
                             "radiance)",
                             what, path, i / 3 % (size_t)w, i / 3 / (size_t)w, v, (double)scale,
                             (double)PGI_MAX_RADIANCE);
        }
    pgi__env *e = calloc(1, sizeof *e);
    float *cdf_row = malloc((size_t)h * sizeof *cdf_row), *cdf_col = malloc(n * sizeof *cdf_col);
    if (!e || !cdf_row || !cdf_col) {
        free(e);
        free(cdf_row);
        free(cdf_col);
        pgi_image_free(&img);
        return pgi__fail(PGI_ERR_OOM, "%s: out of memory for a %dx%d environment map", what, w, h);
    }
    for (size_t i = 0; i < 3 * n; i++) img.rgb[i] *= scale;
    e->rgb = img.rgb;
    e->w = w;
    e->h = h;
    e->cdf_row = cdf_row;
    e->cdf_col = cdf_col;
    e->rot = rotation_deg * (PGI__PI / 180.f);
    snprintf(e->path, sizeof e->path, "%s", path);
    env_frame(e, v3_load(up));
    double total = 0.0, integral[3] = {0.0, 0.0, 0.0};
    for (int y = 0; y < h; y++) {
        const double om = row_solid_angle(y, w, h);
        double row = 0.0;
        float *cc = cdf_col + (size_t)y * w;
        for (int x = 0; x < w; x++) {
            const float *p = e->rgb + 3 * ((size_t)y * w + x);
            row += (double)v3_lum(v3_load(p));
            cc[x] = (float)row;
            for (int c = 0; c < 3; c++) integral[c] += (double)p[c] * om;
        }
        for (int x = 0; x < w; x++) cc[x] = row > 0.0 ? (float)(cc[x] / row) : (float)(x + 1) / (float)w;
        cc[w - 1] = 1.f;
        total += row * om;
        cdf_row[y] = (float)total;
    }
    for (int y = 0; y < h; y++) cdf_row[y] = total > 0.0 ? (float)(cdf_row[y] / total) : (float)(y + 1) / (float)h;
    cdf_row[h - 1] = 1.f;
    e->lum_integral = total;
    memcpy(e->integral, integral, sizeof integral);
    e->light.type = PGI__LIGHT_ENV;
    *out = e;
    return PGI_OK;
}

void pgi__env_set_radius(pgi__env *e, float R) {
    const double k = PGI__PI * (double)R * (double)R;
    for (int c = 0; c < 3; c++) e->light.power[c] = (float)(e->integral[c] * k);
}

/* Texel of direction w (unit): row, column. */
static inline size_t env_texel(const pgi__env *e, pgi__v3 w) {
    float x = v3_dot(w, v3_load(e->fx)), y = v3_dot(w, v3_load(e->fy)), z = v3_dot(w, v3_load(e->fz));
    float theta = acosf(fminf(1.f, fmaxf(-1.f, y)));
    float u = (atan2f(x, -z) - e->rot) * (0.5f * PGI__INV_PI) + 0.5f;
    u -= floorf(u);
    int col = (int)(u * (float)e->w), row = (int)(theta * PGI__INV_PI * (float)e->h);
    col = col < 0 ? 0 : col >= e->w ? e->w - 1 : col;
    row = row < 0 ? 0 : row >= e->h ? e->h - 1 : row;
    return (size_t)row * (size_t)e->w + (size_t)col;
}

pgi__v3 pgi__env_eval(const pgi__env *e, pgi__v3 w) {
    if (!e->rgb) return v3_load(v3_dot(w, v3_load(e->fy)) > 0.f ? e->sky : e->ground);
    return v3_load(e->rgb + 3 * env_texel(e, w));
}

float pgi__env_pdf(const pgi__env *e, pgi__v3 w) {
    if (!e->rgb) return (v3_dot(w, v3_load(e->fy)) > 0.f ? e->p_sky : 1.f - e->p_sky) * (0.5f * PGI__INV_PI);
    if (!(e->lum_integral > 0.0)) return 0.f;
    return (float)((double)v3_lum(v3_load(e->rgb + 3 * env_texel(e, w))) / e->lum_integral);
}

/* Frame coordinates (x, y = up, z) to world. */
static inline pgi__v3 env_to_world(const pgi__env *e, float x, float y, float z) {
    return v3_add(v3_add(v3_scale(v3_load(e->fx), x), v3_scale(v3_load(e->fy), y)), v3_scale(v3_load(e->fz), z));
}

pgi__v3 pgi__env_sample(const pgi__env *e, float u1, float u2, float *pdf) {
    if (!e->rgb) {
        /* a hemisphere by luminance, then uniform in it */
        float ps = e->p_sky, y;
        if (u1 < ps) {
            float t = u1 / ps;
            y = 1.f - fminf(t, 1.f);                     /* (0, 1] */
        } else y = -(u1 - ps) / fmaxf(1.f - ps, 1e-30f); /* (-1, 0] */
        y = fminf(1.f, fmaxf(-1.f, y));
        float r = sqrtf(fmaxf(0.f, 1.f - y * y)), phi = 2.f * PGI__PI * u2;
        pgi__v3 w = env_to_world(e, r * cosf(phi), y, r * sinf(phi));
        *pdf = pgi__env_pdf(e, w);
        return w;
    }
    float pr, pc;
    size_t row = pgi__cdf_pick(e->cdf_row, (size_t)e->h, u1, &pr);
    float fr = pr > 0.f ? (u1 - (row ? e->cdf_row[row - 1] : 0.f)) / pr : 0.5f;
    const float *cc = e->cdf_col + row * (size_t)e->w;
    size_t col = pgi__cdf_pick(cc, (size_t)e->w, u2, &pc);
    float fc = pc > 0.f ? (u2 - (col ? cc[col - 1] : 0.f)) / pc : 0.5f;
    fr = fminf(fmaxf(fr, 0.f), 1.f);
    fc = fminf(fmaxf(fc, 0.f), 0.99999994f);
    /* uniform in the texel: cos(theta) between the row's edges, phi across the column */
    float c0 = cosf(PGI__PI * (float)row / (float)e->h), c1 = cosf(PGI__PI * (float)(row + 1) / (float)e->h);
    float y = c0 + (c1 - c0) * fr;
    float r = sqrtf(fmaxf(0.f, 1.f - y * y));
    float phi = 2.f * PGI__PI * (((float)col + fc) / (float)e->w - 0.5f) + e->rot;
    pgi__v3 w = env_to_world(e, r * sinf(phi), y, -r * cosf(phi));
    *pdf = pgi__env_pdf(e, w); /* of the texel pgi__env_eval reads (the same but at a texel's edge) */
    return w;
}

pgi__v3 pgi__env_sample_direct(const pgi__env *e, pgi__v3 ns, float u1, float u2, float *pdf) {
    pgi__v3 w;
    if (!e->rgb) {
        w = pgi_to_world(pgi_sample_cosine(u1, u2), ns);
    } else if (u1 < 0.5f) {
        float p;
        w = pgi__env_sample(e, 2.f * u1, u2, &p);
    } else {
        w = pgi_to_world(pgi_sample_cosine(fminf(2.f * u1 - 1.f, 1.f), u2), ns);
    }
    *pdf = pgi__env_pdf_direct(e, ns, w);
    return w;
}

pgi__v3 pgi__env_sample_direct_map(const pgi__env *e, const pgi__env_frame *f, float u1, float u2, float *pdf,
                                   pgi__v3 *le) {
    pgi__v3 w;
    if (u1 < 0.5f) {
        float p;
        w = pgi__env_sample(e, 2.f * u1, u2, &p);
    } else {
        w = pgi__env_frame_dir(f, pgi_sample_cosine(fminf(2.f * u1 - 1.f, 1.f), u2));
    }
    *pdf = pgi__env_pdf_direct(e, f->n, w);
    *le = pgi__env_eval(e, w);
    return w;
}

float pgi__env_pdf_direct(const pgi__env *e, pgi__v3 ns, pgi__v3 w) {
    float pc = fmaxf(0.f, v3_dot(ns, w)) * PGI__INV_PI;
    if (!e->rgb) return pc;
    return 0.5f * pc + 0.5f * pgi__env_pdf(e, w);
}
