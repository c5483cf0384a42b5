// Per-photon footprints on the GPU (trace_fp.comp; docs/bvh.md, radius policies): the tracer hooks
// of src/photon/radius.c (fp_*) and the photon differentials of src/photon/differentials.c (pd_*),
// function for function, in the same order of operations (not `precise`: the footprints are
// compared with the CPU's statistically, as the photons are). The emission differentials of each
// light type (pgi__pd_emit) are light.glsl's light_emit_pd. Include after scene.glsl (verts, tris,
// mats, lobes, basis, v3_cross, lobe_eval).
#ifndef PGIS_DIFFERENTIALS_GLSL
#define PGIS_DIFFERENTIALS_GLSL

#include "footprint.glsl"

#define FP_FIXED 0u // pgi_radius_policy
#define FP_PATH 1u
#define FP_DIFFERENTIALS 2u

struct FpParams { // pgi__fp_params (pgi__fp_params_init on the host)
    uint policy;
    float r_min, r_max, smoothing, smoothing_caustic, delta;
};

struct PDiff { // pgi__pdiff
    vec3 dp[2], dd[2];
    float rho;
    bool diffuse;
};

bool fp_finite(vec3 a) { return !any(isnan(a)) && !any(isinf(a)); }

// ---------------------------------------------------------------- differentials.c
void pd_emit_dir(inout PDiff pd, vec3 d, vec3 axis, float scale) {
    vec3 t, b;
    basis(axis, t, b);
    float ct = v3_dot(d, axis), st = sqrt(max(0.0, 1.0 - ct * ct));
    float x = v3_dot(d, t), y = v3_dot(d, b), l = sqrt(x * x + y * y);
    float cp = l > 0.0 ? x / l : 1.0, sp = l > 0.0 ? y / l : 0.0;
    // eq. 8: d_cos = (-cos phi cos theta, -sin phi cos theta, sin theta), d_phi = (-sin phi, cos phi, 0)
    pd.dd[0] = ((t * cp + b * sp) * -ct + axis * st) * scale;
    pd.dd[1] = (t * -sp + b * cp) * scale;
    pd.dp[0] = pd.dp[1] = vec3(0.0);
}

void pd_transfer(inout PDiff pd, vec3 d, float t, vec3 n) {
    const float dn = v3_dot(d, n);
    for (int k = 0; k < 2; k++) {
        vec3 q = pd.dp[k] + pd.dd[k] * t;
        float dt = abs(dn) > 1e-6 ? -v3_dot(q, n) / dn : 0.0;
        pd.dp[k] = q + d * dt;
    }
}

void pd_reflect(inout PDiff pd, vec3 d, vec3 n, vec3 dn[2]) {
    const float dN = v3_dot(d, n);
    for (int k = 0; k < 2; k++) {
        float ddN = v3_dot(pd.dd[k], n) + v3_dot(d, dn[k]);
        pd.dd[k] = pd.dd[k] - (dn[k] * dN + n * ddN) * 2.0;
    }
}

void pd_refract(inout PDiff pd, vec3 d, vec3 n, vec3 dn[2], float eta, vec3 t) {
    const float dN = v3_dot(d, n), tN = v3_dot(t, n);
    const float mu = eta * dN - tN;
    const float dmu_f = abs(tN) > 1e-6 ? eta - eta * eta * dN / tN : eta;
    for (int k = 0; k < 2; k++) {
        float ddN = v3_dot(pd.dd[k], n) + v3_dot(d, dn[k]);
        pd.dd[k] = pd.dd[k] * eta - (dn[k] * mu + n * (dmu_f * ddN));
    }
}

void pd_roulette(inout PDiff pd, float p) {
    if (!(p > 0.0) || p >= 1.0) return;
    const float f = 1.0 / sqrt(p);
    for (int k = 0; k < 2; k++) {
        pd.dp[k] *= f;
        pd.dd[k] *= f;
    }
}

