/* Portals: their geometry, and sampling lines and directions through them (portal.h). */
#include "portal.h"

#include <stdlib.h>
#include <string.h>

#include "core/core.h"

const char *pgi__portal_from_quad(pgi__portal *p, const float v[4][3]) {
    memset(p, 0, sizeof *p);
    for (int i = 0; i < 4; i++)
        if (!v3_finite(v3_load(v[i]))) return "a corner is not finite";
    const pgi__v3 o = v3_load(v[0]), e1 = v3_sub(v3_load(v[1]), o), e2 = v3_sub(v3_load(v[3]), o);
    const float l1 = v3_len(e1), l2 = v3_len(e2), size = fmaxf(l1, l2);
    const pgi__v3 c = v3_cross(e1, e2);
    const float area = v3_len(c);
    if (!(size > 0.f) || !(area > 1e-6f * size * size) || !isfinite(area))
        return "is degenerate (its corners are on one line or the same point)";
    const pgi__v3 far = v3_add(o, v3_add(e1, e2));
    if (!(v3_len(v3_sub(far, v3_load(v[2]))) <= 1e-3f * size))
        return "is not a parallelogram (the third corner must be the second plus the fourth minus the first)";
    const pgi__v3 n = v3_scale(c, 1.f / area);
    v3_store(p->o, o);
    v3_store(p->e1, e1);
    v3_store(p->e2, e2);
    v3_store(p->n, n);
    p->area = area;
    v3_store(p->centre, v3_add(o, v3_scale(v3_add(e1, e2), 0.5f)));
    const pgi__v3 a = v3_cross(e2, n), b = v3_cross(n, e1);
    v3_store(p->d1, v3_scale(a, 1.f / v3_dot(e1, a)));
    v3_store(p->d2, v3_scale(b, 1.f / v3_dot(e2, b)));
    p->rect = fabsf(v3_dot(e1, e2)) <= 1e-4f * l1 * l2;
    return NULL;
}

/* ------------------------------------------------------------ emission */

/* Integral over the directions w (towards the sky) with -w . n > 0 of L(w) (-w . n): pi times the
 * mean radiance of 32 x 32 stratified cosine-weighted directions about -n. */
static pgi__v3 sky_through(const pgi__env *env, pgi__v3 n) {
    const int R = 32;
    pgi__v3 acc = v3(0.f, 0.f, 0.f);
    for (int i = 0; i < R; i++)
        for (int j = 0; j < R; j++) {
            const pgi__v3 w =
                pgi_to_world(pgi_sample_cosine(((float)i + 0.5f) / (float)R, ((float)j + 0.5f) / (float)R), v3_neg(n));
            acc = v3_add(acc, pgi__env_eval(env, w));
        }
    return v3_scale(acc, PGI__PI / (float)(R * R));
}

pgi_status pgi__portal_emit_init(pgi__portal_emit *e, const pgi_scene *s) {
    pgi__portal_emit_free(e);
    e->p = s->portals;
    e->n = s->nportals;
    if (!s->nportals) return PGI_OK;
    e->cdf = malloc(s->nportals * sizeof *e->cdf);
    e->w = malloc(s->nportals * sizeof *e->w);
    if (!e->cdf || !e->w) {
        pgi__portal_emit_free(e);
        return pgi__fail(PGI_ERR_OOM, "%s", "out of memory for the portals");
    }
    double acc = 0.0, rgb[3] = {0, 0, 0};
    for (size_t i = 0; i < s->nportals; i++) {
        double lum = 0.0;
        if (s->env) {
            const pgi__v3 L = v3_scale(sky_through(s->env, v3_load(s->portals[i].n)), s->portals[i].area);
            lum = fmax(0.0, (double)v3_lum(L));
            rgb[0] += L.x;
            rgb[1] += L.y;
            rgb[2] += L.z;
        }
        e->w[i] = lum;
        acc += lum;
        e->cdf[i] = (float)acc;
    }
    e->sky_lum = acc;
    for (int c = 0; c < 3; c++) e->sky_rgb[c] = (float)rgb[c];
    for (size_t i = 0; i < s->nportals; i++) {
        e->cdf[i] = acc > 0.0 ? (float)(e->cdf[i] / acc) : (float)(i + 1) / (float)s->nportals;
        e->w[i] = acc > 0.0 ? e->w[i] / acc : 1.0 / (double)s->nportals;
    }
    e->cdf[s->nportals - 1] = 1.f;
    e->map_mix = s->env && s->env->rgb;
    return PGI_OK;
}

void pgi__portal_emit_free(pgi__portal_emit *e) {
    free(e->cdf);
    free(e->w);
    memset(e, 0, sizeof *e);
}

