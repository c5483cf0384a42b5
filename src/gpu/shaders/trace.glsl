// The photon tracer's scene view, random numbers, emission and BSDF sampling (trace.comp). The
// records are gpu_trace.c's (scalars only, so that std430 and the C structs agree); the functions
// mirror src/photon/trace.c start_path, src/scene/bsdf.c (pgi__scene_surface_untextured,
// pgi__bsdf_sample), src/scene/texture.c (bilinear, wrapping, sRGB table) and src/core/core.h
// (sampling, v3_basis / pgi_to_world). Include after bvh.glsl and gather.glsl (lobes at binding 7).
// Photon tracing's emission and BSDF sampling (trace.comp), on the GPU scene (scene.glsl, bindings
// 0..10; gpu_scene.h) and its emission records (binding 11, pgi__gpu_scene_emit). The functions
// mirror src/photon/trace.c start_path, src/scene/bsdf.c pgi__bsdf_sample, src/scene/env.c
// pgi__env_sample (constant sky) and src/core/core.h's sampling; the lights' own parts are
// light.glsl's. The path itself is trace_path (trace.comp; with TRACE_FOOTPRINTS defined,
// trace_fp.comp: the radius policies' hooks of differentials.glsl and binding 15, the footprints).
// Include after scene.glsl and light.glsl (and differentials.glsl with TRACE_FOOTPRINTS).
#ifndef PGIS_TRACE_GLSL
#define PGIS_TRACE_GLSL

struct Emit { // pgi__gpu_emit
    vec3 power;
    float cdf;
};

layout(std430, set = 0, binding = 11) readonly restrict buffer Emits { Emit emits[]; };
layout(std430, set = 0, binding = 12) writeonly restrict buffer Slots { Photon slots[]; };
layout(std430, set = 0, binding = 13) writeonly restrict buffer Counts { uint counts[]; };
layout(std430, set = 0, binding = 14) restrict buffer Counters { uint counters[]; }; // 0: rays

layout(push_constant) uniform Push {
    SceneInfo scene;
    uint path0_lo, path0_hi; // global index of the launch's first path
    uint npaths;             // paths of this launch
    uint bounces;            // 1..64: the slots a path
    uint seed_lo, seed_hi;
    uint nemit; // emission records (lights, the sky last)
    uint pad;
#ifdef TRACE_FOOTPRINTS
    uint policy; // pgi__fp_params (FpParams)
    float r_min, r_max, smoothing, smoothing_caustic, delta;
    uint pad1, pad2;
#endif
} pc;

#ifdef TRACE_FOOTPRINTS
layout(std430, set = 0, binding = 15) writeonly restrict buffer FpSlots { Footprint fslots[]; };
#endif

// A path's random numbers: scene.glsl's counter-based hash, stream (path index, seed, PURPOSE):
// path i's numbers depend on (seed, i) alone, whatever the launch and invocation order.
#define TRACE_PURPOSE 0x50484f54u // "PHOT"
Rng path_rng(uint lo, uint hi) { return rng_seed(pc.seed_lo, pc.seed_hi, TRACE_PURPOSE ^ (hi * 0x9e3779b9u), lo); }

// ---------------------------------------------------------------- core.h
float maxc(vec3 a) { return max(a.x, max(a.y, a.z)); }

