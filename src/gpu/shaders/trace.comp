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
// The path is trace.glsl's trace_path; trace_fp.comp is the same with the radius policies'
// footprints. Buffers: 0..10 the GPU scene (gpu_scene.h), 11 its emission records
// (pgi__gpu_scene_emit), 12 slots, 13 counts, 14 counters.
#version 450
#extension GL_GOOGLE_include_directive : require
layout(local_size_x = 64) in;

#include "common.glsl"
#include "scene.glsl"
#include "light.glsl"
#include "trace.glsl"

void main() {
    const uint k = linear_group() * 64u + gl_LocalInvocationID.x;
    if (k < pc.npaths) trace_path(k);
}
