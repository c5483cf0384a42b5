/* Photon differentials, the differentials radius policy (see differentials.h and docs/bvh.md for
 * the equations and the choices made where the papers leave them open; the hooks that call these
 * are in radius.c). */
#include "differentials.h"

#include "photongi/photongi.h"
#include "scene/light.h"

void pgi__pd_emit_dir(pgi__pdiff *pd, pgi__v3 d, pgi__v3 axis, float scale) {
    pgi__v3 t, b;
    v3_basis(axis, &t, &b);
    float ct = v3_dot(d, axis), st = sqrtf(fmaxf(0.f, 1.f - ct * ct));
    float x = v3_dot(d, t), y = v3_dot(d, b), l = sqrtf(x * x + y * y);
    float cp = l > 0.f ? x / l : 1.f, sp = l > 0.f ? y / l : 0.f;
    /* eq. 8: d_cos = (-cos phi cos theta, -sin phi cos theta, sin theta), d_phi = (-sin phi, cos phi, 0) */
    pgi__v3 d1 = v3_add(v3_scale(v3_add(v3_scale(t, cp), v3_scale(b, sp)), -ct), v3_scale(axis, st));
    pgi__v3 d2 = v3_add(v3_scale(t, -sp), v3_scale(b, cp));
    pd->dd[0] = v3_scale(d1, scale);
    pd->dd[1] = v3_scale(d2, scale);
    pd->dp[0] = pd->dp[1] = v3(0.f, 0.f, 0.f);
}

void pgi__pd_transfer(pgi__pdiff *pd, pgi__v3 d, float t, pgi__v3 n) {
    float dn = v3_dot(d, n);
    for (int k = 0; k < 2; k++) {
        pgi__v3 q = v3_madd(pd->dp[k], pd->dd[k], t);
        float dt = fabsf(dn) > 1e-6f ? -v3_dot(q, n) / dn : 0.f;
        pd->dp[k] = v3_madd(q, d, dt);
    }
}

void pgi__pd_reflect(pgi__pdiff *pd, pgi__v3 d, pgi__v3 n, const pgi__v3 dn[2]) {
    float dN = v3_dot(d, n);
    for (int k = 0; k < 2; k++) {
        float ddN = v3_dot(pd->dd[k], n) + v3_dot(d, dn[k]);
        pd->dd[k] = v3_sub(pd->dd[k], v3_scale(v3_add(v3_scale(dn[k], dN), v3_scale(n, ddN)), 2.f));
    }
}

void pgi__pd_refract(pgi__pdiff *pd, pgi__v3 d, pgi__v3 n, const pgi__v3 dn[2], float eta, pgi__v3 t) {
    float dN = v3_dot(d, n), tN = v3_dot(t, n);
    float mu = eta * dN - tN;
    float dmu_f = fabsf(tN) > 1e-6f ? eta - eta * eta * dN / tN : eta;
    for (int k = 0; k < 2; k++) {
        float ddN = v3_dot(pd->dd[k], n) + v3_dot(d, dn[k]);
        float dmu = dmu_f * ddN;
        pd->dd[k] = v3_sub(v3_scale(pd->dd[k], eta), v3_add(v3_scale(dn[k], mu), v3_scale(n, dmu)));
    }
}

void pgi__pd_roulette(pgi__pdiff *pd, float p) {
    if (!(p > 0.f) || p >= 1.f) return;
    float f = 1.f / sqrtf(p);
    for (int k = 0; k < 2; k++) {
        pd->dp[k] = v3_scale(pd->dp[k], f);
        pd->dd[k] = v3_scale(pd->dd[k], f);
    }
}

void pgi__pd_reemit(pgi__pdiff *pd, pgi__v3 d_out, pgi__v3 n) {
    float A = v3_len(v3_cross(pd->dp[0], pd->dp[1])); /* |dp1 x dp2|; Delta^2 cancels in eq. 13 */
    pgi__pd_emit_dir(pd, d_out, n, 1.f);
    float B = v3_len(v3_cross(pd->dd[0], pd->dd[1]));
    float v = B > 0.f ? sqrtf(A / B) : 0.f;
    pd->dp[0] = v3_scale(pd->dd[0], v); /* eq. 11 at the re-emission point */
    pd->dp[1] = v3_scale(pd->dd[1], v);
    pd->diffuse = 1;
}

void pgi__pd_footprint(const pgi__pdiff *pd, const pgi__fp_params *p, pgi__v3 n, pgi__footprint *o) {
    pgi__v3 ax[2];
    for (int k = 0; k < 2; k++) {
        pgi__v3 q = v3_sub(pd->dp[k], v3_scale(n, v3_dot(pd->dp[k], n))); /* in the tangent plane */
        float l = v3_len(q);
        float f = pd->diffuse ? p->smoothing * (l > 0.f ? powf(l, -0.75f) : 0.f) : p->smoothing_caustic;
        ax[k] = v3_scale(q, p->delta * f);
    }
    float r = sqrtf(v3_len(v3_cross(ax[0], ax[1])));
    o->r_raw = r;
    float rmax = p->r_max;
    if (!(r >= 1e-4f * rmax) || !isfinite(r) || !v3_finite(ax[0]) || !v3_finite(ax[1])) {
        /* degenerate (collinear or vanishing axes): a circle of the longer axis' length */
        float l = fmaxf(v3_len(ax[0]), v3_len(ax[1]));
        l = isfinite(l) ? fminf(fmaxf(l, 1e-2f * rmax), rmax) : rmax;
        pgi__v3 t, b;
        v3_basis(n, &t, &b);
        ax[0] = v3_scale(t, l);
        ax[1] = v3_scale(b, l);
        r = l;
        if (!isfinite(o->r_raw)) o->r_raw = rmax;
    } else if (r > rmax) {
        ax[0] = v3_scale(ax[0], rmax / r);
        ax[1] = v3_scale(ax[1], rmax / r);
        r = sqrtf(v3_len(v3_cross(ax[0], ax[1])));
    }
    /* very skewed ellipses: keep each semi-axis within 4 r_max (bounds the boxes) */
    for (int k = 0; k < 2; k++) {
        float l = v3_len(ax[k]);
        if (l > 4.f * rmax) ax[k] = v3_scale(ax[k], 4.f * rmax / l);
    }
    r = sqrtf(v3_len(v3_cross(ax[0], ax[1])));
    if (!(r > 0.f)) r = 1e-2f * rmax;
    o->r = r;
    v3_store(o->a, ax[0]);
    v3_store(o->b, ax[1]);
}