double pgi__portal_sun_area(const pgi_scene *s, pgi__v3 d) {
    double a = 0.0;
    for (size_t i = 0; i < s->nportals; i++)
        a += (double)s->portals[i].area * fmax(0.0, (double)v3_dot(v3_load(s->portals[i].n), d));
    return a;
}

double pgi__portal_share(const pgi_scene *s) {
    if (!s->nportals) return 0.0;
    double in = 0.0, all = 0.0;
    for (size_t i = 0; i < s->nlights; i++) {
        const pgi__light *L = &s->lights[i];
        if (L->type != PGI__LIGHT_SUN) continue;
        all += fmax(0.0, (double)v3_lum(v3_load(L->power)));
        in += fmax(0.0, (double)v3_lum(v3_load(L->color))) * pgi__portal_sun_area(s, v3_load(L->dir));
    }
    if (s->env) {
        all += fmax(0.0, (double)v3_lum(v3_load(s->env->light.power)));
        for (size_t i = 0; i < s->nportals; i++)
            in += fmax(0.0, (double)v3_lum(sky_through(s->env, v3_load(s->portals[i].n)))) * s->portals[i].area;
    }
    return all > 0.0 ? in / all : 0.0;
}

/* The start of a line through x along d: outside the bounding sphere (centre c, radius R). */
static inline pgi__v3 line_start(pgi__v3 x, pgi__v3 d, pgi__v3 c, float R) {
    return v3_madd(x, d, -(v3_dot(v3_sub(x, c), d) + 1.01f * R));
}

int pgi__portal_sun_emit(const pgi_scene *s, pgi__v3 dir, float u0, float u1, float u2, pgi__v3 c, float R, pgi__v3 *o,
                         float *weight) {
    const double tot = pgi__portal_sun_area(s, dir);
    if (!(tot > 0.0)) return 0;
    /* the portal by its area across the beam */
    const double target = (double)u0 * tot;
    double acc = 0.0;
    size_t k = s->nportals - 1;
    for (size_t i = 0; i < s->nportals; i++) {
        const double a = (double)s->portals[i].area * fmax(0.0, (double)v3_dot(v3_load(s->portals[i].n), dir));
        acc += a;
        if (a > 0.0 && target < acc) {
            k = i;
            break;
        }
    }
    while (k > 0 && !(v3_dot(v3_load(s->portals[k].n), dir) > 0.f)) k--; /* the last facing one */
    const pgi__v3 x = pgi__portal_point(&s->portals[k], u1, u2);
    /* the line's density across the beam: 1 / tot for each portal it crosses facing the sun */
    int count = 0;
    for (size_t i = 0; i < s->nportals; i++) {
        float t;
        if (i == k) count++;
        else if (v3_dot(v3_load(s->portals[i].n), dir) > 0.f && pgi__portal_hit(&s->portals[i], x, dir, &t)) count++;
    }
    *o = line_start(x, dir, c, R);
    *weight = (float)(tot / (double)count);
    return 1;
}

int pgi__portal_sky_emit(const pgi__portal_emit *e, const pgi__env *env, const float u[5], pgi__v3 c, float R,
                         pgi__v3 *o, pgi__v3 *d, pgi__v3 *flux) {
    if (!(e->sky_lum > 0.0)) return 0;
    float pk;
    const size_t k = pgi__cdf_pick(e->cdf, e->n, u[0], &pk);
    const pgi__portal *P = &e->p[k];
    const pgi__v3 x = pgi__portal_point(P, u[3], u[4]);
    /* the direction towards the sky, w: by the cosine about -n, or (a map, half the time) by the
     * map's density */
    pgi__v3 w;
    float u1 = u[1];
    int by_map = 0;
    if (e->map_mix) {
        by_map = u1 < 0.5f;
        u1 = by_map ? 2.f * u1 : 2.f * u1 - 1.f;
        if (!(u1 < 1.f)) u1 = nextafterf(1.f, 0.f);
    }
    if (by_map) {
        float pdf;
        w = pgi__env_sample(env, u1, u[2], &pdf);
        if (!(pdf > 0.f)) return 0;
    } else {
        w = pgi_to_world(pgi_sample_cosine(u1, u[2]), v3_neg(v3_load(P->n)));
    }
    const pgi__v3 dir = v3_neg(w);
    /* the line's density: over every portal it crosses inwards, pick x point x direction / cos */
    const float pm = e->map_mix ? pgi__env_pdf(env, w) : 0.f;
    double dens = 0.0;
    for (size_t i = 0; i < e->n; i++) {
        const pgi__portal *Q = &e->p[i];
        const float cn = v3_dot(v3_load(Q->n), dir);
        float t;
        if (!(cn > 0.f) || !(e->w[i] > 0.0)) continue;
        if (i != k && !pgi__portal_hit(Q, x, dir, &t)) continue;
        const double cosd = (double)cn / PGI__PI; /* the cosine's solid-angle density */
        const double pd = e->map_mix ? 0.5 * cosd + 0.5 * (double)pm : cosd;
        dens += e->w[i] * pd / ((double)Q->area * (double)cn);
    }
    if (!(dens > 0.0)) return 0;
    *o = line_start(x, dir, c, R);
    *d = dir;
    *flux = v3_scale(pgi__env_eval(env, w), (float)(1.0 / dens));
    return 1;
}