void pd_reemit(inout PDiff pd, vec3 d_out, vec3 n) {
    const float A = v3_len(v3_cross(pd.dp[0], pd.dp[1])); // |dp1 x dp2|; Delta^2 cancels in eq. 13
    pd_emit_dir(pd, d_out, n, 1.0);
    const float B = v3_len(v3_cross(pd.dd[0], pd.dd[1]));
    const float v = B > 0.0 ? sqrt(A / B) : 0.0;
    pd.dp[0] = pd.dd[0] * v; // eq. 11 at the re-emission point
    pd.dp[1] = pd.dd[1] * v;
    pd.diffuse = true;
}

// pgi__pd_footprint: the clamped ellipse at the hit (normal n); pad0 the radius before the clamp
// (r_raw, for the histogram: trace_compact_fp.comp)
Footprint pd_footprint(PDiff pd, FpParams p, vec3 n) {
    vec3 ax[2];
    for (int k = 0; k < 2; k++) {
        vec3 q = pd.dp[k] - n * v3_dot(pd.dp[k], n); // in the tangent plane
        float l = v3_len(q);
        float f = pd.diffuse ? p.smoothing * (l > 0.0 ? pow(l, -0.75) : 0.0) : p.smoothing_caustic;
        ax[k] = q * (p.delta * f);
    }
    float r = sqrt(v3_len(v3_cross(ax[0], ax[1])));
    float r_raw = r;
    const float rmax = p.r_max;
    if (!(r >= 1e-4 * rmax) || isinf(r) || !fp_finite(ax[0]) || !fp_finite(ax[1])) {
        // degenerate (collinear or vanishing axes): a circle of the longer axis' length
        float l = max(v3_len(ax[0]), v3_len(ax[1]));
        l = !isnan(l) && !isinf(l) ? min(max(l, 1e-2 * rmax), rmax) : rmax;
        vec3 t, b;
        basis(n, t, b);
        ax[0] = t * l;
        ax[1] = b * l;
        if (isnan(r_raw) || isinf(r_raw)) r_raw = rmax;
    } else if (r > rmax) {
        ax[0] *= rmax / r;
        ax[1] *= rmax / r;
    }
    // very skewed ellipses: keep each semi-axis within 4 r_max (bounds the boxes)
    for (int k = 0; k < 2; k++) {
        float l = v3_len(ax[k]);
        if (l > 4.0 * rmax) ax[k] *= 4.0 * rmax / l;
    }
    r = sqrt(v3_len(v3_cross(ax[0], ax[1])));
    if (!(r > 0.0)) r = 1e-2 * rmax;
    return Footprint(r, ax[0].x, ax[0].y, ax[0].z, ax[1].x, ax[1].y, ax[1].z, n.x, n.y, n.z, r_raw, 0.0);
}

// pgi__pd_normal_derivative: the interpolated shading normal's derivatives along dp (zero without
// vertex normals: `normals` false)
void pd_normal_derivative(bool normals, uint prim, float bu, float bv, vec3 dp[2], vec3 ref, out vec3 dn[2]) {
    dn[0] = dn[1] = vec3(0.0);
    if (!normals) return;
    const uvec4 t = tris[prim];
    const vec3 a = verts[t.x].pos_u.xyz, b = verts[t.y].pos_u.xyz, c = verts[t.z].pos_u.xyz;
    const vec3 n0 = verts[t.x].nrm_v.xyz, n1 = verts[t.y].nrm_v.xyz, n2 = verts[t.z].nrm_v.xyz;
    const vec3 e1 = b - a, e2 = c - a;
    const float g11 = v3_dot(e1, e1), g12 = v3_dot(e1, e2), g22 = v3_dot(e2, e2), det = g11 * g22 - g12 * g12;
    if (!(abs(det) > 0.0)) return;
    const vec3 N = n0 * (1.0 - bu - bv) + n1 * bu + n2 * bv;
    const float L = v3_len(N);
    if (!(L > 0.0)) return;
    const vec3 nh = N * (1.0 / L);
    const float sign = v3_dot(nh, ref) >= 0.0 ? 1.0 : -1.0;
    for (int k = 0; k < 2; k++) {
        float r1 = v3_dot(dp[k], e1), r2 = v3_dot(dp[k], e2);
        float du = (g22 * r1 - g12 * r2) / det, dv = (g11 * r2 - g12 * r1) / det;
        vec3 dN = (n1 - n0) * du + (n2 - n0) * dv;
        dn[k] = (dN - nh * v3_dot(dN, nh)) * (sign / L);
    }
}

