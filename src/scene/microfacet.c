/* The microfacet plastic's albedo table and lobe set-up (bsdf.h, PGI__MAT_PLASTIC).
 *
 * E(mu, alpha, eta) = int f_spec(wi, wo) cos(wo) dwo is the directional albedo of the
 * untinted GGX lobe with a dielectric's Fresnel: mu = cos(wi), alpha the roughness, eta the
 * index. It is computed, not stored: on the first use of an index node (or
 * pgi__ggx_prepare), every (mu, alpha) entry of that node is integrated by a fixed
 * midpoint rule over the visible-normal sampling of wi (Heitz 2018), whose weight
 * F(wi.h) G2 / G1(wi) is bounded by 1, so PGI__GGX_NQ^2 points give E to about 1e-4. Each
 * entry is a fixed sum in a fixed order: the same bits whatever the thread count.
 *
 * Nodes: mu = x^2 with x uniform in [0, 1] (PGI__GGX_NMU; E is linear in x between them),
 * alpha = y^2 with y uniform in [sqrt(PGI__GGX_ALPHA_MIN), 1] (NA; linear in alpha between
 * them), and the indices of k_eta (linear in the normal-incidence reflectance F0(eta)
 * between them). With 32 x 32 nodes a node (one index) costs about 40 ms to compute, once a
 * process; a material whose Ni is a node needs one, any other two. E_avg =
 * 2 int E(mu) mu dmu is integrated exactly over the piecewise-linear (in x) interpolant, so
 * the Lambertian base's normalisation 1 / (1 - E_avg) matches the E it is used with and the
 * base of a white plastic reflects exactly 1 - E(wo) (bsdf.h). */
#include <stdatomic.h>

#include "bsdf.h"

#define NA 32
#define PGI__GGX_NQ 32 /* a multiple of 4 */
static const float k_eta[] = {1.05f, 1.1f,  1.15f, 1.2f, 1.25f, 1.3f, 1.35f, 1.4f, 1.45f, 1.5f, 1.55f, 1.6f,
                              1.65f, 1.7f,  1.75f, 1.8f, 1.85f, 1.9f, 1.95f, 2.f,  2.1f,  2.2f, 2.3f,  2.4f,
                              2.5f,  2.75f, 3.f,   3.5f, 4.f,   4.5f, 5.f,   6.f,  7.f,   8.f,  10.f};
#define NETA ((int)(sizeof k_eta / sizeof k_eta[0]))

static float g_E[NETA][NA][PGI__GGX_NMU];
static float g_Eavg[NETA][NA];
static atomic_int g_ready[NETA];

static float node_alpha(int j) {
    float y0 = sqrtf(PGI__GGX_ALPHA_MIN), y = y0 + (1.f - y0) * (float)j / (float)(NA - 1);
    return y * y;
}

/* E(mu) of the untinted lobe by the midpoint rule over visible-normal samples. */
static float albedo_quadrature(float mu, float alpha, float eta) {
    const float a2 = alpha * alpha;
    pgi__v3 V = v3(sqrtf(fmaxf(0.f, 1.f - mu * mu)), 0.f, mu);
    const float rV = pgi__ggx_root(a2, V.z);
    double sum = 0.0;
    /* V lies in the xz plane, so the weight is even in the sample's component along y (t1 =
     * r cos(2 pi u2) in pgi__ggx_sample_vndf): the half of the u2 points with cos > 0 count twice. */
    for (int i = 0; i < PGI__GGX_NQ; i++) {
        double row = 0.0;
        for (int jj = 0; jj < PGI__GGX_NQ / 2; jj++) {
            int j = jj < PGI__GGX_NQ / 4 ? jj : jj + PGI__GGX_NQ / 2;
            float u1 = ((float)i + 0.5f) / (float)PGI__GGX_NQ, u2 = ((float)j + 0.5f) / (float)PGI__GGX_NQ;
            pgi__v3 h = pgi__ggx_sample_vndf(V, alpha, u1, u2);
            float vh = v3_dot(V, h);
            if (!(vh > 0.f)) continue;
            pgi__v3 L = v3_sub(v3_scale(h, 2.f * vh), V);
            if (!(L.z > 0.f)) continue;
            float rL = pgi__ggx_root(a2, L.z);
            /* G2 / G1(V), height-correlated Smith */
            float g = (V.z + rV) * L.z / (rV * L.z + rL * V.z);
            row += (double)(pgi__fresnel_dielectric(vh, 1.f, eta) * g);
        }
        sum += row;
    }
    return (float)(2.0 * sum / (double)(PGI__GGX_NQ * PGI__GGX_NQ));
}

/* 2 int_0^1 E(mu) mu dmu = int_0^1 E(x) 4 x^3 dx for E linear in x between the nodes:
 * 3-point Gauss-Legendre on each segment (exact for the degree-4 integrand). */
static float albedo_average(const float *E) {
    static const double gx[3] = {-0.7745966692414834, 0.0, 0.7745966692414834}, gw[3] = {5.0 / 9, 8.0 / 9, 5.0 / 9};
    const double h = 1.0 / (PGI__GGX_NMU - 1);
    double s = 0.0;
    for (int k = 0; k + 1 < PGI__GGX_NMU; k++) {
        for (int q = 0; q < 3; q++) {
            double t = 0.5 * (gx[q] + 1.0), x = ((double)k + t) * h;
            double e = (double)E[k] + ((double)E[k + 1] - (double)E[k]) * t;
            s += gw[q] * 0.5 * h * e * 4.0 * x * x * x;
        }
    }
    return (float)s;
}