void pgi__pd_normal_derivative(const pgi_scene *s, uint32_t prim, float bu, float bv, const pgi__v3 dp[2], pgi__v3 ref,
                               pgi__v3 dn[2]) {
    dn[0] = dn[1] = v3(0.f, 0.f, 0.f);
    if (!s->nrm) return;
    const uint32_t *t = s->tri + 3 * (size_t)prim;
    pgi__v3 a = pgi__scene_vertex(s, t[0]), b = pgi__scene_vertex(s, t[1]), c = pgi__scene_vertex(s, t[2]);
    pgi__v3 n0 = v3_load(s->nrm + 3 * (size_t)t[0]), n1 = v3_load(s->nrm + 3 * (size_t)t[1]),
            n2 = v3_load(s->nrm + 3 * (size_t)t[2]);
    pgi__v3 e1 = v3_sub(b, a), e2 = v3_sub(c, a);
    float g11 = v3_dot(e1, e1), g12 = v3_dot(e1, e2), g22 = v3_dot(e2, e2), det = g11 * g22 - g12 * g12;
    if (!(fabsf(det) > 0.f)) return;
    pgi__v3 N = v3_add(v3_add(v3_scale(n0, 1.f - bu - bv), v3_scale(n1, bu)), v3_scale(n2, bv));
    float L = v3_len(N);
    if (!(L > 0.f)) return;
    pgi__v3 nh = v3_scale(N, 1.f / L);
    float sign = v3_dot(nh, ref) >= 0.f ? 1.f : -1.f;
    for (int k = 0; k < 2; k++) {
        float r1 = v3_dot(dp[k], e1), r2 = v3_dot(dp[k], e2);
        float du = (g22 * r1 - g12 * r2) / det, dv = (g11 * r2 - g12 * r1) / det;
        pgi__v3 dN = v3_add(v3_scale(v3_sub(n1, n0), du), v3_scale(v3_sub(n2, n0), dv));
        dn[k] = v3_scale(v3_sub(dN, v3_scale(nh, v3_dot(dN, nh))), sign / L);
    }
}

/* ------------------------------------------- per-policy parts of the hooks */

void pgi__pd_emit(pgi__pdiff *pd, const pgi__light *L, float pl, pgi__v3 d, float sun_radius) {
    pl = fmaxf(pl, 1e-12f);
    const pgi__light_diff ld = pgi__light_diff_start(L, pl, d, sun_radius); /* the light's part */
    if (ld.parallel) {
        pgi__v3 t, b;
        v3_basis(d, &t, &b);
        pd->dp[0] = v3_scale(t, ld.scale);
        pd->dp[1] = v3_scale(b, ld.scale);
        pd->dd[0] = pd->dd[1] = v3(0.f, 0.f, 0.f);
        return;
    }
    pgi__pd_emit_dir(pd, d, ld.axis, ld.scale);
    if (!ld.offset) return;
    float B = v3_len(v3_cross(pd->dd[0], pd->dd[1]));
    float v = B > 0.f ? sqrtf(ld.area / B) : 0.f;
    pd->dp[0] = v3_scale(pd->dd[0], v);
    pd->dp[1] = v3_scale(pd->dd[1], v);
}

void pgi__pd_scatter(pgi__pdiff *pd, const pgi_scene *s, uint32_t prim, float bu, float bv, const pgi__surface *sf,
                     pgi__v3 wi, pgi__v3 wo) {
    const int spec = pgi__mat_specular(sf->mat);
    if (!spec) {
        float side = v3_dot(wo, sf->ng) >= 0.f ? 1.f : -1.f;
        pgi__pd_reemit(pd, wo, v3_scale(sf->ns, side));
        return;
    }
    pgi__v3 d = v3_neg(wi);
    float side = v3_dot(wi, sf->ng) >= 0.f ? 1.f : -1.f; /* +1: arriving on the normal's side */
    pgi__v3 n = v3_scale(sf->ns, side);                  /* facing the incoming photon: d.n < 0 */
    pgi__v3 dn[2];
    pgi__pd_normal_derivative(s, prim, bu, bv, pd->dp, n, dn);
    if (v3_dot(wo, sf->ng) * side >= 0.f) {
        pgi__pd_reflect(pd, d, n, dn);
    } else {
        float ior = sf->mat->ior;
        float eta = side > 0.f ? 1.f / ior : ior;
        pgi__pd_refract(pd, d, n, dn, eta, wo);
    }
}