// ---------------------------------------------------------------- emission (trace.c start_path)
// Path flux: the light's power over its pick probability (divided by the paths emitted later);
// L the light (type LIGHT_ENV for the sky), pl its pick probability.
bool start_path(inout Rng rng, out vec3 o, out vec3 d, out vec3 flux, out Light L, out float pl) {
    L = Light(vec3(0.0), LIGHT_ENV, vec3(0.0), 0.0, vec3(0.0), 0.0, vec3(0.0), 0u);
    pl = 0.0;
    o = vec3(0.0);
    d = vec3(0.0, 0.0, 1.0);
    flux = vec3(0.0);
    const float ul = rng_f(rng);
    uint lo = 0u, hi = pc.nemit - 1u;
    while (lo < hi) {
        uint mid = (lo + hi) / 2u;
        if (ul < emits[mid].cdf) hi = mid;
        else lo = mid + 1u;
    }
    precise float p = emits[lo].cdf - (lo > 0u ? emits[lo - 1u].cdf : 0.0);
    pl = p;
    if (!(pl > 0.0)) return false;
    flux = emits[lo].power * (1.0 / pl);
    const vec3 centre = emits[pc.nemit].power;
    const float radius = emits[pc.nemit].cdf;
    const bool sky = lo >= pc.scene.nlights; // the last entry: the sky
    const uint type = sky ? LIGHT_ENV : lights[lo].type;
    const vec4 u = light_draw(rng, type);
    if (sky) // the sky's frame and its upper hemisphere's probability are the records after the table
        return light_emit_sky(u, emits[pc.nemit + 1u].power, vec3(pc.scene.upx, pc.scene.upy, pc.scene.upz),
                              emits[pc.nemit + 2u].power, emits[pc.nemit + 1u].cdf, pc.scene.sky.xyz,
                              pc.scene.ground.xyz, centre, radius, pl, o, d, flux);
    L = lights[lo];
    light_emit(L, u, centre, radius, pc.scene.eps, o, d);
    return true;
}

bool mat_specular(uint type) { return type == MAT_MIRROR || type == MAT_GLASS; }


// ---------------------------------------------------------------- BSDF sampling (bsdf.c)
// The lobe of material m is lobes[m] (model 0 for Lambert, mirror and glass).
float glossy_pick(uint m, vec3 kd, vec3 ns, vec3 wi) {
    float wd = 0.2126 * kd.x + 0.7152 * kd.y + 0.0722 * kd.z;
    float wsp = 0.2126 * lobes[m].ksx + 0.7152 * lobes[m].ksy + 0.0722 * lobes[m].ksz;
    if (lobes[m].model == LOBE_GGX) {
        float ci = v3_dot(wi, ns);
        if (!(ci > 0.0)) return 0.0;
        float e = lobe_E(m, ci);
        wsp *= e;
        wd *= 1.0 - e;
    }
    return wd + wsp > 0.0 ? wsp / (wd + wsp) : 0.0;
}

float ggx_pdf(uint m, vec3 n, vec3 wi, vec3 wo) {
    float ci = v3_dot(n, wi);
    if (!(ci > 0.0)) return 0.0;
    vec3 h = wi + wo;
    float hl = v3_len(h);
    if (!(hl > 0.0)) return 0.0;
    float hn = v3_dot(h, n) / hl;
    if (!(hn > 0.0)) return 0.0;
    const float a2 = lobes[m].a2;
    return ggx_D(a2, hn) / (2.0 * (ci + ggx_root(a2, ci)));
}

float glossy_pdf(uint m, vec3 ns, vec3 wi, vec3 wo) {
    if (lobes[m].model == LOBE_GGX) return ggx_pdf(m, ns, wi, wo);
    const float s = lobes[m].s;
    vec3 h = v3_norm(wi + wo);
    float hn = max(0.0, v3_dot(h, ns)), hw = abs(v3_dot(h, wo));
    return hw > 0.0 ? (s + 1.0) / float(2.0 * PGIS_PI) * pow(hn, s) / (4.0 * hw) : 0.0;
}