static void build_node(int e) {
#pragma omp parallel for schedule(dynamic, 1)
    for (int ja = 0; ja < NA; ja++) {
        float alpha = node_alpha(ja);
        for (int k = 0; k < PGI__GGX_NMU; k++) {
            float x = (float)k / (float)(PGI__GGX_NMU - 1);
            /* mu = 0 exactly is the limit; a tiny cosine keeps the formulas finite */
            g_E[e][ja][k] = albedo_quadrature(fmaxf(x * x, 1e-6f), alpha, k_eta[e]);
        }
        g_Eavg[e][ja] = albedo_average(g_E[e][ja]);
    }
}

static void ensure_node(int e) {
    if (atomic_load_explicit(&g_ready[e], memory_order_acquire)) return;
#pragma omp critical(pgi_ggx_table)
    {
        if (!atomic_load_explicit(&g_ready[e], memory_order_relaxed)) {
            build_node(e);
            atomic_store_explicit(&g_ready[e], 1, memory_order_release);
        }
    }
}

static float clamp_eta(float eta) {
    return !(eta >= k_eta[0]) ? k_eta[0] : eta > k_eta[NETA - 1] ? k_eta[NETA - 1] : eta;
}

/* The index node e at or below eta and the weight t of node e + 1 (linear in F0); t = 0
 * (node e alone, e + 1 neither built nor read) when eta is a node. */
static int eta_segment(float eta, float *t) {
    int e = 0;
    while (e < NETA - 1 && eta >= k_eta[e + 1]) e++;
    *t = 0.f;
    if (e < NETA - 1 && eta > k_eta[e]) {
        float f0 = pgi__fresnel_f0(k_eta[e]), f1 = pgi__fresnel_f0(k_eta[e + 1]);
        *t = fminf(1.f, fmaxf(0.f, (pgi__fresnel_f0(eta) - f0) / (f1 - f0)));
    }
    return e;
}

void pgi__ggx_prepare(float eta) {
    float t;
    int e = eta_segment(clamp_eta(eta), &t);
    ensure_node(e);
    if (t > 0.f) ensure_node(e + 1);
}

void pgi__lobe_init(pgi__lobe *l, pgi__lobe_model model, pgi__v3 ks, float s, float eta) {
    l->model = model;
    l->ks = ks;
    l->s = s;
    l->eta = eta;
    l->a2 = 0.f;
    l->inv_1mEavg = 1.f;
    if (model != PGI__LOBE_GGX) return;
    float alpha = s < PGI__GGX_ALPHA_MIN ? PGI__GGX_ALPHA_MIN : s > 1.f ? 1.f : s;
    l->s = alpha;
    l->a2 = alpha * alpha;
    l->eta = clamp_eta(eta);
    float te;
    int e = eta_segment(l->eta, &te);
    ensure_node(e);
    const int e1 = te > 0.f ? e + 1 : e; /* node e + 1 only where it weighs */
    ensure_node(e1);
    float y0 = sqrtf(PGI__GGX_ALPHA_MIN), ya = (sqrtf(alpha) - y0) / (1.f - y0) * (float)(NA - 1);
    int ja = (int)ya;
    if (ja > NA - 2) ja = NA - 2;
    if (ja < 0) ja = 0;
    /* linear in alpha between the nodes (E is nearly linear in alpha where alpha is small) */
    float a0 = node_alpha(ja), a1 = node_alpha(ja + 1);
    float ta = fminf(1.f, fmaxf(0.f, (alpha - a0) / (a1 - a0)));
    float w00 = (1.f - te) * (1.f - ta), w01 = (1.f - te) * ta, w10 = te * (1.f - ta), w11 = te * ta;
    for (int k = 0; k < PGI__GGX_NMU; k++)
        l->E[k] = w00 * g_E[e][ja][k] + w01 * g_E[e][ja + 1][k] + w10 * g_E[e1][ja][k] + w11 * g_E[e1][ja + 1][k];
    float eavg = w00 * g_Eavg[e][ja] + w01 * g_Eavg[e][ja + 1] + w10 * g_Eavg[e1][ja] + w11 * g_Eavg[e1][ja + 1];
    l->inv_1mEavg = 1.f / (1.f - eavg);
}

pgi__lobe_model pgi__lobe_params(const pgi__material *m, pgi__v3 *ks, float *s, float *eta) {
    if (m->type == PGI__MAT_PHONG) {
        *ks = v3_load(m->ks);
        *s = m->shininess;
        *eta = 0.f;
        return PGI__LOBE_PHONG;
    }
    if (m->type == PGI__MAT_PLASTIC) {
        *eta = clamp_eta(m->ior);
        float f0 = pgi__fresnel_f0(*eta);
        *ks = v3(fminf(1.f, m->ks[0] / f0), fminf(1.f, m->ks[1] / f0), fminf(1.f, m->ks[2] / f0));
        *s = pgi__ggx_alpha_from_ns(m->shininess);
        return PGI__LOBE_GGX;
    }
    *ks = v3(0.f, 0.f, 0.f);
    *s = *eta = 0.f;
    return PGI__LOBE_NONE;
}

void pgi__lobe_of_material(const pgi__material *m, pgi__lobe *l) {
    pgi__v3 ks;
    float s, eta;
    pgi__lobe_model model = pgi__lobe_params(m, &ks, &s, &eta);
    pgi__lobe_init(l, model, ks, s, eta);
}
