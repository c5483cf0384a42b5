// Photon tracing on the GPU, last step (gpu_trace.c): every stored photon's flux times
// 1 / paths emitted (the CPU tracer's final division, in float as there).
#version 450
#extension GL_GOOGLE_include_directive : require
layout(local_size_x = 64) in;
#include "common.glsl"

struct Photon {
    float px, py, pz, dx, dy, dz, fr, fg, fb;
};
layout(std430, set = 0, binding = 0) restrict buffer Out { Photon outp[]; };

layout(push_constant) uniform Push {
    uint n;
    float inv;
    uint pad0, pad1;
} pc;

void main() {
    const uint i = linear_group() * 64u + gl_LocalInvocationID.x;
    if (i >= pc.n) return;
    outp[i].fr *= pc.inv;
    outp[i].fg *= pc.inv;
    outp[i].fb *= pc.inv;
}