// pgi__pd_scatter at surface sf of triangle prim (spec: a mirror or glass)
void pd_scatter(inout PDiff pd, bool normals, uint prim, float bu, float bv, Surf sf, bool spec, vec3 wi, vec3 wo) {
    if (!spec) {
        const float side = v3_dot(wo, sf.ng) >= 0.0 ? 1.0 : -1.0;
        pd_reemit(pd, wo, sf.ns * side);
        return;
    }
    const vec3 d = -wi;
    const float side = v3_dot(wi, sf.ng) >= 0.0 ? 1.0 : -1.0; // +1: arriving on the normal's side
    const vec3 n = sf.ns * side;                               // facing the incoming photon: d.n < 0
    vec3 dn[2];
    pd_normal_derivative(normals, prim, bu, bv, pd.dp, n, dn);
    if (v3_dot(wo, sf.ng) * side >= 0.0) {
        pd_reflect(pd, d, n, dn);
    } else {
        const float ior = mats[sf.mat].ior;
        pd_refract(pd, d, n, dn, side > 0.0 ? 1.0 / ior : ior, wo);
    }
}

// ---------------------------------------------------------------- radius.c (the tracer's hooks)
// pgi__fp_emit: after light_emit_pd where the policy is differentials
void fp_start(inout PDiff pd) {
    pd.dp[0] = pd.dp[1] = pd.dd[0] = pd.dd[1] = vec3(0.0);
    pd.rho = 1.0;
    pd.diffuse = false;
}

void fp_hit(inout PDiff pd, FpParams p, vec3 d, float t, vec3 ng) {
    if (p.policy == FP_DIFFERENTIALS) pd_transfer(pd, d, t, ng);
}

// pgi__fp_store (pad0: the radius before the clamp, as pgi__footprint.r_raw)
Footprint fp_store(PDiff pd, FpParams p, vec3 ng) {
    if (p.policy == FP_DIFFERENTIALS) return pd_footprint(pd, p, ng);
    const float rho = pd.rho > 0.0 ? min(pd.rho, 1.0) : 0.0;
    const float r = p.r_min + (p.r_max - p.r_min) * sqrt(1.0 - rho);
    return Footprint(r, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, ng.x, ng.y, ng.z, r, 0.0);
}

// pgi__fp_scatter: after the BSDF sampled wo from wi (both away from the surface) with weight w
void fp_scatter(inout PDiff pd, FpParams p, bool normals, uint prim, float bu, float bv, Surf sf, vec3 kd, bool spec,
                vec3 wi, vec3 wo, vec3 w) {
    if (p.policy == FP_PATH) {
        // a priori probability of scattering into ||Gamma|| = 1e-3 sr around wo: the whole
        // reflectance for a delta lobe, f cos ||Gamma|| otherwise (eq. 5)
        float pb;
        if (spec) pb = v3_lum(w);
        else {
            const vec3 ns = sf.ns * (v3_dot(wi, sf.ng) >= 0.0 ? 1.0 : -1.0);
            const uint m = sf.mat, model = lobes[m].model;
            vec3 f = kd * float(PGIS_INV_PI);
            if (model != 0u)
                f += lobe_eval(m, kd, ns, wi, wo, model == LOBE_GGX ? 1.0 - lobe_E(m, v3_dot(ns, wo)) : 0.0);
            pb = v3_lum(f) * max(0.0, v3_dot(wo, ns)) * 1e-3;
        }
        pd.rho *= pb > 0.0 ? min(pb, 1.0) : 0.0;
    } else if (p.policy == FP_DIFFERENTIALS) {
        pd_scatter(pd, normals, prim, bu, bv, sf, spec, wi, wo);
    }
}

void fp_roulette(inout PDiff pd, FpParams p, float survive) {
    if (p.policy == FP_DIFFERENTIALS) pd_roulette(pd, survive);
}

#endif