// bsdf.h pgi__ggx_sample_vndf (Heitz 2018)
vec3 ggx_sample_vndf(vec3 V, float alpha, float u1, float u2) {
    vec3 Vh = v3_norm(vec3(alpha * V.x, alpha * V.y, V.z));
    float lensq = Vh.x * Vh.x + Vh.y * Vh.y;
    vec3 T1 = lensq > 0.0 ? vec3(-Vh.y, Vh.x, 0.0) * (1.0 / sqrt(lensq)) : vec3(1.0, 0.0, 0.0);
    vec3 T2 = cross(Vh, T1);
    float r = sqrt(u1), phi = float(2.0 * PGIS_PI) * u2;
    float t1 = r * cos(phi), t2 = r * sin(phi), sv = 0.5 * (1.0 + Vh.z);
    t2 = (1.0 - sv) * sqrt(max(0.0, 1.0 - t1 * t1)) + sv * t2;
    vec3 Nh = T1 * t1 + T2 * t2 + Vh * sqrt(max(0.0, 1.0 - t1 * t1 - t2 * t2));
    return v3_norm(vec3(alpha * Nh.x, alpha * Nh.y, max(0.0, Nh.z)));
}

bool bsdf_sample(Surf sf, vec3 kd, vec3 wi, float u1, float u2, float u3, out vec3 wo, out vec3 weight) {
    const uint m = sf.mat;
    const uint type = mats[m].type;
    const float side = v3_dot(wi, sf.ng) >= 0.0 ? 1.0 : -1.0;
    const vec3 ng = sf.ng * side, ns = sf.ns * side;
    const vec3 ks = mats[m].ks;
    wo = vec3(0.0, 0.0, 1.0);
    weight = vec3(0.0);
    if (type == MAT_MIRROR) {
        wo = reflect_v(wi, ns);
        weight = ks;
        return v3_dot(wo, ng) > 0.0;
    }
    if (type == MAT_GLASS) {
        const float ior = mats[m].ior;
        float eta_i = side > 0.0 ? 1.0 : ior, eta_t = side > 0.0 ? ior : 1.0;
        float ci = min(1.0, max(0.0, v3_dot(wi, ns)));
        float F = fresnel_dielectric(ci, eta_i, eta_t);
        if (u1 < F) {
            wo = reflect_v(wi, ns);
            weight = vec3(1.0);
            return v3_dot(wo, ng) > 0.0;
        }
        float eta = eta_i / eta_t;
        float st2 = eta * eta * (1.0 - ci * ci);
        float ct = sqrt(max(0.0, 1.0 - st2));
        wo = v3_norm(-wi * eta - ns * (ct - eta * ci));
        weight = ks;
        return v3_dot(wo, ng) < 0.0;
    }
    if (type == MAT_PHONG || type == MAT_PLASTIC) {
        const float ps = glossy_pick(m, kd, ns, wi);
        if (u3 < ps) {
            if (lobes[m].model == LOBE_GGX) {
                vec3 t, b;
                basis(ns, t, b);
                vec3 V = vec3(v3_dot(wi, t), v3_dot(wi, b), v3_dot(wi, ns));
                wo = reflect_v(wi, to_world(ggx_sample_vndf(V, lobes[m].s, u1, u2), ns));
            } else {
                const float s = lobes[m].s;
                float ct = pow(u1, 1.0 / (s + 1.0)), st = sqrt(max(0.0, 1.0 - ct * ct)),
                      phi = float(2.0 * PGIS_PI) * u2;
                vec3 h = to_world(vec3(st * cos(phi), st * sin(phi), ct), ns);
                wo = reflect_v(wi, h);
            }
        } else {
            wo = to_world(sample_cosine(u1, u2), ns);
        }
        float cg = v3_dot(wo, ng), cs = v3_dot(wo, ns);
        if (!(cg > 0.0) || !(cs > 0.0)) return false;
        float pdf = ps * glossy_pdf(m, ns, wi, wo) + (1.0 - ps) * cs * float(PGIS_INV_PI);
        if (!(pdf > 0.0)) return false;
        const float one_m_eo = lobes[m].model == LOBE_GGX ? 1.0 - lobe_E(m, v3_dot(ns, wo)) : 0.0;
        vec3 f = kd * float(PGIS_INV_PI) + lobe_eval(m, kd, ns, wi, wo, one_m_eo);
        weight = f * (cs / pdf);
        return true;
    }
    wo = to_world(sample_cosine(u1, u2), ns);
    weight = kd;
    return v3_dot(wo, ng) > 0.0;
}

