// Photon tracing on the GPU (src/gpu/gpu_trace.c, docs/gpu.md "Photon tracing"): one invocation a
// light path, the CPU tracer's policy (src/photon/trace.c) step for step:
//   light picked by power (the scene's light CDF), emission per light type (point, spot, sun, area
//   triangle's cosine lobe, constant sky), the ray cast through the GPU BVH (bvh.glsl, closest hit over (0, inf)),
//   storage from the second hit on at non-specular surfaces, BSDF sampling (bsdf.c: Lambert,
//   Blinn-Phong, GGX plastic, mirror, glass), flux-preserving Russian roulette, at most `bounces`
//   scattering events.
// Path k of the launch is global path pc.path0 + k. Its photons go to its own fixed slots
// slots[k * bounces ...] (a path stores at most `bounces` photons), its photon count to counts[k];
// gpu_trace.c then scans the counts and compacts the slots in path order (trace_compact.comp), so
// that the photons and the paths emitted do not depend on the order in which invocations run.
// Random numbers: counter-based, trace.glsl path_rng (scene.glsl's hash; not the CPU's PCG streams).
// Buffers: 0..10 the GPU scene (gpu_scene.h), 11 its emission records (pgi__gpu_scene_emit),
// 12 slots, 13 counts, 14 counters.
#version 450
#extension GL_GOOGLE_include_directive : require
layout(local_size_x = 64) in;

#include "common.glsl"
#include "scene.glsl"
#include "light.glsl"
#include "trace.glsl"

void main() {
    const uint k = linear_group() * 64u + gl_LocalInvocationID.x;
    if (k >= pc.npaths) return;
    const uint slot0 = k * pc.bounces;
    uint stored = 0u, rays = 0u;
    Rng rng = path_rng(pc.path0_lo + k, pc.path0_hi + (pc.path0_lo + k < pc.path0_lo ? 1u : 0u));
    vec3 o, d, flux;
    if (start_path(rng, o, d, flux)) {
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
            if (b >= 1u && !mat_specular(type)) {
                slots[slot0 + stored] = Photon(p.x, p.y, p.z, wi.x, wi.y, wi.z, flux.x, flux.y, flux.z);
                stored++;
            }
            if (b >= pc.bounces) break;
            const vec3 kd = surface_kd(sf);
            const float r1 = rng_f(rng), r2 = rng_f(rng), r3 = rng_f(rng);
            vec3 wo, w;
            if (!bsdf_sample(sf, kd, wi, r1, r2, r3, wo, w)) break;
            precise vec3 nf = flux * w;
            const float mf = maxc(flux);
            const float R = mf > 0.0 ? min(1.0, maxc(nf) / mf) : 0.0;
            if (!(rng_f(rng) < R)) break;
            flux = nf * (1.0 / R);
            if (any(isnan(flux)) || any(isinf(flux))) break;
            precise vec3 off = (v3_dot(wo, ng) >= 0.0 ? ng : -ng) * pc.scene.eps;
            o = p + off;
            d = wo;
        }
    }
    counts[k] = stored;
    if (rays > 0u) atomicAdd(counters[0], rays);
}
