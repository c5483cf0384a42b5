// Photon tracing on the GPU with per-photon footprints (radius policies `path` and `differentials`,
// gpu_trace.c, docs/gpu.md "Photon tracing"): trace.comp's paths (trace.glsl trace_path) carrying
// the policy's state (differentials.glsl, light.glsl light_emit_pd), each stored photon's footprint
// (footprint.glsl, pgi__gpu_footprint) into its own slot of binding 15 beside the photon's slot;
// trace_compact_fp.comp compacts them as trace_compact.comp the photons. Buffers: trace.comp's
// 0..14, 15 the footprint slots. Push: trace.comp's, then the policy's parameters (pgi__fp_params).
#version 450
#extension GL_GOOGLE_include_directive : require
layout(local_size_x = 64) in;

#define TRACE_FOOTPRINTS
#include "common.glsl"
#include "scene.glsl"
#include "differentials.glsl"
#include "light.glsl"
#include "trace.glsl"

void main() {
    const uint k = linear_group() * 64u + gl_LocalInvocationID.x;
    if (k < pc.npaths) trace_path(k);
}