/* ------------------------------------------------------------ direct light */

/* A rectangular portal seen from x, for sampling its solid angle uniformly (Ureña, Fajardo and
 * King 2013, "An Area-Preserving Parametrization for Spherical Rectangles"): the rectangle in a
 * frame at x (axes along its edges, z0 < 0 its distance), the spherical rectangle's angles, and
 * its solid angle S. */
typedef pgi__portal_sph sph_rect;

/* acos(c) for c in [-1, 1] (clamped), within 1e-7 rad: Abramowitz and Stegun 4.4.46, a polynomial
 * of degree 7 times sqrt(1 - |c|). libm's acosf took a quarter of the portal samples' set-up. */
static inline float fast_acos(float c) {
    const float a = c < 0.f ? -c : c, m = a < 1.f ? a : 1.f;
    const float p =
        ((((((-0.0012624911f * m + 0.0066700901f) * m - 0.0170881256f) * m + 0.0308918810f) * m - 0.0501743046f) * m +
          0.0889789874f) *
             m -
         0.2145988016f) *
            m +
        1.5707963050f;
    const float r = sqrtf(1.f - m) * p;
    return c < 0.f ? PGI__PI - r : r;
}

static int sph_rect_init(const pgi__portal *p, pgi__v3 o, sph_rect *r) {
    const pgi__v3 e1 = v3_load(p->e1), e2 = v3_load(p->e2);
    const float l1 = v3_len(e1), l2 = v3_len(e2);
    r->x = v3_scale(e1, 1.f / l1);
    r->y = v3_scale(e2, 1.f / l2);
    r->z = v3_cross(r->x, r->y);
    const pgi__v3 d = v3_sub(v3_load(p->o), o);
    r->x0 = v3_dot(d, r->x);
    r->y0 = v3_dot(d, r->y);
    r->z0 = v3_dot(d, r->z);
    if (r->z0 > 0.f) {
        r->z0 = -r->z0;
        r->z = v3_neg(r->z);
    }
    if (!(-r->z0 > 1e-5f * fmaxf(l1, l2))) return 0; /* x in the portal's plane */
    r->x1 = r->x0 + l1;
    r->y1 = r->y0 + l2;
    const pgi__v3 v00 = v3(r->x0, r->y0, r->z0), v01 = v3(r->x0, r->y1, r->z0), v10 = v3(r->x1, r->y0, r->z0),
                  v11 = v3(r->x1, r->y1, r->z0);
    const pgi__v3 n0 = v3_norm(v3_cross(v00, v10)), n1 = v3_norm(v3_cross(v10, v11)), n2 = v3_norm(v3_cross(v11, v01)),
                  n3 = v3_norm(v3_cross(v01, v00));
    const float g0 = fast_acos(-v3_dot(n0, n1)), g1 = fast_acos(-v3_dot(n1, n2)), g2 = fast_acos(-v3_dot(n2, n3)),
                g3 = fast_acos(-v3_dot(n3, n0));
    r->b0 = n0.z;
    r->b1 = n2.z;
    r->k = 2.f * PGI__PI - g2 - g3;
    r->S = g0 + g1 - r->k;
    /* a tiny solid angle is lost to rounding (the angles' sum cancels): area sampling then */
    return isfinite(r->S) && r->S > 1e-3f;
}

static pgi__v3 sph_rect_sample(const sph_rect *r, pgi__v3 o, float u, float v) {
    const float au = u * r->S + r->k;
    const float fu = (cosf(au) * r->b0 - r->b1) / sinf(au);
    /* (clamps as conditionals: fminf and fmaxf are calls without -ffinite-math-only) */
    float cu = (fu > 0.f ? 1.f : -1.f) / sqrtf(fu * fu + r->b0 * r->b0);
    cu = cu < -1.f ? -1.f : cu > 1.f ? 1.f : cu;
    const float s2 = 1.f - cu * cu;
    float xu = -(cu * r->z0) / sqrtf(s2 > 1e-12f ? s2 : 1e-12f);
    xu = xu < r->x0 ? r->x0 : xu > r->x1 ? r->x1 : xu;
    const float d = sqrtf(xu * xu + r->z0 * r->z0);
    const float h0 = r->y0 / sqrtf(d * d + r->y0 * r->y0), h1 = r->y1 / sqrtf(d * d + r->y1 * r->y1);
    const float hv = h0 + v * (h1 - h0), hv2 = hv * hv;
    const float yv = hv2 < 1.f - 1e-6f ? hv * d / sqrtf(1.f - hv2) : r->y1;
    return v3_add(o, v3_add(v3_add(v3_scale(r->x, xu), v3_scale(r->y, yv)), v3_scale(r->z, r->z0)));
}