// ---------------------------------------------------------------- a path (trace.comp, trace_fp.comp)
// Path k of the launch; with TRACE_FOOTPRINTS (trace_fp.comp) it carries the radius policy's
// state (differentials.glsl: rho, or the photon differentials) through the CPU tracer's hooks and
// writes each stored photon's footprint to fslots[], slot for slot with slots[].
void trace_path(const uint k) {
    const uint slot0 = k * pc.bounces;
    uint stored = 0u, rays = 0u;
    Rng rng = path_rng(pc.path0_lo + k, pc.path0_hi + (pc.path0_lo + k < pc.path0_lo ? 1u : 0u));
    vec3 o, d, flux;
    Light L;
    float pl;
#ifdef TRACE_FOOTPRINTS
    const FpParams fp = FpParams(pc.policy, pc.r_min, pc.r_max, pc.smoothing, pc.smoothing_caustic, pc.delta);
    const bool normals = (pc.scene.flags & SCENE_NORMALS) != 0u;
    PDiff pd;
    fp_start(pd);
#endif
    if (start_path(rng, o, d, flux, L, pl)) {
#ifdef TRACE_FOOTPRINTS
        if (fp.policy == FP_DIFFERENTIALS) light_emit_pd(L, pl, d, emits[pc.nemit].cdf, pd);
#endif
        const float inf = uintBitsToFloat(0x7F800000u);
        for (uint b = 0u;; b++) {
            BvhHit h;
            bvh_trace(o, d, 0.0, inf, false, h);
            rays++;
            if (h.prim == BVH_EMPTY) break;
            precise vec3 p = o + d * h.t;
            const Surf sf = scene_surface(pc.scene, h.prim, h.u, h.v);
            const vec3 wi = -d;
            const vec3 ng = v3_dot(wi, sf.ng) >= 0.0 ? sf.ng : -sf.ng;
            const uint type = mats[sf.mat].type;
#ifdef TRACE_FOOTPRINTS
            fp_hit(pd, fp, d, h.t, ng);
#endif
            if (b >= 1u && !mat_specular(type)) {
#ifdef TRACE_FOOTPRINTS
                fslots[slot0 + stored] = fp_store(pd, fp, ng);
#endif
                slots[slot0 + stored] = Photon(p.x, p.y, p.z, wi.x, wi.y, wi.z, flux.x, flux.y, flux.z);
                stored++;
            }
            if (b >= pc.bounces) break;
            const vec3 kd = surface_kd(sf);
            const float r1 = rng_f(rng), r2 = rng_f(rng), r3 = rng_f(rng);
            vec3 wo, w;
            if (!bsdf_sample(sf, kd, wi, r1, r2, r3, wo, w)) break;
#ifdef TRACE_FOOTPRINTS
            fp_scatter(pd, fp, normals, h.prim, h.u, h.v, sf, kd, mat_specular(type), wi, wo, w);
#endif
            precise vec3 nf = flux * w;
            const float mf = maxc(flux);
            const float R = mf > 0.0 ? min(1.0, maxc(nf) / mf) : 0.0;
            if (!(rng_f(rng) < R)) break;
            flux = nf * (1.0 / R);
            if (any(isnan(flux)) || any(isinf(flux))) break;
#ifdef TRACE_FOOTPRINTS
            fp_roulette(pd, fp, R);
#endif
            precise vec3 off = (v3_dot(wo, ng) >= 0.0 ? ng : -ng) * pc.scene.eps;
            o = p + off;
            d = wo;
        }
    }
    counts[k] = stored;
    if (rays > 0u) atomicAdd(counters[0], rays);
}

#endif