float pgi__portal_direct_weights(const pgi__portal *p, size_t n, pgi__v3 x, pgi__v3 ns, float *w,
                                 pgi__portal_sph cache[PGI__PORTAL_CACHE]) {
    float sum = 0.f;
    float *sa = w + n;
    for (size_t i = 0; i < n; i++) {
        const pgi__v3 v = v3_sub(x, v3_load(p[i].centre)); /* from the portal to x */
        const float r2 = v3_dot(v, v), cp = v3_dot(v3_load(p[i].n), v);
        float wi = 0.f;
        sa[i] = 0.f;
        /* a portal wholly below x's horizon (its four corners) lights nothing: not picked */
        const pgi__v3 d0 = v3_sub(v3_load(p[i].o), x);
        const float h0 = v3_dot(ns, d0), h1 = v3_dot(ns, v3_load(p[i].e1)), h2 = v3_dot(ns, v3_load(p[i].e2));
        const int above = h0 > 0.f || h0 + h1 > 0.f || h0 + h2 > 0.f || h0 + h1 + h2 > 0.f;
        if (cp > 0.f && r2 > 0.f && above) {
            const float r = sqrtf(r2), cr = -v3_dot(ns, v) / r;
            sph_rect sr;
            if (p[i].rect && sph_rect_init(&p[i], x, &sr)) { /* its solid angle, sampled exactly */
                sa[i] = sr.S;
                if (i < PGI__PORTAL_CACHE) cache[i] = sr;
            }
            const float omega = sa[i] > 0.f ? sa[i] : p[i].area * (cp / r) / r2;
            wi = omega * (0.1f + (cr > 0.f ? cr : 0.f));
            if (!isfinite(wi)) wi = sa[i] = 0.f;
        }
        w[i] = wi;
        sum += wi;
    }
    if (sum > 0.f)
        for (size_t i = 0; i < n; i++) w[i] /= sum;
    return sum;
}

int pgi__portal_direct_sample(const pgi__portal *p, size_t n, const float *w,
                              const pgi__portal_sph cache[PGI__PORTAL_CACHE], pgi__v3 x, float u0, float u2,
                              pgi__v3 *dir) {
    size_t k = 0;
    float acc = 0.f, lo = 0.f;
    for (k = 0; k < n; k++) {
        lo = acc;
        acc += w[k];
        if (u0 < acc && w[k] > 0.f) break;
    }
    if (k == n) { /* rounding: the last portal with weight */
        while (k > 0 && !(w[k - 1] > 0.f)) k--;
        if (k == 0) return 0;
        k--;
        lo = acc - w[k];
    }
    /* u0's place within the portal's share is the point's first number: stratified picks then
     * stratify the points across each portal too */
    float u1 = (u0 - lo) / w[k];
    u1 = u1 > 0.f ? (u1 < 1.f ? u1 : nextafterf(1.f, 0.f)) : 0.f;
    pgi__v3 y;
    sph_rect sr;
    if (w[n + k] > 0.f && k < PGI__PORTAL_CACHE) y = sph_rect_sample(&cache[k], x, u1, u2);
    else if (w[n + k] > 0.f && sph_rect_init(&p[k], x, &sr)) y = sph_rect_sample(&sr, x, u1, u2);
    else y = pgi__portal_point(&p[k], u1, u2);
    const pgi__v3 v = v3_sub(y, x);
    const float l = v3_len(v);
    if (!(l > 0.f)) return 0;
    *dir = v3_scale(v, 1.f / l);
    return 1;
}

float pgi__portal_direct_pdf(const pgi__portal *p, size_t n, const float *w, pgi__v3 x, pgi__v3 dir) {
    float pdf = 0.f;
    for (size_t i = 0; i < n; i++) {
        if (!(w[i] > 0.f)) continue;
        const float cn = -v3_dot(v3_load(p[i].n), dir); /* light travels -dir */
        float t;
        if (!(cn > 0.f) || !pgi__portal_hit(&p[i], x, dir, &t) || !(t > 0.f)) continue;
        pdf += w[i] * (w[n + i] > 0.f ? 1.f / w[n + i] : t * t / (p[i].area * cn));
    }
    return pdf;
}
